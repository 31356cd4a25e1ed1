"""nprl.LWRRegressor: scikit-learn's own estimator checks, and the
regression's numbers against closed forms and finite differences."""
import pickle

import numpy as np
import pytest
from sklearn.base import clone
from sklearn.utils.estimator_checks import check_estimator

import nprl
from nprl import LWRRegressor


def test_scikit_learns_estimator_checks_pass():
    results = check_estimator(LWRRegressor(), on_fail=None)
    failed = [(r["check_name"], str(r["exception"])) for r in results if r["status"] == "failed"]
    assert not failed, failed
    # the only skips are the ones the environment decides: array API
    # input (the estimator does not declare array API support) and, without
    # pandas, pandas input
    skipped = {r["check_name"] for r in results if r["status"] == "skipped"}
    assert skipped <= {"check_array_api_input", "check_regressor_data_not_an_array"}, skipped
    assert len(results) - len(skipped) >= 50


def rows(n, d, seed, scale=1.0):
    return np.random.default_rng(seed).uniform(-1, 1, size=(n, d)) * scale


def test_a_linear_function_is_fitted_exactly_in_any_units():
    for units in ([1.0, 1.0], [0.048, 0.048], [1e6, 1e-3]):
        units = np.asarray(units)
        X, T = rows(60, 2, 3) * units, rows(20, 2, 4) * units
        f = lambda X: 2.0 + 3.0 * X[:, 0] / units[0] - X[:, 1] / units[1]  # noqa: E731
        model = LWRRegressor().fit(X, f(X))
        assert model.score(T, f(T)) == pytest.approx(1.0, abs=1e-9)
        # the Jacobian of a linear function is its coefficients
        np.testing.assert_allclose(model.jacobian(T[:3]), np.tile([3.0 / units[0], -1.0 / units[1]], (3, 1)), rtol=1e-6)


def test_the_jacobian_is_the_derivative_of_the_prediction():
    X = rows(300, 2, 5)
    y = np.sin(3 * X[:, 0]) * np.cos(2 * X[:, 1])
    model = LWRRegressor(tune_evals=0).fit(X, y)
    q = rows(5, 2, 6) * 0.8
    h = 1e-6
    numeric = np.stack(
        [(model.predict(q + h * e) - model.predict(q - h * e)) / (2 * h) for e in np.eye(2)], axis=1
    )
    np.testing.assert_allclose(model.jacobian(q), numeric, rtol=1e-5, atol=1e-7)


def test_prediction_intervals_cover_new_observations_at_their_level():
    rng = np.random.default_rng(7)
    X = rng.uniform(-1, 1, size=(1500, 1))
    f = lambda X: np.sin(2 * X[:, 0])  # noqa: E731
    y = f(X) + 0.1 * rng.standard_normal(1500)
    model = LWRRegressor(confidence_level=0.9).fit(X[:1000], y[:1000])
    lo, hi = model.prediction_interval(X[1000:])
    coverage = np.mean((lo <= y[1000:]) & (y[1000:] <= hi))
    assert 0.86 <= coverage <= 0.94, coverage
    # the noise estimate is the noise's variance
    assert np.median(model.noise_variance(X[1000:])) == pytest.approx(0.01, rel=0.15)
    # the mean's confidence interval is inside the prediction interval
    clo, chi = model.confidence_interval(X[1000:])
    assert np.all((lo <= clo) & (chi <= hi))
    mean, std = model.predict(X[1000:], return_std=True)
    assert np.all(std > 0) and np.all(std < 0.1)


def test_several_outputs_are_fitted_at_once():
    X = rows(200, 2, 8)
    Y = np.stack([X[:, 0] + X[:, 1], 2 * X[:, 0] - X[:, 1]], axis=1)
    model = LWRRegressor().fit(X, Y)
    T = rows(10, 2, 9) * 0.5
    assert model.predict(T).shape == (10, 2)
    assert model.jacobian(T).shape == (10, 2, 2)
    np.testing.assert_allclose(model.jacobian(T)[0], [[1.0, 1.0], [2.0, -1.0]], atol=1e-6)


def test_a_constant_input_is_left_out():
    X = rows(100, 3, 10)
    X[:, 1] = 4.0
    y = X[:, 0] ** 2 + X[:, 2]
    model = LWRRegressor().fit(X, y)
    assert model.scales_[1] == 0.0 and model.n_features_in_ == 3
    assert model.jacobian(X[:2])[:, 1].tolist() == [0.0, 0.0]


def test_partial_fit_adds_rows_without_tuning_again():
    X, y = rows(100, 1, 11), None
    y = np.sin(3 * X[:, 0])
    model = LWRRegressor().fit(X[:50], y[:50])
    before = (model.bandwidth_, model.tune_evals_)
    model.partial_fit(X[50:], y[50:])
    assert model.model_.n_points == 100
    assert (model.bandwidth_, model.tune_evals_) == before
    with pytest.raises(ValueError):
        model.partial_fit(rows(3, 2, 12), np.zeros(3))


def test_errors_are_value_errors_with_the_rust_message():
    x = np.column_stack([rows(30, 1, 13)[:, 0], np.full(30, 5.0)])
    with pytest.raises(nprl.LwrError, match="input 1 has standard deviation 0"):
        nprl._nprl.LwrCore.fit(x, np.ones((30, 1)), "gaussian", "linear", None, 0, 0, 0.95, "lm")
    assert issubclass(nprl.LwrError, ValueError)
    with pytest.raises(ValueError, match="tune_method must be"):
        nprl._nprl.LwrCore.fit(x[:, :1], np.ones((30, 1)), "gaussian", "linear", None, 0, 0, 0.95, "simplex")
    with pytest.raises(ValueError, match="1 sample"):
        LWRRegressor().fit([[1.0]], [2.0])


def test_pickled_and_cloned_models_predict_alike():
    X = rows(80, 2, 15)
    y = X[:, 0] * X[:, 1]
    model = LWRRegressor(degree="quadratic").fit(X, y)
    again = pickle.loads(pickle.dumps(model))
    np.testing.assert_array_equal(again.predict(X), model.predict(X))
    assert clone(model).get_params() == model.get_params()


@pytest.mark.parametrize("kernel", ["gaussian", "tricube"])
def test_a_query_beyond_the_support_is_extrapolated_from_its_nearest_points(kernel):
    X = rows(60, 2, 21)
    y = 2.0 * X[:, 0] - X[:, 1] + 0.5
    model = LWRRegressor(kernel=kernel, tune_evals=0).fit(X, y)
    far = np.array([[0.1, 0.2], [30.0, -30.0]])
    np.testing.assert_allclose(model.predict(far), 2.0 * far[:, 0] - far[:, 1] + 0.5, rtol=1e-6)


@pytest.mark.parametrize("method", ["lm", "compass"])
def test_both_tuning_methods_lower_the_loo_error(method):
    X = rows(150, 3, 22)
    y = np.sin(2 * X[:, 0]) + X[:, 1] ** 2
    model = LWRRegressor(tune_method=method).fit(X, y)
    untuned = LWRRegressor(tune_evals=0).fit(X, y)
    assert model.tune_evals_ > 0
    assert model.loo_mse_ < np.mean((y - untuned.predict(X)) ** 2) * 10
    assert model.scales_[2] == 0.0  # the noise input left out of the distance
