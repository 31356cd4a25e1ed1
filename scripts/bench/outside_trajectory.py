"""Outside solvers on nprl-bench's trajectory set, in its record format.

Solves the DDP form of the registry's swing-ups (ddp::problems: the
pendulum, cart-pole and acrobot of the `systems` crate, semi-implicit Euler
with dt = 0.01, the quadratic task cost without a 1/2, zero warm start)
with

- `crocoddyl-ddp`, `crocoddyl-fddp`: Crocoddyl's SolverDDP and SolverFDDP
  on its native C++ models (pinocchio free forward dynamics,
  IntegratedActionModelEuler, weighted-quadratic costs; the models and
  weights of scripts/compare_ddp.py and scripts/golden/crocoddyl_golden.py),
  at most 1000 iterations, its default stopping test. The pendulum is
  exactly ours; Crocoddyl has no native under-actuated model for the
  cart-pole's layout, so (as in compare_ddp.py) the pole joint is actuated
  too with its torque weighted 1e4: the record keeps the cart force only,
  and the runner rolls it out through the exact under-actuated dynamics.
  The acrobot is not run by Crocoddyl (the same trick on a fixed-base
  double pendulum is not checked against ours; not done).
- `casadi-ipopt`: CasADi + IPOPT (exact Hessian, MUMPS, tol 1e-10, at most
  3000 iterations) on the direct multiple-shooting transcription of the
  same discrete problem (states and controls as variables, the semi-implicit
  Euler step as equality constraints), written here from the equations in
  systems/src/{pendulum,cart_pole,acrobot}.rs; all three systems.

Every record stores the final controls stacked as `x`; the runner
recomputes `f` as their rollout through the exact dynamics scored by the
task cost (the trajectory set's figure of merit), and `f0` from the start.
The DDP twin does not depend on lambda, so each run is written for both
lambda instances of its horizon (one solve, two records).

Evaluations (`evals`): IPOPT's own counts, one evaluation of the
constraints or the cost as one rollout, one of their Jacobian or of the
Lagrangian's Hessian as n (the Eq. 3 form's parameter count, as the runner
counts a linearisation). Crocoddyl does not expose its line-search trials:
its records count one rollout and one linearisation per iteration
(`iterations K, line-search trials not counted` in the status), a lower
bound. Times are Python-driven C++ (Crocoddyl) and CasADi's compiled
callbacks; the trajectory report compares evaluations and the figure of
merit, times only as measured.

Run from the repository root (uses .venv-ref/, made from
scripts/requirements.txt on first use):
  python3 scripts/bench/outside_trajectory.py [--repeats 1] [--filter NAME]
Writes results/benchmarks/trajectory/outside/{crocoddyl,casadi}.json.
"""
import argparse
import json
import os
import pathlib
import sys
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")
SCRIPTS = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(SCRIPTS))
from _venv import ROOT, ensure_venv  # noqa: E402

ensure_venv(__file__)
sys.path.insert(0, str(SCRIPTS / "golden"))
import numpy as np  # noqa: E402

DT = 0.01
G = 9.81
# system: (nq, target, horizons, n of the Eq. 3 form per horizon)
SYSTEMS = {
    "pendulum": (1, [np.pi, 0.0], [50, 100, 200]),
    "cartpole": (2, [0.0, np.pi, 0.0, 0.0], [100, 200, 400]),
    "acrobot": (2, [np.pi, 0.0, 0.0, 0.0], [200, 400]),
}
LAMBDAS = ["1e0", "1e2"]


def weights(nq):
    """ddp::problems' QuadraticCost weights (no 1/2): running state, control, terminal."""
    return (np.array([0.5 * DT] * nq + [0.05 * DT] * nq), 0.005 * DT, np.array([50.0] * nq + [5.0] * nq))


