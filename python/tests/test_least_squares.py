"""nprl.least_squares against scipy.optimize.least_squares and NIST's
certified values."""
import numpy as np
import pytest
import scipy.sparse as sp
from scipy.optimize import least_squares as scipy_least_squares

import nprl

# NIST StRD Misra1a: y = b1 (1 - exp(-b2 x)), certified values and standard errors
MISRA_X = np.array([77.6, 114.9, 141.1, 190.8, 239.9, 289.0, 332.8, 378.4, 434.8, 477.3, 536.8, 593.1, 689.1, 760.0])
MISRA_Y = np.array([10.07, 14.73, 17.94, 23.93, 29.61, 35.18, 40.02, 44.82, 50.76, 55.05, 61.01, 66.40, 75.47, 81.78])
MISRA_B = np.array([2.3894212918e02, 5.5015643181e-04])
MISRA_SE = np.array([2.7070075241e00, 7.2668688436e-06])


def misra(b):
    return MISRA_Y - b[0] * (1 - np.exp(-b[1] * MISRA_X))


def misra_jac(b):
    e = np.exp(-b[1] * MISRA_X)
    return np.stack([-(1 - e), -b[0] * MISRA_X * e], axis=1)


@pytest.mark.parametrize("method", ["trf", "lm", "derivative-free", "powell"])
def test_misra1a_reaches_nists_certified_values(method):
    r = nprl.least_squares(misra, [500.0, 1e-4], method=method, ftol=1e-12, xtol=1e-12, gtol=1e-12)
    assert r.success, r.message
    np.testing.assert_allclose(r.x, MISRA_B, rtol=1e-5 if method == "powell" else 1e-7)
    s = scipy_least_squares(misra, [500.0, 1e-4], ftol=1e-12, xtol=1e-12, gtol=1e-12)
    np.testing.assert_allclose(r.x, s.x, rtol=1e-5 if method == "powell" else 1e-7)
    assert r.cost == pytest.approx(s.cost, rel=1e-6)
    np.testing.assert_allclose(r.fun, misra(r.x))
    if method != "powell":
        np.testing.assert_allclose(r.standard_errors, MISRA_SE, rtol=1e-3)


def test_the_trust_regions_scaling_follows_x_scale():
    # "jac": scaled by the Jacobian's running column norms (MINPACK's), which
    # on Misra1a's parameters (sizes 1e2 and 1e-4) takes another path to
    # the same certified values
    plain = nprl.least_squares(misra, [500.0, 1e-4], ftol=1e-12, xtol=1e-12, gtol=1e-12)
    scaled = nprl.least_squares(misra, [500.0, 1e-4], x_scale="jac", ftol=1e-12, xtol=1e-12, gtol=1e-12)
    assert plain.success and scaled.success
    np.testing.assert_allclose(scaled.x, MISRA_B, rtol=1e-7)
    assert scaled.nfev != plain.nfev
    with pytest.raises(NotImplementedError):
        nprl.least_squares(misra, [500.0, 1e-4], x_scale=[1.0, 1e-6])


def test_an_analytic_jacobian_is_used_and_counted():
    r = nprl.least_squares(misra, [500.0, 1e-4], jac=misra_jac)
    assert r.success and r.njev >= 1
    # at scipy's default tolerances (1e-8), within 1e-7 of the certified
    # values (the last step is taken before the cost's test stops)
    np.testing.assert_allclose(r.x, MISRA_B, rtol=1e-7)
    np.testing.assert_allclose(r.jac, misra_jac(r.x))
    np.testing.assert_allclose(r.grad, misra_jac(r.x).T @ misra(r.x))
    # fewer residual calls than with differences
    assert r.nfev < nprl.least_squares(misra, [500.0, 1e-4]).nfev


def broyden_tridiagonal(x):
    # More, Garbow and Hillstrom's problem 30: minimum 0
    xp = np.concatenate([[0.0], x, [0.0]])
    return (3 - 2 * x) * x - xp[:-2] - 2 * xp[2:] + 1


