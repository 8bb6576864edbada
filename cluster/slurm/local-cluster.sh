#!/usr/bin/env bash
# A one-node SLURM cluster on this machine, for trying the recipes in this folder and for
# tests/test_slurm.py: Debian's slurm-wlm (slurmctld + slurmd, authenticated by munge), every file
# it writes under one directory, no cgroups and no systemd, so it runs in a container too.
#
#   local-cluster.sh install    apt-get install slurmctld, slurmd, slurm-client and munge
#                               (with sudo when not root); does not start anything
#   local-cluster.sh start DIR  write DIR/slurm.conf and a fresh munge key, start munged,
#                               slurmctld and slurmd, wait until the node takes jobs
#   local-cluster.sh stop DIR   cancel every job, wait for them to end, stop the daemons, then
#                               end any process still carrying this cluster's SLURM_CONF
#
# After `start`, `export SLURM_CONF=DIR/slurm.conf` points sbatch, squeue, scancel and srun at it.
# The node is this machine as `slurmd -C` sees it (CPUs, RealMemory), in partition `local`.
# Processes are tracked by their parent-child links (proctrack/linuxproc) and not bound to CPUs
# (task/none), so a job sees every CPU of the machine whatever it booked. The daemons run as the
# user who starts them (SlurmUser): root's cluster runs anyone's jobs, another user's only their
# own. Bounds: START_LIMIT_S (default 60) for the node to come up; STOP_LIMIT_S (default 60) for
# the jobs to end before they are killed.
set -euo pipefail

START_LIMIT_S=${START_LIMIT_S:-60}
STOP_LIMIT_S=${STOP_LIMIT_S:-60}
NODE=moonbot-local

log() { printf '[local-slurm] %s\n' "$*" >&2; }
die() { log "$*"; exit 1; }

install() {
    local sudo=""
    [ "$(id -u)" -eq 0 ] || sudo=sudo
    if command -v slurmctld >/dev/null && command -v slurmd >/dev/null && command -v sbatch >/dev/null \
            && command -v munged >/dev/null; then
        return
    fi
    log "installing slurmctld slurmd slurm-client munge"
    $sudo apt-get update -qq
    # Debian's maintainer scripts would start the system's munged and slurm daemons where an init
    # system runs; `start` runs its own, so those are neither needed nor in the way (other ports,
    # other sockets).
    $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
        slurmctld slurmd slurm-client munge
}

# free_ports N: N distinct TCP ports nothing listens on now (the kernel's choices for port 0, all
# held at once so that none is chosen twice).
free_ports() {
    python3 -c 'import socket, sys
held = [socket.socket() for _ in range(int(sys.argv[1]))]
for s in held: s.bind(("127.0.0.1", 0))
print(*(s.getsockname()[1] for s in held))' "$1"
}

# parent PID: its parent's pid (0 once past init, or when PID is gone).
parent() { awk '{print $4}' "/proc/$1/stat" 2>/dev/null || echo 0; }

# related PID: whether PID is this script, one of its ancestors (the caller) or descendants (the
# commands it runs, which inherit SLURM_CONF from it).
related() {
    local pid=$1 p=$$
    while [ "$p" -gt 1 ]; do [ "$p" = "$pid" ] && return 0; p=$(parent "$p"); done
    p=$pid
    while [ "$p" -gt 1 ]; do [ "$p" = $$ ] && return 0; p=$(parent "$p"); done
    return 1
}

# cluster_pids CONF: the processes whose environment holds SLURM_CONF=CONF — the daemons (started
# with it), the slurmstepd they fork and the jobs (sbatch passes the submitter's environment on) —
# other than this script, its callers and its own commands.
cluster_pids() {
    local conf=$1 pid
    for pid in $(ls /proc | grep -E '^[0-9]+$'); do
        { tr '\0' '\n' < "/proc/$pid/environ"; } 2>/dev/null | grep -qxF "SLURM_CONF=$conf" || continue
        related "$pid" || echo "$pid"
    done
    return 0
}

