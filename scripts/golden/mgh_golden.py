"""Golden values for `trajopt::problems::mgh`, the Moré-Garbow-Hillstrom test set.

An independent NumPy implementation of the 35 residual functions of
J. J. Moré, B. S. Garbow, K. E. Hillstrom, "Testing Unconstrained Optimization
Software", ACM TOMS 7(1), 17-41, 1981, written from the paper's formulas
(vectorised over the residuals, unlike the Rust loops), at the standard sizes
of trajopt's `mgh::all()`.

Writes trajopt/tests/data/mgh_golden.json with, per problem:
- `x0`, `f0` = f(x0) and `r0` = the residuals at x0;
- a second fixed point `x1` = x0 + 0.1 (1 + |x0|) sin(j + 1) and `r1` there;
- `minpack_lm`: scipy.optimize.least_squares(method="lm") from x0 (MINPACK's
  lmdif, forward-difference Jacobian, ftol = xtol = gtol = 1e-15): the final
  f = sum r^2 (scipy's `cost` is half of it), x, nfev, status. For comparisons
  only: the Rust tests check these for sanity, not equality. Reruns can
  differ in the last digits of these (and take a few more or fewer
  evaluations): NumPy's vectorised sums round differently with the arrays'
  memory alignment, and MINPACK's path amplifies that.
And, at the top level, `minpack1_initial_norms`: the initial residual norms
||f(scale x0)|| printed in MINPACK-1's test results (the outputs of the lmder
and hybrj test drivers of Moré, Garbow, Hillstrom, "User Guide for MINPACK-1",
ANL-80-74, 1980), 8 significant digits, for the problems and sizes where
MINPACK-1 uses the same residuals. This script checks its own functions
against them before writing anything.

Run from the repository root:
  python3 -m venv .venv-ref && .venv-ref/bin/pip install numpy scipy
  .venv-ref/bin/python scripts/golden/mgh_golden.py
Floats are written by repr (json), so they round-trip exactly.
"""
import json
import pathlib

import numpy as np
import scipy
from scipy.optimize import least_squares

OUT = pathlib.Path(__file__).resolve().parents[2] / "trajopt" / "tests" / "data" / "mgh_golden.json"


def idx(m):
    """The paper's 1-based indices i = 1..m as floats."""
    return np.arange(1, m + 1, dtype=float)


def rosenbrock(x, m):
    return np.array([10 * (x[1] - x[0] ** 2), 1 - x[0]])


def freudenstein_roth(x, m):
    a, b = x
    return np.array([-13 + a + ((5 - b) * b - 2) * b, -29 + a + ((b + 1) * b - 14) * b])


def powell_badly_scaled(x, m):
    return np.array([1e4 * x[0] * x[1] - 1, np.exp(-x[0]) + np.exp(-x[1]) - 1.0001])


def brown_badly_scaled(x, m):
    return np.array([x[0] - 1e6, x[1] - 2e-6, x[0] * x[1] - 2])


def beale(x, m):
    i = idx(3)
    return np.array([1.5, 2.25, 2.625]) - x[0] * (1 - x[1] ** i)


def jennrich_sampson(x, m):
    i = idx(m)
    return 2 + 2 * i - (np.exp(i * x[0]) + np.exp(i * x[1]))


def helical_valley(x, m):
    a, b, c = x
    if a > 0:
        theta = np.arctan(b / a) / (2 * np.pi)
    elif a < 0:
        theta = np.arctan(b / a) / (2 * np.pi) + 0.5
    else:
        theta = 0.25 if b >= 0 else -0.25
    return np.array([10 * (c - 10 * theta), 10 * (np.sqrt(a * a + b * b) - 1), c])


BARD_Y = np.array([0.14, 0.18, 0.22, 0.25, 0.29, 0.32, 0.35, 0.39, 0.37, 0.58, 0.73, 0.96, 1.34, 2.10, 4.39])


def bard(x, m):
    u = idx(15)
    v = 16 - u
    w = np.minimum(u, v)
    return BARD_Y - (x[0] + u / (v * x[1] + w * x[2]))


