# shellcheck shell=bash
#
# scripts/slurm/cluster.sh -- bring up / tear down a throwaway single-node
# Slurm cluster on localhost, for tests.  Source it; do not execute it.
#
#   source scripts/slurm/cluster.sh
#   slurm_install                      # apt-get install slurm-wlm munge if missing
#   dir=$(mktemp -d)
#   trap 'slurm_stop "$dir"' EXIT
#   slurm_start "$dir"                 # exports SLURM_CONF=$dir/slurm.conf
#   jid=$(sbatch --parsable --array=0-3 --output="$dir/out-%A_%a" --wrap 'true')
#   slurm_wait_jobs -t 120 "$jid"      # wait until the job left the queue
#   slurm_job_states "$jid"            # "0 COMPLETED" / "1 COMPLETED" / ...
#
# Functions (all return non-zero on failure instead of exiting, and work
# under `set -euo pipefail`):
#
#   slurm_install
#       Installs slurm-wlm and munge with apt-get (needs root) unless sbatch,
#       slurmctld, slurmd and munged are already present.  Runs
#       `apt-get update` only if the first install attempt fails.
#
#   slurm_start DIR
#       Starts munged (only if no working munged answers on the default
#       socket; creates /etc/munge/munge.key if missing), writes
#       DIR/slurm.conf for the host's short hostname (`hostname -s`), starts
#       slurmctld and slurmd (daemonized, as root) and waits until the node
#       is `idle` in sinfo.  Everything Slurm writes (config, state, spool,
#       logs, pid files) lives under DIR; munge keeps its usual system paths
#       (/etc/munge, /run/munge, /var/lib/munge, /var/log/munge).
#       Exports SLURM_CONF=DIR/slurm.conf into the calling shell so that
#       sbatch/squeue/scancel/scontrol talk to this cluster -- so call it
#       directly, not inside $(...) or a pipeline.
#       On timeout ($SLURM_START_TIMEOUT s, default 60) or any error it
#       prints the daemon logs to stderr, stops whatever it started, and
#       returns 1.  Fails early if a slurmctld/slurmd of another cluster is
#       already running (the ports would clash).  If the cluster in DIR is
#       already up, it only re-exports SLURM_CONF and waits for idle.
#       Optional environment: SLURM_CLUSTER_NAME (default "localtest"),
#       SLURM_CTLD_PORT (6817), SLURMD_PORT (6818), SLURM_START_TIMEOUT (60).
#
#   slurm_stop [DIR]
#       Cancels all jobs still in the queue, waits briefly for them to end,
#       `scontrol shutdown`s the daemons, then TERM/KILLs any slurmctld,
#       slurmd or slurmstepd of this cluster that is still alive, and stops
#       munged only if slurm_start started it.  Idempotent, always returns 0,
#       fine for `trap 'slurm_stop "$dir"' EXIT`.  DIR defaults to the
#       directory of $SLURM_CONF.
#
#   slurm_wait_jobs [-t TIMEOUT_S] JOBID...
#       Waits until none of the given jobs (array jobs include all their
#       tasks; JOBID_TASK also accepted) is in a non-final state (pending,
#       running, completing, ...).  Default timeout $SLURM_WAIT_TIMEOUT or
#       300 s.  Prints the final "JOBID TASKID STATE" lines to stderr.
#       Returns 0 when drained, 124 on timeout (after printing squeue).
#       Jobs unknown to slurmctld (never existed / purged) count as done;
#       an unreachable slurmctld counts as "still waiting".
#       It does not check success: use slurm_job_states for that.
#
#   slurm_job_states JOBID
#       Prints one line "TASKID STATE" per array task of JOBID, sorted by
#       task id (a not-yet-split pending remainder shows as e.g. "2-3
#       PENDING"; a non-array job prints "- STATE").  STATE is Slurm's
#       JobState: COMPLETED, FAILED, CANCELLED, TIMEOUT, PENDING, RUNNING ...
#       There is no accounting (accounting_storage/none, so no sacct); this
#       works because slurm.conf sets MinJobAge=3600, which keeps finished
#       jobs in slurmctld's memory (and in `scontrol show job`) for an hour.
#
# Notes on the generated slurm.conf:
#   * SelectType=select/cons_tres + CR_CPU and a NodeName line with only
#     CPUs= and RealMemory= from `slurmd -C`: every logical CPU is
#     schedulable on its own, so N 1-CPU array tasks run at once on N CPUs
#     (with the socket/core/thread layout listed, CR_CPU would give at most
#     one job per core).  Memory is not a consumable resource.
#   * DependencyParameters=kill_invalid_depend: a job whose dependency can
#     never be satisfied (e.g. afterok on a job that failed or was
#     cancelled) is cancelled (JobState=CANCELLED, Reason=
#     DependencyNeverSatisfied) instead of staying PENDING with that reason
#     forever, so the queue drains.  In Slurm 22.05 the option must go in
#     DependencyParameters; under SchedulerParameters (its pre-20.02 home)
#     it is silently ignored.
#   * proctrack/linuxproc + task/none: no cgroups needed.

