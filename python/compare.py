#!/usr/bin/env python3
"""The Python package beside the references its users would pick, in one
run, written to results/python/comparison.{json,md} (stamped with the
commit):

1. NIST StRD (the 27 problems from both certified starts): nprl.least_squares
   and scipy.optimize.least_squares, both method="trf", 2-point
   differences, at scipy's default tolerances and at 1e-15; every call of
   `fun` counted on both sides (scipy's own nfev leaves out the differences'
   calls). "Solved": parameters to LRE >= 4 against NIST's certified
   values. Reported: problems each solves, the largest relative difference
   of x between the two where both solve, and the median evaluations.
2. The call overhead: wall time per residual evaluation of a solve minus
   the time spent inside the residual function in the same solves, on
   Misra1a.
3. LWRRegressor (defaults) against KNeighborsRegressor with k by 5-fold
   GridSearchCV on standardised inputs, on scikit-learn's diabetes data and
   on California-housing-sized synthetic data (make_friedman1, 20640 rows,
   8 inputs, noise 1), 80/20 splits of seeds 0 to SEEDS - 1: held-out RMSE, fit and
   predict seconds.

Run, with the package installed (python/ci.sh's venv, or `maturin develop`):
    python python/compare.py [--seeds 5]
"""
import argparse
import json
import os
import pathlib
import re
import subprocess
import sys
import time

import numpy as np
from scipy.optimize import least_squares as scipy_least_squares

import nprl

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts" / "bench"))
from outside import nist_problems  # noqa: E402  (the benchmark's own NIST models and parser)


def certified(name):
    text = (ROOT / "bench" / "data" / "nist" / f"{name}.dat").read_text()
    return np.array([float(l.split("=")[1].split()[2]) for l in text.splitlines() if re.match(r"\s*b\d+\s*=", l)])


def lre(x, c):
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.abs(x - c) / np.abs(c)
    return float(np.min(np.where(rel == 0, 15.0, -np.log10(rel))))


def counted(fun, m):
    calls = [0]

    def f(b):
        calls[0] += 1
        return fun(b, m)

    return f, calls


def nist(tol):
    rows = []
    for name, fun, n, m, starts in nist_problems():
        c = certified(name)
        for start, x0 in starts:
            row = {"problem": name, "start": int(start)}
            for who, solve in (("nprl", nprl.least_squares), ("scipy", scipy_least_squares)):
                f, calls = counted(fun, m)
                kw = {} if tol is None else {"ftol": tol, "xtol": tol, "gtol": tol}
                t = time.perf_counter()
                try:
                    with np.errstate(all="ignore"):
                        r = solve(f, np.array(x0, float), method="trf", max_nfev=None if who == "nprl" else 100 * n, **kw)
                    x = r.x
                except Exception as e:  # a failure is a record, not a crash
                    x = np.full(n, np.nan)
                    row[f"{who}_error"] = str(e)[:200]
                row[f"{who}_seconds"] = time.perf_counter() - t
                row[f"{who}_nfev"] = calls[0]
                row[f"{who}_lre"] = lre(x, c) if np.all(np.isfinite(x)) else 0.0
                row[f"{who}_x"] = [float(v) for v in x]
            rows.append(row)
    both = [r for r in rows if r["nprl_lre"] >= 4 and r["scipy_lre"] >= 4]
    diff = [float(np.max(np.abs(np.array(r["nprl_x"]) / np.array(r["scipy_x"]) - 1))) for r in both]
    return {
        "tolerance": "scipy's defaults (1e-8)" if tol is None else f"{tol:g}",
        "runs": len(rows),
        "nprl_solved": sum(r["nprl_lre"] >= 4 for r in rows),
        "scipy_solved": sum(r["scipy_lre"] >= 4 for r in rows),
        "nprl_lre6": sum(r["nprl_lre"] >= 6 for r in rows),
        "scipy_lre6": sum(r["scipy_lre"] >= 6 for r in rows),
        "both": len(both),
        "x_within_1e-6": sum(d <= 1e-6 for d in diff),
        # of the runs both solve whose x differ by more: how many of ours are
        # the closer to NIST's certified values (the larger LRE)
        "apart_nprl_closer": sum(d > 1e-6 and r["nprl_lre"] >= r["scipy_lre"] for d, r in zip(diff, both)),
        "largest_x_difference": max(diff) if diff else None,
        "nprl_median_nfev": float(np.median([r["nprl_nfev"] for r in both])) if both else None,
        "scipy_median_nfev": float(np.median([r["scipy_nfev"] for r in both])) if both else None,
        "rows": rows,
    }


