#!/usr/bin/env python3
"""Run a command that shows fxshade's progress bar on stderr and print, for
each new step, the wall and CPU seconds the step before it took.

    XDG_CACHE_HOME=$(mktemp -d) scripts/time-steps.py fxshade report --out rep

CPU time is the command's own (all its threads) plus its children it has
waited for (Icarus runs, say), read from /proc (Linux only)."""

import os
import subprocess
import sys
import time


def main() -> int:
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    t0 = time.time()
    p = subprocess.Popen(sys.argv[1:], stderr=subprocess.PIPE, stdout=subprocess.DEVNULL)
    tick = os.sysconf("SC_CLK_TCK")

    def cpu() -> float:
        try:
            with open(f"/proc/{p.pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            # utime, stime, cutime, cstime
            return sum(int(x) for x in fields[11:15]) / tick
        except (OSError, IndexError, ValueError):
            return float("nan")

    buf = b""
    last, last_wall, last_cpu = None, 0.0, 0.0
    while True:
        c = p.stderr.read(1)
        if not c:
            break
        if c not in b"\r\n":
            buf += c
            continue
        line = buf.decode(errors="replace").strip()
        buf = b""
        if not line:
            continue
        step = line.split("]")[-1].strip() if "]" in line else line
        step = step.rsplit("(", 1)[0].strip()
        if step == last:
            continue
        wall, used = time.time() - t0, cpu()
        print(
            f"{wall:7.1f} s, {used:7.1f} CPU-s "
            f"(previous step {wall - last_wall:5.1f} s, {used - last_cpu:6.1f} CPU-s): {step}",
            flush=True,
        )
        last, last_wall, last_cpu = step, wall, used
    p.wait()
    print(f"{time.time() - t0:7.1f} s: exit {p.returncode}", flush=True)
    return p.returncode


if __name__ == "__main__":
    sys.exit(main())
