#!/usr/bin/env python3
"""How well an LWR made from a learning run's first trials predicts the *next* trial,
against what leave-one-out cross-validation says, for several choices of inputs.

    cargo build --release -p nprl-lwr --features cli --bin lwr-fit
    python3 scripts/next_trial_error.py RUN_DIR [RUN_DIR ...] [--lwr-fit target/release/lwr-fit]
                                        [--max-train 3] [--tune-evals 150] [--work /tmp/next_trial_error]

Each RUN_DIR is the output of `swingup learn --out RUN_DIR` (its trial_NN.csv files). For
n = 1 .. --max-train, the training pairs of trials 1..n (inputs: the observed state and
the sent command; target: the next observed change of angular velocity, as the
swingup models learn) are written to CSV and `lwr-fit` (tricube kernel, metric tuned by
leave-one-out) fits them, then predicts trial n + 1. Printed per run and n, for each set
of inputs: the tuned model's leave-one-out nMSE and its nMSE on the next trial, and the
sensor-noise floor of the next trial (the nMSE of its noisy targets against the noise-free
ones).

What it showed (issue 18, commit message of the grouped input selection): leave-one-out
sits at the noise floor for every choice of inputs, because along a 60 Hz trajectory a
left-out sample is predicted from its neighbours in time; the next-trial error differs by
orders of magnitude, and is lowest without the hand's position and velocity.
"""
import argparse
import csv
import json
import pathlib
import subprocess

INPUTS = {
    "all five": ["theta", "theta_dot", "x", "x_dot", "u"],
    "no x, x_dot": ["theta", "theta_dot", "u"],
    "theta, u": ["theta", "u"],
}


def pairs(path):
    rows = list(csv.DictReader(open(path)))
    out = []
    for a, b in zip(rows, rows[1:]):
        out.append(dict(
            theta=float(a["obs_theta"]), theta_dot=float(a["obs_theta_dot"]), x=float(a["obs_x"]),
            x_dot=float(a["obs_x_dot"]), u=float(a["command"]),
            y=float(b["obs_theta_dot"]) - float(a["obs_theta_dot"]),
            y_true=float(b["theta_dot"]) - float(a["theta_dot"])))
    return out


def write(path, data, cols):
    with open(path, "w") as f:
        f.write(",".join(cols + ["y"]) + "\n")
        for d in data:
            f.write(",".join(repr(d[c]) for c in cols + ["y"]) + "\n")


def noise_floor(data):
    ys = [d["y"] for d in data]
    mean = sum(ys) / len(ys)
    var = sum((y - mean) ** 2 for y in ys) / len(ys)
    return sum((d["y"] - d["y_true"]) ** 2 for d in data) / len(data) / var


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", type=pathlib.Path)
    ap.add_argument("--lwr-fit", default="target/release/lwr-fit")
    ap.add_argument("--max-train", type=int, default=3)
    ap.add_argument("--tune-evals", type=int, default=150)
    ap.add_argument("--work", type=pathlib.Path, default=pathlib.Path("/tmp/next_trial_error"))
    args = ap.parse_args()
    args.work.mkdir(parents=True, exist_ok=True)
    print("| run | trials fitted | inputs | LOO nMSE | next-trial nMSE | next trial's noise floor |")
    print("|---|---:|---|---:|---:|---:|")
    for run in args.runs:
        trials = sorted(run.glob("trial_*.csv"))
        for n in range(1, min(args.max_train, len(trials) - 1) + 1):
            train = [p for t in trials[:n] for p in pairs(t)]
            test = pairs(trials[n])
            for name, cols in INPUTS.items():
                tr, te = args.work / "train.csv", args.work / "test.csv"
                write(tr, train, cols)
                write(te, test, cols)
                out = subprocess.run(
                    [args.lwr_fit, "--train", str(tr), "--test", str(te), "--target", "y", "--kernel", "tricube",
                     "--tune-evals", str(args.tune_evals), "--json"],
                    check=True, capture_output=True, text=True).stdout
                r = json.loads(out)
                print(f"| {run.name} | {n} | {name} | {r['loo_nmse']:.4f} | {r['test']['nmse']:.4g} "
                      f"| {noise_floor(test):.4f} |", flush=True)


if __name__ == "__main__":
    main()
