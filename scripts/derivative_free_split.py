"""Per seed range, from a learning grid's runs.jsonl: successes, median trial
of success, plans converged, and how each derivative-free plan's Eq. 3
criterion compares with Gauss-Newton's on the same problem (recorded by
planner.compare_gauss_newton). Standard library only.

  python3 scripts/derivative_free_split.py results/derivative-free/runs.jsonl
"""
import json
import statistics
import sys

path = sys.argv[1] if len(sys.argv) > 1 else "results/derivative-free/runs.jsonl"
runs = [json.loads(line) for line in open(path) if line.strip()]
versions = sorted({r.get("code_version", "") for r in runs})
print(f"{len(runs)} runs from {path}, made at {', '.join(versions)}")
print("| variant | seeds | succeeded | median trial | median run (s) | plans converged | converged, at most 1e-3 above GN | above GN by > 1e-3 | below GN by > 1e-3 |")
print("|---|---|---|---|---|---|---|---|---|")
for variant in sorted({r["variant"] for r in runs}):
    for lo, hi in [(1, 20), (21, 40)]:
        rs = [r for r in runs if r["variant"] == variant and lo <= r["seed"] <= hi]
        if not rs:
            continue
        trials = [r["success_trial"] for r in rs if r["success_trial"]]
        median = statistics.median(trials) if trials else "-"
        plans = sum(len(r["plan_statuses"]) for r in rs)
        converged = sum(s.startswith("Converged") for r in rs for s in r["plan_statuses"])
        same = above = below = compared = 0
        for r in rs:
            for s, c, g in zip(r["plan_statuses"], r.get("plan_costs", []), r.get("plan_gauss_newton_costs", [])):
                if g is None:
                    continue
                compared += 1
                rel = (c - g) / g
                same += s.startswith("Converged") and rel <= 1e-3
                above += rel > 1e-3
                below += rel < -1e-3
        cmp = lambda n: f"{n}/{compared}" if compared else "-"
        secs = statistics.median(r["seconds"] for r in rs)
        print(f"| {variant} | {lo}-{hi} | {len(trials)}/{len(rs)} | {median} | {secs:.1f} | {converged}/{plans} | {cmp(same)} | {cmp(above)} | {cmp(below)} |")