GAUSS_Y = np.array(
    [0.0009, 0.0044, 0.0175, 0.0540, 0.1295, 0.2420, 0.3521, 0.3989, 0.3521, 0.2420, 0.1295, 0.0540, 0.0175,
     0.0044, 0.0009])


def gaussian(x, m):
    t = (8 - idx(15)) / 2
    return x[0] * np.exp(-x[1] * (t - x[2]) ** 2 / 2) - GAUSS_Y


MEYER_Y = np.array([34780, 28610, 23650, 19630, 16370, 13720, 11540, 9744, 8261, 7030, 6005, 5147, 4427, 3820,
                    3307, 2872], dtype=float)


def meyer(x, m):
    t = 45 + 5 * idx(16)
    return x[0] * np.exp(x[1] / (t + x[2])) - MEYER_Y


def gulf(x, m):
    t = idx(m) / 100
    y = 25 + np.abs(-50 * np.log(t)) ** (2 / 3)
    return np.exp(-np.abs(y - x[1]) ** x[2] / x[0]) - t


def box3d(x, m):
    t = idx(m) / 10
    return np.exp(-t * x[0]) - np.exp(-t * x[1]) - x[2] * (np.exp(-t) - np.exp(-10 * t))


def powell_singular(x, m):
    return np.array([x[0] + 10 * x[1], np.sqrt(5) * (x[2] - x[3]), (x[1] - 2 * x[2]) ** 2,
                     np.sqrt(10) * (x[0] - x[3]) ** 2])


def wood(x, m):
    return np.array([10 * (x[1] - x[0] ** 2), 1 - x[0], np.sqrt(90) * (x[3] - x[2] ** 2), 1 - x[2],
                     np.sqrt(10) * (x[1] + x[3] - 2), (x[1] - x[3]) / np.sqrt(10)])


KO_Y = np.array([0.1957, 0.1947, 0.1735, 0.1600, 0.0844, 0.0627, 0.0456, 0.0342, 0.0323, 0.0235, 0.0246])
KO_U = np.array([4, 2, 1, 0.5, 0.25, 0.167, 0.125, 0.1, 0.0833, 0.0714, 0.0625])


def kowalik_osborne(x, m):
    u = KO_U
    return KO_Y - x[0] * (u ** 2 + u * x[1]) / (u ** 2 + u * x[2] + x[3])


def brown_dennis(x, m):
    t = idx(m) / 5
    return (x[0] + t * x[1] - np.exp(t)) ** 2 + (x[2] + x[3] * np.sin(t) - np.cos(t)) ** 2


OSB1_Y = np.array([0.844, 0.908, 0.932, 0.936, 0.925, 0.908, 0.881, 0.850, 0.818, 0.784, 0.751, 0.718, 0.685,
                   0.658, 0.628, 0.603, 0.580, 0.558, 0.538, 0.522, 0.506, 0.490, 0.478, 0.467, 0.457, 0.448,
                   0.438, 0.431, 0.424, 0.420, 0.414, 0.411, 0.406])


def osborne1(x, m):
    t = 10 * (idx(33) - 1)
    return OSB1_Y - (x[0] + x[1] * np.exp(-t * x[3]) + x[2] * np.exp(-t * x[4]))


def biggs_exp6(x, m):
    t = idx(m) / 10
    y = np.exp(-t) - 5 * np.exp(-10 * t) + 3 * np.exp(-4 * t)
    return x[2] * np.exp(-t * x[0]) - x[3] * np.exp(-t * x[1]) + x[5] * np.exp(-t * x[4]) - y


OSB2_Y = np.array([
    1.366, 1.191, 1.112, 1.013, 0.991, 0.885, 0.831, 0.847, 0.786, 0.725, 0.746, 0.679, 0.608, 0.655, 0.616,
    0.606, 0.602, 0.626, 0.651, 0.724, 0.649, 0.649, 0.694, 0.644, 0.624, 0.661, 0.612, 0.558, 0.533, 0.495,
    0.500, 0.423, 0.395, 0.375, 0.372, 0.391, 0.396, 0.405, 0.428, 0.429, 0.523, 0.562, 0.607, 0.653, 0.672,
    0.708, 0.633, 0.668, 0.645, 0.632, 0.591, 0.559, 0.597, 0.625, 0.739, 0.710, 0.729, 0.720, 0.636, 0.581,
    0.428, 0.292, 0.162, 0.098, 0.054])


