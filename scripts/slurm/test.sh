#!/bin/bash
# The job-array scripts against a live Slurm (issue 53): installs Debian's
# slurm-wlm and munge when missing, starts a single-node cluster on
# localhost (scripts/slurm/cluster.sh), and checks, for both programs,
# that a 4-task array with its merge as a dependent job gives the records
# of one process in every field but timings:
#
# 1. `swingup experiments`: a quick grid (6 runs) as a 4-task array; one
#    task is cancelled (scancel) once it saved a run; submitted again
#    alone (--array=1) it is refused (it cannot tell the array's size);
#    the whole array submitted again makes only the missing run (the
#    cancelled shard resumes, without loss or duplicates; finished shards
#    end at once); the merge runs after it (--dependency=afterok).
# 2. `nprl-bench`: the Rosenbrock instances of the MGH set, 3 solvers, as a
#    4-task array and its merge.
# 3. A task that fails (the storage layer's fault hook fails its shard's
#    first write): its dependent merge is never run, and the merge run by
#    hand refuses, naming the shard.
#
# Then it stops the daemons it started. Run from anywhere, as root (it
# installs packages and starts daemons); it builds the two programs (the
# test profile, optimised, which `cargo test --workspace` has built
# already) unless NPRL_BIN names a directory holding `swingup` and
# `nprl-bench`. Wall time: about two minutes.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo=$(cd "$here/../.." && pwd)
# shellcheck source=scripts/slurm/cluster.sh
source "$here/cluster.sh"

started=$(date +%s)
say() { printf 'slurm test: %s\n' "$*"; }
fail() {
    printf 'slurm test: FAILED: %s\n' "$*" >&2
    exit 1
}

