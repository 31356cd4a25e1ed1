"""Golden values for `ddp`: the pendulum swing-up of `ddp::problems::pendulum_swingup`
solved by Crocoddyl's SolverDDP.

Writes ddp/tests/data/crocoddyl_pendulum.json: the problem (horizon, dt, weights),
Crocoddyl's optimal cost, controls, iteration count and version.

Setting up (from the repository root; `pip install crocoddyl` alone pulls a
pinocchio whose forward dynamics return zero acceleration, so pin it):
  python3 -m venv .venv-ref
  .venv-ref/bin/pip install crocoddyl pin==4.0.0 libpinocchio==4.0.0
  OMP_NUM_THREADS=1 .venv-ref/bin/python scripts/golden/crocoddyl_golden.py

The problem is built from Crocoddyl's own C++ models, matching ours exactly:
- a pinocchio pendulum (revolute joint, 1 kg point mass 1 m below it; theta = 0
  hangs down) under DifferentialActionModelFreeFwdDynamics with full actuation,
  so theta'' = u - 9.81 sin(theta);
- IntegratedActionModelEuler with dt = 0.01, which is semi-implicit
  (v' = v + dt a, q' = q + dt v'), as `ddp::Pendulum`;
- Crocoddyl multiplies running costs by dt: the differential running cost
  1/2 (theta - pi)^2 + 0.1/2 omega^2 + 0.01/2 u^2 becomes ours,
  dt [1/2 (theta - pi)^2 + 0.1/2 omega^2 + 0.01/2 u^2];
  the terminal cost 100/2 (theta - pi)^2 + 10/2 omega^2 is not scaled.
  Crocoddyl's ActivationModelWeightedQuad is 1/2 r^T W r while ddp's
  QuadraticCost, like trajopt's TrackingCost, has no 1/2: the weights here
  (W) are twice the QuadraticCost weights of ddp::problems (dt (0.5, 0.05),
  dt 0.005, (50, 5)); the costs are the same.
The script checks that gravity acts and that the discretisation matches by
rolling out a control sequence both with Crocoddyl and with a direct numpy
implementation of our step.
Floats are written by repr (json), so they round-trip exactly.
"""
import json
import os
import pathlib
import sys

import numpy as np

os.environ.setdefault("OMP_NUM_THREADS", "1")
import crocoddyl  # noqa: E402
import pinocchio as pin  # noqa: E402

HORIZON = 200
DT = 0.01
X0 = np.array([0.0, 0.0])
TARGET = np.array([np.pi, 0.0])


def pendulum_model(axis=(0.0, 1.0, 0.0)):
    """A 1 kg point mass 1 m below a revolute joint (theta = 0 hangs down)."""
    model = pin.Model()
    joint = model.addJoint(0, pin.JointModelRevoluteUnaligned(np.array(axis)), pin.SE3.Identity(), "theta")
    model.appendBodyToJoint(joint, pin.Inertia(1.0, np.array([0.0, 0.0, -1.0]), np.zeros((3, 3))), pin.SE3.Identity())
    return model


def check_gravity(model):
    data = model.createData()
    acc = pin.aba(model, data, np.array([1.0]), np.zeros(1), np.zeros(1))[0]
    expected = -9.81 * np.sin(1.0)
    if abs(acc - expected) > 1e-9:
        sys.exit(f"pinocchio forward dynamics are wrong: theta'' = {acc}, expected {expected} (pin {pin.__version__})")


def build_problem(model, horizon, running_state_w, control_w, terminal_state_w, target, x0, nthreads=1, actuation=None):
    state = actuation.state if actuation is not None else crocoddyl.StateMultibody(model)
    if actuation is None:
        actuation = crocoddyl.ActuationModelFull(state)
    nu = actuation.nu

    def costs(state_w, with_control):
        cm = crocoddyl.CostModelSum(state, nu)
        x_res = crocoddyl.ResidualModelState(state, target, nu)
        cm.addCost("state", crocoddyl.CostModelResidual(state, crocoddyl.ActivationModelWeightedQuad(np.array(state_w)), x_res), 1.0)
        if with_control:
            u_res = crocoddyl.ResidualModelControl(state, nu)
            cm.addCost("control", crocoddyl.CostModelResidual(state, crocoddyl.ActivationModelWeightedQuad(np.array(control_w)), u_res), 1.0)
        return cm

    running = crocoddyl.IntegratedActionModelEuler(
        crocoddyl.DifferentialActionModelFreeFwdDynamics(state, actuation, costs(running_state_w, True)), DT
    )
    terminal = crocoddyl.IntegratedActionModelEuler(
        crocoddyl.DifferentialActionModelFreeFwdDynamics(state, actuation, costs(terminal_state_w, False)), 0.0
    )
    problem = crocoddyl.ShootingProblem(x0, [running] * horizon, terminal)
    problem.nthreads = nthreads
    return problem


def pendulum_problem(horizon):
    return build_problem(pendulum_model(), horizon, [1.0, 0.1], [0.01], [100.0, 10.0], TARGET, X0)


def our_cost(us):
    """Direct numpy transcription of ddp::problems::pendulum_swingup."""
    x = X0.copy()
    total = 0.0
    for u in us:
        d = x - TARGET
        total += DT * (0.5 * d[0] ** 2 + 0.05 * d[1] ** 2 + 0.005 * u[0] ** 2)
        w = x[1] + DT * (u[0] - 9.81 * np.sin(x[0]))
        x = np.array([x[0] + DT * w, w])
    d = x - TARGET
    return total + 50.0 * d[0] ** 2 + 5.0 * d[1] ** 2


def solve(problem, maxiter=200):
    solver = crocoddyl.SolverDDP(problem)
    xs = [problem.x0] * (problem.T + 1)
    us = [np.zeros(problem.runningModels[0].nu)] * problem.T
    converged = solver.solve(xs, us, maxiter, False)
    return solver, converged


def main():
    check_gravity(pendulum_model())
    problem = pendulum_problem(HORIZON)
    # same discretisation and costs: Crocoddyl's rollout cost equals ours
    rng = np.random.default_rng(0)
    us = [rng.uniform(-5, 5, size=1) for _ in range(HORIZON)]
    xs = problem.rollout(us)
    croc_cost = problem.calc(xs, us)
    mine = our_cost(us)
    if abs(croc_cost - mine) > 1e-10 * abs(mine):
        sys.exit(f"discretisation mismatch: Crocoddyl {croc_cost!r}, ours {mine!r}")
    solver, converged = solve(problem)
    if not converged:
        sys.exit("Crocoddyl did not converge")
    out = {
        "crocoddyl_version": crocoddyl.__version__,
        "pinocchio_version": pin.__version__,
        "problem": "ddp::problems::pendulum_swingup",
        "horizon": HORIZON,
        "dt": DT,
        "cost": float(solver.cost),
        "cost_of_controls_by_our_formula": float(our_cost(solver.us)),
        "iterations": int(solver.iter),
        "controls": [float(u[0]) for u in solver.us],
        "final_state": [float(v) for v in solver.xs[-1]],
    }
    path = pathlib.Path(__file__).resolve().parents[2] / "ddp" / "tests" / "data" / "crocoddyl_pendulum.json"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {path}: cost {out['cost']!r} after {out['iterations']} iterations (discretisation check {croc_cost!r} vs {mine!r})")


if __name__ == "__main__":
    main()
