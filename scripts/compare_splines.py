#!/usr/bin/env python3
"""Side-by-side speed and agreement: the `splines` crate against scipy and PyWavelets.

    python3 scripts/compare_splines.py [SIZES...]      (default 100 1000 10000 100000)

Sets up its own virtual environment (.venv-ref/, from scripts/requirements.txt)
on first use, runs `cargo run --release -p nprl-drivers --bin splines_timing`, times the
Python libraries on the same inputs in the same run, and prints for each
operation and size the median time per call, the ratio python / rust, and
whether the results agree (a checksum of each result, recomputed here).

Compared operations (same inputs on both sides, see scripts/drivers/src/bin/splines_timing.rs):
  bspline_design_matrix  scipy.interpolate.BSpline.design_matrix (CSR) vs design_matrix_rows (CSR)
  wavedec / waverec      pywt.wavedec / pywt.waverec, db4, symmetric mode, maximal level
                         vs splines::wavelet (allocating API, and the planned allocation-free one)
"""
import json
import subprocess
import sys

from _venv import ROOT, ensure_venv, median_time  # noqa: E402  (scripts/ is on sys.path)


def inputs(n):
    import numpy as np

    k = np.arange(n)
    times = np.clip((k + 0.5 + 0.3 * np.sin(1.7 * k)) / n, 0.0, 1.0)
    n_coeffs = max(n // 10, 4)
    breaks = np.linspace(0.0, 1.0, n_coeffs - 3 + 1)
    knots = np.r_[[0.0] * 3, breaks, [1.0] * 3]
    signal = np.sin(0.37 * k) + 0.1 * np.cos(1.7 * k)
    return times, knots, signal


def python_results(n):
    import numpy as np
    import pywt
    from scipy.interpolate import BSpline

    times, knots, signal = inputs(n)
    out = {}
    m = BSpline.design_matrix(times, knots, 3).tocsr()
    rows = np.repeat(np.arange(n), np.diff(m.indptr))
    out["bspline_design_matrix"] = (
        median_time(lambda: BSpline.design_matrix(times, knots, 3), 7, 10),
        float(np.sum(m.data * (m.indices + 1) * (rows % 7 + 1))),
    )
    coeffs = pywt.wavedec(signal, "db4", mode="symmetric")
    flat = np.concatenate(coeffs)
    out["wavedec"] = (
        median_time(lambda: pywt.wavedec(signal, "db4", mode="symmetric"), 7, 10),
        float(np.sum(flat * (np.arange(flat.size) % 5 + 1))),
    )
    rec = pywt.waverec(coeffs, "db4", mode="symmetric")[:n]
    out["waverec"] = (
        median_time(lambda: pywt.waverec(coeffs, "db4", mode="symmetric"), 7, 10),
        float(np.sum(rec * (np.arange(n) % 5 + 1))),
    )
    return out


def main():
    ensure_venv(__file__)
    sizes = [int(a) for a in sys.argv[1:]] or [100, 1000, 10000, 100000]
    cmd = ["cargo", "run", "--quiet", "--release", "-p", "nprl-drivers", "--bin", "splines_timing", "--", *map(str, sizes)]
    rust = [json.loads(line) for line in subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True).stdout.splitlines() if line.startswith("{")]
    print(f"{'operation':<34}{'n':>8}{'python':>12}{'rust':>12}{'ratio':>9}  agree")
    for n in sizes:
        py = python_results(n)
        for r in (r for r in rust if r["n"] == n):
            base = r["kind"].split(":")[0]
            if base not in py:
                continue
            t_py, check_py = py[base]
            agree = abs(r["checksum"] - check_py) <= 1e-9 * max(1.0, abs(check_py))
            print(f"{r['kind']:<34}{n:>8}{t_py * 1e6:>10.1f}us{r['seconds'] * 1e6:>10.1f}us{t_py / r['seconds']:>8.1f}x  {'yes' if agree else 'NO'}")


if __name__ == "__main__":
    main()
