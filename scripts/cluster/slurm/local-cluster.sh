#!/bin/bash
# A single-node Slurm on this machine, for trying the templates and for the
# test suite: munge, slurmctld and slurmd with a generated slurm.conf and
# every file (key, state, logs, pids) under DIR. Needs root and Debian's
# slurmctld, slurmd, slurm-client and munge; no cgroups (proctrack/pgid,
# task/none).
#   scripts/cluster/slurm/local-cluster.sh start DIR   # prints: export SLURM_CONF=DIR/slurm.conf
#   scripts/cluster/slurm/local-cluster.sh stop DIR    # stops the daemons by their pids
set -euo pipefail
cmd=${1:?usage: local-cluster.sh start|stop DIR}
dir=${2:?usage: local-cluster.sh start|stop DIR}

stop() {
  for p in slurmd slurmctld munged; do
    f="$dir/run/$p.pid"
    if [ -s "$f" ]; then
      pid=$(cat "$f")
      kill "$pid" 2>/dev/null || true
      for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
      kill -9 "$pid" 2>/dev/null || true
      rm -f "$f"
    fi
  done
}

case "$cmd" in
stop)
  stop
  exit 0
  ;;
start) ;;
*)
  echo "local-cluster.sh: $cmd: give start or stop" >&2
  exit 2
  ;;
esac

if [ "$(id -u)" != 0 ]; then
  echo "local-cluster.sh: a single-node Slurm runs as root here (SlurmUser=root)" >&2
  exit 1
fi
for t in munged mungekey slurmctld slurmd sbatch; do
  if ! command -v "$t" >/dev/null 2>&1; then
    echo "local-cluster.sh: $t is missing: apt-get install slurmctld slurmd slurm-client munge" >&2
    exit 1
  fi
done
mkdir -p "$dir"
dir=$(cd "$dir" && pwd)
case "$dir" in
*[[:space:]#=]*)
  echo "local-cluster.sh: $dir: slurm.conf cannot hold a path with spaces, # or =" >&2
  exit 2
  ;;
esac
mkdir -p "$dir"/{munge,state,spool,log,run}
chmod 700 "$dir/munge"
trap 'stop' ERR
[ -s "$dir/munge/munge.key" ] || mungekey -c -k "$dir/munge/munge.key" >/dev/null
munged --force --socket="$dir/munge/munge.socket" --key-file="$dir/munge/munge.key" \
  --pid-file="$dir/run/munged.pid" --log-file="$dir/log/munged.log" \
  --seed-file="$dir/munge/munged.seed"
# Two distinct free ports, found while both are held.
read -r ctld_port d_port < <(python3 -c '
import socket
a, b = socket.socket(), socket.socket()
a.bind(("", 0)); b.bind(("", 0))
print(a.getsockname()[1], b.getsockname()[1])')
host=$(hostname -s)
cpus=$(nproc)
cat > "$dir/slurm.conf" <<CONF
ClusterName=fxshade
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$dir/munge/munge.socket
CredType=cred/munge
ProctrackType=proctrack/pgid
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
SlurmctldPort=$ctld_port
SlurmdPort=$d_port
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MinJobAge=3600
ReturnToService=2
NodeName=$host CPUs=$cpus State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$dir/slurm.conf"
slurmctld -f "$SLURM_CONF" -i
slurmd -f "$SLURM_CONF"
# Ready when the node takes jobs.
# (A bound only so that a broken set-up ends: 10 minutes.)
for _ in $(seq 3000); do
  if sinfo -h -o %T 2>/dev/null | grep -qE '^(idle|mixed|allocated)'; then
    echo "export SLURM_CONF=$SLURM_CONF"
    exit 0
  fi
  sleep 0.2
done
echo "local-cluster.sh: the node did not come up; logs in $dir/log" >&2
stop
exit 1
