"""nprl.ddp on built-in systems and on Python callables, against the
Riccati solution of a linear-quadratic problem."""
import numpy as np
import pytest

import nprl

DT = 0.01


def test_the_builtin_pendulum_swings_up():
    r = nprl.ddp("pendulum", horizon=200)
    assert r.success and r.status == "Converged"
    assert abs(r.states[-1][0] - np.pi) < 0.05
    assert r.states.shape == (201, 2) and r.controls.shape == (200, 1) and r.gains.shape == (200, 1, 2)
    # Eq. 2 at the plan is the plan's control; Eq. 1 at the plan its value
    np.testing.assert_allclose(r.policy(10, r.states[10]), r.controls[10])
    assert r.value_model(0, r.states[0]) == pytest.approx(r.value[0])
    assert r.value[0] == pytest.approx(r.cost, rel=1e-6)


def test_full_ddp_and_ilqr_reach_the_same_plan():
    a = nprl.ddp("pendulum", horizon=100, method="ilqr")
    b = nprl.ddp("pendulum", horizon=100, method="ddp")
    assert a.success and b.success
    assert a.cost == pytest.approx(b.cost, rel=1e-4)


def riccati(A, B, Q, R, Qf, N, x0):
    # the cost sum x'Qx + u'Ru + x_N'Qf x_N (no 1/2): P_N = Qf,
    # K = -(R + B'PB)^-1 B'PA, P = Q + A'PA + A'PB K
    P, gains = Qf, []
    for _ in range(N):
        K = -np.linalg.solve(R + B.T @ P @ B, B.T @ P @ A)
        P = Q + A.T @ P @ A + A.T @ P @ B @ K
        gains.append(K)
    return gains[::-1], float(x0 @ P @ x0)


def test_a_linear_quadratic_problem_gives_the_riccati_solution():
    A = np.array([[1.0, DT], [-0.2 * DT, 1.0]])
    B = np.array([[0.0], [DT]])
    Q, R, Qf = np.diag([1.0, 0.1]), np.array([[0.01]]), np.diag([10.0, 1.0])
    x0 = np.array([1.0, -0.5])
    gains, cost = riccati(A, B, Q, R, Qf, 50, x0)
    for jac in (None, lambda x, u: (A, B)):
        r = nprl.ddp(lambda x, u: A @ x + B @ u, x0, 50, n_controls=1, jac=jac, q=Q, r=R, qf=Qf)
        assert r.success
        assert r.cost == pytest.approx(cost, rel=1e-7)
        np.testing.assert_allclose(r.gains[0], gains[0], rtol=1e-5)
        np.testing.assert_allclose(r.gains[30], gains[30], rtol=1e-5)
    assert r.nfev > 0


def test_control_limits_are_kept():
    r = nprl.ddp("pendulum", horizon=200, u_bounds=(-2.0, 2.0))
    assert np.all(np.abs(r.controls) <= 2.0 + 1e-12)


def test_errors_name_what_is_wrong():
    with pytest.raises(nprl.DdpError):
        nprl.ddp(lambda x, u: x, [0.0, 0.0], 10, n_controls=1, q=[1.0, 1.0], r=[1.0], target=[0.0])
    with pytest.raises(ValueError, match="n_controls"):
        nprl.ddp(lambda x, u: x, [0.0], 10, q=[1.0], r=[1.0])
    with pytest.raises(ValueError, match="step returned 3 values, expected 2"):
        nprl.ddp(lambda x, u: np.zeros(3), [0.0, 0.0], 10, n_controls=1, q=[1.0, 1.0], r=[1.0])

    class Mine(Exception):
        pass

    def step(x, u):
        if x[0] > 0.5:
            raise Mine("the user's model")
        return x + DT * np.array([x[1], u[0]])

    with pytest.raises(Mine, match="the user's model"):
        nprl.ddp(step, [0.0, 0.0], 100, n_controls=1, q=[1.0, 0.1], r=[1e-4], target=[1.0, 0.0])
