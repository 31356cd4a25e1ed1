"""Golden values for the `splines` crate's B-splines, from scipy.interpolate.

Writes splines/tests/data/scipy_bspline.json:
  - design matrices (scipy.interpolate.BSpline.design_matrix) and derivative
    design matrices (columns = BSpline(t, e_j, k).derivative(r)(x)) for several
    degrees and knot vectors (clamped, uniform, non-uniform, repeated knots),
    at random times inside the domain and at both ends;
  - weighted least-squares fits (scipy.interpolate.make_lsq_spline);
  - knot insertion (scipy.interpolate.insert).

Run from the repository root:
  python3 -m venv .venv-ref && .venv-ref/bin/pip install -r scripts/requirements.txt
  .venv-ref/bin/python scripts/golden/scipy_bspline_golden.py
Floats are written by repr (json), so they round-trip exactly.
"""
import json
import pathlib

import numpy as np
import scipy
from scipy.interpolate import BSpline, insert, make_lsq_spline

rng = np.random.default_rng(20261121)


def clamped(breaks, k):
    return np.r_[[breaks[0]] * k, breaks, [breaks[-1]] * k]


BASES = [
    ("degree0", 0, np.array([0.0, 0.25, 0.5, 1.0])),
    ("linear_clamped", 1, clamped(np.linspace(0, 2, 5), 1)),
    ("quadratic_repeated_knot", 2, clamped(np.array([0.0, 0.3, 0.3, 0.7, 1.0]), 2)),
    ("cubic_clamped_uniform", 3, clamped(np.linspace(0.0, 2.5, 23), 3)),
    ("cubic_nonuniform", 3, clamped(np.array([-1.0, -0.9, -0.2, 0.0, 0.05, 0.6, 2.0]), 3)),
    ("cubic_unclamped_uniform", 3, np.linspace(-0.3, 1.3, 17)),
    ("quintic_clamped", 5, clamped(np.sort(np.r_[0.0, rng.uniform(0, 3, 6), 3.0]), 5)),
]


def times_in(t, k, n):
    lo, hi = t[k], t[len(t) - k - 1]
    x = np.sort(rng.uniform(lo, hi, n))
    return np.r_[lo, x, hi]


cases = []
for name, k, t in BASES:
    n = len(t) - k - 1
    x = times_in(t, k, 23)
    design = BSpline.design_matrix(x, t, k).toarray()
    derivs = {}
    for r in range(1, k + 2):
        cols = []
        for j in range(n):
            e = np.zeros(n)
            e[j] = 1.0
            spl = BSpline(t, e, k)
            cols.append(spl(x, nu=r) if r <= k else np.zeros_like(x))
        derivs[str(r)] = np.array(cols).T.tolist()
    cases.append(
        {
            "name": name,
            "degree": k,
            "knots": t.tolist(),
            "times": x.tolist(),
            "design": design.tolist(),
            "derivatives": derivs,
        }
    )

fits = []
for name, k, t in BASES[1:]:
    x = times_in(t, k, 80)
    y = np.sin(3.0 * x) + 0.1 * rng.standard_normal(x.size)
    w = rng.uniform(0.5, 2.0, x.size)
    c = make_lsq_spline(x, y, t, k, w=w).c
    fits.append(
        {"name": name, "degree": k, "knots": t.tolist(), "times": x.tolist(), "values": y.tolist(),
         "weights": w.tolist(), "coeffs": c.tolist()}
    )

inserts = []
for name, k, t in BASES[1:]:
    n = len(t) - k - 1
    c = rng.standard_normal(n)
    lo, hi = t[k], t[n]
    at = float(rng.uniform(lo, hi))
    t2, c2, _ = insert(at, (t, np.r_[c, np.zeros(k + 1)], k))
    inserts.append(
        {"name": name, "degree": k, "knots": t.tolist(), "coeffs": c.tolist(), "at": at,
         "new_knots": t2.tolist(), "new_coeffs": c2[: len(t2) - k - 1].tolist()}
    )

out = {
    "source": f"scipy {scipy.__version__}, numpy {np.__version__}; scripts/golden/scipy_bspline_golden.py",
    "bases": cases,
    "fits": fits,
    "inserts": inserts,
}
path = pathlib.Path(__file__).resolve().parents[2] / "splines" / "tests" / "data" / "scipy_bspline.json"
path.write_text(json.dumps(out))
print(f"wrote {path} ({path.stat().st_size} bytes)")