def accelerations(system, q, v, u, lib):
    """The accelerations of systems/src/<system>.rs, for numpy or casadi (`lib`)."""
    sin, cos = lib.sin, lib.cos
    if system == "pendulum":
        return [u[0] - G * sin(q[0])]
    if system == "cartpole":
        mc, mp, length = 1.0, 0.1, 0.5
        s, c = sin(q[1]), cos(q[1])
        d = mc + mp * s * s
        w = v[1]
        return [(u[0] + mp * s * (length * w * w + G * c)) / d,
                (-u[0] * c - mp * length * w * w * c * s - (mc + mp) * G * s) / (length * d)]
    # acrobot: point masses of 1 kg at the ends of 1 m links, torque at the elbow
    m1, m2, l1, l2 = 1.0, 1.0, 1.0, 1.0
    a = m2 * l1 * l2
    c2, s2 = cos(q[1]), sin(q[1])
    s1, s12 = sin(q[0]), sin(q[0] + q[1])
    m11 = (m1 + m2) * l1 ** 2 + m2 * l2 ** 2 + 2 * a * c2
    m12 = m2 * l2 ** 2 + a * c2
    m22 = m2 * l2 ** 2
    h1 = -G * ((m1 + m2) * l1 * s1 + m2 * l2 * s12) + a * s2 * (2 * v[0] + v[1]) * v[1]
    h2 = -G * m2 * l2 * s12 + u[0] - a * s2 * v[0] ** 2
    det = m11 * m22 - m12 * m12
    return [(m22 * h1 - m12 * h2) / det, (m11 * h2 - m12 * h1) / det]


def step(system, x, u, nq, lib):
    """Semi-implicit Euler: v' = v + dt a(x, u), q' = q + dt v'."""
    q, v = x[:nq], x[nq:]
    acc = accelerations(system, q, v, u, lib)
    v_next = [v[i] + DT * acc[i] for i in range(nq)]
    q_next = [q[i] + DT * v_next[i] for i in range(nq)]
    return q_next + v_next


def rollout_cost(system, controls):
    """The task cost of `controls` (N x 1) rolled out from rest hanging down."""
    nq, target, _ = SYSTEMS[system]
    wq, wu, wf = weights(nq)
    x = np.zeros(2 * nq)
    total = 0.0
    for u in controls:
        total += float(wq @ (x - target) ** 2 + wu * u[0] ** 2)
        x = np.array(step(system, x, u, nq, np))
    total += float(wf @ (x - target) ** 2)
    return total if np.isfinite(total) else float(np.finfo(float).max)


def solve_ipopt(system, horizon):
    """CasADi + IPOPT on the multiple-shooting transcription; (controls, status, converged, evals per linearisation kind)."""
    import casadi as ca
    nq, target, _ = SYSTEMS[system]
    nx = 2 * nq
    wq, wu, wf = weights(nq)
    X = ca.MX.sym("X", nx, horizon + 1)
    U = ca.MX.sym("U", 1, horizon)
    cost, cons = 0, [X[:, 0] - np.zeros(nx)]
    for k in range(horizon):
        d = X[:, k] - target
        cost += ca.dot(ca.DM(wq), d * d) + wu * U[0, k] ** 2
        nxt = step(system, [X[i, k] for i in range(nx)], [U[0, k]], nq, ca)
        cons.append(X[:, k + 1] - ca.vertcat(*nxt))
    d = X[:, horizon] - target
    cost += ca.dot(ca.DM(wf), d * d)
    w = ca.vertcat(ca.reshape(X, -1, 1), ca.reshape(U, -1, 1))
    g = ca.vertcat(*cons)
    solver = ca.nlpsol("s", "ipopt", {"x": w, "f": cost, "g": g},
                       {"ipopt.print_level": 0, "print_time": False, "ipopt.tol": 1e-10,
                        "ipopt.max_iter": 3000, "ipopt.linear_solver": "mumps"})
    w0 = np.zeros(w.shape[0])
    res = solver(x0=w0, lbg=0, ubg=0)
    stats = solver.stats()
    u = np.array(res["x"]).ravel()[nx * (horizon + 1):]
    counts = {k: int(stats.get(k, 0)) for k in ("n_call_nlp_f", "n_call_nlp_g", "n_call_nlp_grad_f",
                                                  "n_call_nlp_jac_g", "n_call_nlp_hess_l")}
    return u.reshape(horizon, 1), stats["return_status"], bool(stats["success"]), counts


def crocoddyl_problem(system, horizon):
    from compare_ddp import cartpole_problem, pendulum_problem
    return {"pendulum": pendulum_problem, "cartpole": cartpole_problem}[system](horizon)


