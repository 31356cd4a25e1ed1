#!/usr/bin/env python3
"""`lwr`'s front door on scikit-learn's diabetes data, side by side with
scikit-learn's KNeighborsRegressor (k by 5-fold GridSearchCV) and, with
--kernelreg, statsmodels' KernelReg (local linear, bandwidths by cv_ls), in
one run, on one 80/20 split.

    python3 scripts/lwr_diabetes.py [--seed S] [--kernelreg] [--compass] [--tune-evals N] [--tune-points P]
    python3 scripts/lwr_diabetes.py --summarize FILE   (the tables of several seeds: means and counts)

Sets up its own virtual environment (.venv-ref/, from scripts/requirements.txt)
on first use; NPRL_ANY_PYTHON=1 runs in the current Python instead (it needs
numpy, scikit-learn and, for --kernelreg, statsmodels). The data are
scikit-learn's bundled copy (load_diabetes: 442 rows, 10 inputs, no download).

lwr: `LwrModel::fit(&x, &y)` (scales 1/sd, the bandwidth and scales tuned by
leave-one-out with Levenberg-Marquardt, 300 evaluations at most; with
--compass also by the compass search), then `predict_many`, timed in
`cargo run --release -p nprl-drivers --bin lwr_fit_timing`. Prints per method
the test RMSE, the fit (tuning) time and the prediction time; lwr also the
coverage of its 95 % prediction intervals.
"""
import argparse
import json
import pathlib
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from _venv import ROOT, ensure_venv  # noqa: E402

ensure_venv(__file__)

import numpy as np  # noqa: E402
from sklearn.datasets import load_diabetes  # noqa: E402
from sklearn.model_selection import GridSearchCV, train_test_split  # noqa: E402
from sklearn.neighbors import KNeighborsRegressor  # noqa: E402
from sklearn.pipeline import make_pipeline  # noqa: E402
from sklearn.preprocessing import StandardScaler  # noqa: E402


def rmse(pred, y):
    return float(np.sqrt(np.mean((np.asarray(pred) - np.asarray(y)) ** 2)))


def run_lwr(xtr, ytr, xte, yte, tune_evals=None, tune_points=None, method=None):
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump({"train_x": xtr.tolist(), "train_y": ytr.tolist(), "test_x": xte.tolist(), "test_y": yte.tolist()}, f)
    cmd = ["cargo", "run", "--quiet", "--release", "-p", "nprl-drivers", "--bin", "lwr_fit_timing", "--", f.name]
    if tune_evals is not None or method is not None:
        cmd += [str(300 if tune_evals is None else tune_evals), str(tune_points or 0)]
    if method is not None:
        cmd.append(method)
    out = subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True).stdout
    pathlib.Path(f.name).unlink()
    return json.loads(out.strip().splitlines()[-1])


def run_knn(xtr, ytr, xte, yte):
    t = time.perf_counter()
    search = GridSearchCV(
        make_pipeline(StandardScaler(), KNeighborsRegressor()),
        {"kneighborsregressor__n_neighbors": list(range(1, 51)), "kneighborsregressor__weights": ["uniform", "distance"]},
        cv=5,
        scoring="neg_mean_squared_error",
    ).fit(xtr, ytr)
    fit_s = time.perf_counter() - t
    t = time.perf_counter()
    pred = search.predict(xte)
    return {"fit_s": fit_s, "predict_s": time.perf_counter() - t, "rmse": rmse(pred, yte),
            "k": search.best_params_["kneighborsregressor__n_neighbors"]}


def run_kernelreg(xtr, ytr, xte, yte):
    from statsmodels.nonparametric.kernel_regression import KernelReg
    t = time.perf_counter()
    model = KernelReg(ytr, xtr, var_type="c" * xtr.shape[1], reg_type="ll", bw="cv_ls")
    fit_s = time.perf_counter() - t
    t = time.perf_counter()
    pred, _ = model.fit(xte)
    return {"fit_s": fit_s, "predict_s": time.perf_counter() - t, "rmse": rmse(pred, yte)}


