"""Golden values for `trajopt::fit::Loss` and robust fits through `trajopt::LeastSquares`.

scipy.optimize.least_squares's robust losses (`soft_l1`, `huber`, `cauchy`,
`arctan`, and `linear`), taken from scipy itself:

- `rho`: for each loss, scipy's own loss function (the private
  `scipy.optimize._lsq.least_squares.IMPLEMENTED_LOSSES` callables, which
  return rho, rho' and rho'' of z) at a grid of z from 0 to 1e4;
- `fits`: for each loss, least_squares(method="trf") with that loss and
  f_scale = 0.1 on an exponential decay y = 2 exp(-0.7 t) sampled at 20
  points with three gross outliers, from x0 = (1, 0.1), tolerances 1e-15:
  the final x and scipy's cost (half of the sum of C^2 rho).

Writes trajopt/tests/data/scipy_losses.json. Run from the repository root:
  python3 -m venv .venv-ref && .venv-ref/bin/pip install numpy scipy
  .venv-ref/bin/python scripts/golden/scipy_losses_golden.py
Floats are written by repr (json), so they round-trip exactly.
"""

import json
import pathlib

import numpy as np
import scipy
from scipy.optimize import least_squares
from scipy.optimize._lsq.least_squares import IMPLEMENTED_LOSSES

LOSSES = ["linear", "soft_l1", "huber", "cauchy", "arctan"]
Z = [0.0, 1e-8, 1e-3, 0.25, 0.5, 1.0, 1.5, 2.0, 10.0, 123.0, 1e4]
T = np.linspace(0.0, 4.0, 20)
Y = 2.0 * np.exp(-0.7 * T)
Y[[3, 9, 15]] += [1.5, -1.0, 2.0]


def residuals(b):
    return Y - b[0] * np.exp(-b[1] * T)


def main():
    out = {"scipy_version": scipy.__version__, "z": Z, "rho": {}, "fits": {}, "t": list(T), "y": list(Y)}
    z = np.array(Z)
    for loss in LOSSES:
        f = IMPLEMENTED_LOSSES[loss]
        if f is None:  # linear
            rho, drho = z, np.ones_like(z)
        else:
            values = np.empty((3, z.size))
            f(z, values, cost_only=False)  # scipy writes rho, rho', rho'' into `values`
            rho, drho = values[0], values[1]
        out["rho"][loss] = {"rho": [float(v) for v in rho], "drho": [float(v) for v in drho]}
        res = least_squares(
            residuals, [1.0, 0.1], loss=loss, f_scale=0.1, method="trf", ftol=1e-15, xtol=1e-15, gtol=1e-15
        )
        out["fits"][loss] = {"x": [float(v) for v in res.x], "cost": float(res.cost), "status": int(res.status)}
    path = pathlib.Path(__file__).resolve().parents[2] / "trajopt" / "tests" / "data" / "scipy_losses.json"
    path.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