_slurm_log() { printf 'slurm: %s\n' "$*" >&2; }

# Full path of a program, also looking in the sbin directories (which are
# not always on a non-root PATH).
_slurm_bin() {
    local p
    p=$(command -v "$1" 2>/dev/null) && { printf '%s\n' "$p"; return 0; }
    for p in /usr/sbin/"$1" /sbin/"$1" /usr/bin/"$1"; do
        [[ -x $p ]] && { printf '%s\n' "$p"; return 0; }
    done
    return 1
}

# _slurm_alive PID NAME: PID is a live (non-zombie) process called NAME.
_slurm_alive() {
    local pid=${1:-} name=${2:-} comm state
    [[ $pid =~ ^[0-9]+$ ]] || return 1
    comm=$(cat "/proc/$pid/comm" 2>/dev/null) || return 1
    [[ -z $name || $comm == "$name" ]] || return 1
    state=$(sed -n 's/^State:[[:space:]]*\([A-Z]\).*/\1/p' "/proc/$pid/status" 2>/dev/null) || return 1
    [[ $state != Z && $state != X ]]
}

# _slurm_pidfile FILE NAME: print the pid in FILE if that process is alive.
_slurm_pidfile() {
    local pid
    [[ -r $1 ]] || return 1
    pid=$(tr -dc '0-9' <"$1" 2>/dev/null) || return 1
    _slurm_alive "$pid" "$2" && printf '%s\n' "$pid"
}

# _slurm_our_pids DIR: pids of slurmctld/slurmd/slurmstepd belonging to the
# cluster in DIR (from the pid files, plus a scan of /proc for daemons
# started with `-f DIR/slurm.conf` or carrying SLURM_CONF=DIR/slurm.conf).
_slurm_our_pids() {
    local dir=$1 conf=$1/slurm.conf p pid comm cmd env
    {
        _slurm_pidfile "$dir/run/slurmctld.pid" slurmctld || true
        _slurm_pidfile "$dir/run/slurmd.pid" slurmd || true
        for p in /proc/[0-9]*; do
            pid=${p#/proc/}
            comm=$(cat "$p/comm" 2>/dev/null) || continue
            case $comm in slurmctld | slurmscriptd | slurmd | slurmstepd) ;; *) continue ;; esac
            cmd=$'\n'$(tr '\0' '\n' 2>/dev/null <"$p/cmdline" || true)$'\n'
            env=$'\n'$(tr '\0' '\n' 2>/dev/null <"$p/environ" || true)$'\n'
            if [[ $cmd == *$'\n'"$conf"$'\n'* || $env == *$'\n'"SLURM_CONF=$conf"$'\n'* ]]; then
                _slurm_alive "$pid" && printf '%s\n' "$pid"
            fi
        done
        true
    } | sort -un
}

