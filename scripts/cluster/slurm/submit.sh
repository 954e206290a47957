#!/bin/bash
# fxshade on Slurm in one line: prebuild, an N-task shard array, the merge.
#   scripts/cluster/slurm/submit.sh 8 results normalize --count 8000000
# prints the merge job's id; its exit status and output are the verdict
# (sacct -j ID, or the fxshade-merge-ID.out file).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
n=${1:?usage: submit.sh N RESULT_DIR UNIT [rtl-check arguments]}
results=${2:?usage: submit.sh N RESULT_DIR UNIT [rtl-check arguments]}
shift 2
case "$n" in
'' | *[!0-9]* | 0)
  echo "submit.sh: N = $n: give the number of shards, 1 or more" >&2
  exit 2
  ;;
esac
mkdir -p "$results"
pre=$(sbatch --parsable "$here/prebuild.sbatch" "$@")
# If the prebuild fails the array is cancelled (not left pending), and the
# merge still runs and reports that no shard ran.
array=$(sbatch --parsable --dependency="afterok:$pre" --kill-on-invalid-dep=yes \
  --array="0-$((n - 1))" \
  "$here/shard.sbatch" "$results" "$@")
sbatch --parsable --dependency="afterany:$array" "$here/merge.sbatch" "$results"
