"""Outside solvers on the Moré-Garbow-Hillstrom set, in nprl-bench's record format.

Runs, on the 35 problems of `trajopt::problems::mgh` at their standard sizes
from 1, 10 and 100 x0 (Watson's x0 = 0 scales to scale * (1, ..., 1), as in
MINPACK-1's driver and in Rust), these solvers:

- `scipy-lm`: scipy.optimize.least_squares(method="lm"), MINPACK's lmdif
  (forward-difference Jacobian), ftol = xtol = gtol = 1e-15;
- `scipy-trf`: least_squares(method="trf"), 2-point Jacobian, the same tolerances;
- `nlopt-praxis`, `nlopt-newuoa`: NLopt's PRAXIS (Brent's principal axis) and
  NEWUOA (Powell) on f = sum r^2, ftol_rel = 1e-15, xtol_rel = 1e-12.

The residuals are those of scripts/golden/mgh_golden.py (an independent NumPy
implementation written from the paper, imported, not copied). Every residual
call is counted (finite-difference calls included: an evaluation equivalent,
as in Rust) and the budget is the runner's: BUDGET * (n + 1) evaluations and
TIME_LIMIT seconds per run. The trace of the best f so far is thinned by the
rule of bench/src/record.rs (`thin_trace`). Each run is timed REPEATS times
(median).

Writes OUT/scipy.json and OUT/nlopt.json (default OUT =
results/benchmarks/outside), which `nprl-bench` merges into its profiles.

Run from the repository root (makes .venv-bench/ on first use):
  python3 scripts/bench/outside_mgh.py [--budget 2000] [--time-limit 10] [--repeats 3]
"""
import argparse
import json
import math
import os
import pathlib
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[2]
VENV = ROOT / ".venv-bench"
PACKAGES = ["numpy==2.4.6", "scipy==1.17.1", "nlopt==2.11.0"]


def ensure_venv():
    """Re-executes this script inside .venv-bench (made on first use)."""
    py = VENV / "bin" / "python"
    if pathlib.Path(sys.prefix).resolve() == VENV.resolve():
        return
    if not py.exists():
        subprocess.run([sys.executable, "-m", "venv", str(VENV)], check=True)
        subprocess.run([str(py), "-m", "pip", "install", "-q", *PACKAGES], check=True)
    os.execv(str(py), [str(py), __file__, *sys.argv[1:]])


class Spent(Exception):
    """The run's budget is used up."""


class Counted:
    """f = sum r^2 through a counter, a best-so-far trace and the budget."""

    def __init__(self, fun, m, max_evals, time_limit):
        self.fun, self.m = fun, m
        self.max_evals, self.deadline = max_evals, time.perf_counter() + time_limit
        self.evals, self.best, self.trace, self.spent = 0, math.inf, [], False

    def residuals(self, x):
        import numpy as np
        if self.evals >= self.max_evals or time.perf_counter() > self.deadline:
            self.spent = True
            raise Spent()
        with np.errstate(all="ignore"):
            r = np.asarray(self.fun(np.asarray(x, float), self.m), float)
        self.evals += 1
        f = float(np.sum(r * r))
        if math.isfinite(f) and f < self.best:
            self.best = f
            self.trace.append((self.evals, f))
        return r

    def cost(self, x):
        r = self.residuals(x)
        return float(r @ r)


def thin_trace(trace):
    """bench/src/record.rs's thin_trace: keep the first, the last, and each
    point where f - f_end fell to 90% of its value at the last point kept."""
    if not trace:
        return []
    f_end = trace[-1][1]
    kept = []
    for i, (e, f) in enumerate(trace):
        if not kept or i + 1 == len(trace) or f - f_end <= 0.9 * (kept[-1][1] - f_end):
            kept.append((e, f))
    return kept


def run_scipy(method, c, x0):
    import numpy as np
    from scipy.optimize import least_squares
    try:
        res = least_squares(c.residuals, x0, method=method, ftol=1e-15, xtol=1e-15, gtol=1e-15,
                            max_nfev=c.max_evals)
        return f"status {res.status}", res.status > 0
    except Spent:
        return "budget", False
    except (ValueError, np.linalg.LinAlgError) as e:
        return f"error: {e}", False


