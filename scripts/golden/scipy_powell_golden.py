"""Golden values for `trajopt::powell`, from scipy.optimize.minimize(method="Powell").

Writes trajopt/tests/data/scipy_powell.json: for each problem the start point,
scipy's solution x, final cost, number of cost evaluations (nfev) and
iterations (nit) at scipy's default tolerances (xtol = ftol = 1e-4), and the
number of evaluations after which scipy's best cost first reached its final
cost (`nfev_to_final`).

Run from the repository root:
  python3 -m venv .venv-ref && .venv-ref/bin/pip install -r scripts/requirements.txt
  .venv-ref/bin/python scripts/golden/scipy_powell_golden.py
Floats are written by repr (json), so they round-trip exactly.
"""
import json
import pathlib

import numpy as np
import scipy
from scipy.optimize import minimize


def rosenbrock(x):
    return float(np.sum(100.0 * (x[1:] - x[:-1] ** 2) ** 2 + (1.0 - x[:-1]) ** 2))


def powell_singular(x):
    return float(
        (x[0] + 10 * x[1]) ** 2 + 5 * (x[2] - x[3]) ** 2 + (x[1] - 2 * x[2]) ** 4 + 10 * (x[0] - x[3]) ** 4
    )


PROBLEMS = [
    ("rosenbrock", rosenbrock, [-1.2, 1.0], [1.0, 1.0]),
    ("powell_singular", powell_singular, [3.0, -1.0, 0.0, 1.0], [0.0, 0.0, 0.0, 0.0]),
]


def main():
    out = {"scipy_version": scipy.__version__, "problems": []}
    for name, f, x0, minimiser in PROBLEMS:
        values = []

        def counted(x, f=f, values=values):
            v = f(x)
            values.append(v)
            return v

        res = minimize(counted, np.array(x0), method="Powell")
        best = np.minimum.accumulate(values)
        nfev_to_final = int(np.argmax(best <= res.fun)) + 1
        out["problems"].append(
            {
                "name": name,
                "x0": x0,
                "minimiser": minimiser,
                "x": [float(v) for v in res.x],
                "cost": float(res.fun),
                "nfev": int(res.nfev),
                "nit": int(res.nit),
                "nfev_to_final": nfev_to_final,
                "message": str(res.message),
            }
        )
    path = pathlib.Path(__file__).resolve().parents[2] / "trajopt" / "tests" / "data" / "scipy_powell.json"
    path.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
