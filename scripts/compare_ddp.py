"""Compare `ddp` with Crocoddyl's SolverDDP on the pendulum and cart-pole
swing-ups (`ddp::problems`) over horizons 100 to 5000: iterations, total
solve time and time per iteration, from one run of each.

Running (from the repository root): `python3 scripts/compare_ddp.py [repeats]`.
It re-executes itself in .venv-ref (created from scripts/requirements.txt,
which pins crocoddyl 3.2.1, pin 4.0.0 and libpinocchio 4.0.0: newer pins
give a pinocchio whose forward dynamics silently return zero acceleration).

Also Crocoddyl's own unicycle benchmark (its native ActionModelUnicycle,
horizons 20 / 100 / 1000), whose model is so cheap that it measures the
solvers rather than the dynamics. Both sides report the best of `repeats` solves (default 5; 3 for the
cart-pole). Crocoddyl is single-threaded (OMP_NUM_THREADS=1, problem.nthreads
= 1) and uses its native C++ models (pinocchio free forward dynamics,
semi-implicit IntegratedActionModelEuler, weighted-quadratic costs scaled by
dt), the same discrete problems as ours (checked for the pendulum by
scripts/golden/crocoddyl_golden.py); its weighted quadratic has a 1/2 that
ddp's QuadraticCost does not, so the weights below are twice those of
ddp::problems and of the unicycle in the ddp_timing driver (scripts/drivers). Our `ddp` runs with default settings
(iLQR: the `pendulum` and `cartpole` rows; `pendulum-ddp` uses the pendulum's
second derivatives). Iteration counts: Crocoddyl counts the final iteration
whose backward pass meets its stopping test (it still takes a step); ours
stops before the line search of that iteration, so ours is usually one less.
"""
import json
import os
import pathlib
import subprocess
import sys
import time

os.environ["OMP_NUM_THREADS"] = "1"
from _venv import ensure_venv  # noqa: E402  (scripts/ is on sys.path)

ensure_venv(__file__)
sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent / "golden"))
import crocoddyl  # noqa: E402
import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402
from crocoddyl_golden import build_problem, check_gravity, pendulum_model  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[1]
HORIZONS = [100, 500, 1000, 5000]


def cartpole_model():
    """Cart (1 kg, prismatic x) carrying a 0.1 kg point mass 0.5 m below a
    revolute joint about -y (so theta > 0 moves the mass towards +x, as in
    ddp::CartPole; theta = 0 hangs down)."""
    model = pin.Model()
    cart = model.addJoint(0, pin.JointModelPX(), pin.SE3.Identity(), "cart")
    model.appendBodyToJoint(cart, pin.Inertia(1.0, np.zeros(3), np.zeros((3, 3))), pin.SE3.Identity())
    pole = model.addJoint(cart, pin.JointModelRevoluteUnaligned(np.array([0.0, -1.0, 0.0])), pin.SE3.Identity(), "pole")
    model.appendBodyToJoint(pole, pin.Inertia(0.1, np.array([0.0, 0.0, -0.5]), np.zeros((3, 3))), pin.SE3.Identity())
    return model


def cartpole_problem(horizon):
    # Crocoddyl has no native under-actuated model for this joint layout (a
    # Python ActuationModelAbstract would put Python calls in its inner loop),
    # so the pole is actuated too but its torque costs 1e4 dt/2 tau^2: the
    # problem differs from ours by that penalty (cost differences of order 1e-4).
    return build_problem(
        cartpole_model(),
        horizon,
        [1.0, 1.0, 0.1, 0.1],
        [0.01, 1e4],
        [100.0, 100.0, 10.0, 10.0],
        np.array([0.0, np.pi, 0.0, 0.0]),
        np.zeros(4),
    )


def pendulum_problem(horizon):
    return build_problem(
        pendulum_model(), horizon, [1.0, 0.1], [0.01], [100.0, 10.0], np.array([np.pi, 0.0]), np.zeros(2)
    )


def unicycle_problem(horizon):
    x0 = np.array([-1.0, -1.0, 1.0])
    problem = crocoddyl.ShootingProblem(x0, [crocoddyl.ActionModelUnicycle()] * horizon, crocoddyl.ActionModelUnicycle())
    problem.nthreads = 1
    return problem


def croc_solve(make, horizon, repeats, maxiter=200):
    best = None
    for _ in range(repeats):
        problem = make(horizon)
        solver = crocoddyl.SolverDDP(problem)
        xs = [problem.x0] * (horizon + 1)
        us = [np.zeros(problem.runningModels[0].nu)] * horizon
        t0 = time.perf_counter()
        converged = solver.solve(xs, us, maxiter, False)
        t = time.perf_counter() - t0
        if best is None or t < best[0]:
            best = (t, solver.iter, solver.cost, converged)
    return best


def ours(repeats):
    cmd = ["cargo", "run", "--release", "-q", "-p", "nprl-drivers", "--bin", "ddp_timing", "--", str(repeats)]
    out = subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True).stdout
    return {(r["system"], r["horizon"]): r for r in map(json.loads, out.strip().splitlines())}


def main():
    repeats = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    check_gravity(pendulum_model())
    mine = ours(repeats)
    print(f"crocoddyl {crocoddyl.__version__}, pinocchio {pin.__version__}, 1 thread; best of {repeats} (cart-pole {min(repeats, 3)})")
    header = f"{'system':<13} {'N':>5} | {'iters ours/croc':>15} | {'total ms ours':>13} {'croc':>9} | {'us/iter ours':>12} {'croc':>9} {'croc/ours':>9} | {'cost rel diff':>13}"
    print(header)
    print("-" * len(header))
    for system, make, reps, horizons in [
        ("unicycle", unicycle_problem, repeats, [20, 100, 1000]),
        ("pendulum", pendulum_problem, repeats, HORIZONS),
        ("pendulum-ddp", pendulum_problem, repeats, HORIZONS),
        ("cartpole", cartpole_problem, min(repeats, 3), HORIZONS),
    ]:
        for horizon in horizons:
            t, it, cost, converged = croc_solve(make, horizon, reps)
            m = mine[(system, horizon)]
            croc_per_it = 1e6 * t / max(it, 1)
            our_per_it = 1e3 * m["per_iteration_ms"]
            rel = abs(m["cost"] - cost) / abs(cost)
            flag = "" if converged and m["status"] == "Converged" else f"  (ours {m['status']}, croc converged={converged})"
            print(
                f"{system:<13} {horizon:>5} | {m['iterations']:>7}/{it:<7} | {m['total_ms']:>13.3f} {1e3 * t:>9.3f} | "
                f"{our_per_it:>12.1f} {croc_per_it:>9.1f} {croc_per_it / our_per_it:>9.2f} | {rel:>13.2e}{flag}"
            )


if __name__ == "__main__":
    main()
