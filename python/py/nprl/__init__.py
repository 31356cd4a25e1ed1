"""Nonparametric model-based reinforcement learning (Atkeson's paper), from
Python: the Rust toolkit's front doors in the conventions of scikit-learn,
scipy and gymnasium.

- :class:`LWRRegressor`: locally weighted regression, a scikit-learn
  estimator (metric tuned by leave-one-out in ``fit``, confidence and
  prediction intervals, exact Jacobians, online ``partial_fit``).
- :func:`least_squares`: nonlinear least squares with
  ``scipy.optimize.least_squares``'s signature and result.
- :func:`ddp`: DDP / iLQR over Python callables or a built-in system.
- :mod:`nprl.envs`: the paper's pendulum swing-up robot as a gymnasium
  environment (needs ``gymnasium``: ``pip install nprl[envs]``).

Errors of the Rust routines are raised as :class:`LwrError`,
:class:`LeastSquaresError` and :class:`DdpError`, each a ``ValueError``.
"""
from ._nprl import DdpError, LeastSquaresError, LwrError, __version__
from .control import DdpResult, ddp
from .least_squares import least_squares
from .lwr import LWRRegressor

__all__ = [
    "LWRRegressor",
    "least_squares",
    "ddp",
    "DdpResult",
    "LwrError",
    "LeastSquaresError",
    "DdpError",
    "__version__",
]