def summarize(path):
    """The summary over the seeds of a file of this script's tables: per
    method, the mean test RMSE and fit time, and the splits on which it is
    at most KernelReg's RMSE and faster than KNN."""
    runs = {}
    for line in pathlib.Path(path).read_text().splitlines():
        if line.startswith("## Summary"):
            break
        cells = [c.strip() for c in line.strip("|").split("|")]
        if line.startswith("diabetes,"):
            runs[line] = {}
            current = runs[line]
        elif line.startswith("| ") and len(cells) == 5 and cells[0] not in ("method", "---"):
            current[cells[0]] = (float(cells[1]), float(cells[2]))
    methods = list(next(iter(runs.values())))
    print(f"over {len(runs)} splits")
    print("| method | mean test RMSE | mean fit s | splits with RMSE <= KernelReg's | splits with fit faster than KNN |")
    print("|---|---|---|---|---|")
    for m in methods:
        rmse = [r[m][0] for r in runs.values()]
        fit = [r[m][1] for r in runs.values()]
        le = sum(r[m][0] <= r["KernelReg ll, cv_ls"][0] for r in runs.values() if "KernelReg ll, cv_ls" in r)
        fast = sum(r[m][1] < r["KNN, k by GridSearchCV"][1] for r in runs.values())
        print(f"| {m} | {np.mean(rmse):.2f} | {np.mean(fit):.3f} | {le} of {len(runs)} | {fast} of {len(runs)} |")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--summarize", metavar="FILE", help="only summarise a file of this script's tables over its seeds")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--kernelreg", action="store_true")
    parser.add_argument("--compass", action="store_true", help="also lwr tuned by the compass search (TuneMethod::Compass)")
    parser.add_argument("--tune-evals", type=int, help="lwr's tuning evaluations (default: LwrModel::fit's)")
    parser.add_argument("--tune-points", type=int, default=0, help="lwr's points per evaluation (0: all)")
    args = parser.parse_args()
    if args.summarize:
        return summarize(args.summarize)
    x, y = load_diabetes(return_X_y=True)
    xtr, xte, ytr, yte = train_test_split(x, y, test_size=0.2, random_state=args.seed)
    subprocess.run(["cargo", "build", "--quiet", "--release", "-p", "nprl-drivers", "--bin", "lwr_fit_timing"],
                   cwd=ROOT, check=True)
    label = "lwr (LwrModel::fit)" if args.tune_evals is None else f"lwr ({args.tune_evals} evaluations, {args.tune_points or 'all'} points)"
    rows = [(label, run_lwr(xtr, ytr, xte, yte, args.tune_evals, args.tune_points))]
    if args.compass:
        rows.append(("lwr (compass search)", run_lwr(xtr, ytr, xte, yte, args.tune_evals, args.tune_points, "compass")))
    rows.append(("KNN, k by GridSearchCV", run_knn(xtr, ytr, xte, yte)))
    if args.kernelreg:
        rows.append(("KernelReg ll, cv_ls", run_kernelreg(xtr, ytr, xte, yte)))
    commit = subprocess.run(["git", "rev-parse", "--short=7", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    print(f"diabetes, 80/20 split (seed {args.seed}): {len(ytr)} training and {len(yte)} test rows; commit {commit}")
    print("| method | test RMSE | fit s | predict s | notes |")
    print("|---|---|---|---|---|")
    for name, r in rows:
        notes = []
        if "coverage" in r:
            notes.append(f"95 % intervals cover {r['coverage']:.0%}")
        if r.get("tune_evals") is not None:
            notes.append(f"{r['tune_evals']} leave-one-out evaluations, LOO nMSE {r['loo']:.4f}")
        if "k" in r:
            notes.append(f"k = {r['k']}")
        print(f"| {name} | {r['rmse']:.2f} | {r['fit_s']:.3f} | {r['predict_s']:.4f} | {', '.join(notes)} |")


if __name__ == "__main__":
    main()
