#!/usr/bin/env python3
"""Can cached node statistics (Moore, Schneider & Deng 1997) or a shorter
truncation of the Gaussian make the LWR query sublinear in the data at the
same answers? A prototype that counts the work, not a timing (issue 35).

    python3 scripts/lwr_node_statistics.py [--queries N] [SIZES...]   (default 1000 10000 100000)

Needs numpy only (any Python with numpy; the repository's .venv-ref/ has it).

The data is compare_lwr.py's: inputs a, b, c ~ U(-1, 1), y = sin(3a) + 0.5b +
0.1 N(0, 1), with one Gaussian metric held fixed over the sizes (as a model
whose metric was tuned once and then receives more data): scales (1, 1, 1)
("3-D") or (1, 1, 0) ("2-D", the irrelevant input c scaled to 0), and the
bandwidth h at which the default truncation u < 5 holds about 10 % of the
data (the coverage issue 35 measured on a tuned metric).

For each size and each query (uniform in [-0.8, 0.8]^3) the local linear fit
is computed

  exact       over every point with u = |s - q| / h < 5 (the crate's query),
  truncated   over u < c for c = 4, 3.5, 3: a shorter Gaussian whose dropped
              weight is bounded exactly by (points in the annulus) x exp(-c^2/2),
  nodes       on a k-d tree (leaves of at most 32 points, as the crate's)
              whose every node caches its count and the moments
              sum w, sum w w', sum y, sum w y of its points about its box's
              centre (w = s - centre): a node whose weights lie within
              [k_min, k_max] is added as a whole with the weight
              (k_min + k_max) / 2, the moments shifted to the query, when
                rel tau:   k_max - k_min <= 2 tau k_min (every point's weight
                           within a relative tau: a stated tolerance), or
                abs tau:   (k_max - k_min) / 2 <= tau W / N with W and N the
                           exact fit's total weight and point count (Moore's
                           rule with the exact totals: an optimistic bound on
                           what a real implementation, which only has lower
                           bounds on W, would reach);
              other nodes are opened, leaves summed point by point.

and reports per method the mean work per query (points summed one by one,
plus nodes added whole) and the largest |prediction - exact prediction| over
the queries, in units of the noise's standard deviation (0.1).
"""
import argparse
import math
import subprocess
import sys

import numpy as np

CUTOFF = 5.0
LEAF = 32
NOISE = 0.1


def make_data(n, seed):
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1.0, 1.0, (n, 3))
    y = np.sin(3.0 * x[:, 0]) + 0.5 * x[:, 1] + NOISE * rng.standard_normal(n)
    return x, y


def bandwidth_for_coverage(scales, coverage, cutoff):
    """h such that the ball u < cutoff holds `coverage` of U(-1, 1)^3 in the
    scaled coordinates (ignoring the edges; measured below)."""
    dims = [s for s in scales if s > 0]
    volume = np.prod([2.0 * s for s in dims])
    d = len(dims)
    unit_ball = math.pi ** (d / 2) / math.gamma(d / 2 + 1)
    radius = (coverage * volume / unit_ball) ** (1.0 / d)
    return radius / cutoff


class Node:
    __slots__ = ("lo", "hi", "idx", "left", "right", "n", "centre", "sw", "sww", "sy", "swy")


def build(s, y, idx):
    node = Node()
    pts = s[idx]
    node.lo, node.hi = pts.min(axis=0), pts.max(axis=0)
    node.idx = idx
    node.n = len(idx)
    node.centre = 0.5 * (node.lo + node.hi)
    w = pts - node.centre
    node.sw = w.sum(axis=0)
    node.sww = w.T @ w
    node.sy = y[idx].sum()
    node.swy = w.T @ y[idx]
    node.left = node.right = None
    if len(idx) > LEAF:
        j = int(np.argmax(node.hi - node.lo))
        order = idx[np.argsort(pts[:, j], kind="stable")]
        half = len(order) // 2
        node.left = build(s, y, order[:half])
        node.right = build(s, y, order[half:])
    return node


def box_u2(node, q, h):
    """The smallest and largest u^2 over the node's box."""
    near = np.clip(q, node.lo, node.hi) - q
    far = np.maximum(np.abs(node.lo - q), np.abs(node.hi - q))
    return float(near @ near) / (h * h), float(far @ far) / (h * h)


def solve(a, b):
    d = a.shape[0]
    ridge = 1e-10 * np.trace(a) * np.eye(d)
    ridge[0, 0] = 0.0
    return np.linalg.solve(a + ridge, b)[0]


def exact_fit(s, y, q, h, cutoff):
    delta = s - q
    u2 = np.einsum("ij,ij->i", delta, delta) / (h * h)
    inside = u2 < cutoff * cutoff
    k = np.exp(-0.5 * u2[inside])
    z = np.hstack([np.ones((inside.sum(), 1)), delta[inside]])
    a = (z * k[:, None]).T @ z
    b = (z * k[:, None]).T @ y[inside]
    return solve(a, b), int(inside.sum()), float(k.sum()), u2


