#!/usr/bin/env python3
"""A solver for nprl-bench in plain Python, over the process protocol.

    cargo run --release -p nprl-bench -- --solvers gauss-newton \
        --solver-cmd "python3 scripts/bench/client_lm.py" --out target/py-lm

The protocol (JSON lines on standard input and output) is in
bench/src/process.rs and bench/README.md. The solver is a textbook
Levenberg-Marquardt (Marquardt's diagonal scaling, damping halved on
success and multiplied by 4 on failure), standard library only: it needs
no virtual environment, and bench/tests/open_benchmark.rs runs it.
"""

import json
import sys


def ask(message):
    print(json.dumps(message), flush=True)
    return json.loads(sys.stdin.readline())


class Spent(Exception):
    """The runner refused an evaluation (the budget, or a failure)."""


def evaluate(kind, x):
    reply = ask({kind: x})
    if "error" in reply:
        raise Spent(reply["error"])
    return reply[kind]


def solve(x, n, m):
    """Levenberg-Marquardt from x; returns how it stopped."""
    r = evaluate("residuals", x)
    if any(v is None for v in r):
        return "non-finite start", False
    f, mu = sum(v * v for v in r), 1e-3
    for _ in range(10000):
        jac = evaluate("jacobian", x)
        g = [sum(jac[i][j] * r[i] for i in range(m)) for j in range(n)]
        a = [[sum(jac[i][j] * jac[i][k] for i in range(m)) for k in range(n)] for j in range(n)]
        if max(abs(v) for v in g) < 1e-15 * (1 + f):
            return "gradient", True
        while True:
            step = gauss([[a[j][k] + (mu * max(a[j][j], 1e-12) if j == k else 0) for k in range(n)] for j in range(n)],
                         [-v for v in g])
            trial = [x[j] + step[j] for j in range(n)]
            rt = evaluate("residuals", trial)
            ft = float("inf") if any(v is None for v in rt) else sum(v * v for v in rt)
            if ft < f:
                small = sum(s * s for s in step) <= 1e-30 * (1 + sum(v * v for v in x)) or f - ft <= 1e-15 * f
                x, r, f, mu = trial, rt, ft, max(mu / 2, 1e-12)
                if small:
                    return "small step", True
                break
            mu *= 4
            if mu > 1e16:
                return "damping", False
    return "iterations", False


def gauss(a, b):
    """Solves a y = b by Gaussian elimination with partial pivoting."""
    n = len(b)
    for c in range(n):
        p = max(range(c, n), key=lambda i: abs(a[i][c]))
        a[c], a[p], b[c], b[p] = a[p], a[c], b[p], b[c]
        for i in range(c + 1, n):
            t = a[i][c] / a[c][c] if a[c][c] else 0.0
            b[i] -= t * b[c]
            for k in range(c, n):
                a[i][k] -= t * a[c][k]
    y = [0.0] * n
    for i in reversed(range(n)):
        y[i] = (b[i] - sum(a[i][k] * y[k] for k in range(i + 1, n))) / (a[i][i] or 1.0)
    return y


def main():
    print(json.dumps({"solver": "py-lm"}), flush=True)
    for line in sys.stdin:
        problem = json.loads(line)["problem"]
        try:
            status, converged = solve(problem["x0"], problem["n"], problem["m"])
            print(json.dumps({"done": {"status": status, "converged": converged}}), flush=True)
        except Spent as e:
            print(json.dumps({"done": {"status": str(e), "converged": False}}), flush=True)
        except (ArithmeticError, TypeError, ValueError) as e:
            print(json.dumps({"failed": repr(e)}), flush=True)


if __name__ == "__main__":
    main()
