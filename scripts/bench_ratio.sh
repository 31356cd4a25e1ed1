#!/usr/bin/env bash
# Compares criterion benchmark binaries of two versions, run alternately
# (before, after, before, after, ...) so that the machine's load falls on
# both alike.
#
#   scripts/bench_ratio.sh [-r ROUNDS] BEFORE_BIN AFTER_BIN [BEFORE_BIN AFTER_BIN ...] [-- CRITERION_ARGS...]
#
# Each pair is one bench target built at two commits (e.g.
# `cargo bench -p trajopt --no-run` in two worktrees, then
# target/release/deps/gauss_newton-* and powell-*). Every round runs each
# binary once, in the order before, after of each pair. Criterion's
# arguments default to `--warm-up-time 1 --measurement-time 3 --noplot`.
# Benches are matched by name; for each, the median over the rounds of
# criterion's point estimate is taken per version, and the table gives
# after / before (below 1: the after version is faster), with the
# geometric mean over the benches both versions have. Benches found in
# one version only are listed apart.
set -euo pipefail

rounds=3
if [[ "${1:-}" == "-r" ]]; then
  rounds="$2"
  shift 2
fi
bins=()
while [[ $# -gt 0 && "$1" != "--" ]]; do
  bins+=("$1")
  shift
done
[[ "${1:-}" == "--" ]] && shift
crit_args=("$@")
if [[ ${#crit_args[@]} -eq 0 ]]; then
  crit_args=(--warm-up-time 1 --measurement-time 3 --noplot)
fi
if [[ ${#bins[@]} -eq 0 || $(( ${#bins[@]} % 2 )) -ne 0 ]]; then
  echo "usage: $0 [-r ROUNDS] BEFORE_BIN AFTER_BIN [BEFORE_BIN AFTER_BIN ...] [-- CRITERION_ARGS...]" >&2
  exit 2
fi
for b in "${bins[@]}"; do
  [[ -x "$b" ]] || { echo "not an executable: $b" >&2; exit 2; }
done

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# criterion's report on stdout -> "name<TAB>nanoseconds" (the point estimate,
# the middle of the three figures on the `time:` line)
parse() {
  awk '
    function ns(v, u) {
      if (u == "ps") return v / 1000
      if (u == "ns") return v
      if (u == "µs" || u == "us") return v * 1000
      if (u == "ms") return v * 1e6
      if (u == "s") return v * 1e9
      return -1
    }
    /time:[ \t]+\[/ {
      line = $0
      sub(/^[ \t]+/, "", line)
      head = line
      sub(/[ \t]*time:.*/, "", head)
      if (head != "") name = head
      rest = line
      sub(/.*time:[ \t]+\[/, "", rest)
      split(rest, f, /[ \t]+/)
      printf "%s\t%.6f\n", name, ns(f[3] + 0, f[4])
      next
    }
    NF > 0 && $0 !~ /^[ \t]/ { name = $1 }
  '
}

for ((round = 1; round <= rounds; round++)); do
  for ((i = 0; i < ${#bins[@]}; i += 2)); do
    for side in before after; do
      bin=${bins[$i]}
      [[ $side == after ]] && bin=${bins[$((i + 1))]}
      echo "round $round/$rounds: $side $(basename "$bin")" >&2
      # a criterion home of its own per version: no comparisons across them
      CRITERION_HOME="$work/home-$side" "$bin" --bench "${crit_args[@]}" > "$work/out.txt" 2> "$work/err.txt" \
        || { cat "$work/err.txt" >&2; exit 1; }
      parse < "$work/out.txt" >> "$work/$side.tsv"
    done
  done
done

# median per bench and version, then the table
awk -F'\t' '
  function median(list,    a, n, i, j, t) {
    n = split(list, a, " ")
    for (i = 2; i <= n; i++) for (j = i; j > 1 && a[j - 1] + 0 > a[j] + 0; j--) { t = a[j]; a[j] = a[j - 1]; a[j - 1] = t }
    return (n % 2) ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
  }
  function show(v) {
    if (v >= 1e9) return sprintf("%.3f s", v / 1e9)
    if (v >= 1e6) return sprintf("%.3f ms", v / 1e6)
    if (v >= 1e3) return sprintf("%.3f us", v / 1e3)
    return sprintf("%.1f ns", v)
  }
  FNR == 1 { side = (FILENAME ~ /before\.tsv$/) ? "before" : "after" }
  {
    key = side SUBSEP $1
    vals[key] = (key in vals) ? vals[key] " " $2 : $2
    if (!($1 in seen)) { seen[$1] = 1; order[++n] = $1 }
  }
  END {
    printf "%-48s %14s %14s %8s\n", "bench", "before", "after", "ratio"
    logsum = 0; m = 0
    for (k = 1; k <= n; k++) {
      b = order[k]
      if (!(("before" SUBSEP b) in vals) || !(("after" SUBSEP b) in vals)) { only[b] = 1; continue }
      mb = median(vals["before" SUBSEP b]); ma = median(vals["after" SUBSEP b])
      r = ma / mb
      printf "%-48s %14s %14s %8.3f\n", b, show(mb), show(ma), r
      logsum += log(r); m++
    }
    if (m > 0) printf "%-48s %14s %14s %8.3f\n", "geometric mean (" m " benches)", "", "", exp(logsum / m)
    for (b in only) printf "only in %s: %s\n", ((("before" SUBSEP b) in vals) ? "before" : "after"), b
  }
' "$work/before.tsv" "$work/after.tsv"
