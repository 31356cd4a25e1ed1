#!/usr/bin/env python3
"""Golden trajectories for `swingup::plant`, from an outside integrator:
scipy.integrate.solve_ivp (DOP853, rtol = atol = 1e-12) on an independently
derived ODE, with the command held constant over each 1/60 s sample.

Writes swingup/tests/data/plant_{human,robot,robot_lag}.csv, read by
swingup/tests/plant_golden.rs (the Rust test never runs Python). Run from the
repository root (sets up .venv-ref/ from scripts/requirements.txt on first use):

    python3 scripts/golden/plant_golden.py [OUT_DIR]

Model (derived here, not copied from the Rust code). A point mass m at the end
of a massless rod of length l hangs from a hand at horizontal position x;
theta is measured from hanging straight down. The bob is at
    (x + l sin(theta), -l cos(theta)),
its velocity (x' + l cos(theta) theta', l sin(theta) theta'), so
    L = T - V = m/2 (x'^2 + 2 l x' theta' cos(theta) + l^2 theta'^2) + m g l cos(theta).
The hand's acceleration x'' = a is prescribed (the hand is a motion source),
so only theta is a generalised coordinate:
    d/dt dL/dtheta' = m (l x'' cos(theta) - l x' theta' sin(theta) + l^2 theta'')
    dL/dtheta       = -m l x' theta' sin(theta) - m g l sin(theta)
Adding viscous damping at the pivot as the generalised force -m l^2 b theta'
(the Rust plant's `damping` b, in 1/s) and dividing by m l^2:
    theta'' = -(g/l) sin(theta) - (a/l) cos(theta) - b theta',   x'' = a.
Hand: without lag (tau = 0) a = u, the command; with lag tau > 0 the actual
acceleration is a fifth state with a' = (u - a)/tau, continuous across samples.
The command u is held over [k dt, (k+1) dt) (zero-order hold), and each sample
is integrated by its own solve_ivp call, so the integrator never steps across
the discontinuity in u.

Cases (PlantParams::human(), ::robot() and, because robot() has no lag,
robot() with lag = 0.05 s): from hanging at rest and from a large nonzero
state, under one deterministic command sequence (a sum of cosines, N samples,
|u| <= 12 m/s^2 < u_limit = 15, so no clipping).

CSV layout: '#' comment lines (source, versions, parameters as `# param name =
value`), then a header line `case,k,t,u,theta,theta_dot,x,x_dot,a`; row k holds
the state at t = k dt and the command u applied over the following sample (the
last row of a case has u = nan, unused). Without lag, a is the command last
applied (0 in row 0), as `PlantState::a` is. Floats by repr, so they round-trip.
"""
import math
import pathlib
import platform
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1]))
from _venv import ROOT, ensure_venv  # noqa: E402

if __name__ == "__main__":
    ensure_venv(__file__)

import numpy as np  # noqa: E402
import scipy  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

DT = 1.0 / 60.0
N = 120  # samples, 2 s
RTOL = ATOL = 1e-12

# the Rust constructors' values (swingup/src/plant/mod.rs); the Rust test checks
# them against PlantParams::human() / robot() so a change there shows up here
HUMAN = {"gravity": 9.81, "length": 0.5, "damping": 0.05, "lag": 0.0, "dt": DT}
ROBOT = {**HUMAN, "length": 0.6, "damping": 0.2}
ROBOT_LAG = {**ROBOT, "lag": 0.05}

# (name, theta, theta_dot, x, x_dot, a); a matters only with lag
STARTS = [
    ("hanging", [0.0, 0.0, 0.0, 0.0], 0.0),
    ("moving", [2.5, -1.5, 0.1, -0.3], 1.5),
]


