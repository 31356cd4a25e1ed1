"""Outside solvers on the MGH and NIST StRD sets, in nprl-bench's record format.

Sets (`--set`):

- `mgh`: the 35 problems of `trajopt::problems::mgh` at their standard sizes
  from 1, 10 and 100 x0 (Watson's x0 = 0 scales to scale * (1, ..., 1), as in
  MINPACK-1's driver and in Rust); the residuals are those of
  scripts/golden/mgh_golden.py (an independent NumPy implementation written
  from the paper, imported, not copied);
- `nist`: the 27 NIST StRD nonlinear regression problems from their two
  certified starts (records' `scale` = the start's number), read from
  bench/data/nist/*.dat by this script's own parser, with the models written
  here from the files' model lines (r = y - f(x; b); Nelson: log y - f);
  independent of bench/src/nist.rs.

Solvers (`--groups`):

- `scipy-lm`: scipy.optimize.least_squares(method="lm"), MINPACK's lmdif
  (forward-difference Jacobian), ftol = xtol = gtol = 1e-15;
- `scipy-trf`: least_squares(method="trf"), 2-point Jacobian, the same tolerances;
- `nlopt-praxis`, `nlopt-newuoa`: NLopt's PRAXIS (Brent's principal axis) and
  NEWUOA (Powell) on f = sum r^2, ftol_rel = 1e-15, xtol_rel = 1e-12;
- `pdfo-newuoa`, `pdfo-bobyqa`: PDFO's NEWUOA and BOBYQA (Powell's own
  Fortran, no bounds) on f, PDFO's defaults (initial trust-region radius
  1, npt = 2n + 1) but a final radius of 1e-12 and at most the budget's
  evaluations (PDFO's maxfev; PDFO cannot be stopped from the objective, so
  past the time limit the objective returns the best f so far, uncounted,
  until maxfev);
- `dfols`: DFO-LS (Cartis and Roberts), derivative-free Gauss-Newton on
  linear interpolation models of the residuals, its defaults but
  rhoend = 1e-12 and maxfun = the budget (group `dfols`, file dfols.json).

Every residual call is counted (finite-difference calls included: an
evaluation equivalent, as in Rust) and the budget is the runner's: BUDGET *
(n + 1) evaluations and TIME_LIMIT seconds per run. The trace of the best f
so far is thinned by the rule of bench/src/record.rs (`thin_trace`). Each
run is timed REPEATS times (median). Every record holds its start `x0` and
the final point `x` (that of the best f evaluated, which is what each
solver returns), from which the runner recomputes f(x0) and f itself (and,
on the NIST set, the parameters' log relative error).

Writes OUT/<group>.json (default OUT = results/benchmarks/outside for mgh,
results/benchmarks/nist/outside for nist), which `nprl-bench` merges.

Run from the repository root:
  python3 scripts/bench/outside.py [--set mgh] [--budget 2000] [--time-limit 10] [--repeats 3] [--groups scipy,nlopt,pdfo,dfols]

It makes two virtual environments on first use: .venv-bench/ (numpy 2,
scipy, nlopt, DFO-LS) and .venv-bench-pdfo/ (pdfo 2.2.0, which needs numpy < 2); the
pdfo group runs in the second, as a child process of this script.
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
PACKAGES = ["numpy==2.4.6", "scipy==1.17.1", "nlopt==2.11.0", "DFO-LS==1.6.5"]
# pdfo 2.2.0's compiled Fortran needs numpy < 2
VENV_PDFO = ROOT / ".venv-bench-pdfo"
PACKAGES_PDFO = ["numpy==1.26.4", "pdfo==2.2.0"]
GROUPS = ("scipy", "nlopt", "pdfo", "dfols")
SETS = ("mgh", "nist")


def venv_python(venv, packages):
    """The Python of `venv`, made with `packages` on first use."""
    py = venv / "bin" / "python"
    if not py.exists():
        subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
        subprocess.run([str(py), "-m", "pip", "install", "-q", *packages], check=True)
    return py


def ensure_venv(venv, packages):
    """Re-executes this script inside `venv` (made on first use)."""
    if pathlib.Path(sys.prefix).resolve() == venv.resolve():
        return
    py = venv_python(venv, packages)
    os.execv(str(py), [str(py), __file__, *sys.argv[1:]])


class Spent(Exception):
    """The run's budget is used up."""