_slurm_munge_works() {
    local munge unmunge
    munge=$(_slurm_bin munge) && unmunge=$(_slurm_bin unmunge) || return 1
    "$munge" -n </dev/null 2>/dev/null | "$unmunge" >/dev/null 2>&1
}

slurm_install() {
    local missing=0 b
    for b in sbatch slurmctld slurmd munged; do
        _slurm_bin "$b" >/dev/null || missing=1
    done
    ((missing)) || return 0
    _slurm_log "installing slurm-wlm and munge with apt-get"
    if ! DEBIAN_FRONTEND=noninteractive apt-get install -y slurm-wlm munge; then
        _slurm_log "install failed; running apt-get update and retrying"
        if ! { DEBIAN_FRONTEND=noninteractive apt-get update &&
            DEBIAN_FRONTEND=noninteractive apt-get install -y slurm-wlm munge; }; then
            _slurm_log "apt-get install slurm-wlm munge failed"
            return 1
        fi
    fi
    for b in sbatch slurmctld slurmd munged; do
        _slurm_bin "$b" >/dev/null || { _slurm_log "$b still missing after install"; return 1; }
    done
}

# _slurm_munge_start DIR: make sure a munged answers; remember in
# DIR/run/munged.ours if we started it.
_slurm_munge_start() {
    local dir=$1 key=/etc/munge/munge.key munged mungekey i pid
    if [[ ! -s $key ]]; then
        _slurm_log "creating munge key $key"
        install -d -o munge -g munge -m 0700 /etc/munge || return 1
        if mungekey=$(_slurm_bin mungekey); then
            "$mungekey" --create --keyfile="$key" || return 1
        else
            dd if=/dev/urandom of="$key" bs=1024 count=1 status=none || return 1
        fi
        chown munge:munge "$key" && chmod 0400 "$key" || return 1
    fi
    if _slurm_munge_works; then
        return 0 # someone else's munged: leave it alone
    fi
    munged=$(_slurm_bin munged) || { _slurm_log "munged not installed (run slurm_install)"; return 1; }
    install -d -o munge -g munge -m 0755 /run/munge || return 1
    if id munge >/dev/null 2>&1; then
        runuser -u munge -- "$munged" || { _slurm_log "munged failed to start"; return 1; }
    else
        "$munged" --force || { _slurm_log "munged failed to start"; return 1; }
    fi
    for ((i = 0; i < 100; i++)); do
        _slurm_munge_works && break
        sleep 0.1
    done
    pid=$(_slurm_pidfile /run/munge/munged.pid munged) || pid=
    if [[ -n $pid ]]; then
        printf '%s\n' "$pid" >"$dir/run/munged.ours"
    fi
    _slurm_munge_works || { _slurm_log "munged started but munge -n | unmunge fails"; return 1; }
}

_slurm_dump_logs() {
    local dir=$1 f
    for f in "$dir"/log/slurmctld.log "$dir"/log/slurmd.log /var/log/munge/munged.log; do
        [[ -r $f ]] || continue
        printf '===== %s (last 60 lines) =====\n' "$f" >&2
        tail -n 60 "$f" >&2 || true
    done
}

