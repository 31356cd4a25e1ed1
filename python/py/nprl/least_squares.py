"""Nonlinear least squares with ``scipy.optimize.least_squares``'s
signature, over the Rust solvers."""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.optimize import Bounds, OptimizeResult

from . import _nprl

_METHODS = {
    "trf": "trust-region",
    "dogbox": "trust-region",
    "lm": "trust-region",
    "derivative-free": "derivative-free",
    "powell": "powell",
}


def _bounds(bounds, n):
    if isinstance(bounds, Bounds):
        lb, ub = bounds.lb, bounds.ub
    else:
        if len(bounds) != 2:
            raise ValueError("`bounds` must contain 2 elements.")
        lb, ub = bounds
    lb = np.broadcast_to(np.asarray(lb, dtype=float), (n,)).copy()
    ub = np.broadcast_to(np.asarray(ub, dtype=float), (n,)).copy()
    if np.any(lb >= ub):
        raise ValueError("Each lower bound must be strictly less than each upper bound.")
    if np.all(np.isinf(lb)) and np.all(np.isinf(ub)):
        return None, None
    return lb, ub


def _pattern(jac_sparsity, m, n):
    pattern = sp.csr_array(jac_sparsity if sp.issparse(jac_sparsity) else np.atleast_2d(jac_sparsity))
    if pattern.shape != (m, n):
        raise ValueError(f"`jac_sparsity` has shape {pattern.shape}, expected {(m, n)}.")
    pattern = sp.csr_array(pattern != 0)
    pattern.sum_duplicates()
    pattern.sort_indices()
    return [int(i) for i in pattern.indptr], [int(j) for j in pattern.indices]


