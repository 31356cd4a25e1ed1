#!/usr/bin/env python3
"""Side by side: trajopt's Gauss-Newton (and its Newton mode, exact
second-order term, and its adaptive choice between the two) against scipy,
CasADi + IPOPT and Ceres on the same soft-dynamics pendulum swing-up (trajopt::problems::pendulum_swingup).

    python3 scripts/compare_trajopt.py [--lambda L] [--max-iters K] [HORIZONS...]
                                         (defaults: lambda 1e2, trajopt's cap of 200 iterations; 150 1000)

Sets up its own virtual environment (.venv-ref/, from scripts/requirements.txt)
on first use, runs `cargo run --release -p nprl-drivers --bin eq3_timing`, and
solves the same problem (same bases, weights, lambda and starting point) with
  - scipy.optimize.least_squares, method 'trf', with the Jacobian's sparsity
    pattern (finite differences grouped by it) and tight inner tolerances
    (tr_options atol = btol = 1e-14, as the trf solver otherwise stalls here);
  - CasADi's IPOPT with exact derivatives (if casadi installs);
  - Ceres through pyceres (if it installs; up to N = 5000): sparse normal
    Cholesky, analytic Jacobians evaluated by numpy in blocks of 25 time
    steps. Ceres calls back into Python for every block, so its time is
    mostly that overhead: read it as "a general solver driven from Python",
    not as Ceres' own speed.
Prints wall times of the solves (model building excluded; trajopt best of 5,
IPOPT best of 3, scipy and Ceres one run), their ratios to
trajopt's Newton mode on one thread (the ratio column: how many times slower
than it), the time per iteration, and the final costs with their relative
difference; trajopt's modes also with the normal equations formed (and factorised) on two
threads (`GaussNewton::solve_parallel`, rows "2 thr"); and, per horizon, how
many times faster than IPOPT each trajopt row is. Different
solvers can stop at different local minima; the cost column shows it.
"""
import json
import subprocess
import sys
import time

from _venv import ROOT, ensure_venv  # noqa: E402  (scripts/ is on sys.path)
DT = 1.0 / 60.0
# scipy's trf takes minutes beyond this horizon
SCIPY_MAX_HORIZON = 2000
# Ceres' Python callbacks take minutes beyond this horizon
CERES_MAX_HORIZON = 5000