class Counted:
    """f = sum r^2 through a counter, a best-so-far trace and the budget."""

    def __init__(self, fun, m, max_evals, time_limit):
        self.fun, self.m = fun, m
        self.max_evals, self.deadline = max_evals, time.perf_counter() + time_limit
        self.evals, self.best, self.trace, self.spent = 0, math.inf, [], False
        self.best_x = None

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
            self.best_x = [float(v) for v in x]
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


def run_pdfo(method, c, x0):
    import warnings
    from pdfo import pdfo

    def objective(x):
        try:
            f = c.cost(x)
        except Spent:
            # PDFO cannot be stopped from here: the best so far, until maxfev
            return c.best if math.isfinite(c.best) else 1e300
        return f if math.isfinite(f) else 1e300

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            res = pdfo(objective, list(x0), method=method,
                       options={"radius_final": 1e-12, "maxfev": int(c.max_evals), "quiet": True})
        except (ValueError, RuntimeError, ArithmeticError) as e:
            return f"error: {type(e).__name__}", False
    if c.spent:
        return "budget", False
    # 0: the final radius reached, 1: ftarget, 3: maxfev
    status = int(res.status)
    return ("success" if status == 0 else f"status {status}"), status in (0, 1)


def run_dfols(c, x0):
    import warnings
    import numpy as np
    import dfols

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            soln = dfols.solve(c.residuals, np.asarray(x0, float), rhoend=1e-12, maxfun=int(c.max_evals))
        except Spent:
            return "budget", False
        except (ValueError, np.linalg.LinAlgError, ArithmeticError) as e:
            return f"error: {type(e).__name__}", False
    if c.spent:
        return "budget", False
    # EXIT_SUCCESS = 0 (rho reached rhoend); 1 maxfun, 2 slow, 3 false success, < 0 errors
    return ("success" if soln.flag == soln.EXIT_SUCCESS else f"flag {soln.flag}"), soln.flag == soln.EXIT_SUCCESS


NIST = ROOT / "bench" / "data" / "nist"


def nist_model(name):
    """f(b, x) of NIST problem `name`, written from the files' model lines."""
    import numpy as np
    e, pi = np.exp, np.pi
    rational = lambda num, den: lambda b, x: np.polyval(b[num - 1::-1], x) / (1 + x * np.polyval(b[:num - 1:-1], x))
    models = {
        "Misra1a": lambda b, x: b[0] * (1 - e(-b[1] * x)),
        "BoxBOD": lambda b, x: b[0] * (1 - e(-b[1] * x)),
        "Chwirut1": lambda b, x: e(-b[0] * x) / (b[1] + b[2] * x),
        "Chwirut2": lambda b, x: e(-b[0] * x) / (b[1] + b[2] * x),
        "DanWood": lambda b, x: b[0] * x ** b[1],
        "Misra1b": lambda b, x: b[0] * (1 - (1 + b[1] * x / 2) ** -2),
        "Misra1c": lambda b, x: b[0] * (1 - (1 + 2 * b[1] * x) ** -0.5),
        "Misra1d": lambda b, x: b[0] * b[1] * x / (1 + b[1] * x),
        "Kirby2": rational(3, 2),
        "Hahn1": rational(4, 3),
        "Thurber": rational(4, 3),
        "MGH09": lambda b, x: b[0] * (x ** 2 + x * b[1]) / (x ** 2 + x * b[2] + b[3]),
        "MGH10": lambda b, x: b[0] * e(b[1] / (x + b[2])),
        "MGH17": lambda b, x: b[0] + b[1] * e(-x * b[3]) + b[2] * e(-x * b[4]),
        "Eckerle4": lambda b, x: (b[0] / b[1]) * e(-0.5 * ((x - b[2]) / b[1]) ** 2),
        "Rat42": lambda b, x: b[0] / (1 + e(b[1] - b[2] * x)),
        "Rat43": lambda b, x: b[0] / (1 + e(b[1] - b[2] * x)) ** (1 / b[3]),
        "Bennett5": lambda b, x: b[0] * (b[1] + x) ** (-1 / b[2]),
        # NIST's arctan lies in (0, pi) here: atan2 reproduces the certified RSS
        "Roszman1": lambda b, x: b[0] - b[1] * x - np.arctan2(b[2], x - b[3]) / pi,
        "ENSO": lambda b, x: (b[0] + b[1] * np.cos(2 * pi * x / 12) + b[2] * np.sin(2 * pi * x / 12)
                              + b[4] * np.cos(2 * pi * x / b[3]) + b[5] * np.sin(2 * pi * x / b[3])
                              + b[7] * np.cos(2 * pi * x / b[6]) + b[8] * np.sin(2 * pi * x / b[6])),
        "Nelson": lambda b, x: b[0] - b[1] * x[:, 0] * e(-b[2] * x[:, 1]),
    }
    for k in (1, 2, 3):
        models[f"Gauss{k}"] = lambda b, x: (b[0] * e(-b[1] * x) + b[2] * e(-(x - b[3]) ** 2 / b[4] ** 2)
                                            + b[5] * e(-(x - b[6]) ** 2 / b[7] ** 2))
        models[f"Lanczos{k}"] = lambda b, x: b[0] * e(-b[1] * x) + b[2] * e(-b[3] * x) + b[4] * e(-b[5] * x)
    return models[name]