start() {
    local dir
    dir=$(realpath -m "$1")
    [ ! -e "$dir/slurm.conf" ] || die "$dir/slurm.conf exists: stop that cluster and remove $dir first"
    for exe in munged mungekey slurmctld slurmd sinfo; do
        command -v "$exe" >/dev/null || die "$exe not found: run '$0 install' (Debian: slurmctld slurmd slurm-client munge)"
    done
    mkdir -p "$dir"/{munge,ctld,spool,log}
    chmod 700 "$dir" "$dir/munge"
    local user node_line ctld_port slurmd_port
    user=$(id -un)
    # The node as slurmd detects it, so that slurmd does not drain it for a mismatch; `slurmd -C`
    # prints `NodeName=<host> CPUs=… RealMemory=…` and a second line with the uptime.
    node_line=$(slurmd -C | head -n 1 | sed -E 's/^NodeName=[^ ]+ //')
    read -r ctld_port slurmd_port < <(free_ports 2)
    cat > "$dir/slurm.conf" <<EOF
# Written by cluster/slurm/local-cluster.sh: a one-node cluster on $(hostname -s).
ClusterName=moonbot-local
SlurmctldHost=$(hostname -s)(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=$user
SlurmdUser=$user
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$dir/munge/munge.socket
StateSaveLocation=$dir/ctld
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
# No cgroups (a container may not delegate them): processes are tracked by their parent links
# and not confined to the CPUs or memory they booked.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
SlurmdTimeout=60
InactiveLimit=0
KillWait=10
NodeName=$NODE NodeAddr=127.0.0.1 NodeHostname=$(hostname -s) $node_line State=UNKNOWN
PartitionName=local Nodes=$NODE Default=YES MaxTime=INFINITE State=UP
EOF
    mungekey --create --keyfile="$dir/munge/munge.key" --force
    chmod 600 "$dir/munge/munge.key"
    export SLURM_CONF="$dir/slurm.conf"
    munged --force --socket="$dir/munge/munge.socket" --key-file="$dir/munge/munge.key" \
        --pid-file="$dir/munge/munged.pid" --log-file="$dir/log/munged.log" --seed-file="$dir/munge/munged.seed"
    # -i: ignore state files (a fresh cluster); both daemonize and write their pid files.
    slurmctld -i -f "$SLURM_CONF"
    slurmd -N "$NODE" -f "$SLURM_CONF"
    local deadline=$((SECONDS + START_LIMIT_S)) state=""
    while [ "$SECONDS" -lt "$deadline" ]; do
        state=$(sinfo -h -n "$NODE" -o '%T' 2>/dev/null || true)
        case "$state" in idle|mixed|allocated) log "node $NODE is $state; export SLURM_CONF=$SLURM_CONF"; return 0 ;; esac
        sleep 1
    done
    log "node $NODE not up after $START_LIMIT_S s (state: ${state:-none}); logs in $dir/log"
    tail -n 20 "$dir"/log/*.log >&2 || true
    stop "$dir"
    return 1
}

stop() {
    local dir
    dir=$(realpath -m "$1")
    export SLURM_CONF="$dir/slurm.conf"
    [ -e "$SLURM_CONF" ] || { log "no $SLURM_CONF: nothing to stop"; return 0; }
    # Cancel every job while slurmctld and slurmd still run, so that each ends as SLURM ends it.
    if [ -s "$dir/slurmctld.pid" ] && kill -0 "$(cat "$dir/slurmctld.pid")" 2>/dev/null; then
        scancel --full --quiet --partition=local 2>/dev/null || true
        local deadline=$((SECONDS + STOP_LIMIT_S))
        while [ "$SECONDS" -lt "$deadline" ] && [ -n "$(squeue -h -o %i 2>/dev/null || true)" ]; do sleep 1; done
    fi
    local name pid
    for name in slurmd slurmctld munge/munged; do
        pid=$(cat "$dir/$name.pid" 2>/dev/null || true)
        if [ -n "$pid" ]; then kill "$pid" 2>/dev/null || true; fi
    done
    # Whatever is left of this cluster (a job that ignored scancel, a slurmstepd, a daemon that
    # did not stop): SIGTERM after 5 s, SIGKILL after 10 more.
    local left signal
    for signal in TERM KILL; do
        for _ in $(seq 5); do
            left=$(cluster_pids "$SLURM_CONF")
            [ -z "$left" ] && return 0
            sleep 1
        done
        log "SIG$signal to what is left: $(echo $left)"
        kill "-$signal" $left 2>/dev/null || true
        [ "$signal" = TERM ] && sleep 5
    done
}

case "${1:-}" in
    install) install ;;
    start) [ $# -eq 2 ] || die "usage: $0 start DIR"; start "$2" ;;
    stop) [ $# -eq 2 ] || die "usage: $0 stop DIR"; stop "$2" ;;
    *) sed -n '2,19p' "$0" | sed 's/^# \{0,1\}//'; exit 2 ;;
esac