def solve_crocoddyl(system, horizon, feasible):
    import crocoddyl
    problem = crocoddyl_problem(system, horizon)
    solver = (crocoddyl.SolverFDDP if feasible else crocoddyl.SolverDDP)(problem)
    nu = problem.runningModels[0].nu
    xs = [problem.x0] * (horizon + 1)
    us = [np.zeros(nu)] * horizon
    converged = solver.solve(xs, us, 1000, False)
    # the cart-pole's pole torque is a penalised stand-in for its absence: keep the cart force
    controls = np.array([[float(u[0])] for u in solver.us])
    return controls, f"iterations {solver.iter}, line-search trials not counted", bool(converged), int(solver.iter)


def record(solver, name, n, f0, controls, status, converged, f_evals, jac_evals, time_s, repeats):
    f = rollout_cost(name.split("-")[0], controls)
    evals = f_evals + n * jac_evals
    trace = [[1, f0]] + ([[max(evals, 1), f]] if f < f0 else [])
    return {"solver": solver, "set": "trajectory", "problem": name, "n": n, "m": 0, "scale": 1.0,
            "status": status, "converged": converged, "f0": f0, "f": f, "f_star": None,
            "f_evals": f_evals, "jac_evals": jac_evals, "evals": evals, "time_s": time_s,
            "repeats": repeats, "trace": trace, "x": [float(v) for v in controls.ravel()]}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=1, help="timings per solve (median)")
    ap.add_argument("--filter", default=None, help="only instances whose name contains this")
    ap.add_argument("--out", default=str(ROOT / "results" / "benchmarks" / "trajectory" / "outside"))
    args = ap.parse_args()
    import casadi
    import crocoddyl
    ours = json.loads((ROOT / "results" / "benchmarks" / "trajectory" / "runs.json").read_text())
    n_of = {r["problem"]: r["n"] for r in ours["runs"]}
    files = {"crocoddyl": [], "casadi": []}
    spent = {k: 0.0 for k in files}
    for system, (nq, _, horizons) in SYSTEMS.items():
        for horizon in horizons:
            names = [f"{system}-h{horizon}-lambda{lam}" for lam in LAMBDAS]
            names = [nm for nm in names if args.filter is None or args.filter in nm]
            if not names:
                continue
            f0 = rollout_cost(system, np.zeros((horizon, 1)))
            solvers = [("casadi-ipopt", "casadi")]
            if system != "acrobot":
                solvers += [("crocoddyl-ddp", "crocoddyl"), ("crocoddyl-fddp", "crocoddyl")]
            for solver, group in solvers:
                times, first = [], None
                for _ in range(max(1, args.repeats)):
                    t0 = time.perf_counter()
                    if group == "casadi":
                        out = solve_ipopt(system, horizon)
                    else:
                        out = solve_crocoddyl(system, horizon, solver.endswith("fddp"))
                    times.append(time.perf_counter() - t0)
                    first = first or out
                spent[group] += sum(times)
                times.sort()
                controls, status, converged, counts = first
                for name in names:
                    n = n_of[name]
                    if group == "casadi":
                        f_evals = counts["n_call_nlp_f"] + counts["n_call_nlp_g"]
                        jac_evals = counts["n_call_nlp_grad_f"] + counts["n_call_nlp_jac_g"] + counts["n_call_nlp_hess_l"]
                    else:
                        f_evals, jac_evals = counts, counts
                    rec = record(solver, name, n, f0, controls, status, converged, f_evals, jac_evals,
                                 times[len(times) // 2], max(1, args.repeats))
                    files[group].append(rec)
                    print(f"{name:26s} {solver:15s} f={rec['f']:.6e} evals={rec['evals']:8d} "
                          f"{rec['time_s']:.2e} s {status}", flush=True)
    versions = {"crocoddyl": f"crocoddyl {crocoddyl.__version__} (SolverDDP, SolverFDDP)",
                "casadi": f"casadi {casadi.__version__} + IPOPT (multiple shooting, exact Hessian)"}
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for group, runs in files.items():
        path = out / f"{group}.json"
        source = f"{versions[group]}, scripts/bench/outside_trajectory.py, {spent[group]:.1f} s for the runs"
        path.write_text(json.dumps({"format": "nprl-bench/1", "source": source, "runs": runs}) + "\n")
        print(f"wrote {path} ({len(runs)} runs)")


if __name__ == "__main__":
    main()
