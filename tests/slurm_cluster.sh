#!/usr/bin/env bash
# A real single-host SLURM cluster for the tests: munged, slurmctld and two
# slurmd (nodes n1 and n2 on this host, each on its own port), everything
# (key, state, spool, logs, sockets) inside DIR, nothing in /etc or /run.
#   bash tests/slurm_cluster.sh start DIR   → DIR/env (source it: SLURM_CONF)
#   bash tests/slurm_cluster.sh stop DIR    → every daemon it started, by PID
# Exits 77 (ctest's skip) when slurm-wlm or munge is not installed.
set -euo pipefail
cmd=${1:?usage: slurm_cluster.sh start|stop DIR} dir=${2:?usage: slurm_cluster.sh start|stop DIR}

stop() {
  for f in "$dir"/pids/*.pid; do
    [ -f "$f" ] || continue
    pid=$(cat "$f")
    kill "$pid" 2>/dev/null || true
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$pid" 2>/dev/null || true
    rm -f "$f"
  done
}

# Ports nobody listens on now (the kernel hands out a free one per socket).
free_ports() {
  python3 -c '
import socket
ss = [socket.socket() for _ in range(int(__import__("sys").argv[1]))]
for s in ss: s.bind(("127.0.0.1", 0))
print(" ".join(str(s.getsockname()[1]) for s in ss))' "$1"
}

start() {
  for tool in munged slurmctld slurmd sbatch srun; do
    command -v "$tool" >/dev/null || { echo "slurm_cluster: $tool not installed (apt-get install slurm-wlm munge)" >&2; exit 77; }
  done
  rm -rf "$dir" && mkdir -p "$dir"/{munge,state,spool,log,pids}
  chmod 700 "$dir/munge"
  head -c 1024 /dev/urandom > "$dir/munge/munge.key" && chmod 400 "$dir/munge/munge.key"
  munged --force --key-file "$dir/munge/munge.key" --socket "$dir/munge/socket" \
    --pid-file "$dir/pids/munged.pid" --log-file "$dir/log/munged.log" --seed-file "$dir/munge/seed"
  read -r ctld_port n1_port n2_port < <(free_ports 3)
  host=$(hostname -s)
  cat > "$dir/slurm.conf" <<CONF
ClusterName=reefgen-test
SlurmctldHost=$host
SlurmctldPort=$ctld_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$dir/munge/socket
CredType=cred/munge
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool/%n
SlurmctldPidFile=$dir/pids/slurmctld.pid
SlurmdPidFile=$dir/pids/slurmd-%n.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd-%n.log
PlugStackConfig=$dir/plugstack.conf
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SlurmdParameters=config_overrides
ReturnToService=2
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
InactiveLimit=0
KillWait=5
MinJobAge=300
NodeName=n1 NodeHostname=$host Port=$n1_port CPUs=2 State=UNKNOWN
NodeName=n2 NodeHostname=$host Port=$n2_port CPUs=2 State=UNKNOWN
PartitionName=test Nodes=n1,n2 Default=YES MaxTime=INFINITE State=UP OverSubscribe=YES
CONF
  : > "$dir/plugstack.conf"
  echo "export SLURM_CONF=$dir/slurm.conf" > "$dir/env"
  export SLURM_CONF=$dir/slurm.conf
  slurmctld -f "$SLURM_CONF"
  slurmd -f "$SLURM_CONF" -N n1
  slurmd -f "$SLURM_CONF" -N n2
  # Up when both nodes answer as idle (a few seconds); say why if not.
  for _ in $(seq 150); do
    [ "$(sinfo -h -N -o '%t' 2>/dev/null | grep -c '^idle')" = 2 ] && return 0
    sleep 0.2
  done
  echo "slurm_cluster: the nodes did not come up in 30 s; logs in $dir/log" >&2
  sinfo -N >&2 || true
  tail -n 5 "$dir"/log/*.log >&2 || true
  stop
  exit 1
}

case "$cmd" in
  start) start ;;
  stop) stop ;;
  *) echo "slurm_cluster: start or stop, not $cmd" >&2; exit 2 ;;
esac
