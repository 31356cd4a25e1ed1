#!/usr/bin/env python3
"""Side-by-side: `trajopt::powell` against scipy.optimize.minimize(method="Powell").

    python3 scripts/compare_powell.py [PROBLEM...]
    (default: rosenbrock powell_singular rosenbrock10 rosenbrock50 quadratic10 trivial)

Sets up its own virtual environment (.venv-ref/, from scripts/requirements.txt)
on first use, runs `cargo run --release -p nprl-drivers --bin powell_timing`,
runs scipy's Powell on the same problems from the same starts at its default
settings (xtol = ftol = 1e-4, maxiter = maxfev = 1000 n) in the same run, and
prints for each problem the median time per solve, the ratio scipy / rust,
both evaluation counts, both final costs and whether they agree
(|cost_rust - cost_scipy| <= 1e-8 + 1e-6 |cost_scipy|), and the largest
difference between the two solutions. The `trivial` problem (a 10-D
separable quadratic) gives the time per evaluation with the objective included;
the last line is the solver's own time per evaluation (`powell_timing
--overhead`: solve time minus the time of as many objective calls, over the
evaluations, for n = 2, 5, 10, 20).
"""
import json
import subprocess
import sys

from _venv import ROOT, ensure_venv, median_time  # noqa: E402  (scripts/ is on sys.path)


def problems():
    import numpy as np

    def rosenbrock(x):
        return float(np.sum(100.0 * (x[1:] - x[:-1] ** 2) ** 2 + (1.0 - x[:-1]) ** 2))

    def powell_singular(x):
        return float(
            (x[0] + 10 * x[1]) ** 2 + 5 * (x[2] - x[3]) ** 2 + (x[1] - 2 * x[2]) ** 4 + 10 * (x[0] - x[3]) ** 4
        )

    def quadratic(x):
        d = x - np.arange(x.size) / 10.0
        return float(np.sum((np.arange(x.size) + 1) * d * d) + np.sum(0.5 * d[:-1] * d[1:]))

    def trivial(x):
        return float(np.sum((x - 1.0) ** 2))

    def ext(n):
        return np.array([-1.2 if i % 2 == 0 else 1.0 for i in range(n)])

    return {
        "rosenbrock": (rosenbrock, ext(2)),
        "powell_singular": (powell_singular, np.array([3.0, -1.0, 0.0, 1.0])),
        "rosenbrock10": (rosenbrock, ext(10)),
        "rosenbrock50": (rosenbrock, ext(50)),
        "quadratic10": (quadratic, np.zeros(10)),
        "trivial": (trivial, np.zeros(10)),
    }


def main():
    ensure_venv(__file__)
    import numpy as np
    from scipy.optimize import minimize

    table = problems()
    wanted = sys.argv[1:] or list(table)
    cmd = ["cargo", "run", "--quiet", "--release", "-p", "nprl-drivers", "--bin", "powell_timing", "--", *wanted]
    out = subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True).stdout
    rust = {r["problem"]: r for r in (json.loads(line) for line in out.splitlines() if line.startswith("{"))}
    print(
        f"{'problem':<16}{'n':>4}{'scipy':>11}{'rust':>11}{'ratio':>8}"
        f"{'evals py':>10}{'evals rs':>10}{'cost py':>11}{'cost rs':>11}  agree  {'max|dx|':>8}  rust status"
    )
    for name in wanted:
        f, x0 = table[name]
        r = rust[name]
        res = minimize(f, x0, method="Powell")
        t_py = median_time(lambda: minimize(f, x0, method="Powell"), 5, 5)
        agree = abs(r["cost"] - res.fun) <= 1e-8 + 1e-6 * abs(res.fun)
        dx = float(np.max(np.abs(np.array(r["x"]) - res.x)))
        print(
            f"{name:<16}{x0.size:>4}{t_py * 1e3:>9.3f}ms{r['seconds'] * 1e3:>9.3f}ms{t_py / r['seconds']:>7.0f}x"
            f"{res.nfev:>10}{r['evals']:>10}{res.fun:>11.2e}{r['cost']:>11.2e}  {'yes' if agree else 'NO ':<5}  {dx:>8.1e}  {r['status']}"
        )
        if name == "trivial":
            print(
                f"{'':<20}per evaluation: scipy {t_py / res.nfev * 1e9:.0f} ns, "
                f"rust {r['seconds'] / r['evals'] * 1e9:.1f} ns (objective included)"
            )
    # the solver's own time per evaluation (the objective's time subtracted)
    cmd = ["cargo", "run", "--quiet", "--release", "-p", "nprl-drivers", "--bin", "powell_timing", "--", "--overhead"]
    out = subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True).stdout
    rows = [json.loads(line) for line in out.splitlines() if line.startswith("{")]
    print(
        "rust overhead per evaluation, trivial objective: "
        + ", ".join(f"n={r['n']}: {r['overhead_ns_per_eval']:.0f} ns" for r in rows)
        + " (target: under 1000 ns)"
    )


if __name__ == "__main__":
    main()