def node_fit(root, s, y, q, h, accept):
    d = s.shape[1]
    a = np.zeros((d + 1, d + 1))
    b = np.zeros(d + 1)
    counts = [0, 0]  # points one by one, nodes whole
    stack = [root]
    c2 = CUTOFF * CUTOFF
    while stack:
        node = stack.pop()
        u2_min, u2_max = box_u2(node, q, h)
        if u2_min >= c2:
            continue
        k_max = math.exp(-0.5 * u2_min)
        k_min = math.exp(-0.5 * u2_max) if u2_max < c2 else 0.0
        if node.left is not None and accept(k_min, k_max):
            kbar = 0.5 * (k_min + k_max)
            e = node.centre - q
            sz = np.concatenate([[node.n], node.sw + node.n * e])
            block = node.sww + np.outer(node.sw, e) + np.outer(e, node.sw) + node.n * np.outer(e, e)
            m = np.empty((d + 1, d + 1))
            m[0, :] = sz
            m[:, 0] = sz
            m[1:, 1:] = block
            a += kbar * m
            b += kbar * np.concatenate([[node.sy], node.swy + e * node.sy])
            counts[1] += 1
            continue
        if node.left is None:
            delta = s[node.idx] - q
            u2 = np.einsum("ij,ij->i", delta, delta) / (h * h)
            inside = u2 < c2
            k = np.exp(-0.5 * u2[inside])
            z = np.hstack([np.ones((inside.sum(), 1)), delta[inside]])
            a += (z * k[:, None]).T @ z
            b += (z * k[:, None]).T @ y[node.idx][inside]
            counts[0] += int(inside.sum())
            continue
        stack.append(node.left)
        stack.append(node.right)
    return solve(a, b), counts


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sizes", nargs="*", type=int, default=[1000, 10000, 100000])
    parser.add_argument("--queries", type=int, default=40)
    args = parser.parse_args()
    sys.setrecursionlimit(10000)
    rng = np.random.default_rng(7)
    queries = rng.uniform(-0.8, 0.8, (args.queries, 3))
    taus = [1e-1, 1e-2, 1e-3]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    print("# Cached node statistics and shorter truncations: work per LWR query (issue 35)\n")
    print(
        f"Generated at commit {commit or 'unknown'} by `python3 scripts/lwr_node_statistics.py "
        f"--queries {args.queries} {' '.join(map(str, args.sizes))} > results/lwr_node_statistics.md` "
        "(the method is in the script's docstring). Work is counted, not timed: points summed one by one "
        "and nodes added whole, per query, mean over the queries; errors are the worst over the queries."
    )
    for name, scales in [("3-D", np.array([1.0, 1.0, 1.0])), ("2-D", np.array([1.0, 1.0, 0.0]))]:
        h = bandwidth_for_coverage(scales, 0.10, CUTOFF)
        print(f"\n## {name}: scales {scales.tolist()}, h = {h:.4f}, Gaussian truncated at u < {CUTOFF}")
        print("| n | method | mean points summed | mean nodes added whole | worst error / noise sd |")
        print("|---|---|---|---|---|")
        for n in args.sizes:
            x, y = make_data(n, 42)
            s = x * scales
            root = build(s, y, np.arange(n))
            rows = {}
            for q in queries * scales:
                exact, count, weight, u2 = exact_fit(s, y, q, h, CUTOFF)
                rows.setdefault("exact (u < 5)", []).append((count, 0, 0.0))
                for c in (4.0, 3.5, 3.0):
                    pred, count_c, _, _ = exact_fit(s, y, q, h, c)
                    dropped = float(((u2 >= c * c) & (u2 < CUTOFF**2)).sum()) * math.exp(-0.5 * c * c) / weight
                    rows.setdefault(f"truncated u < {c}", []).append((count_c, 0, abs(pred - exact) / NOISE, dropped))
                for tau in taus:
                    rel = lambda lo, hi, t=tau: hi - lo <= 2.0 * t * lo  # noqa: E731
                    pred, (pts, nodes) = node_fit(root, s, y, q, h, rel)
                    rows.setdefault(f"nodes, rel tau {tau:g}", []).append((pts, nodes, abs(pred - exact) / NOISE))
                    bound = tau * weight / count
                    absolute = lambda lo, hi, b=bound: 0.5 * (hi - lo) <= b  # noqa: E731
                    pred, (pts, nodes) = node_fit(root, s, y, q, h, absolute)
                    rows.setdefault(f"nodes, abs tau {tau:g}", []).append((pts, nodes, abs(pred - exact) / NOISE))
            for method, vals in rows.items():
                pts = np.mean([v[0] for v in vals])
                nodes = np.mean([v[1] for v in vals])
                err = max(v[2] for v in vals)
                extra = ""
                if method.startswith("truncated"):
                    extra = f" (dropped weight at most {max(v[3] for v in vals):.1e} of the total)"
                print(f"| {n} | {method}{extra} | {pts:.0f} | {nodes:.0f} | {err:.1e} |")
            sys.stdout.flush()


if __name__ == "__main__":
    main()
