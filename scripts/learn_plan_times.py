#!/usr/bin/env python3
"""Plan times and outcomes of pure-LWR learning runs, for before/after comparisons
of the LWR's speed.

    python3 scripts/learn_plan_times.py BIN [BIN ...] [--seeds 1-20] [--max-trials 8]
                                        [--out /tmp/learn_plan_times]

Each BIN is a `swingup` binary (e.g. target/release/swingup built at two commits). For
every seed, each binary in turn runs

    BIN learn --model lwr --seed S --max-trials N --out OUT/<k>/seed-S --force

(alternating binaries per seed, so that the machine's load falls on all alike), and the
script reads the run's trial_NN.json files: per trial the planning time
(`timing.planning`, seconds) and the plan's cost; per run the number of trials and
whether the last one succeeded. It prints, per binary, the median over seeds of each
run's median planning time, and per seed whether the binaries' runs agree (same number
of trials, same success, plan costs equal to 1e-9 relative): a faster LWR that returns
the same predictions must give the same runs.
"""
import argparse
import json
import pathlib
import statistics
import subprocess


def seeds_of(text):
    out = []
    for part in text.split(","):
        lo, _, hi = part.partition("-")
        out.extend(range(int(lo), int(hi or lo) + 1))
    return out


def read_run(path):
    trials = []
    for f in sorted(path.glob("trial_*.json")):
        t = json.loads(f.read_text())
        plan = t.get("plan") or {}
        trials.append(dict(planning=t["timing"]["planning"], cost=plan.get("cost"), success=t["success"]))
    return trials


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("bins", nargs="+")
    ap.add_argument("--seeds", default="1-20")
    ap.add_argument("--max-trials", type=int, default=8)
    ap.add_argument("--out", default="/tmp/learn_plan_times")
    args = ap.parse_args()
    out = pathlib.Path(args.out)
    runs = {k: {} for k in range(len(args.bins))}
    for seed in seeds_of(args.seeds):
        for k, b in enumerate(args.bins):
            d = out / str(k) / f"seed-{seed}"
            cmd = [b, "learn", "--model", "lwr", "--seed", str(seed), "--max-trials", str(args.max_trials),
                   "--out", str(d), "--force"]
            subprocess.run(cmd, check=True, capture_output=True)
            runs[k][seed] = read_run(d)
        line = [f"seed {seed}:"]
        for k in runs:
            tr = runs[k][seed]
            med = statistics.median(t["planning"] for t in tr[1:]) if len(tr) > 1 else float("nan")
            line.append(f"bin{k} {len(tr)} trials, success {tr[-1]['success']}, median plan {med:.3f} s")
        base = runs[0][seed]
        for k in list(runs)[1:]:
            other = runs[k][seed]
            same = len(base) == len(other) and all(
                a["success"] == b["success"]
                and (a["cost"] == b["cost"] or (a["cost"] is not None and b["cost"] is not None
                                                and abs(a["cost"] - b["cost"]) <= 1e-9 * max(1.0, abs(a["cost"]))))
                for a, b in zip(base, other))
            line.append(f"bin{k} same as bin0: {same}")
        print("; ".join(line), flush=True)
    for k, b in enumerate(args.bins):
        meds = [statistics.median(t["planning"] for t in tr[1:]) for tr in runs[k].values() if len(tr) > 1]
        print(f"bin{k} {b}: median over {len(meds)} seeds of the run's median plan time "
              f"{statistics.median(meds):.3f} s" if meds else f"bin{k}: no planned trials")


if __name__ == "__main__":
    main()
