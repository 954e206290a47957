#!/bin/bash
# BENCHMARKS.md "Sharded runs on a scheduler": the same rtl-check regression
# locally (--jobs 2) and as Slurm arrays of 2, 8 and 32 shards on the
# single-node Slurm of scripts/cluster/slurm/local-cluster.sh (as root).
#   scripts/bench-shards.sh [WORKDIR]     (default /tmp/fxshade-bench-shards)
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
work=${1:-/tmp/fxshade-bench-shards}
F=${FXSHADE:-$repo/target/release/fxshade}
export FXSHADE=$F FXSHADE_CACHE_DIR=$work/cache
rm -rf "$work"
mkdir -p "$work/run"
"$F" rtl-check normalize --prebuild >/dev/null
for count in 2000000 8000000; do
  s=$(date +%s.%N)
  "$F" rtl-check normalize --count "$count" --jobs 2 >/dev/null 2>&1
  e=$(date +%s.%N)
  echo "local, --jobs 2, $count vectors: $(echo "$e - $s" | bc) s"
done
eval "$("$repo/scripts/cluster/slurm/local-cluster.sh" start "$work/slurm")"
trap '"$repo/scripts/cluster/slurm/local-cluster.sh" stop "$work/slurm"' EXIT
cd "$work/run"
for n in 2 8 32; do
  for count in 2000000 8000000; do
    rm -rf res
    s=$(date +%s.%N)
    id=$("$repo/scripts/cluster/slurm/submit.sh" "$n" res normalize --count "$count")
    while squeue -h | grep -q .; do sleep 0.2; done
    e=$(date +%s.%N)
    state=$(scontrol show job "$id" | grep -o "JobState=[A-Z]*")
    shard_s=$(python3 -c "
import glob, json
print(round(sum(json.load(open(f))['seconds'] for f in glob.glob('res/*.json')), 1))")
    echo "Slurm, $n shards, $count vectors: $(echo "$e - $s" | bc) s, merge $state, shards simulated $shard_s s in all"
  done
done