def osborne2(x, m):
    t = (idx(65) - 1) / 10
    model = (x[0] * np.exp(-t * x[4]) + x[1] * np.exp(-(t - x[8]) ** 2 * x[5])
             + x[2] * np.exp(-(t - x[9]) ** 2 * x[6]) + x[3] * np.exp(-(t - x[10]) ** 2 * x[7]))
    return OSB2_Y - model


def watson(x, m):
    n = len(x)
    t = idx(29)[:, None] / 29
    j = idx(n)[None, :]
    # sum_{j>=2} (j-1) x_j t^(j-2): the j = 1 term has a zero weight
    s1 = ((j - 1) * x[None, :] * t ** np.maximum(j - 2, 0)).sum(axis=1)
    s2 = (x[None, :] * t ** (j - 1)).sum(axis=1)
    return np.concatenate([s1 - s2 ** 2 - 1, [x[0], x[1] - x[0] ** 2 - 1]])


def extended_rosenbrock(x, m):
    out = np.empty(len(x))
    out[0::2] = 10 * (x[1::2] - x[0::2] ** 2)
    out[1::2] = 1 - x[0::2]
    return out


def extended_powell_singular(x, m):
    a, b, c, d = x[0::4], x[1::4], x[2::4], x[3::4]
    out = np.empty(len(x))
    out[0::4] = a + 10 * b
    out[1::4] = np.sqrt(5) * (c - d)
    out[2::4] = (b - 2 * c) ** 2
    out[3::4] = np.sqrt(10) * (a - d) ** 2
    return out


def penalty1(x, m):
    return np.concatenate([np.sqrt(1e-5) * (x - 1), [np.dot(x, x) - 0.25]])


def penalty2(x, m):
    n = len(x)
    i = idx(n)
    y = np.exp(i / 10) + np.exp((i - 1) / 10)
    sa = np.sqrt(1e-5)
    mid = sa * (np.exp(x[1:] / 10) + np.exp(x[:-1] / 10) - y[1:])
    tail = sa * (np.exp(x[1:] / 10) - np.exp(-0.1))
    last = np.sum((n - i + 1) * x ** 2) - 1
    return np.concatenate([[x[0] - 0.2], mid, tail, [last]])


def variably_dimensioned(x, m):
    s = np.sum(idx(len(x)) * (x - 1))
    return np.concatenate([x - 1, [s, s * s]])


def trigonometric(x, m):
    n = len(x)
    return n - np.sum(np.cos(x)) + idx(n) * (1 - np.cos(x)) - np.sin(x)


def brown_almost_linear(x, m):
    n = len(x)
    return np.concatenate([x[:-1] + np.sum(x) - (n + 1), [np.prod(x) - 1]])


def discrete_boundary_value(x, m):
    n = len(x)
    h = 1 / (n + 1)
    t = idx(n) * h
    xp = np.concatenate([[0.0], x, [0.0]])
    return 2 * x - xp[:-2] - xp[2:] + h ** 2 * (x + t + 1) ** 3 / 2


def discrete_integral_equation(x, m):
    n = len(x)
    h = 1 / (n + 1)
    t = idx(n) * h
    q = (x + t + 1) ** 3
    lower = np.tril(np.ones((n, n)))  # j <= i
    s_below = lower @ (t * q)
    s_above = (1 - lower) @ ((1 - t) * q)
    return x + h * ((1 - t) * s_below + t * s_above) / 2


def broyden_tridiagonal(x, m):
    xp = np.concatenate([[0.0], x, [0.0]])
    return (3 - 2 * x) * x - xp[:-2] - 2 * xp[2:] + 1