if [ -z "${NPRL_BIN:-}" ]; then
    say "building swingup and nprl-bench"
    # the test profile: the binaries `cargo test --workspace` builds (no rebuild after it)
    (cd "$repo" && cargo build --quiet --profile test -p swingup -p nprl-bench)
    NPRL_BIN=$(cd "$repo" && cargo metadata --format-version 1 --no-deps |
        python3 -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')/debug
fi
export NPRL_BIN
for program in swingup nprl-bench; do
    [ -x "$NPRL_BIN/$program" ] || fail "no $program in $NPRL_BIN"
done

slurm_install
work=$(mktemp -d /tmp/nprl-slurm-test.XXXXXX)
cleanup() {
    slurm_stop "$work/cluster" || true
    if [ "${KEEP_SLURM_TEST:-0}" = 1 ]; then
        say "kept $work"
    else
        rm -rf "$work"
    fi
}
trap cleanup EXIT
mkdir -p "$work/cluster" "$work/logs"
slurm_start "$work/cluster"
say "cluster up ($(sinfo -h -o '%N %c CPUs %T'))"
cd "$work/logs"

# the records of a directory without what depends on the clock, sorted
timeless() {
    python3 - "$@" <<'PY'
import json, sys
kind, path = sys.argv[1], sys.argv[2]
if kind == "experiments":
    runs = json.load(open(path))["runs"]
    clock = ("seconds", "replan_ms", "first_plan_ms")
    key = lambda r: (r["experiment"], r["variant"], r["seed"])
else:
    runs = json.load(open(path))["runs"]
    clock = ("time_s",)
    key = lambda r: (r["set"], r["problem"], r["scale"], r["solver"])
for r in runs:
    for k in clock:
        r.pop(k, None)
print(json.dumps(sorted(runs, key=key), sort_keys=True))
PY
}

# the state of each task of JOB, as "TASK STATE" lines
states() { slurm_job_states "$1"; }

all_completed() {
    local job=$1 bad
    bad=$(states "$job" | awk '$2 != "COMPLETED"')
    [ -z "$bad" ] || fail "job $job: tasks not completed: $bad ($(tail -n 20 slurm-*"$job"* 2>/dev/null))"
}

# ---------------------------------------------------------------- 1. grid
grid=(lambda --quick --seeds 2 --max-trials 3)
say "grid: one process"
RAYON_NUM_THREADS=1 "$NPRL_BIN/swingup" experiments "${grid[@]}" --out "$work/grid-one" >"$work/logs/grid-one.log"
say "grid: a 4-task array"
job=$(sbatch --parsable --array=0-3 --cpus-per-task=1 "$here/experiments.sbatch" "$work/grid" "${grid[@]}")
# task 1 is shard 2 of 4: two runs, the second the grid's longest; cancel
# it once the first is saved
cancelled=
for _ in $(seq 1 600); do
    if [ -s "$work/grid/runs-2-of-4.jsonl" ] && states "$job" | grep -q '^1 RUNNING$'; then
        scancel "${job}_1"
        cancelled=1
        break
    fi
    states "$job" | grep -q '^1 \(COMPLETED\|FAILED\)$' && break
    sleep 0.1
done
[ -n "$cancelled" ] || fail "task 1 of job $job ended before it could be cancelled mid-run ($(states "$job"))"
slurm_wait_jobs -t 300 "$job"
states "$job" | grep -q '^1 CANCELLED$' || fail "task 1 was not cancelled: $(states "$job")"
saved=$(wc -l <"$work/grid/runs-2-of-4.jsonl")
[ "$saved" -ge 1 ] || fail "the cancelled task saved no run"
say "grid: task 1 cancelled with $saved run(s) of its shard saved"
# submitted again alone, the task cannot tell the array's size: refused
alone=$(sbatch --parsable --array=1 --cpus-per-task=1 "$here/experiments.sbatch" "$work/grid" "${grid[@]}")
slurm_wait_jobs -t 120 "$alone"
states "$alone" | grep -q '^1 FAILED$' || fail "task 1 submitted alone was not refused: $(states "$alone")"
grep -q -- "--shard K/4" slurm-nprl-experiments-"$alone"_1.out ||
    fail "the refusal does not say what to do: $(cat slurm-nprl-experiments-"$alone"_1.out)"
say "grid: task 1 submitted alone (--array=1) refused, saying to pass --shard K/4"
say "grid: the whole array submitted again, its merge after it"
again=$(sbatch --parsable --array=0-3 --cpus-per-task=1 "$here/experiments.sbatch" "$work/grid" "${grid[@]}")
merge=$(sbatch --parsable --dependency=afterok:"$again" "$here/merge.sbatch" experiments "$work/grid")
slurm_wait_jobs -t 300 "$again" "$merge"
all_completed "$again"
all_completed "$merge"
grep -q "resuming: $saved finished run(s) read back" slurm-nprl-experiments-"$again"_1.out ||
    fail "the resubmitted task did not resume: $(cat slurm-nprl-experiments-"$again"_1.out)"
ran=$(cat slurm-nprl-experiments-"$again"_*.out | grep -c '^\[' || true)
[ "$ran" -eq $((2 - saved)) ] || fail "the resubmitted array ran $ran run(s), not the $((2 - saved)) missing"
[ "$(wc -l <"$work/grid/runs-2-of-4.jsonl")" -eq 2 ] || fail "shard 2 of 4 holds other than its 2 runs"
[ "$(timeless experiments "$work/grid/experiments.json")" = "$(timeless experiments "$work/grid-one/experiments.json")" ] ||
    fail "the merged grid differs from the one-process grid"
say "grid: merged records equal the one-process run's (but timings); the cancelled task resumed without loss or duplicates"

# --------------------------------------------------------------- 2. bench
solvers=gauss-newton,powell,dfo-ls
bench=(--set mgh --filter rosenbrock --solvers "$solvers" --repeats 1)
say "bench: one process"
"$NPRL_BIN/nprl-bench" "${bench[@]}" --out "$work/bench-one" >"$work/logs/bench-one.log" 2>&1
say "bench: a 4-task array"
job=$(sbatch --parsable --array=0-3 "$here/bench.sbatch" "$work/bench" "${bench[@]}")
merge=$(sbatch --parsable --dependency=afterok:"$job" "$here/merge.sbatch" bench "$work/bench")
slurm_wait_jobs -t 300 "$job" "$merge"
all_completed "$job"
all_completed "$merge"
[ "$(timeless bench "$work/bench/runs.json")" = "$(timeless bench "$work/bench-one/runs.json")" ] ||
    fail "the merged benchmark differs from the one-process benchmark"
[ -s "$work/bench/benchmarks.md" ] || fail "the merge wrote no report"
say "bench: merged records equal the one-process run's (but timings)"

# ---------------------------------------------------- 3. a failing shard
say "a failing task: shard 2 of 2 cannot write its runs"
# (through sbatch's environment: --export would split the value at its commas)
job=$(NPRL_STORE_FAULT=op=write,nth=1,persist,path=runs-2-of-2.jsonl sbatch --parsable --array=0-1 \
    "$here/experiments.sbatch" "$work/failing" lambda --quick --seeds 1 --max-trials 1)
merge=$(sbatch --parsable --dependency=afterok:"$job" "$here/merge.sbatch" experiments "$work/failing")
slurm_wait_jobs -t 300 "$job" "$merge"
states "$job" | grep -q '^1 FAILED$' || fail "task 1 did not fail: $(states "$job")"
states "$merge" | grep -q 'CANCELLED' || fail "the merge after a failed task was not cancelled: $(states "$merge")"
if "$NPRL_BIN/swingup" experiments merge "$work/failing" >merge-failing.out 2>&1; then
    fail "the merge of a failed shard passed"
fi
grep -q "shard 2/2" merge-failing.out || fail "the merge's refusal does not name the shard: $(cat merge-failing.out)"
say "the merge refused: $(tail -n 1 merge-failing.out)"

say "passed in $(($(date +%s) - started)) s"
