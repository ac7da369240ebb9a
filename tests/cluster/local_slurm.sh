#!/usr/bin/env bash
# A one-node SLURM cluster on this machine, for tests/test_slurm.py (pytest marker `slurm`).
#
#   tests/cluster/local_slurm.sh install      the Debian packages only (root, apt-get)
#   tests/cluster/local_slurm.sh start DIR    install if needed, configure, start every daemon,
#                                             return once the node is idle (a start that fails
#                                             stops what it had started)
#   tests/cluster/local_slurm.sh stop DIR     cancel the jobs, stop every daemon started from DIR
#   tests/cluster/local_slurm.sh env DIR      the variables that point clients at the cluster
#
# Everything lives under DIR (keep it short: it holds unix sockets, at most 107 bytes long):
# configuration, spool, logs, the database and the munge key. The one file outside it is the
# symlink /etc/slurm/slurm.conf -> DIR/etc/slurm.conf: snakemake's SLURM jobstep executor drops
# SLURM_CONF from the environment of the `srun` it runs inside each job, so `srun` only finds
# the cluster at the default path. A slurm.conf there that this script did not write is never
# touched (exit 77: a real SLURM installation is not ours to reconfigure).
#
# Daemons, all bound to 127.0.0.1:
#   munged     authentication (own key and socket, so a system munged is left alone)
#   mariadbd   the accounting database (own data directory, TCP on 127.0.0.1 only)
#   slurmdbd   accounting, as on production clusters: the executor plugin validates the
#              account with `sacctmgr` (and reads failure reasons, or job states where the
#              profile does not ask for squeue, with `sacct`); the test reads every job's
#              account, partition, memory, time limit and state back from `sacct`
#   slurmctld  controller;  slurmd  the one compute node (this machine's CPUs and memory)
#
# One such cluster at a time: `start` stops one left behind whose daemons are gone, and exits
# 77 while another one runs, unless RF_SLURM_TAKEOVER=1 says that its owner is known to be gone
# (tests/test_slurm.py holds a lock across start and stop and sets it).
#
# Exit status 77: SLURM cannot be installed or started here (not root, no apt-get, the
# packages cannot be fetched, a foreign slurm.conf, another test cluster running, ports taken);
# the last line says why.
# Settings (environment): RF_SLURM_ACCOUNT (rftest), RF_SLURM_PARTITION (rfdebug),
# RF_SLURM_CLUSTER (roughflow-test), RF_SLURM_PORT (16817; it and the next three ports).
set -euo pipefail

PACKAGES=(slurmctld slurmd slurm-client slurmdbd munge mariadb-server-core mariadb-client-core)
ACCOUNT=${RF_SLURM_ACCOUNT:-rftest}
PARTITION=${RF_SLURM_PARTITION:-rfdebug}
CLUSTER=${RF_SLURM_CLUSTER:-roughflow-test}
PORT=${RF_SLURM_PORT:-16817}
CTLD_PORT=$PORT SLURMD_PORT=$((PORT + 1)) DBD_PORT=$((PORT + 2)) DB_PORT=$((PORT + 3))
SYSTEM_CONF=/etc/slurm/slurm.conf
MARKER="# written by roughflow tests/cluster/local_slurm.sh"

log() { echo "local_slurm: $*" >&2; }
skip() { echo "local_slurm: cannot run SLURM here: $*" >&2; exit 77; }
die() { echo "local_slurm: error: $*" >&2; exit 1; }

# Polls "$@" every 0.5 s until it succeeds; fails once $1 seconds have passed ($2 names it).
wait_for() {
    local deadline=$((SECONDS + $1)) what=$2
    shift 2
    until "$@" >/dev/null 2>&1; do
        [ "$SECONDS" -lt "$deadline" ] || return 1
        sleep 0.5
    done
    log "$what: ok"
}

installed() {
    local p
    for p in "${PACKAGES[@]}"; do
        dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || return 1
    done
}

cmd_install() {
    if installed; then
        return 0
    fi
    [ "$(id -u)" = 0 ] || skip "the packages ${PACKAGES[*]} are not installed and this is not root"
    command -v apt-get >/dev/null || skip "the SLURM packages are not installed and there is no apt-get"
    log "installing ${PACKAGES[*]}"
    local out
    # Postinst scripts would start the packaged services (system munge, slurmd on the
    # default ports): the cluster here is started by hand, from DIR, so they stay off.
    if ! out=$( (apt-get update -q && DEBIAN_FRONTEND=noninteractive RUNLEVEL=1 \
            apt-get install -y -q --no-install-recommends "${PACKAGES[@]}") 2>&1); then
        skip "apt-get could not install the packages: $(tail -n 3 <<<"$out" | tr '\n' ' ')"
    fi
    installed || skip "apt-get finished but the packages are not all installed"
}