def nist_problems():
    """(name, fun, n, m, [(1, start 1), (2, start 2)]) of every NIST file, parsed here."""
    import re
    import numpy as np
    out = []
    for path in sorted(NIST.glob("*.dat")):
        lines = path.read_text().splitlines()
        params = [l for l in lines if re.match(r"\s*b\d+\s*=", l)]
        starts = [[float(l.split("=")[1].split()[k]) for l in params] for k in (0, 1)]
        table = next(i for i, l in enumerate(lines) if re.match(r"Data:\s+y", l))
        data = np.array([[float(v) for v in l.split()] for l in lines[table + 1:] if l.strip()])
        name = path.stem
        y = np.log(data[:, 0]) if name == "Nelson" else data[:, 0]
        x = data[:, 1:] if name == "Nelson" else data[:, 1]
        model = nist_model(name)
        fun = (lambda model, x, y: lambda b, m: y - model(b, x))(model, x, y)
        out.append((name, fun, len(params), len(y), [(1.0, starts[0]), (2.0, starts[1])]))
    return out


def mgh_problems():
    """(name, fun, n, m, [(scale, start)]) of the MGH set, from scripts/golden/mgh_golden.py."""
    import numpy as np
    sys.path.insert(0, str(ROOT / "scripts" / "golden"))
    import mgh_golden
    out = []
    for pid, key, fun, n, m, x0 in mgh_golden.problems():
        x0 = np.array(x0, float)
        starts = [(scale, np.full(n, scale) if (scale != 1.0 and not x0.any()) else scale * x0)
                  for scale in (1.0, 10.0, 100.0)]
        out.append((f"{pid:02d}_{key}", fun, n, m, starts))
    return out


def parse_args():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--budget", type=int, default=2000, help="simplex gradients (n + 1 evaluations) per run")
    ap.add_argument("--time-limit", type=float, default=10.0, help="seconds per run")
    ap.add_argument("--repeats", type=int, default=3, help="timings per run (median)")
    ap.add_argument("--filter", default=None, help="only problems whose name contains this")
    ap.add_argument("--set", default="mgh", choices=SETS, help="problem set")
    ap.add_argument("--groups", default=",".join(GROUPS), help="comma-separated: " + ", ".join(GROUPS))
    ap.add_argument("--out", default=None,
                    help="default results/benchmarks/outside (mgh), results/benchmarks/nist/outside (nist)")
    args = ap.parse_args()
    if args.out is None:
        base = ROOT / "results" / "benchmarks"
        args.out = str(base / "outside" if args.set == "mgh" else base / args.set / "outside")
    args.groups = [g.strip() for g in args.groups.split(",") if g.strip()]
    unknown = [g for g in args.groups if g not in GROUPS]
    if unknown or not args.groups:
        ap.error(f"unknown or no groups: {unknown}; known: {', '.join(GROUPS)}")
    return args


def main():
    args = parse_args()
    if args.groups == ["pdfo"]:
        ensure_venv(VENV_PDFO, PACKAGES_PDFO)
        run_groups(args, ["pdfo"])
        return
    ensure_venv(VENV, PACKAGES)
    here = [g for g in args.groups if g != "pdfo"]
    run_groups(args, here)
    if "pdfo" in args.groups:
        # the same options, the pdfo group alone, in its own environment
        argv, skip = [], False
        for a in sys.argv[1:]:
            if skip or a == "--groups" or a.startswith("--groups="):
                skip = a == "--groups"
                continue
            argv.append(a)
        py = venv_python(VENV_PDFO, PACKAGES_PDFO)
        subprocess.run([str(py), __file__, *argv, "--groups", "pdfo"], check=True)


