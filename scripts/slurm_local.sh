#!/usr/bin/env bash
# A single-node Slurm cluster on this machine, for tests and for trying scripts/slurm_sweep.sh without a real
# cluster. Everything lives under DIR (munge key, socket and log; slurm.conf; state, spool, pid and log files):
# nothing in /etc or /var is read or written, so it runs beside a system Slurm or munge and leaves no trace.
#
#   scripts/slurm_local.sh start DIR   starts munged, slurmctld and slurmd (as root) and waits until the node is
#                                      idle; prints the line to export (SLURM_CONF=DIR/slurm.conf)
#   scripts/slurm_local.sh stop DIR    stops them by their pid files and waits for them to exit
#   scripts/slurm_local.sh env DIR     prints `export SLURM_CONF=...` (eval "$(scripts/slurm_local.sh env DIR)")
#
# Every client command (sinfo, sbatch, squeue, scancel) must see SLURM_CONF=DIR/slurm.conf. Start is idempotent:
# daemons left by an earlier start in DIR (even a crashed one) are stopped and the cluster's state is cleared
# first. Exits 77 (ctest's "skipped") when not root or when slurm-wlm or munge is not installed, 1 when a daemon
# does not come up (its log is printed). Needs Debian 12's slurm-wlm (22.05) and munge (scripts/setup.sh).
set -euo pipefail

SKIP=77
usage() {
  echo "usage: $0 start|stop|env DIR" >&2
  exit 2
}
[ $# -eq 2 ] || usage
cmd=$1
dir=$2
case $cmd in start | stop | env) ;; *) usage ;; esac
if [ "$cmd" = stop ] && [ ! -d "$dir" ]; then
  echo "slurm_local: no cluster in $dir (no such directory)"
  exit 0
fi
mkdir -p "$dir"
dir=$(cd "$dir" && pwd)  # absolute: the daemons and the job's tasks run in other directories
conf=$dir/slurm.conf

if [ "$cmd" = env ]; then
  echo "export SLURM_CONF=$conf"
  exit 0
fi

# Whether process $1 runs: a zombie has exited (the daemons are orphans, and an init that is slow to reap them,
# as in some containers, leaves them as zombies for a while).
alive() {
  local state
  state=$(sed -n 's/^State:[[:space:]]*\([A-Z]\).*/\1/p' /proc/"$1"/status 2>/dev/null || true)
  [ -n "$state" ] && [ "$state" != Z ]
}

# Stops the daemon whose pid file is $1 (if it runs) and waits up to 20 s for it to exit, then SIGKILLs it. A pid
# file naming a process of another program (a pid reused after a reboot) is left alone.
stop_daemon() {
  local pidfile=$1 name=$2 pid i
  [ -f "$pidfile" ] || return 0
  pid=$(cat "$pidfile" 2>/dev/null || true)
  rm -f "$pidfile"
  [[ "$pid" =~ ^[0-9]+$ ]] || return 0
  [ "$(cat /proc/"$pid"/comm 2>/dev/null || true)" = "$name" ] || return 0
  kill -TERM "$pid" 2>/dev/null || return 0
  for i in $(seq 1 200); do
    alive "$pid" || return 0
    sleep 0.1
  done
  echo "slurm_local: $name (pid $pid) did not exit in 20 s; killing it" >&2
  kill -KILL "$pid" 2>/dev/null || true
}

stop_all() {
  # slurmd first (it would report to a controller that is gone), munged last (both daemons authenticate with it).
  stop_daemon "$dir/slurmd.pid" slurmd
  stop_daemon "$dir/slurmctld.pid" slurmctld
  stop_daemon "$dir/munged.pid" munged
}

if [ "$cmd" = stop ]; then
  stop_all
  echo "slurm_local: stopped the cluster in $dir"
  exit 0
fi

# --- start ---
if [ "$(id -u)" -ne 0 ]; then
  echo "slurm_local: skipped: the local cluster runs its daemons as root (SlurmUser=root); run as root" >&2
  exit $SKIP