def broyden_banded(x, m):
    n = len(x)
    out = np.empty(n)
    for i in range(n):
        js = [j for j in range(max(0, i - 5), min(n - 1, i + 1) + 1) if j != i]
        out[i] = x[i] * (2 + 5 * x[i] ** 2) + 1 - sum(x[j] * (1 + x[j]) for j in js)
    return out


def linear_full_rank(x, m):
    n = len(x)
    a = np.eye(m, n) - 2.0 / m
    return a @ x - 1


def linear_rank1(x, m):
    a = np.outer(idx(m), idx(len(x)))
    return a @ x - 1


def linear_rank1_zero(x, m):
    n = len(x)
    a = np.outer(idx(m) - 1, idx(n))
    a[0, :] = 0
    a[-1, :] = 0
    a[:, 0] = 0
    a[:, -1] = 0
    return a @ x - 1


def chebyquad(x, m):
    n = len(x)
    # shifted Chebyshev polynomials by their trigonometric definition where
    # |2x - 1| <= 1, else by cosh (they are polynomials: both agree)
    y = 2 * x - 1
    i = idx(m)[:, None]
    inside = np.abs(y) <= 1
    tv = np.where(inside, np.cos(i * np.arccos(np.clip(y, -1, 1))),
                  np.sign(y) ** i * np.cosh(i * np.arccosh(np.maximum(np.abs(y), 1))))
    k = idx(m)
    integral = np.zeros(m)
    even = k % 2 == 0
    integral[even] = -1 / (k[even] ** 2 - 1)
    return tv.sum(axis=1) / n - integral


# (id, key, function, n, m, x0)
def problems():
    def grid_start(n):
        t = idx(n) / (n + 1)
        return t * (t - 1)

    return [
        (1, "rosenbrock", rosenbrock, 2, 2, [-1.2, 1]),
        (2, "freudenstein_roth", freudenstein_roth, 2, 2, [0.5, -2]),
        (3, "powell_badly_scaled", powell_badly_scaled, 2, 2, [0, 1]),
        (4, "brown_badly_scaled", brown_badly_scaled, 2, 3, [1, 1]),
        (5, "beale", beale, 2, 3, [1, 1]),
        (6, "jennrich_sampson", jennrich_sampson, 2, 10, [0.3, 0.4]),
        (7, "helical_valley", helical_valley, 3, 3, [-1, 0, 0]),
        (8, "bard", bard, 3, 15, [1, 1, 1]),
        (9, "gaussian", gaussian, 3, 15, [0.4, 1, 0]),
        (10, "meyer", meyer, 3, 16, [0.02, 4000, 250]),
        (11, "gulf", gulf, 3, 99, [5, 2.5, 0.15]),
        (12, "box3d", box3d, 3, 10, [0, 10, 20]),
        (13, "powell_singular", powell_singular, 4, 4, [3, -1, 0, 1]),
        (14, "wood", wood, 4, 6, [-3, -1, -3, -1]),
        (15, "kowalik_osborne", kowalik_osborne, 4, 11, [0.25, 0.39, 0.415, 0.39]),
        (16, "brown_dennis", brown_dennis, 4, 20, [25, 5, -5, -1]),
        (17, "osborne1", osborne1, 5, 33, [0.5, 1.5, -1, 0.01, 0.02]),
        (18, "biggs_exp6", biggs_exp6, 6, 13, [1, 2, 1, 1, 1, 1]),
        (19, "osborne2", osborne2, 11, 65, [1.3, 0.65, 0.65, 0.7, 0.6, 3, 5, 7, 2, 4.5, 5.5]),
        (20, "watson", watson, 6, 31, [0] * 6),
        (21, "extended_rosenbrock", extended_rosenbrock, 10, 10, [-1.2, 1] * 5),
        (22, "extended_powell_singular", extended_powell_singular, 12, 12, [3, -1, 0, 1] * 3),
        (23, "penalty1", penalty1, 10, 11, list(idx(10))),
        (24, "penalty2", penalty2, 10, 20, [0.5] * 10),
        (25, "variably_dimensioned", variably_dimensioned, 10, 12, list(1 - idx(10) / 10)),
        (26, "trigonometric", trigonometric, 10, 10, [0.1] * 10),
        (27, "brown_almost_linear", brown_almost_linear, 10, 10, [0.5] * 10),
        (28, "discrete_boundary_value", discrete_boundary_value, 10, 10, list(grid_start(10))),
        (29, "discrete_integral_equation", discrete_integral_equation, 10, 10, list(grid_start(10))),
        (30, "broyden_tridiagonal", broyden_tridiagonal, 10, 10, [-1] * 10),
        (31, "broyden_banded", broyden_banded, 10, 10, [-1] * 10),
        (32, "linear_full_rank", linear_full_rank, 5, 10, [1] * 5),
        (33, "linear_rank1", linear_rank1, 5, 10, [1] * 5),
        (34, "linear_rank1_zero", linear_rank1_zero, 5, 10, [1] * 5),
        (35, "chebyquad", chebyquad, 10, 10, list(idx(10) / 11)),
    ]