def problem(horizon, lam):
    """The numpy twin of trajopt::problems::pendulum_swingup."""
    import numpy as np
    from scipy.interpolate import BSpline

    times = np.arange(horizon + 1) * DT
    t_end = times[-1]
    t = times
    s = np.minimum(t / 2.0, 1.0)
    ref = np.zeros((horizon + 1, 4))
    ref[:, 0] = np.pi * s * s * (3.0 - 2.0 * s)
    ref[:, 1] = np.where(t < 2.0, np.pi * 6.0 * s * (1.0 - s) / 2.0, 0.0)

    def basis(n_coeffs):
        n_int = n_coeffs - 3
        breaks = np.array([t_end if i == n_int else 0.0 + t_end * (i / n_int) for i in range(n_int + 1)])
        return np.r_[[0.0] * 3, breaks, [t_end] * 3]

    kx, ku = basis(horizon // 6 + 4), basis(horizon // 8 + 4)
    phix = BSpline.design_matrix(times, kx, 3).tocsr()
    phiu = BSpline.design_matrix(times[:-1], ku, 3).tocsr()
    ncx, ncu = phix.shape[1], phiu.shape[1]
    # start: least-squares fit of the reference, zero controls
    cx = np.linalg.lstsq(phix.toarray(), ref, rcond=None)[0]
    theta0 = np.r_[cx.T.ravel(), np.zeros(ncu)]
    sq = np.sqrt
    wq, wr, wqf = sq(np.array([1.0, 0.1, 1.0, 0.1])), sq(0.01), sq(np.array([1000.0, 100.0, 1000.0, 100.0]))
    w_cons = sq(lam) / DT
    return dict(times=times, ref=ref, phix=phix, phiu=phiu, ncx=ncx, ncu=ncu, theta0=theta0,
                wq=wq, wr=wr, wqf=wqf, w_cons=w_cons, horizon=horizon)


def euler_step(th, om, hx, hv, u, sin, cos):
    """One semi-implicit Euler step of the hand-driven pendulum, elementwise
    over numpy arrays or CasADi expressions (`sin`, `cos` of that library)."""
    acc = -(9.81 / 0.5) * sin(th) - (u / 0.5) * cos(th) - 0.05 * om
    om1 = om + DT * acc
    th1 = th + DT * om1
    hv1 = hv + DT * u
    hx1 = hx + DT * hv1
    return th1, om1, hx1, hv1


def residuals_np(theta, p):
    import numpy as np

    ncx, n = p["ncx"], p["horizon"]
    x = p["phix"] @ theta[: 4 * ncx].reshape(4, ncx).T
    u = p["phiu"] @ theta[4 * ncx:]
    th, om, hx, hv = x[:-1, 0], x[:-1, 1], x[:-1, 2], x[:-1, 3]
    f = np.stack(euler_step(th, om, hx, hv, u, np.sin, np.cos), axis=1)
    d = x - p["ref"]
    return np.concatenate([
        (d[:-1] * p["wq"]).ravel(),
        p["wr"] * u,
        d[-1] * p["wqf"],
        (p["w_cons"] * (x[1:] - f)).ravel(),
    ])


def sparsity(p):
    """The Jacobian's structural nonzeros, in the residual order of residuals_np."""
    import numpy as np
    import scipy.sparse as sp

    ncx, ncu, n = p["ncx"], p["ncu"], p["horizon"]
    sx = (p["phix"] != 0).astype(float)
    su = (p["phiu"] != 0).astype(float)
    # kron(rows of Phi_x, block) has rows k*4+i and columns j*4+c; theta has c*ncx+j
    perm = [j * 4 + c for c in range(4) for j in range(ncx)]

    def states(rows, channel_block):
        return sp.kron(rows, channel_block).tocsc()[:, perm]

    eye, full = sp.identity(4), sp.csr_matrix(np.ones((4, 4)))
    zu = lambda r: sp.csr_matrix((r, ncu))
    task_x = sp.hstack([states(sx[:-1], eye), zu(4 * n)])
    task_u = sp.hstack([sp.csr_matrix((n, 4 * ncx)), su])
    term = sp.hstack([states(sx[-1:], eye), zu(4)])
    cons = sp.hstack([states(sx[1:], eye) + states(sx[:-1], full), sp.kron(su, np.ones((4, 1)))])
    return (sp.vstack([task_x, task_u, term, cons]) != 0).astype(float).tocsr()


def solve_scipy(p):
    from scipy.optimize import least_squares

    start = time.perf_counter()
    res = least_squares(residuals_np, p["theta0"], args=(p,), method="trf", jac_sparsity=sparsity(p),
                        x_scale="jac", ftol=1e-12, xtol=1e-12, gtol=1e-12, max_nfev=20000,
                        tr_options=dict(atol=1e-14, btol=1e-14, maxiter=5000))
    return time.perf_counter() - start, float(2.0 * res.cost), res.nfev


def solve_casadi(p):
    try:
        import casadi as ca
    except ImportError:
        return None
    import numpy as np

    ncx, ncu, n = p["ncx"], p["ncu"], p["horizon"]
    theta = ca.SX.sym("theta", 4 * ncx + ncu)
    cx = ca.reshape(theta[: 4 * ncx], ncx, 4)
    x = ca.mtimes(ca.DM(p["phix"].tocsc()), cx)
    u = ca.mtimes(ca.DM(p["phiu"].tocsc()), theta[4 * ncx:])
    th, om, hx, hv = x[:-1, 0], x[:-1, 1], x[:-1, 2], x[:-1, 3]
    f = ca.horzcat(*euler_step(th, om, hx, hv, u, ca.sin, ca.cos))
    d = x - ca.DM(p["ref"])
    cost = 0
    for i in range(4):
        cost += p["wq"][i] ** 2 * ca.sumsqr(d[:-1, i]) + p["wqf"][i] ** 2 * d[-1, i] ** 2
    cost += p["wr"] ** 2 * ca.sumsqr(u) + p["w_cons"] ** 2 * ca.sumsqr(x[1:, :] - f)
    solver = ca.nlpsol("s", "ipopt", {"x": theta, "f": cost},
                       {"ipopt.print_level": 0, "print_time": 0, "ipopt.tol": 1e-10, "ipopt.max_iter": 3000})
    elapsed = float("inf")
    for _ in range(3):  # best of 3, as trajopt's times
        start = time.perf_counter()
        sol = solver(x0=p["theta0"])
        elapsed = min(elapsed, time.perf_counter() - start)
    return elapsed, float(sol["f"]), solver.stats().get("iter_count")


def solve_ceres(p, chunk=25):
    """Ceres (pyceres) with sparse normal Cholesky, if pyceres installs.

    Parameter blocks: each state coefficient (its 4 channels) and each control
    coefficient; residual blocks: runs of `chunk` time steps, evaluated with
    numpy (Ceres calls back into Python once per block and evaluation, so its
    time includes that overhead)."""
    try:
        import pyceres
    except ImportError:
        return None
    import numpy as np

    n, ncx, ncu = p["horizon"], p["ncx"], p["ncu"]
    phix, phiu = p["phix"].toarray(), p["phiu"].toarray()
    theta0 = p["theta0"]
    xblocks = [np.array(theta0[[c * ncx + j for c in range(4)]], dtype=float) for j in range(ncx)]
    ublocks = [np.array([theta0[4 * ncx + j]], dtype=float) for j in range(ncu)]
    wq, wr, wqf, w = p["wq"], p["wr"], p["wqf"], p["w_cons"]
    ref = p["ref"]

    class Chunk(pyceres.CostFunction):
        def __init__(self, k0, k1):
            pyceres.CostFunction.__init__(self)
            self.k0, self.k1 = k0, k1  # steps k0..k1-1, and the terminal stage if k1 == n + 1
            rows_x = range(k0, min(k1 + 1, n + 1))
            rows_u = range(k0, min(k1, n))
            cols = lambda phi, rows: np.nonzero(phi[list(rows)].any(axis=0))[0]
            self.jx, self.ju = cols(phix, rows_x), cols(phiu, rows_u)
            self.px = phix[k0:min(k1 + 1, n + 1)][:, self.jx]
            self.pu = phiu[k0:min(k1, n)][:, self.ju] if len(rows_u) else np.zeros((0, 0))
            steps = min(k1, n) - k0
            self.steps, self.terminal = steps, k1 == n + 1
            self.nres = 9 * steps + (4 if self.terminal else 0)
            self.set_num_residuals(self.nres)
            self.set_parameter_block_sizes([4] * len(self.jx) + [1] * len(self.ju))

        def blocks(self):
            return [xblocks[j] for j in self.jx] + [ublocks[j] for j in self.ju]

        def Evaluate(self, parameters, residuals, jacobians):
            nx, nu, s = len(self.jx), len(self.ju), self.steps
            cx = np.array(parameters[:nx])  # (nx, 4)
            cu = np.array([q[0] for q in parameters[nx:]])
            x = self.px @ cx
            u = self.pu @ cu if nu else np.zeros(0)
            r = np.zeros(self.nres)
            jac = np.zeros((self.nres, 4 * nx + nu))
            for i in range(s):
                k = self.k0 + i
                th, om, hx, hv = x[i]
                uk = u[i]
                acc = -(9.81 / 0.5) * np.sin(th) - (uk / 0.5) * np.cos(th) - 0.05 * om
                om1 = om + DT * acc
                f = np.array([th + DT * om1, om1, hx + DT * (hv + DT * uk), hv + DT * uk])
                da = np.array([-(9.81 / 0.5) * np.cos(th) + (uk / 0.5) * np.sin(th), -0.05, 0.0, 0.0])
                dom1 = np.array([DT * da[0], 1.0 + DT * da[1], 0.0, 0.0])
                # f = (th + dt om1, om1, hx + dt (hv + dt u), hv + dt u)
                fx = np.array([[1.0 + DT * dom1[0], DT * dom1[1], 0.0, 0.0], dom1,
                               [0.0, 0.0, 1.0, DT], [0.0, 0.0, 0.0, 1.0]])
                dom1_du = DT * (-np.cos(th) / 0.5)
                fu = np.array([DT * dom1_du, dom1_du, DT * DT, DT])
                row = 9 * i
                r[row:row + 4] = wq * (x[i] - ref[k])
                r[row + 4] = wr * uk
                r[row + 5:row + 9] = w * (x[i + 1] - f)
                # d/dC_j for the state blocks (columns 4 j + c), d/dU_j (columns 4 nx + j)
                for j in range(nx):
                    a, b = self.px[i, j], self.px[i + 1, j]
                    for c in range(4):
                        jac[row + c, 4 * j + c] = wq[c] * a
                        jac[row + 5:row + 9, 4 * j + c] = w * ((np.arange(4) == c) * b - fx[:, c] * a)
                for j in range(nu):
                    jac[row + 4, 4 * nx + j] = wr * self.pu[i, j]
                    jac[row + 5:row + 9, 4 * nx + j] = -w * fu * self.pu[i, j]
            if self.terminal:
                row = 9 * s
                r[row:row + 4] = wqf * (x[s] - ref[n])
                for j in range(nx):
                    for c in range(4):
                        jac[row + c, 4 * j + c] = wqf[c] * self.px[s, j]
            residuals[:] = r
            if jacobians is not None:
                for bi in range(nx):
                    if jacobians[bi] is not None:
                        jacobians[bi][:] = jac[:, 4 * bi:4 * bi + 4].ravel()
                for bj in range(nu):
                    if jacobians[nx + bj] is not None:
                        jacobians[nx + bj][:] = jac[:, 4 * nx + bj]
            return True

    problem = pyceres.Problem()
    costs = []
    for k0 in range(0, n + 1, chunk):
        c = Chunk(k0, min(k0 + chunk, n + 1))
        costs.append(c)
        problem.add_residual_block(c, None, c.blocks())
    options = pyceres.SolverOptions()
    options.linear_solver_type = pyceres.LinearSolverType.SPARSE_NORMAL_CHOLESKY
    options.function_tolerance = 1e-14
    options.gradient_tolerance = 1e-14
    options.parameter_tolerance = 1e-14
    options.max_num_iterations = 1000
    summary = pyceres.SolverSummary()
    start = time.perf_counter()
    pyceres.solve(options, problem, summary)
    elapsed = time.perf_counter() - start
    theta = np.r_[np.array(xblocks).T.ravel(), np.array(ublocks).ravel()]
    r = residuals_np(theta, p)
    return elapsed, float(r @ r), summary.num_successful_steps + summary.num_unsuccessful_steps


def main():
    ensure_venv(__file__)
    args = sys.argv[1:]
    lam, max_iters = 1e2, []
    while args[:1] in (["--lambda"], ["--max-iters"]):
        if args[0] == "--lambda":
            lam = float(args[1])
        else:
            max_iters = ["--max-iters", str(int(args[1]))]
        args = args[2:]
    horizons = [int(a) for a in args] or [150, 1000]
    cmd = ["cargo", "run", "--quiet", "--release", "-p", "nprl-drivers", "--bin", "eq3_timing", "--", *max_iters, str(lam),
           *map(str, horizons)]
    out = subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True).stdout
    ours = {(d["horizon"], d["mode"]): d for d in map(json.loads, (l for l in out.splitlines() if l.startswith("{")))}
    print(f"lambda = {lam:g}; times are wall seconds of one solve (trajopt: best of 5)")
    print(f"{'N':>6} {'solver':<26}{'seconds':>10}{'ratio':>9}{'iters/evals':>12}{'ms/iter':>9}{'final cost':>18}{'rel. diff':>11}")
    for n in horizons:
        p = problem(n, lam)
        r0 = residuals_np(p["theta0"], p)
        o, gn, ad = ours[(n, "newton")], ours[(n, "gauss_newton")], ours[(n, "adaptive")]
        assert abs(float(r0 @ r0) - o["initial_cost"]) <= 1e-9 * o["initial_cost"], (float(r0 @ r0), o["initial_cost"])
        rows = [("trajopt Newton", o["seconds"], o["iterations"], o["cost"]),
                ("trajopt Gauss-Newton", gn["seconds"], gn["iterations"], gn["cost"]),
                ("trajopt adaptive", ad["seconds"], ad["iterations"], ad["cost"])]
        # the same modes with the normal equations formed on two threads (solve_parallel)
        for mode, name in (("newton_2t", "Newton"), ("gauss_newton_2t", "Gauss-Newton"), ("adaptive_2t", "adaptive")):
            if (n, mode) in ours:
                d = ours[(n, mode)]
                rows.append((f"trajopt {name} 2 thr", d["seconds"], d["iterations"], d["cost"]))
        if n <= SCIPY_MAX_HORIZON:
            t, c, ev = solve_scipy(p)
            rows.append(("scipy least_squares", t, ev, c))
        cas = solve_casadi(p)
        if cas is not None:
            rows.append(("CasADi + IPOPT", cas[0], cas[2], cas[1]))
        if n <= CERES_MAX_HORIZON:
            ceres = solve_ceres(p)
            if ceres is not None:
                rows.append(("Ceres (pyceres)", ceres[0], ceres[2], ceres[1]))
        for name, secs, its, cost in rows:
            per_iter = f"{1e3 * secs / its:>9.3f}" if its else f"{'':>9}"
            print(f"{n:>6} {name:<26}{secs:>10.4f}{secs / o['seconds']:>8.1f}x{its:>12}{per_iter}{cost:>18.10g}"
                  f"{(cost - o['cost']) / o['cost']:>11.1e}")
        if cas is not None:
            # how many times faster than IPOPT each trajopt mode is
            speedups = ", ".join(f"{name[len('trajopt '):]} {cas[0] / secs:.1f}x"
                                 for name, secs, _, _ in rows if name.startswith("trajopt"))
            print(f"{n:>6} vs IPOPT: {speedups}")


if __name__ == "__main__":
    main()
