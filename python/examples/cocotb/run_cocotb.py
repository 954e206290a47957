#!/usr/bin/env python3
"""Emit a unit's module with fxshade and run the cocotb scoreboard on Icarus.

    python run_cocotb.py UNIT [--set KEY=VALUE]... [--n N] [--seed S]
                              [--stall PERCENT] [--rtl FILE.v] [--out DIR]
                              [--fxshade PATH]

Writes ``<module>.v`` with ``fxshade rtl UNIT`` (or takes ``--rtl FILE.v``,
e.g. your own implementation with the same ports), builds it with Icarus
through cocotb's runner and runs ``test_fxshade_scoreboard``. Prints
``P passed, F failed`` (output vectors) and exits 0 only when every one
passed.
"""

import argparse
import os
import shutil
import subprocess
import sys
from pathlib import Path

from cocotb_tools.runner import get_results, get_runner

import fxshade

HERE = Path(__file__).resolve().parent


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("unit", choices=fxshade.units())
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    ap.add_argument("--n", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--stall", type=int, default=25)
    ap.add_argument("--rtl", type=Path, help="a Verilog file to test instead of fxshade's")
    ap.add_argument("--out", type=Path, default=Path("cocotb_build"))
    ap.add_argument("--fxshade", default=shutil.which("fxshade") or "fxshade")
    a = ap.parse_args()

    unit = fxshade.Unit(a.unit, set=a.set)
    module = unit.module
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / "result.txt").unlink(missing_ok=True)
    if a.rtl is None:
        cmd = [a.fxshade, "rtl", a.unit, "--out", str(a.out), "--force"]
        for s in a.set:
            cmd += ["--set", s]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        rtl = a.out / f"{module}.v"
    else:
        rtl = a.rtl.resolve()
    runner = get_runner("icarus")
    runner.build(
        sources=[rtl],
        hdl_toplevel=module,
        build_dir=a.out / "sim_build",
        always=True,
        timescale=("1ns", "1ps"),
    )
    env = {
        "FXS_UNIT": a.unit,
        "FXS_SETS": "\n".join(a.set),
        "FXS_N": str(a.n),
        "FXS_SEED": str(a.seed),
        "FXS_STALL": str(a.stall),
        "FXS_RESULT": str((a.out / "result.txt").resolve()),
        "PYTHONPATH": os.pathsep.join([str(HERE), os.environ.get("PYTHONPATH", "")]),
    }
    xml = runner.test(
        test_module="test_fxshade_scoreboard",
        hdl_toplevel=module,
        build_dir=a.out / "sim_build",
        test_dir=a.out,
        extra_env=env,
        timescale=("1ns", "1ps"),
    )
    tests, failed = get_results(xml)
    result = a.out / "result.txt"
    if result.exists():
        passed, mismatched = result.read_text().split()
        print(f"{passed} passed, {mismatched} failed")
    else:
        print(f"0 passed, {a.n} failed (the test stopped: see the log above)")
    sys.exit(0 if failed == 0 and tests > 0 else 1)


if __name__ == "__main__":
    main()
