"""Locally weighted regression as a scikit-learn estimator."""
from __future__ import annotations

from numbers import Integral, Real
from typing import Optional

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils._param_validation import Interval, StrOptions
from sklearn.utils.validation import check_is_fitted, validate_data

from . import _nprl


class LWRRegressor(RegressorMixin, BaseEstimator):
    """Locally weighted regression (Atkeson, Moore and Schaal 1997) on a k-d
    tree: at each query a local polynomial is fitted to the stored points,
    each weighted by a kernel of its scaled distance to the query.

    ``fit`` sets each input's scale to 1 / its standard deviation (so the
    bandwidth is in standard deviations), then tunes the bandwidth and the
    scales by leave-one-out cross-validation (a scale that reaches 0 takes
    its input out of the distance: the weights ignore it, the local model
    stays linear in it); ``tune_evals=0`` keeps the initial metric. Inputs
    constant over the rows carry no information and are left out of the
    model (scale 0, derivative 0).

    Parameters
    ----------
    kernel : {"gaussian", "tricube", "epanechnikov", "bisquare"}
        The weighting kernel.
    degree : {"constant", "linear", "quadratic"}
        The local polynomial (constant: Nadaraya-Watson).
    bandwidth : float or None
        The initial bandwidth in standard deviations of the inputs (None:
        0.5 for the Gaussian kernel, 1.5 for the compact ones).
    tune_evals : int
        Leave-one-out evaluations of the metric's tuning (0: no tuning).
    tune_points : int
        Points cross-validated per evaluation (0: all); a subset makes the
        tuning of large data sets affordable.
    tune_method : {"lm", "compass"}
        The tuning's search: Levenberg-Marquardt on the leave-one-out
        residuals with their exact derivatives (after a compass search over
        the bandwidth; inputs tried at zero, compass sweeps at the end), or
        the derivative-free compass search (more evaluations).
    confidence_level : float
        The level of the confidence and prediction intervals.

    Attributes
    ----------
    n_features_in_ : int
        Inputs seen in ``fit``.
    bandwidth_ : float
        The tuned bandwidth.
    scales_ : ndarray of shape (n_features_in_,)
        The tuned scale of each input in the distance (0: not in the
        distance).
    tune_evals_ : int
        Leave-one-out evaluations the tuning spent.
    loo_mse_ : float or None
        The tuned metric's leave-one-out mean squared error (None untuned).

    Notes
    -----
    A query that no stored point weighs (beyond the kernel's support around
    every point) is predicted from its nearest points, the support widened
    to twice their distance: an extrapolation, with intervals from that
    widened fit.

    Examples
    --------
    >>> import numpy as np
    >>> from nprl import LWRRegressor
    >>> rng = np.random.default_rng(0)
    >>> X = rng.uniform(-1, 1, size=(200, 2))
    >>> y = np.sin(3 * X[:, 0]) + 0.5 * X[:, 1]
    >>> model = LWRRegressor().fit(X[:150], y[:150])
    >>> model.score(X[150:], y[150:]) > 0.95
    True
    >>> mean, std = model.predict(X[150:], return_std=True)
    """

    _parameter_constraints: dict = {
        "kernel": [StrOptions({"gaussian", "tricube", "epanechnikov", "bisquare"})],
        "degree": [StrOptions({"constant", "linear", "quadratic"})],
        "bandwidth": [Interval(Real, 0, None, closed="neither"), None],
        "tune_evals": [Interval(Integral, 0, None, closed="left")],
        "tune_points": [Interval(Integral, 0, None, closed="left")],
        "tune_method": [StrOptions({"lm", "compass"})],
        "confidence_level": [Interval(Real, 0, 1, closed="neither")],
    }

    def __init__(
        self,
        kernel: str = "gaussian",
        degree: str = "linear",
        bandwidth: Optional[float] = None,
        tune_evals: int = 300,
        tune_points: int = 0,
        confidence_level: float = 0.95,
        tune_method: str = "lm",
    ):
        self.kernel = kernel
        self.degree = degree
        self.bandwidth = bandwidth
        self.tune_evals = tune_evals
        self.tune_points = tune_points
        self.confidence_level = confidence_level
        self.tune_method = tune_method

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        tags.target_tags.single_output = True
        return tags

    @staticmethod
    def _targets(y):
        y = np.asarray(y, dtype=np.float64)
        return np.ascontiguousarray(y.reshape(len(y), -1))

    def fit(self, X, y):
        """Stores the rows and tunes the metric by leave-one-out.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        y : array-like of shape (n_samples,) or (n_samples, n_outputs)

        Returns
        -------
        self
        """
        self._validate_params()
        X, y = validate_data(self, X, y, multi_output=True, y_numeric=True, dtype=np.float64)
        if X.shape[0] < 2:
            raise ValueError(f"LWRRegressor needs at least 2 samples, got {X.shape[0]} sample")
        varies = np.ptp(X, axis=0) > 0
        if not varies.any():
            raise ValueError("no input varies over the rows: every feature is constant")
        self.active_inputs_ = np.flatnonzero(varies)
        self._y_ndim = np.ndim(y)
        Y = self._targets(y)
        self.model_ = _nprl.LwrCore.fit(
            self._active(X),
            Y,
            self.kernel,
            self.degree,
            self.bandwidth,
            int(self.tune_evals),
            int(self.tune_points),
            float(self.confidence_level),
            self.tune_method,
        )
        self._settle()
        return self

    def partial_fit(self, X, y):
        """Adds rows without tuning (online learning); the first call fits.

        Returns
        -------
        self
        """
        if not hasattr(self, "model_"):
            return self.fit(X, y)
        X, y = validate_data(self, X, y, multi_output=True, y_numeric=True, dtype=np.float64, reset=False)
        Y = self._targets(y)
        if Y.shape[1] != self.model_.n_outputs:
            raise ValueError(f"y has {Y.shape[1]} outputs, but the model was fitted with {self.model_.n_outputs}")
        self.model_.insert(self._active(X), Y)
        return self

    def _active(self, X):
        return np.ascontiguousarray(X[:, self.active_inputs_])

    def _settle(self):
        settings = self.model_.settings()
        self.bandwidth_ = settings["bandwidth"]
        scales = np.zeros(self.n_features_in_)
        scales[self.active_inputs_] = settings["scales"]
        self.scales_ = scales
        self.tune_evals_ = settings["tune_evals"]
        self.loo_mse_ = settings["tune_objective"]

    def _predictions(self, X):
        check_is_fitted(self)
        X = validate_data(self, X, reset=False, dtype=np.float64)
        return self.model_.predict(self._active(X))

    def _shape(self, a):
        return a[:, 0] if self._y_ndim == 1 else a

    def predict(self, X, return_std: bool = False):
        """The local fits' means at the rows of ``X``.

        Parameters
        ----------
        X : array-like of shape (n_samples, n_features)
        return_std : bool
            Also return the standard error of each mean (the standard
            deviation of the fitted mean, not of a new observation: see
            :meth:`prediction_interval` for that).

        Returns
        -------
        y_mean : ndarray of shape (n_samples,) or (n_samples, n_outputs)
        y_std : ndarray, same shape, only with ``return_std``
        """
        mean, std, _, _, _ = self._predictions(X)
        if return_std:
            return self._shape(mean), self._shape(std)
        return self._shape(mean)

    def confidence_interval(self, X):
        """The ``confidence_level`` interval of the mean at each row:
        ``mean -/+ t * std`` with the local fit's degrees of freedom
        (infinite where it has none). Returns ``(lower, upper)``."""
        mean, _, _, half, _ = self._predictions(X)
        return self._shape(mean - half), self._shape(mean + half)

    def prediction_interval(self, X):
        """The ``confidence_level`` interval of a new observation at each
        row: ``mean -/+ t * sqrt(noise + std**2)``. Returns
        ``(lower, upper)``."""
        mean, _, _, _, half = self._predictions(X)
        return self._shape(mean - half), self._shape(mean + half)

    def noise_variance(self, X):
        """The local fit's estimate of the noise variance at each row (NaN
        without degrees of freedom)."""
        return self._shape(self._predictions(X)[2])

    def jacobian(self, X):
        """The exact derivative of the mean with respect to the inputs at
        each row: shape (n_samples, n_features) for one output,
        (n_samples, n_outputs, n_features) for several (0 for inputs the
        model does not use)."""
        check_is_fitted(self)
        X = validate_data(self, X, reset=False, dtype=np.float64)
        j = self.model_.jacobian(self._active(X))
        out = np.zeros((j.shape[0], j.shape[1], self.n_features_in_))
        out[:, :, self.active_inputs_] = j
        return out[:, 0, :] if self._y_ndim == 1 else out
