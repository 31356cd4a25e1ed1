#!/usr/bin/env python3
"""Side-by-side speed and error: the `lwr` crate against statsmodels' KernelReg and
scikit-learn's neighbour regressors, on the same data in one run.

    python3 scripts/compare_lwr.py [SIZES...]     (default 400 10000)
    options: --kernelreg-max N   largest training size given to KernelReg (default 500;
                                 its cv_ls is O(n^2) per evaluation: ~20 s at 400 points)
             --n-test N          test points (default 1000)

Sets up its own virtual environment (.venv-ref/, from scripts/requirements.txt) on
first use. For each training size it generates seeded data

    inputs a, b, c ~ U(-1, 1),   y = sin(3 a) + 0.5 b + 0.1 N(0, 1)   (c irrelevant)

writes it to a JSON file, runs `cargo run --release -p nprl-drivers --bin lwr_timing`
on it (with all cores, and where KernelReg runs again with RAYON_NUM_THREADS=1),
and times on the same data:

  KernelReg    statsmodels, local linear (reg_type='ll'), Gaussian kernel, bandwidths
               per input by least-squares cross-validation (bw='cv_ls')
  kNN          scikit-learn KNeighborsRegressor on standardised inputs, distance
               weights, k chosen by 5-fold GridSearchCV
  radius       scikit-learn RadiusNeighborsRegressor, same, radius by GridSearchCV
  lwr          LwrModel::tune (bandwidth and per-input scale by closed-form
               leave-one-out, from the metric 1/sd), local linear, Gaussian kernel

and prints per method: time to tune (KernelReg: cv_ls; sklearn: grid search; lwr:
tune), that time relative to lwr's, time per query (one query at a time where the
library allows; sklearn and KernelReg predict the test set in one call), the
leave-one-out / cross-validation nMSE where available, and the test nMSE
(sum (y - yhat)^2 / (n var y) on noisy test targets; the noise floor is printed).
"""
import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

from _venv import ROOT, ensure_venv  # noqa: E402  (scripts/ is on sys.path)
NOISE = 0.1


def make_data(n, n_test, seed):
    import numpy as np

    rng = np.random.default_rng(seed)

    def draw(m):
        x = rng.uniform(-1.0, 1.0, (m, 3))
        y = np.sin(3.0 * x[:, 0]) + 0.5 * x[:, 1] + NOISE * rng.standard_normal(m)
        return x, y

    return (*draw(n), *draw(n_test))


def nmse(pred, y):
    import numpy as np

    ok = np.isfinite(pred)
    return float(np.mean((pred[ok] - y[ok]) ** 2) / np.var(y[ok])), int((~ok).sum())


def run_rust(path, threads=None):
    env = dict(os.environ)
    if threads is not None:
        env["RAYON_NUM_THREADS"] = str(threads)
    cmd = ["cargo", "run", "--quiet", "--release", "-p", "nprl-drivers", "--bin", "lwr_timing", "--", str(path)]
    out = subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True, env=env).stdout
    return [json.loads(line) for line in out.splitlines() if line.startswith("{")][-1]


def run_kernelreg(xtr, ytr, xte, yte):
    import warnings

    from statsmodels.nonparametric.kernel_regression import KernelReg

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = time.perf_counter()
        kr = KernelReg(ytr, xtr, var_type="c" * xtr.shape[1], reg_type="ll", bw="cv_ls")
        tune = time.perf_counter() - t
        t = time.perf_counter()
        pred, _ = kr.fit(xte)
        query = (time.perf_counter() - t) / len(xte)
    err, failed = nmse(pred, yte)
    return dict(tune=tune, query=query, cv=None, test=err, failed=failed, note="bw " + ", ".join(f"{b:.3g}" for b in kr.bw))