def least_squares(
    fun,
    x0,
    jac="2-point",
    bounds=(-np.inf, np.inf),
    method="trf",
    ftol=1e-8,
    xtol=1e-8,
    gtol=1e-8,
    x_scale=None,
    loss="linear",
    f_scale=1.0,
    diff_step=None,
    tr_solver=None,
    tr_options=None,
    jac_sparsity=None,
    max_nfev=None,
    verbose=0,
    args=(),
    kwargs=None,
):
    """Minimises ``0.5 * sum(rho(f_i(x)**2))`` as ``scipy.optimize.least_squares``
    does, with its signature and result fields, over the Rust solvers.

    Parameters are scipy's; the differences:

    method : {"trf", "dogbox", "lm", "derivative-free", "powell"}
        "trf", "dogbox" and "lm" all run the toolkit's trust-region
        Levenberg-Marquardt (Moré's step, as MINPACK's lmder; the region in
        the parameters' units, or scaled by the Jacobian's column norms with
        ``x_scale="jac"``); with ``bounds`` its damped Gauss-Newton, which
        keeps them by projected Newton steps (so "lm" accepts bounds);
        "derivative-free" the derivative-free least-squares mode (residuals
        only; Curtis-Powell-Reid groups with ``jac_sparsity``);
        "powell" Powell's conjugate directions on the cost.
    jac : {"2-point", "3-point"} or callable
        A callable returns the m x n Jacobian (an array or a scipy.sparse
        matrix); "2-point" / "3-point" choose forward or central
        differences ("cs" is not supported).
    ftol, xtol, gtol : float
        The relative cost-decrease, step and gradient tolerances.
    max_nfev : int or None
        For "powell", the cap on evaluations; for the other methods, the
        cap on iterations (default 100 n, as scipy's trf, whose ``nfev``
        leaves out the differences' calls).
    x_scale : None, 1.0 or "jac"
        The trust region's scaling: the parameters' units (None, 1.0, as
        scipy's default) or the Jacobian's running column norms ("jac");
        other values raise NotImplementedError.
    diff_step, tr_solver, tr_options, verbose
        Accepted for compatibility; the linear solver is the solver's own
        (``diff_step`` raises NotImplementedError).

    Returns
    -------
    OptimizeResult with scipy's fields ``x``, ``cost``, ``fun``, ``jac``,
    ``grad``, ``optimality``, ``active_mask`` (``grad`` is ``J^T f`` and
    ``optimality`` its largest free component: with a robust loss, those of
    the squared loss, not of the robust cost), ``nfev`` (every call of
    ``fun``, the differences' included), ``njev``, ``status``, ``message``,
    ``success``, and also ``nit``, ``solver_status`` (the Rust solver's
    status), ``standard_errors`` and ``covariance`` (of the estimate,
    sigma^2 (J^T J)^-1 with sigma^2 = 2 cost / (m - n); None when m <= n or
    J is rank deficient).

    ``status``: 1, 2, 3 as scipy (the gradient, cost and step tests), 0
    a budget used up, -2 the solver stalled (steps kept failing while
    the gradient is not small) or met non-finite values, -3 stopped.

    Raises
    ------
    ValueError
        Bad input, as scipy (non-finite start or residuals at the start,
        bounds, shapes).
    nprl.LeastSquaresError
        A solver's error (a ``ValueError``).
    Any exception ``fun`` or ``jac`` raises, as raised.
    """
    if kwargs is None:
        kwargs = {}
    if method not in _METHODS:
        raise ValueError(f"`method` must be one of {sorted(_METHODS)}, got {method!r}.")
    if not (x_scale is None or (isinstance(x_scale, str) and x_scale == "jac") or np.all(np.asarray(x_scale) == 1.0)):
        raise NotImplementedError("x_scale: give None, 1.0 or 'jac'")
    if diff_step is not None:
        raise NotImplementedError("diff_step: the differences use scipy's default relative steps")
    if not callable(jac) and jac not in ("2-point", "3-point"):
        raise NotImplementedError(f"jac={jac!r}: give a callable, '2-point' or '3-point'")
    x0 = np.atleast_1d(np.asarray(x0, dtype=float)).copy()
    if x0.ndim > 1:
        raise ValueError("`x0` must have at most 1 dimension.")
    if not np.all(np.isfinite(x0)):
        raise ValueError("`x0` must be finite.")
    n = x0.size
    lb, ub = _bounds(bounds, n)
    if lb is not None and np.any((x0 < lb) | (x0 > ub)):
        raise ValueError("`x0` is infeasible.")

    def f(x):
        return np.atleast_1d(fun(x, *args, **kwargs))

    f0 = np.ascontiguousarray(f(x0.copy()), dtype=float).ravel()
    if not np.all(np.isfinite(f0)):
        raise ValueError("Residuals are not finite in the initial point.")
    m = f0.size

    jac_fn = None
    if callable(jac):

        def jac_fn(x):
            j = jac(x, *args, **kwargs)
            return j.toarray() if sp.issparse(j) else j

    sparsity = None if jac_sparsity is None else _pattern(jac_sparsity, m, n)
    out = _nprl.least_squares(
        f,
        x0,
        f0,
        jac_fn,
        "3-point" if jac == "3-point" else "2-point",
        sparsity,
        None if lb is None else list(lb),
        None if ub is None else list(ub),
        _METHODS[method] + ("-jac" if isinstance(x_scale, str) and _METHODS[method] == "trust-region" else ""),
        loss,
        float(f_scale),
        float(ftol),
        float(xtol),
        float(gtol),
        int(max_nfev) if (max_nfev is not None and method != "powell") else 100 * max(n, 1),
        None if max_nfev is None else int(max_nfev),
    )
    x, r, J = out["x"], out["fun"], out["jac"]
    grad = J.T @ r
    active = np.zeros(n, dtype=int)
    if lb is not None:
        active[x <= lb] = -1
        active[x >= ub] = 1
    out["grad"] = grad
    out["optimality"] = float(np.max(np.abs(np.where(active == 0, grad, 0.0)))) if n else 0.0
    out["active_mask"] = active
    if verbose:
        print(f"{out['message']} nfev {out['nfev']}, cost {out['cost']:.6e}")
    return OptimizeResult(**out)