port_taken() { (exec 3<>"/dev/tcp/127.0.0.1/$1") 2>/dev/null; }

pid_alive() { [ -s "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null; }

# Memory limits enforced by the kernel, as on production clusters (a job over its --mem is
# killed, OUT_OF_MEMORY), where a writable cgroup v1 memory hierarchy exists (Slurm 22.05's
# cgroup v2 support needs systemd as init). Elsewhere jobs are only tracked through /proc and
# killed by the accounting poller when seen over their request.
tracking() {
    local dir=$1
    if [ -e /sys/fs/cgroup/memory/memory.limit_in_bytes ] \
        && mkdir /sys/fs/cgroup/memory/roughflow-probe.$$ 2>/dev/null; then
        rmdir /sys/fs/cgroup/memory/roughflow-probe.$$
        printf '%s\n' CgroupPlugin=cgroup/v1 CgroupMountpoint=/sys/fs/cgroup \
            ConstrainRAMSpace=yes ConstrainSwapSpace=yes AllowedSwapSpace=0 \
            >"$dir/etc/cgroup.conf"
        echo "ProctrackType=proctrack/cgroup"
        echo "TaskPlugin=task/cgroup"
    else
        echo "ProctrackType=proctrack/linuxproc"
        echo "TaskPlugin=task/none"
        echo "JobAcctGatherParams=OverMemoryKill"
    fi
}

write_config() {
    local dir=$1 node cpus
    node=$(hostname -s)
    # the node as slurmd sees it (CPUs, sockets, cores, threads, RealMemory)
    cpus=$(slurmd -C | head -n 1 | sed -e 's/^NodeName=[^ ]* //')
    mkdir -p "$dir"/{etc,log,run,spool/ctld,spool/d,munge,db}
    chmod 700 "$dir" "$dir/munge"
    cat >"$dir/etc/slurm.conf" <<EOF
$MARKER (state in $dir)
ClusterName=$CLUSTER
SlurmctldHost=$node(127.0.0.1)
SlurmctldPort=$CTLD_PORT
SlurmdPort=$SLURMD_PORT
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$dir/munge/munge.socket
CredType=cred/munge
StateSaveLocation=$dir/spool/ctld
SlurmdSpoolDir=$dir/spool/d
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
$(tracking "$dir")
MpiDefault=none
SwitchType=switch/none
ReturnToService=2
SchedulerType=sched/backfill
# CPUs and memory are both consumable: --mem requests are scheduled as on a real cluster
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU_Memory
JobAcctGatherType=jobacct_gather/linux
JobAcctGatherFrequency=5
AccountingStorageType=accounting_storage/slurmdbd
AccountingStorageHost=127.0.0.1
AccountingStoragePort=$DBD_PORT
# for slurmdbd connections this names the munge socket (AuthInfo covers the other ones)
AccountingStoragePass=$dir/munge/munge.socket
# jobs of accounts unknown to slurmdbd are rejected, as on production clusters
AccountingStorageEnforce=associations,limits
# sacct shows the plugin's --comment (rule and wildcards of each job)
AccountingStoreFlags=job_comment
JobCompType=jobcomp/none
KillWait=5
MinJobAge=300
NodeName=$node NodeAddr=127.0.0.1 $cpus State=UNKNOWN
# not the default partition: a job without the profile's slurm_partition is rejected
PartitionName=$PARTITION Nodes=$node Default=NO MaxTime=INFINITE State=UP
EOF
    cat >"$dir/etc/slurmdbd.conf" <<EOF
$MARKER
AuthType=auth/munge
AuthInfo=socket=$dir/munge/munge.socket
DbdAddr=127.0.0.1
DbdHost=$node
DbdPort=$DBD_PORT
SlurmUser=root
LogFile=$dir/log/slurmdbd.log
PidFile=$dir/run/slurmdbd.pid
StorageType=accounting_storage/mysql
StorageHost=127.0.0.1
StoragePort=$DB_PORT
StorageUser=slurm
StoragePass=$(cat "$dir/db/password")
StorageLoc=slurm_acct_db
EOF
    chmod 600 "$dir/etc/slurmdbd.conf"
}

start_munge() {
    local dir=$1
    [ -s "$dir/munge/munge.key" ] || head -c 1024 /dev/urandom >"$dir/munge/munge.key"
    chmod 400 "$dir/munge/munge.key"
    munged --force --key-file="$dir/munge/munge.key" --socket="$dir/munge/munge.socket" \
        --pid-file="$dir/run/munged.pid" --log-file="$dir/log/munged.log" \
        --seed-file="$dir/munge/munged.seed" </dev/null >>"$dir/log/munged.log" 2>&1
    wait_for 20 munged bash -c "munge -n -S '$dir/munge/munge.socket' \
        | unmunge -S '$dir/munge/munge.socket'" || die "munged did not start: $dir/log/munged.log"
}

db_sql() { mariadb --no-defaults --socket="$1/db/mysqld.sock" -u root -e "$2"; }

start_mariadb() {
    local dir=$1
    if [ ! -d "$dir/db/data" ]; then
        mariadb-install-db --no-defaults --datadir="$dir/db/data" --user=root \
            --auth-root-authentication-method=socket --skip-test-db \
            >"$dir/log/mariadb-install.log" 2>&1 \
            || die "mariadb-install-db failed: $dir/log/mariadb-install.log"
    fi
    setsid mariadbd --no-defaults --user=root --datadir="$dir/db/data" \
        --socket="$dir/db/mysqld.sock" --port="$DB_PORT" --bind-address=127.0.0.1 \
        --skip-name-resolve --pid-file="$dir/run/mariadbd.pid" \
        --log-error="$dir/log/mariadbd.log" --innodb-lock-wait-timeout=900 \
        </dev/null >>"$dir/log/mariadbd.log" 2>&1 &
    wait_for 60 mariadbd db_sql "$dir" "SELECT 1" || die "mariadbd did not start: $dir/log/mariadbd.log"
    # the account slurmdbd logs in with (root logs in through the socket only)
    db_sql "$dir" "CREATE USER IF NOT EXISTS 'slurm'@'127.0.0.1' \
        IDENTIFIED BY '$(cat "$dir/db/password")';
        GRANT ALL ON slurm_acct_db.* TO 'slurm'@'127.0.0.1';"
}

start_slurmdbd() {
    local dir=$1
    SLURM_CONF="$dir/etc/slurm.conf" slurmdbd </dev/null >>"$dir/log/slurmdbd.log" 2>&1
    wait_for 60 slurmdbd sacctmgr -n list cluster || die "slurmdbd did not start: $dir/log/slurmdbd.log"
    # (a restart on the same DIR finds them in the database already)
    if [ -z "$(sacctmgr -n show associations where cluster="$CLUSTER" account="$ACCOUNT" \
            user="$(id -un)" format=user)" ]; then
        sacctmgr -i add cluster "$CLUSTER" >/dev/null
        sacctmgr -i add account "$ACCOUNT" Cluster="$CLUSTER" \
            Description="roughflow test account" Organization=roughflow >/dev/null
        sacctmgr -i add user "$(id -un)" Account="$ACCOUNT" Cluster="$CLUSTER" >/dev/null
    fi
}

node_idle() { [ "$(sinfo -h -N -p "$PARTITION" -o %t | sort -u)" = idle ]; }

cmd_start() {
    local dir=$1
    cmd_install
    [ "$(id -u)" = 0 ] || skip "the daemons run as root here (SlurmUser=root) and this is not root"
    if [ -L "$SYSTEM_CONF" ] && [ ! -e "$SYSTEM_CONF" ]; then
        # a link to a removed state directory: no installation reads it any more
        rm -f "$SYSTEM_CONF"
    fi
    if [ -e "$SYSTEM_CONF" ]; then
        if ! grep -q "^$MARKER" "$SYSTEM_CONF" 2>/dev/null; then
            skip "$SYSTEM_CONF exists and was not written by this script"
        fi
        local old
        old=$(head -n 1 "$SYSTEM_CONF")
        old=${old#"$MARKER (state in "}
        old=${old%)}
        if [ -n "$old" ] && [ "$old" != "$dir" ]; then
            if pid_alive "$old/run/slurmctld.pid" && [ "${RF_SLURM_TAKEOVER:-0}" != 1 ]; then
                skip "a test cluster from $old is running ($0 stop $old ends it)"
            fi
            log "stopping the cluster left behind in $old"
            cmd_stop "$old"
        fi
    fi
    local p
    for p in "$CTLD_PORT" "$SLURMD_PORT" "$DBD_PORT" "$DB_PORT"; do
        port_taken "$p" && skip "port $p on 127.0.0.1 is taken (set RF_SLURM_PORT)"
    done
    trap 'rc=$?; if [ "$rc" != 0 ]; then cmd_stop "$dir"; fi; exit "$rc"' EXIT
    mkdir -p "$dir/db"
    [ -s "$dir/db/password" ] || head -c 18 /dev/urandom | base64 | tr -d '/+=' >"$dir/db/password"
    chmod 600 "$dir/db/password"
    write_config "$dir"
    mkdir -p "$(dirname "$SYSTEM_CONF")"
    ln -sfn "$dir/etc/slurm.conf" "$SYSTEM_CONF"
    export SLURM_CONF="$dir/etc/slurm.conf"
    start_munge "$dir"
    start_mariadb "$dir"
    start_slurmdbd "$dir"
    slurmctld </dev/null >>"$dir/log/slurmctld.log" 2>&1
    wait_for 60 slurmctld scontrol ping || die "slurmctld did not start: $dir/log/slurmctld.log"
    slurmd </dev/null >>"$dir/log/slurmd.log" 2>&1
    wait_for 60 "node $(hostname -s) idle" node_idle || die "the node is not idle: $(sinfo -N) \
        (see $dir/log/slurmd.log)"
    sinfo -N -o "%N %P %t %c %m" >&2
}

stop_pidfile() {
    local pidfile=$1 name=$2 pid t=0
    [ -s "$pidfile" ] || return 0
    pid=$(cat "$pidfile")
    if kill -0 "$pid" 2>/dev/null; then
        kill -TERM "$pid" 2>/dev/null || true
        while kill -0 "$pid" 2>/dev/null && [ "$t" -lt 60 ]; do
            sleep 0.5
            t=$((t + 1))
        done
        if kill -0 "$pid" 2>/dev/null; then
            log "$name ($pid) did not stop within 30 s: killed"
            kill -KILL "$pid" 2>/dev/null || true
        else
            log "$name ($pid) stopped"
        fi
    fi
    rm -f "$pidfile"
}

cmd_stop() {
    local dir=$1
    [ -d "$dir" ] || return 0
    if pid_alive "$dir/run/slurmctld.pid"; then
        export SLURM_CONF="$dir/etc/slurm.conf"
        # jobs first, so that no slurmstepd outlives its slurmd
        scancel --full --user="$(id -un)" 2>/dev/null || true
        wait_for 30 "job queue empty" bash -c '[ -z "$(squeue -h -o %i)" ]' \
            || log "jobs still queued at shutdown: $(squeue -h -o '%i %T' | tr '\n' ' ')"
    fi
    stop_pidfile "$dir/run/slurmd.pid" slurmd
    stop_pidfile "$dir/run/slurmctld.pid" slurmctld
    stop_pidfile "$dir/run/slurmdbd.pid" slurmdbd
    stop_pidfile "$dir/run/mariadbd.pid" mariadbd
    stop_pidfile "$dir/run/munged.pid" munged
    if [ -e "$dir/etc/cgroup.conf" ]; then
        # the (empty) cgroups slurmd made; rmdir removes empty cgroups only
        find /sys/fs/cgroup/*/"slurm_$(hostname -s)" -depth -type d -exec rmdir {} + \
            2>/dev/null || true
    fi
    if [ -L "$SYSTEM_CONF" ] && [ "$(readlink "$SYSTEM_CONF")" = "$dir/etc/slurm.conf" ]; then
        rm -f "$SYSTEM_CONF"
    fi
}

cmd_env() { echo "SLURM_CONF=$1/etc/slurm.conf"; }

case "${1:-}" in
    install) cmd_install ;;
    start)
        [ -n "${2:-}" ] || die "usage: $0 start DIR"
        mkdir -p "$2"
        cmd_start "$(cd "$2" && pwd)"
        ;;
    stop | env)
        [ -n "${2:-}" ] || die "usage: $0 $1 DIR"
        "cmd_$1" "$(realpath -m "$2")"
        ;;
    *) die "usage: $0 install | start DIR | stop DIR | env DIR" ;;
esac