slurm_start() {
    local dir=${1:-}
    [[ -n $dir ]] || { _slurm_log "usage: slurm_start DIR"; return 2; }
    local ctld slurmd sinfo scontrol host hw cpus mem conf timeout deadline state pid
    if ! { ctld=$(_slurm_bin slurmctld) && slurmd=$(_slurm_bin slurmd) &&
        sinfo=$(_slurm_bin sinfo) && scontrol=$(_slurm_bin scontrol); }; then
        _slurm_log "slurm not installed (run slurm_install)"
        return 1
    fi
    mkdir -p "$dir" && dir=$(cd "$dir" && pwd -P) || return 1
    conf=$dir/slurm.conf
    timeout=${SLURM_START_TIMEOUT:-60}

    # Already running from this DIR?  Then just wait until it is usable.
    if _slurm_pidfile "$dir/run/slurmctld.pid" slurmctld >/dev/null &&
        _slurm_pidfile "$dir/run/slurmd.pid" slurmd >/dev/null; then
        export SLURM_CONF=$conf
        deadline=$((SECONDS + timeout))
        until [[ $(timeout 5 "$sinfo" -h -o %T 2>/dev/null) == idle ]]; do
            if ((SECONDS >= deadline)); then
                _slurm_log "cluster in $dir is running but its node is not idle"
                return 1
            fi
            sleep 0.1
        done
        return 0
    fi
    # Someone else's daemons would hold the ports.
    for pid in $(pgrep -x slurmctld; pgrep -x slurmd); do
        _slurm_alive "$pid" || continue # zombies of earlier runs do not count
        if [[ $'\n'$(_slurm_our_pids "$dir")$'\n' != *$'\n'"$pid"$'\n'* ]]; then
            _slurm_log "a slurmctld/slurmd of another cluster (not $dir) is already running (pid $pid); refusing to start"
            return 1
        fi
    done

    mkdir -p "$dir"/{state,spool,log,run} || return 1
    rm -f "$dir"/run/slurmctld.pid "$dir"/run/slurmd.pid

    _slurm_munge_start "$dir" || { _slurm_dump_logs "$dir"; slurm_stop "$dir"; return 1; }

    host=$(hostname -s) || return 1
    hw=$("$slurmd" -C 2>/dev/null | head -n 1) || true
    cpus=$(sed -n 's/.*[[:space:]]CPUs=\([0-9][0-9]*\).*/\1/p' <<<"$hw")
    mem=$(sed -n 's/.*[[:space:]]RealMemory=\([0-9][0-9]*\).*/\1/p' <<<"$hw")
    [[ -n $cpus ]] || cpus=$(nproc)
    [[ -n $mem ]] || mem=1

    : >"$dir/plugstack.conf"
    cat >"$conf" <<EOF
# Generated by scripts/slurm/cluster.sh -- single-node test cluster.
ClusterName=${SLURM_CLUSTER_NAME:-localtest}
SlurmctldHost=${host}(127.0.0.1)
SlurmctldPort=${SLURM_CTLD_PORT:-6817}
SlurmdPort=${SLURMD_PORT:-6818}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
MpiDefault=none
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SwitchType=switch/none
PlugStackConfig=${dir}/plugstack.conf
SchedulerType=sched/backfill
DependencyParameters=kill_invalid_depend
# Schedule newly submitted batch jobs at the next ~1 s tick, not after 3 s.
SchedulerParameters=batch_sched_delay=0
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MailProg=/bin/true
ReturnToService=2
# Keep finished jobs visible to 'scontrol show job' (no sacct here).
MinJobAge=3600
KillWait=5
InactiveLimit=0
StateSaveLocation=${dir}/state
SlurmdSpoolDir=${dir}/spool
SlurmctldPidFile=${dir}/run/slurmctld.pid
SlurmdPidFile=${dir}/run/slurmd.pid
SlurmctldLogFile=${dir}/log/slurmctld.log
SlurmdLogFile=${dir}/log/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
NodeName=${host} NodeAddr=127.0.0.1 CPUs=${cpus} RealMemory=${mem} State=UNKNOWN
PartitionName=debug Nodes=${host} Default=YES MaxTime=INFINITE State=UP
EOF
    export SLURM_CONF=$conf

    # slurmctld daemonizes; -c = cold start (no jobs/nodes from an old state).
    if ! "$ctld" -f "$conf" -c; then
        _slurm_log "slurmctld failed to start"
        _slurm_dump_logs "$dir"; slurm_stop "$dir"; return 1
    fi
    deadline=$((SECONDS + timeout))
    until [[ $(timeout 5 "$scontrol" ping 2>/dev/null) == *'is UP'* ]]; do
        if [[ -e $dir/run/slurmctld.pid ]] &&
            ! _slurm_pidfile "$dir/run/slurmctld.pid" slurmctld >/dev/null; then
            _slurm_log "slurmctld exited during startup"
            _slurm_dump_logs "$dir"; slurm_stop "$dir"; return 1
        fi
        if ((SECONDS >= deadline)); then
            _slurm_log "slurmctld did not answer 'scontrol ping' within ${timeout}s"
            _slurm_dump_logs "$dir"; slurm_stop "$dir"; return 1
        fi
        sleep 0.1
    done
    if ! "$slurmd" -f "$conf"; then
        _slurm_log "slurmd failed to start"
        _slurm_dump_logs "$dir"; slurm_stop "$dir"; return 1
    fi
    state=
    while ((SECONDS < deadline)); do
        state=$(timeout 5 "$sinfo" -h -o %T 2>/dev/null) || state=
        [[ $state == idle ]] && return 0
        sleep 0.1
    done
    _slurm_log "node did not become idle within ${timeout}s (sinfo state: '${state}')"
    timeout 10 "$sinfo" -N -l >&2 2>/dev/null || true
    timeout 10 "$scontrol" show node >&2 2>/dev/null || true
    _slurm_dump_logs "$dir"
    slurm_stop "$dir"
    return 1
}

