#!/usr/bin/env bash
# The three routes to the model from a user's testbench, measured
# (BENCHMARKS.md, "Your own testbench"): the DPI-C scoreboard against
# rtl-check on the same module, Python eval rows/s per unit, and the cocotb
# scoreboard's vectors/s. Run from the repository root after
#   cargo build --release --workspace && (cd python && maturin build --release)
# with the wheel installed (python3 -m pip install target/wheels/fxshade-*.whl).
set -euo pipefail
cd "$(dirname "$0")/.."
L=$PWD/target/release
export PATH="$L:$PATH"
N=${N:-1000000}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

echo "== DPI-C scoreboard (Verilator -O3, random stalls 25 %), $N vectors"
fxshade rtl normalize --dpi --out "$work/dpi" >/dev/null
(
  cd "$work/dpi"
  verilator --binary -j 2 -O3 --top-module normalize_dpi_tb -Wno-fatal \
    -LDFLAGS "-L$L -lfxshade_capi -Wl,-rpath,$L" \
    normalize_dpi_pkg.sv normalize.v normalize_dpi_tb.sv >/dev/null
  /usr/bin/time -f "dpi-c scoreboard: %e s wall, %U s user" ./obj_dir/Vnormalize_dpi_tb +N="$N" +STALL=25 | grep passed
)
echo "== rtl-check on the same module (Verilator, --jobs 1, --stall 25), $N vectors"
fxshade rtl-check normalize --count "$N" --jobs 1 --stall 25 --json \
  | python3 -c 'import json,sys; r=json.load(sys.stdin); r=r[0] if isinstance(r,list) else r; print("rtl-check:", r["passed"], "passed,", r["failed"], "failed,", round(r["seconds"],2), "s wall,", int(r["vectors_per_second"]), "vectors per simulator CPU s,", int(r["vectors_per_second_end_to_end"]), "vectors/s end to end")'

echo "== Python eval, 10^6 random rows per unit"
python3 - <<'PY'
import time, numpy as np, fxshade
for name in fxshade.units():
    u = fxshade.Unit(name)
    lo = np.array([p["min_code"] for p in u.inputs]); hi = np.array([p["max_code"] for p in u.inputs])
    codes = np.random.default_rng(1).integers(lo, hi, size=(1_000_000, len(lo)), endpoint=True)
    best = min((lambda t: (u.eval(codes), time.perf_counter() - t)[1])(time.perf_counter()) for _ in range(3))
    print(f"python eval {name:13s} {1e6 / best / 1e6:6.2f} M rows/s")
PY

echo "== cocotb scoreboard (Icarus), 20000 vectors"
for u in normalize pipeline; do
  start=$(date +%s.%N)
  python3 python/examples/cocotb/run_cocotb.py "$u" --n 20000 --out "$work/cocotb-$u" | tail -1
  end=$(date +%s.%N)
  python3 -c "print('cocotb $u: %.1f s, %.0f vectors/s' % ($end - $start, 20000 / ($end - $start)))"
done