def run_nlopt(algorithm, c, x0, time_limit):
    import nlopt
    opt = nlopt.opt(algorithm, len(x0))

    def objective(x, grad):
        try:
            f = c.cost(x)
        except Spent:
            opt.force_stop()
            return c.best
        return f if math.isfinite(f) else 1e300

    opt.set_min_objective(objective)
    opt.set_ftol_rel(1e-15)
    opt.set_xtol_rel(1e-12)
    opt.set_maxeval(int(c.max_evals))
    opt.set_maxtime(time_limit)
    try:
        opt.optimize(list(x0))
        code = opt.last_optimize_result()
    except (nlopt.ForcedStop, nlopt.RoundoffLimited, RuntimeError, ValueError) as e:
        if c.spent:
            return "budget", False
        return f"error: {type(e).__name__}", False
    if c.spent:
        return "budget", False
    names = {1: "success", 2: "stopval", 3: "ftol", 4: "xtol", 5: "maxeval", 6: "maxtime"}
    return names.get(code, f"code {code}"), code in (1, 2, 3, 4)


def main():
    ensure_venv()
    import numpy as np
    import scipy
    import nlopt
    sys.path.insert(0, str(ROOT / "scripts" / "golden"))
    import mgh_golden

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--budget", type=int, default=2000, help="simplex gradients (n + 1 evaluations) per run")
    ap.add_argument("--time-limit", type=float, default=10.0, help="seconds per run")
    ap.add_argument("--repeats", type=int, default=3, help="timings per run (median)")
    ap.add_argument("--filter", default=None, help="only problems whose name contains this")
    ap.add_argument("--out", default=str(ROOT / "results" / "benchmarks" / "outside"))
    args = ap.parse_args()

    solvers = {
        "scipy-lm": ("scipy", lambda c, x0: run_scipy("lm", c, x0)),
        "scipy-trf": ("scipy", lambda c, x0: run_scipy("trf", c, x0)),
        "nlopt-praxis": ("nlopt", lambda c, x0: run_nlopt(nlopt.LN_PRAXIS, c, x0, args.time_limit)),
        "nlopt-newuoa": ("nlopt", lambda c, x0: run_nlopt(nlopt.LN_NEWUOA, c, x0, args.time_limit)),
    }
    files = {"scipy": [], "nlopt": []}
    started = time.perf_counter()
    for pid, key, fun, n, m, x0 in mgh_golden.problems():
        name = f"{pid:02d}_{key}"
        if args.filter and args.filter not in name:
            continue
        x0 = np.array(x0, float)
        for scale in (1.0, 10.0, 100.0):
            start = np.full(n, scale) if (scale != 1.0 and not x0.any()) else scale * x0
            for solver, (group, run) in solvers.items():
                times, first = [], None
                for _ in range(max(1, args.repeats)):
                    c = Counted(fun, m, args.budget * (n + 1), args.time_limit)
                    t0 = time.perf_counter()
                    status, converged = run(c, start.copy())
                    times.append(time.perf_counter() - t0)
                    if first is None:
                        first = (c, status, converged)
                c, status, converged = first
                if not c.trace:
                    continue
                times.sort()
                files[group].append({
                    "solver": solver, "set": "mgh", "problem": name, "n": n, "m": m, "scale": scale,
                    "status": status, "converged": bool(converged), "f0": c.trace[0][1], "f": c.best,
                    "f_star": None, "f_evals": c.evals, "jac_evals": 0, "evals": c.evals,
                    "time_s": times[len(times) // 2], "repeats": max(1, args.repeats),
                    "trace": thin_trace(c.trace),
                })
                print(f"{name:30s} x{scale:<5g} {solver:13s} f={c.best:.6e} evals={c.evals:7d} "
                      f"{times[len(times) // 2]:.2e} s {status}", flush=True)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    elapsed = f"{time.perf_counter() - started:.1f} s for the runs of both files"
    sources = {
        "scipy": f"scipy {scipy.__version__} least_squares (numpy {np.__version__}), scripts/bench/outside_mgh.py, {elapsed}",
        "nlopt": f"nlopt {nlopt.__version__} (PRAXIS, NEWUOA), scripts/bench/outside_mgh.py, {elapsed}",
    }
    for group, runs in files.items():
        path = out / f"{group}.json"
        path.write_text(json.dumps({"format": "nprl-bench/1", "source": sources[group], "runs": runs}) + "\n")
        print(f"wrote {path} ({len(runs)} runs)")


if __name__ == "__main__":
    main()
