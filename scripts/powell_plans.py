"""Powell's plans at a large budget (issue 33): one line per planned trial
of `swingup learn` run directories, with the commit that made each run,
Powell's status, criterion, evaluations and time, and Gauss-Newton's
criterion on the same problem (planner.compare_gauss_newton). Standard
library only.

  python3 scripts/powell_plans.py extract RUN_DIR... > results/derivative-free/powell_plans.jsonl
  python3 scripts/powell_plans.py table results/derivative-free/powell_plans.jsonl

`extract` keeps each plan's summary (not its trajectory) and the run's
stamp from its manifest.json; `table` prints the markdown table.
"""
import json
import os
import sys


def extract(dirs):
    for d in dirs:
        manifest = json.load(open(os.path.join(d, "manifest.json")))
        report = json.load(open(os.path.join(d, "report.json")))
        settings = manifest["settings"]
        planner = settings["planner"]
        for t in report["trials"]:
            p = t.get("plan")
            if not p:
                continue
            print(json.dumps({
                "commit": manifest.get("created_by_commit", "").removeprefix("commit "),
                "seed": settings["seed"],
                "trial": t["index"],
                "coefficients": planner["state_coeffs"] * 4 + planner["control_coeffs"],
                "principal_axes": planner.get("powell_principal_axes", 0),
                "budget": planner["powell_evals"],
                "status": p["status"],
                "cost": p["cost"],
                "gauss_newton_cost": p["gauss_newton_cost"],
                "evaluations": p["evaluations"],
                "seconds": p["seconds"],
                "iterations": p["iterations"],
                "success": t["success"],
            }))


def table(path):
    rows = [json.loads(line) for line in open(path) if line.strip()]
    commits = sorted({r["commit"] for r in rows})
    print(f"{len(rows)} plans from {path}, made at {', '.join(commits)}")
    print()
    print("| seed | trial | coefficients | principal axes every | budget | status | sweeps | evaluations | time (s) | criterion | Gauss-Newton's | ratio | trial succeeded |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in sorted(rows, key=lambda r: (r["coefficients"], r["principal_axes"], r["budget"], r["seed"], r["trial"])):
        g = r["gauss_newton_cost"]
        ratio = f"{r['cost'] / g:.3f}" if g else "-"
        print(f"| {r['seed']} | {r['trial']} | {r['coefficients']} | {r['principal_axes'] or 'never'} | {r['budget']} | "
              f"{r['status']} | {r['iterations']} | {r['evaluations']} | {r['seconds']:.0f} | {r['cost']:.4g} | "
              f"{g:.4g} | {ratio} | {'yes' if r['success'] else 'no'} |")


if __name__ == "__main__":
    if len(sys.argv) < 3 or sys.argv[1] not in ("extract", "table"):
        sys.exit(__doc__)
    if sys.argv[1] == "extract":
        extract(sys.argv[2:])
    else:
        table(sys.argv[2])