def overhead():
    """Per evaluation: the solve's wall time minus the time spent inside the
    residual function, both measured in the same solves (so a busy machine
    slows both alike)."""
    name, fun, n, m, starts = next(p for p in nist_problems() if p[0] == "Misra1a")
    x0 = np.array(starts[0][1], float)
    calls, inside = [0], [0.0]

    def f(b):
        t = time.perf_counter()
        r = fun(b, m)
        inside[0] += time.perf_counter() - t
        calls[0] += 1
        return r

    reps = 50
    t = time.perf_counter()
    for _ in range(reps):
        nprl.least_squares(f, x0, ftol=1e-15, xtol=1e-15, gtol=1e-15)
    total = time.perf_counter() - t
    return {"problem": "Misra1a", "evaluations": calls[0] // reps, "seconds_per_evaluation": total / calls[0],
            "function_seconds": inside[0] / calls[0], "overhead_seconds": (total - inside[0]) / calls[0]}


def regression(seeds):
    from sklearn.datasets import load_diabetes, make_friedman1
    from sklearn.model_selection import GridSearchCV, train_test_split
    from sklearn.neighbors import KNeighborsRegressor
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    sets = {
        "diabetes (442 x 10)": load_diabetes(return_X_y=True),
        "friedman1 (20640 x 8, California-housing-sized)": make_friedman1(n_samples=20640, n_features=8, noise=1.0, random_state=0),
    }
    out = []
    for name, (X, y) in sets.items():
        for seed in seeds:
            Xa, Xb, ya, yb = train_test_split(X, y, test_size=0.2, random_state=seed)
            row = {"data": name, "seed": seed}
            knn = GridSearchCV(make_pipeline(StandardScaler(), KNeighborsRegressor()),
                               {"kneighborsregressor__n_neighbors": list(range(1, 51))}, cv=5)
            lwr = nprl.LWRRegressor()
            for who, model in (("lwr", lwr), ("knn", knn)):
                t = time.perf_counter()
                model.fit(Xa, ya)
                t_fit = time.perf_counter() - t
                t = time.perf_counter()
                p = model.predict(Xb)
                row[f"{who}_rmse"] = float(np.sqrt(np.mean((p - yb) ** 2)))
                row[f"{who}_fit_seconds"] = t_fit
                row[f"{who}_predict_seconds"] = time.perf_counter() - t
            row["knn_k"] = knn.best_params_["kneighborsregressor__n_neighbors"]
            row["lwr_bandwidth"] = lwr.bandwidth_
            out.append(row)
            print(f"{name} seed {seed}: lwr {row['lwr_rmse']:.4f} ({row['lwr_fit_seconds']:.1f} s), "
                  f"knn {row['knn_rmse']:.4f} ({row['knn_fit_seconds']:.1f} s)", flush=True)
    return out


