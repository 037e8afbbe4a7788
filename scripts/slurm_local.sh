#!/usr/bin/env bash
# Bring up a one-node Slurm on this machine (Debian's slurm-wlm and munge:
# munged, slurmctld and slurmd), for tests/slurm.rs. Source it or run it; it
# prints the SLURM_CONF to export. A machine where `sinfo` already answers
# (a real cluster) is left alone.
#
#   scripts/setup.sh slurm-wlm munge      # the packages, when missing
#   eval "$(scripts/slurm_local.sh)"      # exports SLURM_CONF
#   scripts/slurm_local.sh stop           # stops what it started
#
# Everything it writes lives in $SWARMSHOT_SLURM_DIR (default
# /tmp/swarmshot-slurm): slurm.conf, the state, logs and pid files; nothing
# in /etc is changed. Slurm runs as the calling user (root on CI), with
# process tracking by /proc and no cgroups, so it also runs in a container.
set -euo pipefail

dir="${SWARMSHOT_SLURM_DIR:-/tmp/swarmshot-slurm}"
conf="$dir/slurm.conf"

stop() {
  for name in slurmd slurmctld munged; do
    if [ -f "$dir/$name.pid" ]; then
      pid=$(cat "$dir/$name.pid")
      kill "$pid" 2>/dev/null || true
      rm -f "$dir/$name.pid"
    fi
  done
}

if [ "${1:-}" = stop ]; then
  stop
  exit 0
fi

if [ -z "${SWARMSHOT_SLURM_DIR:-}" ] && [ -z "${SLURM_CONF:-}" ] && [ -f /etc/slurm/slurm.conf ] \
  && command -v sinfo >/dev/null 2>&1 && timeout 10 sinfo -h >/dev/null 2>&1; then
  echo "slurm_local: a Slurm cluster already answers (sinfo); using it" >&2
  exit 0
fi

for tool in munged munge slurmctld slurmd sbatch scontrol; do
  command -v "$tool" >/dev/null 2>&1 || {
    echo "slurm_local: $tool not found; install Debian's slurm-wlm and munge (scripts/setup.sh slurm-wlm munge)" >&2
    exit 1
  }
done

mkdir -p "$dir/state" "$dir/spool" "$dir/munge"
user=$(id -un)
host=$(hostname -s)
cpus=$(nproc)

# munge: its own key and socket in $dir, so a system munged is not needed.
if [ ! -S "$dir/munge/munge.socket" ] || ! munge -n -S "$dir/munge/munge.socket" >/dev/null 2>&1; then
  if [ ! -f "$dir/munge/munge.key" ]; then
    dd if=/dev/urandom of="$dir/munge/munge.key" bs=1 count=128 status=none
  fi
  chmod 700 "$dir/munge"
  chmod 400 "$dir/munge/munge.key"
  rm -f "$dir/munge/munge.socket" "$dir/munge/munge.socket.lock"
  munged --force --key-file="$dir/munge/munge.key" --socket="$dir/munge/munge.socket" \
    --pid-file="$dir/munged.pid" --log-file="$dir/munged.log" --seed-file="$dir/munge/munge.seed"
  for _ in $(seq 50); do
    munge -n -S "$dir/munge/munge.socket" >/dev/null 2>&1 && break
    sleep 0.1
  done
fi

cat > "$conf.new" <<EOF
# Written by scripts/slurm_local.sh: a one-node Slurm for swarmshot's tests.
ClusterName=swarmshot
SlurmctldHost=$host
SlurmUser=$user
SlurmdUser=$user
AuthType=auth/munge
AuthInfo=socket=$dir/munge/munge.socket
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
SlurmctldPort=6917
SlurmdPort=6918
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
SwitchType=switch/none
ReturnToService=2
SlurmdTimeout=30
InactiveLimit=0
KillWait=5
NodeName=$host CPUs=$cpus State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
mv "$conf.new" "$conf"
export SLURM_CONF="$conf"

running() { [ -f "$dir/$1.pid" ] && kill -0 "$(cat "$dir/$1.pid")" 2>/dev/null; }
running slurmctld || slurmctld -f "$conf"
running slurmd || slurmd -f "$conf"

# Wait until the node takes jobs.
for _ in $(seq 100); do
  state=$(sinfo -h -n "$host" -o %t 2>/dev/null || true)
  case "$state" in
    idle*|mix*|alloc*) break ;;
    down*|drain*) scontrol update nodename="$host" state=resume >/dev/null 2>&1 || true ;;
  esac
  sleep 0.2
done
state=$(sinfo -h -n "$host" -o %t 2>/dev/null || true)
case "$state" in
  idle*|mix*|alloc*) ;;
  *)
    echo "slurm_local: the node is not up (state '${state}'); logs in $dir" >&2
    tail -n 20 "$dir/slurmctld.log" "$dir/slurmd.log" >&2 || true
    exit 1
    ;;
esac
echo "slurm_local: one-node Slurm up ($host, $cpus CPUs), SLURM_CONF=$conf" >&2
echo "export SLURM_CONF=$conf"