def controls():
    """u_k = sum_i A_i cos(2 pi f_i t_k + phi_i): near the pendulums' natural
    frequencies (0.64-0.70 Hz) to swing them far, plus faster terms."""
    t = np.arange(N) * DT
    terms = [(6.0, 0.68, 0.0), (3.5, 1.9, 1.1), (2.0, 3.7, -0.4)]
    u = sum(a * np.cos(2.0 * np.pi * f * t + phi) for a, f, phi in terms)
    return [float(v) for v in u]


def rhs(p, u):
    g, l, b, tau = p["gravity"], p["length"], p["damping"], p["lag"]

    def f(_t, z):
        theta, omega, _x, v = z[:4]
        a = z[4] if tau > 0.0 else u
        dz = [omega, -(g / l) * math.sin(theta) - (a / l) * math.cos(theta) - b * omega, v, a]
        if tau > 0.0:
            dz.append((u - z[4]) / tau)
        return dz

    return f


def simulate(p, s0, a0, us):
    lag = p["lag"] > 0.0
    z = list(s0) + ([a0] if lag else [])
    rows = [(z[:4], a0 if lag else 0.0)]
    for u in us:
        sol = solve_ivp(rhs(p, u), (0.0, p["dt"]), z, method="DOP853", rtol=RTOL, atol=ATOL)
        if not sol.success:
            sys.exit(f"solve_ivp failed: {sol.message}")
        z = [float(v) for v in sol.y[:, -1]]
        rows.append((z[:4], z[4] if lag else u))
    return rows


def rk4(p, s0, a0, us, substeps=10):
    """A plain RK4 at the Rust plant's sub-step, only to print its truncation
    error against DOP853 (the figure the Rust test's tolerance rests on)."""
    lag = p["lag"] > 0.0
    z = np.array(list(s0) + ([a0] if lag else []))
    out = [z[:4].copy()]
    h = p["dt"] / substeps
    for u in us:
        f = rhs(p, u)
        for _ in range(substeps):
            k1 = np.array(f(0, z))
            k2 = np.array(f(0, z + h / 2 * k1))
            k3 = np.array(f(0, z + h / 2 * k2))
            k4 = np.array(f(0, z + h * k3))
            z = z + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out.append(z[:4].copy())
    return np.array(out)


def write(path, name, p, us):
    lines = [
        f"# swingup::plant golden trajectories, case '{name}'",
        f"# source: scripts/golden/plant_golden.py, scipy {scipy.__version__} solve_ivp "
        f"(DOP853, rtol={RTOL!r}, atol={ATOL!r}), numpy {np.__version__}, Python {platform.python_version()}",
        "# theta'' = -(g/l) sin(theta) - (a/l) cos(theta) - b theta', x'' = a; a = u (lag 0) or a' = (u - a)/lag",
        "# row k: state at t = k dt and command u over [t, t + dt) (nan in each case's last row)",
    ]
    lines += [f"# param {k} = {v!r}" for k, v in p.items()]
    lines.append("case,k,t,u,theta,theta_dot,x,x_dot,a")
    for start, s0, a0 in STARTS:
        rows = simulate(p, s0, a0, us)
        err = np.abs(rk4(p, s0, a0, us) - np.array([s for s, _ in rows])).max(axis=0)
        span = np.ptp(np.array([s for s, _ in rows]), axis=0)
        print(f"{name:9} {start:8} max |RK4(h = dt/10) - DOP853| per state {err}, ranges {span}")
        for k, (s, a) in enumerate(rows):
            u = us[k] if k < len(us) else float("nan")
            lines.append(",".join([start, str(k), repr(k * p["dt"]), repr(u), *map(repr, s), repr(a)]))
    path.write_text("\n".join(lines) + "\n")
    print(f"wrote {path}")


def main():
    out = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "swingup" / "tests" / "data"
    out.mkdir(parents=True, exist_ok=True)
    us = controls()
    assert max(map(abs, us)) <= 12.0
    for name, p in [("human", HUMAN), ("robot", ROBOT), ("robot_lag", ROBOT_LAG)]:
        write(out / f"plant_{name}.csv", name, p, us)


if __name__ == "__main__":
    main()