# MINPACK-1's printed initial residual norms ||f(scale x0)||: (id, n, m, driver,
# the norms at scale 1, 10, 100 as far as printed), flattened to (id, n, m,
# scale, norm, driver). lmder's test problems are least-squares problems as here;
# hybrj's are square systems, of which these have the same residuals. Watson's
# scaled starts are scale * (1, ..., 1) (its x0 is 0).
MINPACK1_NORMS_BY_START = [
    (32, 5, 10, "lmder", [5.0000000e+00]),
    (32, 5, 50, "lmder", [8.0622577e+00]),
    (33, 5, 10, "lmder", [2.9152187e+02]),
    (33, 5, 50, "lmder", [3.1016004e+03]),
    (34, 5, 10, "lmder", [1.2603968e+02]),
    (34, 5, 50, "lmder", [1.7489500e+03]),
    (1, 2, 2, "lmder", [4.9193496e+00, 1.3400631e+03, 1.4300005e+05]),
    (7, 3, 3, "lmder", [5.0000000e+01, 1.0295630e+02, 9.9126182e+02]),
    (13, 4, 4, "lmder", [1.4662878e+01, 1.2709839e+03, 1.2688790e+05]),
    (2, 2, 2, "lmder", [2.0012496e+01, 1.2432834e+04, 1.1426455e+07]),
    (8, 3, 15, "lmder", [6.4561363e+00, 3.6141853e+01, 3.8411468e+02]),
    (15, 4, 11, "lmder", [7.2891510e-02, 2.9793701e+00, 2.9959062e+01]),
    (10, 3, 16, "lmder", [4.1153467e+04, 4.1682169e+06]),
    (20, 6, 31, "lmder", [5.4772256e+00, 6.4331258e+03, 6.7425604e+05]),
    (20, 9, 31, "lmder", [5.4772256e+00, 1.2088127e+04, 1.2691093e+06]),
    (20, 12, 31, "lmder", [5.4772256e+00, 1.9220759e+04, 2.0189180e+06]),
    (12, 3, 10, "lmder", [3.2111584e+01]),
    (6, 2, 10, "lmder", [6.4585650e+01]),
    (16, 4, 20, "lmder", [2.8154384e+03, 5.5507335e+05, 6.1211252e+07]),
    (35, 1, 8, "lmder", [1.8862380e+00, 5.3833444e+09, 1.1808873e+18]),
    (35, 8, 8, "lmder", [1.9651386e-01]),
    (35, 9, 9, "lmder", [1.6994993e-01]),
    (35, 10, 10, "lmder", [1.8374783e-01]),
    (27, 10, 10, "lmder", [1.6530216e+01, 9.7656240e+06, 9.7656250e+16]),
    (27, 30, 30, "lmder", [8.3476044e+01]),
    (27, 40, 40, "lmder", [1.2802636e+02]),
    (17, 5, 33, "lmder", [9.3756402e-01]),
    (19, 11, 65, "lmder", [1.4468654e+00]),
    (3, 2, 2, "hybrj", [1.0654866e+00, 1.0000000e+00]),
    (35, 5, 5, "hybrj", [2.2570657e-01, 4.1172432e+06, 5.6361303e+11]),
    (35, 6, 6, "hybrj", [2.1547198e-01, 1.3079247e+08, 1.8755789e+14]),
    (35, 7, 7, "hybrj", [1.8376789e-01, 4.2693282e+09, 6.4143166e+16]),
    (28, 10, 10, "hybrj", [2.8080582e-02, 5.2555258e-01, 1.0657390e+02]),
    (29, 1, 1, "hybrj", [1.2792969e-01, 2.5625000e+00, 8.3611719e+02]),
    (29, 10, 10, "hybrj", [2.5182701e-01, 6.1168330e+00, 1.2693089e+03]),
    (26, 10, 10, "hybrj", [8.4117534e-02, 2.0305195e+01, 9.3369375e+01]),
    (30, 10, 10, "hybrj", [4.5825757e+00, 6.3910093e+02, 6.3337583e+04]),
    (31, 10, 10, "hybrj", [1.8973666e+01, 1.7130922e+04, 1.5949860e+07]),
]
MINPACK1_INITIAL_NORMS = [
    (pid, n, m, 10**k, norm, driver)
    for pid, n, m, driver, norms in MINPACK1_NORMS_BY_START
    for k, norm in enumerate(norms)
]


