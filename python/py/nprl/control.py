"""DDP / iLQR (Eqs. 1-2 of the paper) over Python callables or a built-in
system."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Optional, Union

import numpy as np

from . import _nprl

BUILTIN_SYSTEMS = ("pendulum", "cartpole", "acrobot")


@dataclass
class DdpResult:
    """What :func:`ddp` returns: the plan, its local models, and why the
    solver stopped.

    Attributes
    ----------
    states : ndarray (horizon + 1, n)
    controls : ndarray (horizon, m)
    gains : ndarray (horizon, m, n)
        The feedback gains K_t of Eq. 2.
    value, value_gradient, value_hessian : ndarray
        Eq. 1's local quadratic value function at each step.
    cost, initial_cost : float
        The cost of the plan and of the warm start (no factor 1/2).
    cost_history : list of float
    iterations : int
    status : str
        The Rust solver's status ("Converged", "MaxIterations", ...).
    success : bool
        Whether the solver converged.
    nfev : int
        Calls of the dynamics' step (Python callables) or the solver's
        count (built-in systems).
    solve_time : float
        Seconds.
    """

    states: np.ndarray
    controls: np.ndarray
    gains: np.ndarray
    value: np.ndarray
    value_gradient: np.ndarray
    value_hessian: np.ndarray
    cost: float
    initial_cost: float
    cost_history: list = field(default_factory=list)
    iterations: int = 0
    status: str = ""
    success: bool = False
    nfev: int = 0
    solve_time: float = 0.0

    def policy(self, t: int, x) -> np.ndarray:
        """Eq. 2's local linear policy at step ``t``: ``u_t + K_t (x - x_t)``."""
        x = np.asarray(x, dtype=float)
        return self.controls[t] + self.gains[t] @ (x - self.states[t])

    def value_model(self, t: int, x) -> float:
        """Eq. 1's local quadratic value at step ``t``:
        ``V_t + V_x^T dx + dx^T V_xx dx / 2`` with ``dx = x - x_t``."""
        d = np.asarray(x, dtype=float) - self.states[t]
        return float(self.value[t] + self.value_gradient[t] @ d + 0.5 * d @ self.value_hessian[t] @ d)


def _weights(w, k, name):
    w = np.asarray(w, dtype=float)
    if w.ndim == 0:
        w = np.full(k, float(w))
    if w.ndim == 1:
        if w.size != k:
            raise ValueError(f"`{name}` has {w.size} diagonal entries, expected {k}")
        w = np.diag(w)
    if w.shape != (k, k):
        raise ValueError(f"`{name}` must be {k} x {k}, got shape {w.shape}")
    return [float(v) for v in w.ravel()]


def ddp(
    model: Union[str, Callable],
    x0=None,
    horizon: int = 100,
    *,
    n_controls: Optional[int] = None,
    jac: Optional[Callable] = None,
    q=None,
    r=None,
    qf=None,
    target=None,
    u_init=None,
    u_bounds=None,
    method: str = "ilqr",
    max_iterations: Optional[int] = None,
) -> DdpResult:
    """Plans ``horizon`` steps of ``x' = f(x, u)`` from ``x0`` by DDP/iLQR,
    minimising ``sum_t (x_t - target)^T Q (x_t - target) + u_t^T R u_t +
    (x_N - target)^T Qf (x_N - target)`` (no factor 1/2).

    Parameters
    ----------
    model : str or callable
        A built-in system, ``"pendulum"``, ``"cartpole"`` or ``"acrobot"``
        (its swing-up: time step 0.01 s, cost weights, target and start
        are the defaults of every other argument); or ``step(x, u) -> x'``
        on numpy arrays.
    x0 : array-like (n,)
        The start (built-ins: hanging at rest).
    horizon : int
        Steps.
    n_controls : int
        The control dimension m (callables; default: from ``u_init``).
    jac : callable, optional
        ``jac(x, u) -> (f_x, f_u)``, n x n and n x m; without it, central
        differences of ``step``.
    q, r, qf : array-like
        The weights: a scalar, a diagonal, or a full symmetric matrix
        (``qf`` defaults to ``q``).
    target : array-like (n,)
        The state target (default zeros).
    u_init : array-like (horizon, m)
        The warm start (default zeros).
    u_bounds : (lower, upper), optional
        Box limits on each control (box-DDP, projected Newton).
    method : {"ilqr", "ddp"}
        "ddp" uses the model's second derivatives (the built-ins have
        them; callables do not, so it equals "ilqr" there).
    max_iterations : int, optional

    Returns
    -------
    DdpResult

    Raises
    ------
    nprl.DdpError
        Bad sizes or limits, or a model that fails on the warm start.
    Any exception ``step`` or ``jac`` raises, as raised.
    """
    if isinstance(model, str):
        if model not in BUILTIN_SYSTEMS:
            raise ValueError(f"unknown system {model!r}: one of {BUILTIN_SYSTEMS}")
        d = _nprl.swingup_defaults(model)
        x0 = d["x0"] if x0 is None else x0
        q = d["q"] if q is None else q
        r = d["r"] if r is None else r
        qf = d["qf"] if qf is None else qf
        target = d["target"] if target is None else target
        n_controls = len(d["r"])
    elif not callable(model):
        raise TypeError("`model` must be a built-in system's name or a callable step(x, u)")
    if x0 is None:
        raise ValueError("`x0` is required for a callable model")
    x0 = np.atleast_1d(np.asarray(x0, dtype=float))
    n = x0.size
    if u_init is not None:
        u_init = np.asarray(u_init, dtype=float).reshape(horizon, -1)
        n_controls = u_init.shape[1] if n_controls is None else n_controls
    if n_controls is None:
        raise ValueError("`n_controls` (or `u_init`) is required for a callable model")
    m = int(n_controls)
    if q is None or r is None:
        raise ValueError("`q` and `r` are required for a callable model")
    qf = q if qf is None else qf
    target = np.zeros(n) if target is None else np.asarray(target, dtype=float)
    lower = upper = None
    if u_bounds is not None:
        lower = [float(v) for v in np.broadcast_to(np.asarray(u_bounds[0], dtype=float), (m,))]
        upper = [float(v) for v in np.broadcast_to(np.asarray(u_bounds[1], dtype=float), (m,))]
    out = _nprl.ddp(
        model,
        [float(v) for v in x0],
        int(horizon),
        m,
        jac,
        _weights(q, n, "q"),
        _weights(r, m, "r"),
        _weights(qf, n, "qf"),
        [float(v) for v in target],
        None if u_init is None else u_init.tolist(),
        lower,
        upper,
        method,
        max_iterations,
    )
    return DdpResult(**out)