def test_a_declared_sparsity_saves_evaluations_and_keeps_the_answer():
    n = 60
    pattern = sp.diags([1, 1, 1], [-1, 0, 1], shape=(n, n))
    dense = nprl.least_squares(broyden_tridiagonal, -np.ones(n))
    sparse = nprl.least_squares(broyden_tridiagonal, -np.ones(n), jac_sparsity=pattern)
    assert dense.success and sparse.success
    assert sparse.cost < 1e-14 and dense.cost < 1e-14
    np.testing.assert_allclose(sparse.x, dense.x, atol=1e-8)
    # three colour groups instead of 60 columns per Jacobian
    assert sparse.nfev * 5 < dense.nfev


def test_a_sparse_jacobian_callable_is_accepted():
    n = 20

    def jac(x):
        return sp.diags([-np.ones(n - 1), 3 - 4 * x, -2 * np.ones(n - 1)], [-1, 0, 1], format="csr")

    r = nprl.least_squares(broyden_tridiagonal, -np.ones(n), jac=jac)
    assert r.success and r.cost < 1e-14


def test_bounds_are_kept_and_reported_active():
    # min (x0 - 2)^2 + (x1 + 1)^2 with x0 <= 1, x1 >= 0: the corner (1, 0)
    fun = lambda x: np.array([x[0] - 2.0, x[1] + 1.0])  # noqa: E731
    for method in ["trf", "derivative-free", "powell"]:
        r = nprl.least_squares(fun, [0.0, 0.5], bounds=([-np.inf, 0.0], [1.0, np.inf]), method=method)
        np.testing.assert_allclose(r.x, [1.0, 0.0], atol=1e-7)
        assert r.active_mask.tolist() == [1, -1]
        s = scipy_least_squares(fun, [0.0, 0.5], bounds=([-np.inf, 0.0], [1.0, np.inf]))
        np.testing.assert_allclose(r.x, s.x, atol=1e-7)


@pytest.mark.parametrize("loss", ["soft_l1", "huber", "cauchy", "arctan"])
def test_robust_losses_match_scipy(loss):
    rng = np.random.default_rng(0)
    t = np.linspace(0, 10, 50)
    y = 2.0 * np.exp(-0.3 * t) + 0.02 * rng.standard_normal(50)
    y[[5, 20, 33]] += [1.0, -0.8, 1.5]  # outliers
    fun = lambda b: b[0] * np.exp(-b[1] * t) - y  # noqa: E731
    r = nprl.least_squares(fun, [1.0, 0.1], loss=loss, f_scale=0.05, ftol=1e-12, xtol=1e-12, gtol=1e-12)
    s = scipy_least_squares(fun, [1.0, 0.1], loss=loss, f_scale=0.05, ftol=1e-12, xtol=1e-12, gtol=1e-12)
    assert r.success
    np.testing.assert_allclose(r.x, s.x, rtol=1e-6)
    assert r.cost == pytest.approx(s.cost, rel=1e-8)


def test_args_and_kwargs_reach_the_function():
    r = nprl.least_squares(lambda b, x, y=None: y - b[0] * x, [0.0], args=(np.arange(3.0),), kwargs={"y": np.arange(3.0) * 2})
    assert r.x[0] == pytest.approx(2.0)


def test_exceptions_of_the_callables_are_raised_as_they_are():
    class Mine(Exception):
        pass

    calls = []

    def fun(x):
        calls.append(1)
        if len(calls) > 3:
            raise Mine("from the user's function")
        return x - 1.0

    with pytest.raises(Mine, match="from the user's function"):
        nprl.least_squares(fun, [0.0, 0.0])
    with pytest.raises(ValueError, match="fun returned 3 values, expected 2"):
        nprl.least_squares(lambda x: np.zeros(2 if x[0] == 0 else 3), [0.0, 0.0])
    with pytest.raises(ValueError, match="not finite in the initial point"):
        nprl.least_squares(lambda x: x / 0.0, [0.0])
    with pytest.raises(ValueError, match="infeasible"):
        nprl.least_squares(lambda x: x, [2.0], bounds=(0, 1))
    with pytest.raises(ValueError, match="loss must be one of"):
        nprl.least_squares(lambda x: x, [2.0], loss="l1")
