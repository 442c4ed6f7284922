#!/usr/bin/env bash
# slurm_local.sh — a throwaway one-node Slurm on localhost (munge, slurmctld,
# slurmd) in a directory of its own, for the farm tests and measurements.
#   tools/slurm_local.sh start DIR   start it; prints `export SLURM_CONF=DIR/slurm.conf`
#   tools/slurm_local.sh stop DIR    stop the daemons it started, by their pids
# Everything (keys, sockets, state, spool, logs, pids) lives under DIR; nothing
# is read from or written to /etc or /run. No systemd, no cgroups: process
# tracking by /proc (proctrack/linuxproc) and no task plugin, so it runs in a
# container. The daemons run as the user who starts it (root only here, for a
# cluster that lives for one test).
set -u
cmd=${1:-}
dir=${2:-}
if [ -z "$cmd" ] || [ -z "$dir" ]; then
    echo "usage: $0 start|stop DIR" >&2
    exit 2
fi

# stop: the pids this script wrote, newest first (slurmd, slurmctld, munged);
# TERM, then KILL for any still alive after five seconds
stop() {
    [ -f "$dir/pids" ] || return 0
    # first the jobs still on this cluster (their processes are not the
    # daemons' children once started), two seconds at most
    if [ -f "$dir/slurm.conf" ]; then
        SLURM_CONF=$dir/slurm.conf scancel -u "$(id -un)" 2> /dev/null
        for _ in $(seq 20); do
            [ -z "$(SLURM_CONF=$dir/slurm.conf squeue -h 2> /dev/null)" ] && break
            sleep 0.1
        done
    fi
    local pids
    pids=$(tac "$dir/pids")
    for p in $pids; do kill -TERM "$p" 2>/dev/null; done
    for _ in $(seq 50); do
        local alive=0
        for p in $pids; do kill -0 "$p" 2>/dev/null && alive=1; done
        [ $alive -eq 0 ] && break
        sleep 0.1
    done
    for p in $pids; do kill -KILL "$p" 2>/dev/null; done
    rm -f "$dir/pids"
}

if [ "$cmd" = stop ]; then
    stop
    exit 0
fi
[ "$cmd" = start ] || { echo "$0: unknown command '$cmd' (start or stop)" >&2; exit 2; }
for exe in munged slurmctld slurmd sinfo; do
    command -v "$exe" > /dev/null || { echo "$0: $exe is not installed (tools/setup.sh installs slurm-wlm and munge)" >&2; exit 2; }
done

mkdir -p "$dir"/{munge,state,spool,log,run}
dir=$(cd "$dir" && pwd)
chmod 700 "$dir" "$dir/munge"
user=$(id -un)

# two free TCP ports for slurmctld and slurmd (the kernel picks them), so
# clusters of parallel tests do not collide
read -r ctl_port node_port < <(python3 - << 'EOF'
import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("127.0.0.1", 0))
print(*[x.getsockname()[1] for x in s])
EOF
)

# munge: a fresh 1 KiB key, its own socket; checked with a round trip
head -c 1024 /dev/urandom > "$dir/munge/munge.key"
chmod 400 "$dir/munge/munge.key"
munged --force --key-file="$dir/munge/munge.key" --socket="$dir/munge/munge.sock" \
       --pid-file="$dir/munge/munged.pid" --log-file="$dir/log/munged.log" --seed-file="$dir/munge/seed" \
    || { echo "$0: munged did not start ($dir/log/munged.log)" >&2; exit 1; }
cat "$dir/munge/munged.pid" >> "$dir/pids"
if ! munge -S "$dir/munge/munge.sock" -n | unmunge -S "$dir/munge/munge.sock" > /dev/null; then
    echo "$0: munge round trip failed ($dir/log/munged.log)" >&2
    stop
    exit 1
fi

# the essentials for one node (CPUs from getconf: nproc would follow
# OMP_NUM_THREADS) without systemd or cgroups; CR_Core lets
# 1-CPU tasks share the node; RealMemory left out (a value above the host's
# drains the node); MinJobAge short so finished jobs leave squeue soon
cat > "$dir/slurm.conf" << EOF
ClusterName=kerflocal
SlurmctldHost=localhost
SlurmctldPort=$ctl_port
SlurmdPort=$node_port
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge/munge.sock
SlurmUser=$user
SlurmdUser=$user
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
SchedulerType=sched/backfill
SchedulerParameters=sched_interval=1,bf_interval=1
MinJobAge=60
MessageTimeout=20
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$(getconf _NPROCESSORS_ONLN) State=UNKNOWN
PartitionName=main Nodes=localhost Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$dir/slurm.conf

# -D keeps each daemon in the foreground so $! is its pid
slurmctld -D -i -f "$SLURM_CONF" > "$dir/log/slurmctld.out" 2>&1 &
echo $! >> "$dir/pids"
slurmd -D -N localhost -f "$SLURM_CONF" > "$dir/log/slurmd.out" 2>&1 &
echo $! >> "$dir/pids"

# ready when the node is idle (20 s at most)
for _ in $(seq 200); do
    state=$(sinfo -h -N -o %t 2>/dev/null | head -1)
    [ "$state" = idle ] && break
    sleep 0.1
done
if [ "$state" != idle ]; then
    echo "$0: the node did not come up (state '${state:-none}'; logs in $dir/log)" >&2
    stop
    exit 1
fi
echo "export SLURM_CONF=$SLURM_CONF"
