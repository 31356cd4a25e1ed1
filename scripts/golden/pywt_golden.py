#!/usr/bin/env python3
"""Golden data for the wavelet transforms of the `splines` crate.

Source: PyWavelets (pywt) 1.9.0 with numpy 2.4.6, Python 3.11 (see
scripts/requirements.txt; that wheel's pywt.__version__, which the JSON's
"source" records, reads 1.8.0). Writes splines/tests/data/pywt_golden.json, read by
splines/tests/wavelet.rs; the Rust tests never run Python.

Contents (floats written by json.dump, i.e. by repr, so they round-trip):
- "filters": pywt.Wavelet(name).filter_bank for haar, db2, ..., db8;
- "signals": the input signals, keyed by length (seeded random, values in [-10, 10]);
- "dwt": pywt.dwt for each wavelet (haar, db2, db3, db4) x mode x length
  (all nine modes; 'reflect' and 'antireflect' skip length 1, which pywt refuses);
- "idwt": pywt.idwt of random coefficient pairs (not from an analysis, so the
  synthesis is tested on its own);
- "wavedec": pywt.wavedec at level 2 and at pywt's default (maximum) level,
  for lengths where that level is at most floor(log2(n)); and, for the longer
  filters (db5, ..., db8) x mode, at the deepest level of two signals shorter
  than the filter (n = 2: one level; n = 5: two levels), where the extension
  wraps around the signal several times.

Usage: python3 -m venv .venv-ref && .venv-ref/bin/pip install -r scripts/requirements.txt
       .venv-ref/bin/python scripts/golden/pywt_golden.py
"""

import json
import pathlib
import platform
import warnings

import numpy as np
import pywt

WAVELETS = ["haar", "db2", "db3", "db4"]
ALL_FILTERS = ["haar", "db2", "db3", "db4", "db5", "db6", "db7", "db8"]
# every pywt mode (pywt.Modes.modes, in another order)
MODES = [
    "periodization",
    "symmetric",
    "reflect",
    "zero",
    "constant",
    "periodic",
    "smooth",
    "antisymmetric",
    "antireflect",
]
LONG_WAVELETS = ["db5", "db6", "db7", "db8"]
DWT_LENGTHS = [1, 2, 5, 16, 37, 101]
WAVEDEC_LENGTHS = [2, 5, 16, 37, 64]
LONG_WAVEDEC_LENGTHS = [2, 5]  # at their deepest level, floor(log2(n))
IDWT_LENGTHS = [1, 4, 9]  # raised to the filter's half length where pywt needs it

OUT = pathlib.Path(__file__).resolve().parents[2] / "splines" / "tests" / "data" / "pywt_golden.json"


def floats(a):
    return [float(v) for v in np.asarray(a, dtype=np.float64)]


def main():
    rng = np.random.default_rng(20240611)
    signals = {str(n): floats(rng.uniform(-10.0, 10.0, n)) for n in sorted(set(DWT_LENGTHS + WAVEDEC_LENGTHS))}

    filters = {name: [floats(f) for f in pywt.Wavelet(name).filter_bank] for name in ALL_FILTERS}

    dwt_cases = []
    for w in WAVELETS:
        for mode in MODES:
            for n in DWT_LENGTHS:
                if mode in ("reflect", "antireflect") and n == 1:
                    continue  # pywt refuses; the Rust side extends as a constant
                a, d = pywt.dwt(np.array(signals[str(n)]), w, mode=mode)
                dwt_cases.append({"wavelet": w, "mode": mode, "n": n, "approx": floats(a), "detail": floats(d)})

    idwt_cases = []
    # the modes added last draw their random coefficients after the first six
    # (whose cases thus stay as they were before)
    for modes in (MODES[:6], MODES[6:]):
        for w in WAVELETS:
            half = pywt.Wavelet(w).dec_len // 2
            for mode in modes:
                for m in IDWT_LENGTHS:
                    if mode != "periodization":
                        m = max(m, half)
                    a = rng.uniform(-10.0, 10.0, m)
                    d = rng.uniform(-10.0, 10.0, m)
                    x = pywt.idwt(a, d, w, mode=mode)
                    idwt_cases.append(
                        {"wavelet": w, "mode": mode, "approx": floats(a), "detail": floats(d), "out": floats(x)}
                    )

    wavedec_cases = []

    def add_wavedec(w, mode, n, level):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "level too high" for short signals
            coeffs = pywt.wavedec(np.array(signals[str(n)]), w, mode=mode, level=level)
        wavedec_cases.append(
            {
                "wavelet": w,
                "mode": mode,
                "n": n,
                "level": level,
                "is_max_level": level == pywt.dwt_max_level(n, pywt.Wavelet(w).dec_len),
                "coeffs": [floats(c) for c in coeffs],
            }
        )

    for w in WAVELETS:
        for mode in MODES:
            for n in WAVEDEC_LENGTHS:
                max_level = pywt.dwt_max_level(n, pywt.Wavelet(w).dec_len)
                for level in sorted({2, max_level}):
                    if level < 1 or level > int(np.floor(np.log2(n))):
                        continue
                    add_wavedec(w, mode, n, level)
    for w in LONG_WAVELETS:
        for mode in MODES:
            for n in LONG_WAVEDEC_LENGTHS:
                add_wavedec(w, mode, n, int(np.floor(np.log2(n))))

    data = {
        "source": f"pywt {pywt.__version__}",
        "numpy": np.__version__,
        "python": platform.python_version(),
        "generator": "scripts/golden/pywt_golden.py",
        "filters": filters,
        "signals": signals,
        "dwt": dwt_cases,
        "idwt": idwt_cases,
        "wavedec": wavedec_cases,
    }
    OUT.parent.mkdir(parents=True, exist_ok=True)
    with open(OUT, "w") as f:
        json.dump(data, f)
        f.write("\n")
    print(f"wrote {OUT} ({OUT.stat().st_size} bytes): {len(dwt_cases)} dwt, {len(idwt_cases)} idwt, {len(wavedec_cases)} wavedec cases")


if __name__ == "__main__":
    main()