def markdown(report):
    lines = [f"# nprl (Python) beside scipy and scikit-learn",
             "",
             f"Made by `python python/compare.py --seeds {report['seeds']}` at commit {report['commit']}, nprl {report['version']}, "
             f"scipy {report['scipy']}, scikit-learn {report['sklearn']}, one run.",
             "",
             "## NIST StRD: nprl.least_squares vs scipy.optimize.least_squares (trf, 2-point)",
             "",
             "| tolerances | runs | solved (LRE >= 4) nprl / scipy | LRE >= 6 nprl / scipy | both solve | x within 1e-6 of scipy's | further apart: nprl's the closer to NIST's | largest difference | median evaluations nprl / scipy |",
             "|---|---|---|---|---|---|---|---|---|"]
    for s in report["nist"]:
        diff = "-" if s["largest_x_difference"] is None else f"{s['largest_x_difference']:.1e}"
        lines.append(f"| {s['tolerance']} | {s['runs']} | {s['nprl_solved']} / {s['scipy_solved']} | {s['nprl_lre6']} / {s['scipy_lre6']} | "
                     f"{s['both']} | {s['x_within_1e-6']} | {s['apart_nprl_closer']} of {s['both'] - s['x_within_1e-6']} | {diff} | {s['nprl_median_nfev']:g} / {s['scipy_median_nfev']:g} |")
    o = report["overhead"]
    lines += ["", "Evaluations count every call of `fun`, the differences' included, on both sides. Both run "
              "method=\"trf\" with 2-point differences: scipy's trust region solved by SVD, nprl's by Moré's "
              "algorithm (`StepControl::TrustRegion`, `DampingScale::Identity`); each its own default iteration "
              "cap (scipy's trf 100 n evaluations of `fun` without the differences'; nprl 100 n iterations).", "",
              "## The Python call overhead", "",
              f"On {o['problem']} ({o['evaluations']} evaluations per solve): {o['seconds_per_evaluation'] * 1e6:.1f} us per "
              f"evaluation in a solve, of which the residual function itself takes {o['function_seconds'] * 1e6:.1f} us: "
              f"**{o['overhead_seconds'] * 1e6:.1f} us per evaluation** for the call from Rust, the arrays in and out, and the "
              "solver's own work.", "",
              "## LWRRegressor vs KNeighborsRegressor (k by 5-fold GridSearchCV)", "",
              "| data | seed | LWR RMSE | KNN RMSE (k) | LWR fit + predict s | KNN fit + predict s |", "|---|---|---|---|---|---|"]
    for r in report["regression"]:
        lines.append(f"| {r['data']} | {r['seed']} | {r['lwr_rmse']:.4f} | {r['knn_rmse']:.4f} ({r['knn_k']}) | "
                     f"{r['lwr_fit_seconds']:.2f} + {r['lwr_predict_seconds']:.2f} | {r['knn_fit_seconds']:.2f} + {r['knn_predict_seconds']:.2f} |")
    for data in dict.fromkeys(r["data"] for r in report["regression"]):
        rs = [r for r in report["regression"] if r["data"] == data]
        wins = sum(r["lwr_rmse"] <= r["knn_rmse"] for r in rs)
        lines.append(f"\n{data}: LWR's RMSE at or below KNN's on {wins} of {len(rs)} splits; mean RMSE "
                     f"{np.mean([r['lwr_rmse'] for r in rs]):.4f} (LWR) vs {np.mean([r['knn_rmse'] for r in rs]):.4f} (KNN).")
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=5, help="splits per data set: seeds 0 to SEEDS - 1 (default 5)")
    ap.add_argument("--out", default=str(ROOT / "results" / "python"))
    args = ap.parse_args()
    import scipy
    import sklearn
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"], capture_output=True, text=True).stdout.strip()
    report = {"commit": commit + ("-dirty" if dirty else ""), "version": nprl.__version__, "scipy": scipy.__version__,
              "sklearn": sklearn.__version__}
    report["seeds"] = args.seeds
    report["nist"] = [nist(None), nist(1e-15)]
    for s in report["nist"]:
        print({k: v for k, v in s.items() if k != "rows"}, flush=True)
    report["overhead"] = overhead()
    print(report["overhead"], flush=True)
    report["regression"] = regression(list(range(args.seeds)))
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name, text in (("comparison.json", json.dumps(report, indent=1)), ("comparison.md", markdown(report))):
        # written beside and renamed over: a link at the name is replaced, never followed
        tmp = out / f".{name}.tmp"
        tmp.write_text(text)
        os.replace(tmp, out / name)
    print(f"wrote {out / 'comparison.md'}")


if __name__ == "__main__":
    main()