fi
missing=()
for prog in munged mungekey slurmctld slurmd sinfo sbatch squeue scancel; do
  command -v "$prog" >/dev/null 2>&1 || [ -x "/usr/sbin/$prog" ] || missing+=("$prog")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "slurm_local: skipped: ${missing[*]} not found; install the Debian packages slurm-wlm and munge" \
    "(scripts/setup.sh does)" >&2
  exit $SKIP
fi
export PATH=$PATH:/usr/sbin

stop_all  # an earlier start's daemons in this DIR
rm -rf "$dir/state" "$dir/spool" "$dir/munge"
mkdir -p "$dir/state" "$dir/spool" "$dir/munge" "$dir/log"
# munged refuses a key or socket directory that others may write: DIR itself may be anything (a mktemp -d is
# 0700), so its files live in a 0700 subdirectory.
chmod 0700 "$dir/munge"
mungekey --create --keyfile="$dir/munge/munge.key" --force >/dev/null 2>&1 ||
  dd if=/dev/urandom of="$dir/munge/munge.key" bs=1024 count=1 status=none
chmod 0600 "$dir/munge/munge.key"
rm -f "$dir/munge/munge.sock" "$dir/munge/munge.sock.lock"

# The log of a daemon that did not come up, and failure.
fail() {
  echo "slurm_local: $1" >&2
  shift
  for f in "$@"; do
    [ -f "$f" ] && {
      echo "--- $f (last 30 lines)" >&2
      tail -n 30 "$f" >&2
    }
  done
  stop_all
  exit 1
}

munged --socket="$dir/munge/munge.sock" --pid-file="$dir/munged.pid" --log-file="$dir/log/munged.log" \
  --key-file="$dir/munge/munge.key" --seed-file="$dir/munge/munged.seed" --force ||
  fail "munged did not start" "$dir/log/munged.log"
# munged forks and writes its pid file; credentials round-trip once it serves the socket.
for i in $(seq 1 50); do
  munge -s ok --socket="$dir/munge/munge.sock" 2>/dev/null | unmunge --socket="$dir/munge/munge.sock" \
    >/dev/null 2>&1 && break
  [ "$i" -eq 50 ] && fail "munged does not answer on $dir/munge/munge.sock" "$dir/log/munged.log"
  sleep 0.1
done

# Two free TCP ports for the controller and the node daemon: the kernel's choice of a free port at bind time.
read -r ctld_port slurmd_port < <(python3 -c '
import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("127.0.0.1", 0))
print(*[x.getsockname()[1] for x in s])')

host=$(hostname -s)
cpus=$(nproc)
# Modest and below the machine's memory: a node claiming more than it has is drained ("Low RealMemory").
mem_mib=$(awk '/MemTotal/ { m = int($2 / 1024 / 2); print (m < 1024 ? m : 1024) }' /proc/meminfo)

cat >"$conf" <<EOF
# A single-node cluster written by scripts/slurm_local.sh: everything under $dir.
ClusterName=rtulocal
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge/munge.sock
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
PlugStackConfig=$dir/plugstack.conf
MailProg=/bin/true
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SwitchType=switch/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
# Tasks share the node CPU by CPU, so an array's tasks run side by side.
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
SlurmdTimeout=60
InactiveLimit=0
KillWait=5
MinJobAge=300
MaxArraySize=10001
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem_mib State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
: >"$dir/plugstack.conf"  # no SPANK plugins (not /etc/slurm/plugstack.conf)
export SLURM_CONF=$conf

slurmctld -f "$conf" -i || fail "slurmctld did not start" "$dir/log/slurmctld.log"
slurmd -f "$conf" -N "$host" || fail "slurmd did not start" "$dir/log/slurmd.log"

# Up when the controller answers and the node is idle: bounded, 60 s.
state=""
for i in $(seq 1 120); do
  state=$(sinfo -h -N -n "$host" -o '%t' 2>/dev/null | head -n 1 || true)
  [ "$state" = idle ] && break
  sleep 0.5
done
[ "$state" = idle ] ||
  fail "the node $host is not idle after 60 s (sinfo says '${state:-no answer}')" \
    "$dir/log/slurmctld.log" "$dir/log/slurmd.log"
echo "slurm_local: node $host idle ($cpus CPUs); export SLURM_CONF=$conf"