# _slurm_wait_gone SECS PID...: wait until none of the pids is alive.
_slurm_wait_gone() {
    local secs=$1 i p alive
    shift
    for ((i = 0; i <= secs * 10; i++)); do
        alive=0
        for p in "$@"; do _slurm_alive "$p" && alive=1; done
        ((alive)) || return 0
        sleep 0.1
    done
    return 1
}

slurm_stop() {
    local dir=${1:-}
    if [[ -z $dir && -n ${SLURM_CONF:-} ]]; then dir=$(dirname "$SLURM_CONF"); fi
    [[ -n $dir && -d $dir ]] || return 0
    dir=$(cd "$dir" && pwd -P) || return 0
    local conf=$dir/slurm.conf pids jobs deadline munged_pid
    local scontrol squeue scancel
    scontrol=$(_slurm_bin scontrol) || scontrol=scontrol
    squeue=$(_slurm_bin squeue) || squeue=squeue
    scancel=$(_slurm_bin scancel) || scancel=scancel

    if _slurm_pidfile "$dir/run/slurmctld.pid" slurmctld >/dev/null && [[ -r $conf ]]; then
        # Cancel whatever is left, so no slurmstepd / job processes survive.
        jobs=$(SLURM_CONF=$conf timeout 10 "$squeue" -h -o %A 2>/dev/null | sort -u | tr '\n' ' ') || jobs=
        if [[ -n ${jobs// /} ]]; then
            # shellcheck disable=SC2086
            SLURM_CONF=$conf timeout 10 "$scancel" $jobs >/dev/null 2>&1 || true
            deadline=$((SECONDS + 30))
            while ((SECONDS < deadline)); do
                [[ -z $(SLURM_CONF=$conf timeout 10 "$squeue" -h -o %A 2>/dev/null) ]] && break
                sleep 0.2
            done
        fi
        SLURM_CONF=$conf timeout 10 "$scontrol" shutdown >/dev/null 2>&1 || true
    fi
    pids=$(_slurm_our_pids "$dir")
    if [[ -n $pids ]]; then
        # shellcheck disable=SC2086
        if ! _slurm_wait_gone 20 $pids; then
            # shellcheck disable=SC2086
            kill -TERM $pids 2>/dev/null || true
            # shellcheck disable=SC2086
            _slurm_wait_gone 5 $pids || { kill -KILL $pids 2>/dev/null || true; }
        fi
    fi
    # slurmstepds that were mid-teardown when the daemons went away.
    pids=$(_slurm_our_pids "$dir")
    if [[ -n $pids ]]; then
        # shellcheck disable=SC2086
        kill -TERM $pids 2>/dev/null || true
        # shellcheck disable=SC2086
        _slurm_wait_gone 5 $pids || { kill -KILL $pids 2>/dev/null || true; }
    fi

    if [[ -r $dir/run/munged.ours ]]; then
        munged_pid=$(tr -dc '0-9' <"$dir/run/munged.ours")
        if _slurm_alive "$munged_pid" munged; then
            kill -TERM "$munged_pid" 2>/dev/null || true
            _slurm_wait_gone 10 "$munged_pid" || kill -KILL "$munged_pid" 2>/dev/null || true
        fi
        rm -f "$dir/run/munged.ours"
    fi
    rm -f "$dir/run/slurmctld.pid" "$dir/run/slurmd.pid"
    if [[ ${SLURM_CONF:-} == "$conf" ]]; then unset SLURM_CONF; fi
    return 0
}

# Final (non-queued) job states.
_slurm_final_state() {
    case $1 in
    COMPLETED | CANCELLED | FAILED | TIMEOUT | NODE_FAIL | PREEMPTED | BOOT_FAIL | \
        DEADLINE | OUT_OF_MEMORY | SPECIAL_EXIT | REVOKED) return 0 ;;
    *) return 1 ;;
    esac
}

slurm_job_states() {
    local job=${1:-}
    [[ -n $job ]] || { _slurm_log "usage: slurm_job_states JOBID"; return 2; }
    local out line task state
    out=$(scontrol show job -o "$job" 2>/dev/null) || return 1
    while IFS= read -r line; do
        [[ -n $line ]] || continue
        task=$(sed -n 's/.*[[:space:]]ArrayTaskId=\([^[:space:]]*\).*/\1/p' <<<" $line")
        state=$(sed -n 's/.*[[:space:]]JobState=\([^[:space:]]*\).*/\1/p' <<<" $line")
        printf '%s %s\n' "${task:--}" "${state:-UNKNOWN}"
    done <<<"$out" | sort -n -k1,1
}

slurm_wait_jobs() {
    local timeout=${SLURM_WAIT_TIMEOUT:-300}
    if [[ ${1:-} == -t ]]; then
        timeout=${2:?slurm_wait_jobs: -t needs a value}
        shift 2
    fi
    (($# > 0)) || { _slurm_log "usage: slurm_wait_jobs [-t TIMEOUT_S] JOBID..."; return 2; }
    local ids end job task state pending out
    ids=$(IFS=,; printf '%s' "$*")
    end=$((SECONDS + timeout))
    while :; do
        pending=0
        # -t all: also list finished jobs (kept by MinJobAge); an unknown
        # job id (already purged) makes squeue fail -> check one by one.
        if ! out=$(squeue -h -r -t all --jobs="$ids" -o '%T' 2>/dev/null); then
            out=
            if [[ $(timeout 10 scontrol ping 2>/dev/null) != *'is UP'* ]]; then
                pending=1 # controller unreachable: cannot tell, keep waiting
            else
                for job in "$@"; do
                    out+=$(squeue -h -r -t all --jobs="$job" -o '%T' 2>/dev/null || true)$'\n'
                done
            fi
        fi
        while IFS= read -r state; do
            [[ -z $state ]] && continue
            _slurm_final_state "$state" || pending=1
        done <<<"$out"
        ((pending)) || break
        if ((SECONDS >= end)); then
            _slurm_log "timeout after ${timeout}s waiting for jobs $ids"
            squeue -r -t all --jobs="$ids" -o '%.12i %.10T %.25r %.10M %N' >&2 2>/dev/null || true
            return 124
        fi
        sleep 0.5
    done
    for job in "$@"; do
        slurm_job_states "$job" 2>/dev/null | while read -r task state; do
            printf 'slurm: job %s task %s %s\n' "$job" "$task" "$state" >&2
        done || true
    done
    return 0
}