def run_sklearn(kind, xtr, ytr, xte, yte):
    import warnings

    import numpy as np
    from sklearn.model_selection import GridSearchCV, KFold
    from sklearn.neighbors import KNeighborsRegressor, RadiusNeighborsRegressor
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    if kind == "kNN":
        est = make_pipeline(StandardScaler(), KNeighborsRegressor(weights="distance"))
        grid = {"kneighborsregressor__n_neighbors": [2, 3, 5, 8, 12, 16, 24, 32, 48, 64]}
    else:
        est = make_pipeline(StandardScaler(), RadiusNeighborsRegressor(weights="distance"))
        grid = {"radiusneighborsregressor__radius": list(np.geomspace(0.1, 1.5, 12))}
    search = GridSearchCV(est, grid, cv=KFold(5, shuffle=True, random_state=0), scoring="neg_mean_squared_error", n_jobs=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t = time.perf_counter()
        search.fit(xtr, ytr)
        tune = time.perf_counter() - t
        t = time.perf_counter()
        pred = search.predict(xte)
        query = (time.perf_counter() - t) / len(xte)
    err, failed = nmse(np.asarray(pred, dtype=float), yte)
    cv = float(-search.best_score_ / np.var(ytr))
    (name, value), = search.best_params_.items()
    return dict(tune=tune, query=query, cv=cv, test=err, failed=failed, note=f"{name.split('__')[1]} {value:.3g}")


def fmt_time(s):
    if s is None:
        return "-"
    if s >= 1.0:
        return f"{s:.2f} s"
    if s >= 1e-3:
        return f"{s * 1e3:.1f} ms"
    return f"{s * 1e6:.1f} us"


def main():
    ensure_venv(__file__)
    import numpy as np

    args = sys.argv[1:]
    kernelreg_max, n_test, sizes = 500, 1000, []
    while args:
        a = args.pop(0)
        if a == "--kernelreg-max":
            kernelreg_max = int(args.pop(0))
        elif a == "--n-test":
            n_test = int(args.pop(0))
        else:
            sizes.append(int(a))
    sizes = sizes or [400, 10000]
    subprocess.run(["cargo", "build", "--quiet", "--release", "-p", "nprl-drivers", "--bin", "lwr_timing"], cwd=ROOT, check=True)

    print(f"y = sin(3a) + 0.5b + {NOISE} N(0,1), c irrelevant; {n_test} test points; threads: {os.cpu_count()} cores")
    head = f"{'method':<14}{'n':>7}{'tune':>11}{'tune / lwr':>12}{'per query':>11}{'query / lwr':>13}{'CV nMSE':>9}{'test nMSE':>10}  notes"
    for n in sizes:
        xtr, ytr, xte, yte = make_data(n, n_test, seed=1000 + n)
        with tempfile.TemporaryDirectory() as tmp:
            path = pathlib.Path(tmp) / "data.json"
            path.write_text(json.dumps(dict(train_x=xtr.tolist(), train_y=ytr.tolist(), test_x=xte.tolist(), test_y=yte.tolist())))
            ours = run_rust(path)
            # single-threaded tuning is the fair reference for KernelReg; skip it where KernelReg does not run
            ours1 = run_rust(path, threads=1) if n <= kernelreg_max else ours
        rows = []
        bw = ", ".join("inf" if b is None else f"{b:.3g}" for b in ours["bandwidths"])
        rows.append(("lwr", dict(tune=ours["tune_s"], query=ours["query_s"], cv=ours["loo_nmse"], test=ours["test_nmse"], failed=ours["n_failed"],
                                 note=f"{ours['threads']} threads, {ours['tune_evals']} LOO evals ({ours.get('tune_evals_stopped_early', 0)} stopped early), "
                                      f"bw {bw}; batch {fmt_time(ours['batch_query_s'])}/query")))
        if ours1 is not ours:
            rows.append(("lwr 1 thread", dict(tune=ours1["tune_s"], query=ours1["query_s"], cv=ours1["loo_nmse"], test=ours1["test_nmse"],
                                              failed=ours1["n_failed"], note="RAYON_NUM_THREADS=1")))
        if n <= kernelreg_max:
            rows.append(("KernelReg ll", run_kernelreg(xtr, ytr, xte, yte)))
        rows.append(("sklearn kNN", run_sklearn("kNN", xtr, ytr, xte, yte)))
        rows.append(("sklearn radius", run_sklearn("radius", xtr, ytr, xte, yte)))

        floor = NOISE**2 / np.var(yte)
        print(f"\nn = {n} training points (test nMSE noise floor {floor:.4f})")
        print(head)
        for name, r in rows:
            cv = "-" if r["cv"] is None else f"{r['cv']:.4f}"
            failed = f"; {r['failed']} queries unanswered" if r["failed"] else ""
            ref_tune = ours1["tune_s"]
            ref_query = ours1["query_s"]
            print(f"{name:<14}{n:>7}{fmt_time(r['tune']):>11}{r['tune'] / ref_tune:>11.1f}x{fmt_time(r['query']):>11}"
                  f"{r['query'] / ref_query:>12.1f}x{cv:>9}{r['test']:>10.4f}  {r['note']}{failed}")
        kr = dict(rows).get("KernelReg ll")
        if kr:
            print(f"KernelReg cv_ls / lwr tune: {kr['tune'] / ours['tune_s']:.0f}x ({ours['threads']} threads), "
                  f"{kr['tune'] / ours1['tune_s']:.0f}x (1 thread)")
    print("\nratios: method / lwr (tune: lwr tune with RAYON_NUM_THREADS=1 where KernelReg runs, all cores above; query: lwr one query at a time); > 1: lwr is faster")


if __name__ == "__main__":
    main()
