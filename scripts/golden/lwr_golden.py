#!/usr/bin/env python3
"""Golden values for the `lwr` crate: locally weighted regression computed
with plain numpy (dense weighted least squares at each query) and scipy's
Student-t quantile, written to lwr/tests/data/lwr_golden.json.

Run with the reference environment (numpy, scipy):

    .venv-ref/bin/python scripts/golden/lwr_golden.py

The Rust test `lwr/tests/golden.rs` reads the JSON (it never runs Python) and
compares to 1e-10 relative. Leave-one-out residuals here come from actually
refitting without each point, not from the closed form the crate uses.
"""

import json
import pathlib

import numpy as np
from scipy import stats

OUT = pathlib.Path(__file__).resolve().parents[2] / "lwr" / "tests" / "data" / "lwr_golden.json"


def kernel(name, u, cutoff):
    u = np.asarray(u, dtype=float)
    if name == "Gaussian":
        return np.where(u < cutoff, np.exp(-0.5 * u * u), 0.0)
    inside = u < 1.0
    if name == "Tricube":
        return np.where(inside, (1.0 - u**3) ** 3, 0.0)
    if name == "Epanechnikov":
        return np.where(inside, 1.0 - u**2, 0.0)
    if name == "Bisquare":
        return np.where(inside, (1.0 - u**2) ** 2, 0.0)
    raise ValueError(name)


def design(x, q, degree):
    delta = x - q
    cols = [np.ones(len(x))]
    if degree in ("Linear", "Quadratic"):
        cols += [delta[:, j] for j in range(x.shape[1])]
    if degree == "Quadratic":
        d = x.shape[1]
        cols += [delta[:, a] * delta[:, b] for a in range(d) for b in range(a, d)]
    return np.column_stack(cols)


def fit(x, y, q, case):
    scales = np.asarray(case["scales"])
    h = case["bandwidth"]
    # same support rule as the crate: d^2 < (c h)^2
    support = h * (case["gaussian_cutoff"] if case["kernel"] == "Gaussian" else 1.0)
    d2 = (((x - q) * scales) ** 2).sum(axis=1)
    keep = d2 < support**2
    u = np.sqrt(d2) / h
    k = np.where(keep, kernel(case["kernel"], u, case["gaussian_cutoff"]), 0.0)
    z = design(x, q, case["degree"])
    p = z.shape[1]
    lam = case["ridge"] * np.eye(p)
    lam[0, 0] = 0.0
    a = z.T @ (k[:, None] * z) + lam
    pmat = np.linalg.inv(a)
    beta = np.linalg.solve(a, z.T @ (k[:, None] * y))
    smoother = k * (z @ pmat[:, 0])  # l(q)
    mean = smoother @ y  # = beta[0]
    assert np.allclose(mean, beta[0], rtol=1e-12, atol=1e-12)
    n_lwr = k.sum()
    p_lwr = float(np.sum(k**2 * np.einsum("ij,jk,ik->i", z, pmat, z)))
    dof = n_lwr - p_lwr
    resid = y - z @ beta
    sigma2 = (k[:, None] * resid**2).sum(axis=0) / dof
    lev = float(smoother @ smoother)
    t = float(stats.t.ppf(0.5 + 0.5 * case["confidence_level"], dof))
    se = np.sqrt(sigma2 * lev)
    return {
        "mean": beta[0].tolist(),
        "noise_variance": sigma2.tolist(),
        "std_error": se.tolist(),
        "confidence_half_width": (t * se).tolist(),
        "prediction_half_width": (t * np.sqrt(sigma2 * (1.0 + lev))).tolist(),
        "t_quantile": t,
        "n_lwr": float(n_lwr),
        "p_lwr": p_lwr,
        "leverage": lev,
        "n_neighbors": int((k > 0).sum()),
    }


def loo(x, y, case):
    n = len(x)
    res, lev, fitted = [], [], []
    for i in range(n):
        full = fit(x, y, x[i], case)
        mask = np.arange(n) != i
        rest = fit(x[mask], y[mask], x[i], case)
        res.append((y[i] - np.asarray(rest["mean"])).tolist())
        fitted.append(full["mean"])
        # L_ii: point i's entry of the smoother vector at its own input
        scales = np.asarray(case["scales"])
        z = design(x, x[i], case["degree"])
        d2 = (((x - x[i]) * scales) ** 2).sum(axis=1)
        support = case["bandwidth"] * (case["gaussian_cutoff"] if case["kernel"] == "Gaussian" else 1.0)
        k = np.where(d2 < support**2, kernel(case["kernel"], np.sqrt(d2) / case["bandwidth"], case["gaussian_cutoff"]), 0.0)
        lam = case["ridge"] * np.eye(z.shape[1])
        lam[0, 0] = 0.0
        pmat = np.linalg.inv(z.T @ (k[:, None] * z) + lam)
        lev.append(float(k[i] * z[i] @ pmat[:, 0]))
    res = np.asarray(res)
    fitted = np.asarray(fitted)
    rss = ((y - fitted) ** 2).sum(axis=0)
    tr = sum(lev)
    return {
        "residuals": res.tolist(),
        "leverages": lev,
        "press": (res**2).sum(axis=0).tolist(),
        "gcv": (n * rss / (n - tr) ** 2).tolist(),
    }


def main():
    rng = np.random.default_rng(20240601)
    cases = [
        dict(name="gaussian_linear_2d_2out", d=2, o=2, n=60, kernel="Gaussian", bandwidth=0.5,
             scales=[1.0, 0.5], degree="Linear", ridge=0.0, with_loo=True),
        dict(name="tricube_linear_3d_ridge_dropped_input", d=3, o=1, n=80, kernel="Tricube", bandwidth=0.9,
             scales=[1.0, 2.0, 0.0], degree="Linear", ridge=1e-3, with_loo=True),
        dict(name="bisquare_quadratic_2d", d=2, o=1, n=120, kernel="Bisquare", bandwidth=0.8,
             scales=[1.0, 1.0], degree="Quadratic", ridge=0.0, with_loo=False),
        dict(name="epanechnikov_constant_1d", d=1, o=1, n=50, kernel="Epanechnikov", bandwidth=0.3,
             scales=[1.0], degree="Constant", ridge=0.0, with_loo=True),
        dict(name="gaussian_truncated_quadratic_2d", d=2, o=1, n=100, kernel="Gaussian", bandwidth=0.25,
             scales=[1.5, 1.0], degree="Quadratic", ridge=1e-2, gaussian_cutoff=2.0, with_loo=False),
    ]
    out = []
    for case in cases:
        case.setdefault("gaussian_cutoff", 5.0)
        case["confidence_level"] = 0.95
        d, o, n = case["d"], case["o"], case["n"]
        x = rng.uniform(-1.0, 1.0, size=(n, d))
        y = np.column_stack([np.sin(2.0 * x[:, 0] + k) + 0.5 * x[:, -1] ** 2 for k in range(o)])
        y += 0.05 * rng.standard_normal(size=y.shape)
        queries = rng.uniform(-0.6, 0.6, size=(4, d))
        preds = [fit(x, y, q, case) for q in queries]
        entry = {k: v for k, v in case.items() if k != "with_loo"}
        entry.update(inputs=x.tolist(), outputs=y.tolist(), queries=queries.tolist(), predictions=preds)
        if case["with_loo"]:
            entry["loo"] = loo(x, y, case)
        out.append(entry)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(json.dumps({"generator": "scripts/golden/lwr_golden.py", "cases": out}, indent=1))
    print(f"wrote {OUT} ({len(out)} cases)")


if __name__ == "__main__":
    main()