def run_groups(args, groups):
    """Runs the solvers of `groups` (all in this interpreter) and writes their files."""
    import numpy as np

    solvers, versions = {}, {}
    if "scipy" in groups:
        import scipy
        solvers["scipy-lm"] = ("scipy", lambda c, x0: run_scipy("lm", c, x0))
        solvers["scipy-trf"] = ("scipy", lambda c, x0: run_scipy("trf", c, x0))
        versions["scipy"] = f"scipy {scipy.__version__} least_squares (numpy {np.__version__})"
    if "nlopt" in groups:
        import nlopt
        solvers["nlopt-praxis"] = ("nlopt", lambda c, x0: run_nlopt(nlopt.LN_PRAXIS, c, x0, args.time_limit))
        solvers["nlopt-newuoa"] = ("nlopt", lambda c, x0: run_nlopt(nlopt.LN_NEWUOA, c, x0, args.time_limit))
        versions["nlopt"] = f"nlopt {nlopt.__version__} (PRAXIS, NEWUOA; numpy {np.__version__})"
    if "pdfo" in groups:
        from importlib.metadata import version
        solvers["pdfo-newuoa"] = ("pdfo", lambda c, x0: run_pdfo("newuoa", c, x0))
        solvers["pdfo-bobyqa"] = ("pdfo", lambda c, x0: run_pdfo("bobyqa", c, x0))
        versions["pdfo"] = f"pdfo {version('pdfo')} (NEWUOA, BOBYQA; numpy {np.__version__})"
    if "dfols" in groups:
        import dfols
        solvers["dfols"] = ("dfols", run_dfols)
        versions["dfols"] = f"DFO-LS {dfols.__version__} (numpy {np.__version__})"
    files = {g: [] for g in groups}
    spent = {g: 0.0 for g in groups}
    problems = mgh_problems() if args.set == "mgh" else nist_problems()
    for name, fun, n, m, starts in problems:
        if args.filter and args.filter not in name:
            continue
        for scale, start in starts:
            start = np.array(start, float)
            for solver, (group, run) in solvers.items():
                group_started = time.perf_counter()
                times, first = [], None
                for _ in range(max(1, args.repeats)):
                    c = Counted(fun, m, args.budget * (n + 1), args.time_limit)
                    t0 = time.perf_counter()
                    status, converged = run(c, start.copy())
                    times.append(time.perf_counter() - t0)
                    if first is None:
                        first = (c, status, converged)
                c, status, converged = first
                spent[group] += time.perf_counter() - group_started
                if not c.trace:
                    continue
                times.sort()
                # f0: this script's own f at the start (None where it overflows);
                # the runner recomputes it from the start either way
                with np.errstate(all="ignore"):
                    r0 = np.asarray(fun(start.copy(), m), float)
                    f0 = float(np.sum(r0 * r0))
                files[group].append({
                    "solver": solver, "set": args.set, "problem": name, "n": n, "m": m, "scale": scale,
                    "status": status, "converged": bool(converged),
                    "f0": f0 if math.isfinite(f0) else None, "f": c.best,
                    "f_star": None, "f_evals": c.evals, "jac_evals": 0, "evals": c.evals,
                    "time_s": times[len(times) // 2], "repeats": max(1, args.repeats),
                    "trace": thin_trace(c.trace),
                    "x0": [float(v) for v in start], "x": c.best_x,
                })
                print(f"{name:30s} x{scale:<5g} {solver:13s} f={c.best:.6e} evals={c.evals:7d} "
                      f"{times[len(times) // 2]:.2e} s {status}", flush=True)
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for group, runs in files.items():
        source = (f"{versions[group]}, scripts/bench/outside.py --set {args.set} --time-limit {args.time_limit:g} "
                  f"--budget {args.budget}, {spent[group]:.1f} s for the runs")
        path = out / f"{group}.json"
        path.write_text(json.dumps({"format": "nprl-bench/1", "source": source, "runs": runs}) + "\n")
        print(f"wrote {path} ({len(runs)} runs)")


if __name__ == "__main__":
    main()