def start_at_size(pid, n):
    """x0 of problem `pid` with n parameters (the variable-size problems)."""
    t = idx(n) / (n + 1)
    return {
        20: np.zeros(n), 26: np.full(n, 1 / n), 27: np.full(n, 0.5), 28: t * (t - 1), 29: t * (t - 1),
        30: -np.ones(n), 31: -np.ones(n), 32: np.ones(n), 33: np.ones(n), 34: np.ones(n), 35: t,
    }[pid]


def check_minpack1(table):
    by_id = {p[0]: p for p in table}
    for pid, n, m, scale, norm, _ in MINPACK1_INITIAL_NORMS:
        _, _, f, n_std, _, x0 = by_id[pid]
        x = np.array(x0, float) if n == n_std else start_at_size(pid, n)
        x = np.full(n, float(scale)) if (scale != 1 and not x.any()) else scale * x
        got = np.linalg.norm(f(x, m))
        assert abs(got - norm) <= 6e-8 * norm, (pid, n, m, scale, got, norm)


def main():
    table = problems()
    check_minpack1(table)
    out = {
        "numpy_version": np.__version__,
        "scipy_version": scipy.__version__,
        "minpack1_initial_norms": [
            {"id": pid, "n": n, "m": m, "scale": scale, "norm": norm, "driver": driver}
            for pid, n, m, scale, norm, driver in MINPACK1_INITIAL_NORMS
        ],
        "problems": [],
    }
    for pid, key, f, n, m, x0 in table:
        x0 = np.array(x0, dtype=float)
        assert len(x0) == n
        r0 = f(x0, m)
        assert r0.shape == (m,), (key, r0.shape)
        x1 = x0 + 0.1 * (1 + np.abs(x0)) * np.sin(idx(n))
        r1 = f(x1, m)
        with np.errstate(all="ignore"):
            res = least_squares(lambda x: f(x, m), x0, method="lm", ftol=1e-15, xtol=1e-15, gtol=1e-15,
                                max_nfev=20000 * (n + 1))
        f_lm = float(np.sum(res.fun ** 2))
        out["problems"].append({
            "id": pid,
            "key": key,
            "n": n,
            "m": m,
            "x0": x0.tolist(),
            "f0": float(np.sum(r0 ** 2)),
            "r0": r0.tolist(),
            "x1": x1.tolist(),
            "r1": r1.tolist(),
            "minpack_lm": {"f": f_lm, "x": res.x.tolist(), "nfev": int(res.nfev), "status": int(res.status)},
        })
        print(f"{pid:2d} {key:28s} n={n:2d} m={m:2d} f0={np.sum(r0 ** 2):.6e}  lm: f={f_lm:.6e} "
              f"nfev={res.nfev} status={res.status}")
    OUT.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
