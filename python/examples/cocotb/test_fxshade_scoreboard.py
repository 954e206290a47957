"""A cocotb scoreboard for any emitted fxshade module, against the model.

Drives the module with random input codes (set-up fields, on a pipeline top,
held for runs of rows and sent through their set-up ports first), random
valid and random ready (back-pressure), and checks every output transfer,
in order, against ``fxshade.Unit.eval`` (codes and overflow flags, bit for
bit); it also reports the model's largest error against the f64 reference
(``Unit.reference``). Signals are driven at the falling clock edge and
handshakes sampled once they settle (``ReadOnly``), so there is no race.

Environment (set by ``run_cocotb.py``): FXS_UNIT, FXS_SETS (overrides, one
per line), FXS_N (rows, 2000), FXS_SEED (1), FXS_STALL (percent, 25), FXS_RESULT
(a file to write `passed failed` into).
"""

import os

import cocotb
import numpy as np
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, FallingEdge, ReadOnly

import fxshade


def _mask(code, width):
    return int(code) & ((1 << width) - 1)


def _value(handle, port):
    v = handle.value
    return v.to_signed() if port["signed"] else v.to_unsigned()


@cocotb.test()
async def scoreboard(dut):
    sets = [s for s in os.environ.get("FXS_SETS", "").splitlines() if s.strip()]
    unit = fxshade.Unit(os.environ["FXS_UNIT"], set=sets)
    n = int(os.environ.get("FXS_N", "2000"))
    stall = int(os.environ.get("FXS_STALL", "25")) / 100.0
    rng = np.random.default_rng(int(os.environ.get("FXS_SEED", "1")))
    ins, outs, nf = unit.inputs, unit.outputs, len(unit.flags)

    # Rows of random codes; each set-up group's fields are redrawn with
    # probability 1/8 per row and held otherwise.
    lo = np.array([p["min_code"] for p in ins], dtype=np.int64)
    hi = np.array([p["max_code"] for p in ins], dtype=np.int64)
    codes = rng.integers(lo, hi, size=(n, len(ins)), endpoint=True)
    groups = sorted({p["group"] for p in ins if p["group"]})
    for g in groups:
        cols = [k for k, p in enumerate(ins) if p["group"] == g]
        for i in range(1, n):
            if rng.random() >= 1 / 8:
                codes[i, cols] = codes[i - 1, cols]
    want, want_flags = unit.eval(codes)
    ref = unit.reference(unit.input_values(codes))
    err = np.abs(unit.output_values(want) - ref).max(axis=0)
    dut._log.info(
        "model against its f64 reference, max over these %d uniformly random rows "
        "(near-zero or out-of-range inputs make it large; for information): %s",
        n,
        ", ".join(f"{p['name']} {e:.3g}" for p, e in zip(outs, err)),
    )

    cocotb.start_soon(Clock(dut.clk_i, 10, unit="ns").start())
    dut.rst_ni.value = 0
    dut.valid_i.value = 0
    dut.ready_i.value = 0
    for g in groups:
        getattr(dut, f"{g}_valid_i").value = 0
    await ClockCycles(dut.clk_i, 3)
    dut.rst_ni.value = 1

    held = {g: None for g in groups}
    sent, checked, mismatches, quiet = 0, 0, 0, 0
    offering = None  # None, ("item",) or ("setup", g)
    while checked < n:
        await FallingEdge(dut.clk_i)
        if offering is None and sent < n and rng.random() >= stall:
            row = codes[sent]
            stale = [
                g
                for g in groups
                if held[g] is None
                or any(held[g][k] != row[k] for k, p in enumerate(ins) if p["group"] == g)
            ]
            for k, p in enumerate(ins):
                getattr(dut, f"{p['name']}_i").value = _mask(row[k], p["width"])
            offering = ("setup", stale[0]) if stale else ("item",)
        dut.valid_i.value = int(offering == ("item",))
        for g in groups:
            getattr(dut, f"{g}_valid_i").value = int(offering == ("setup", g))
        dut.ready_i.value = int(rng.random() >= stall)
        await ReadOnly()
        if offering == ("item",) and dut.ready_o.value:
            sent += 1
            offering = None
        elif offering is not None and offering[0] == "setup":
            g = offering[1]
            if getattr(dut, f"{g}_ready_o").value:
                held[g] = codes[sent].copy()
                offering = None
        quiet += 1
        if dut.valid_o.value and dut.ready_i.value:
            quiet = 0
            got = [_value(getattr(dut, f"{p['name']}_o"), p) for p in outs]
            got_flags = dut.ovf_o.value.to_unsigned() if nf else 0
            if got != list(want[checked]) or got_flags != int(want_flags[checked]):
                mismatches += 1
                if mismatches <= 5:
                    dut._log.error(
                        "mismatch at output %d: got %s ovf %x, want %s ovf %x",
                        checked,
                        got,
                        got_flags,
                        list(want[checked]),
                        int(want_flags[checked]),
                    )
            checked += 1
        assert quiet < 10000, f"no output for 10000 cycles after {checked} of {n}"
    dut._log.info("%d passed, %d failed", checked - mismatches, mismatches)
    if os.environ.get("FXS_RESULT"):
        with open(os.environ["FXS_RESULT"], "w") as f:
            f.write(f"{checked - mismatches} {mismatches}\n")
    assert mismatches == 0, f"{mismatches} of {n} outputs differ from the model"
