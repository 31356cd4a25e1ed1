//! `swingup::plant` against golden trajectories from an outside integrator.
//!
//! `tests/data/plant_{human,robot,robot_lag}.csv` come from
//! `scripts/golden/plant_golden.py`: the pendulum-on-a-hand ODE derived there
//! from its Lagrangian, integrated by scipy's `solve_ivp` (DOP853,
//! rtol = atol = 1e-12) one 1/60 s sample at a time with the command held
//! (zero-order hold), for `PlantParams::human()`, `::robot()` and `::robot()`
//! with a 0.05 s hand lag, each from hanging at rest and from a large nonzero
//! state, over 120 samples of a sum-of-cosines command within the actuator
//! limit. The plant is stepped from each case's first row under the same
//! commands and every later row is compared.
//!
//! Tolerances. The golden values are exact for this purpose (DOP853 at 1e-12
//! agrees with itself at 1e-13 to 4e-14). What remains is the plant's RK4
//! truncation error at its sub-step $h = \Delta t / 10 = 1/600$ s, $O(h^4)$
//! globally; a plain numpy RK4 at that $h$ (printed by the script) differs
//! from DOP853 by at most:
//! - without lag: 4e-10 (in $\dot\theta$, whose range is 15 rad/s; the
//!   pendulum goes over the top), hence [`TOL_NO_LAG`] = 1e-9 on every state;
//! - with lag: the lag mode $\dot a = (u - a)/\tau$ has $h/\tau = 1/30$, and
//!   RK4's error on it per sample is $10\,(h/\tau)^5/120\,|u - a| \approx
//!   3.4\cdot10^{-9}\,|u - a|$; the first sample has $|u - a| = 9.4$ m/s², so
//!   $a$ is off by 3.3e-8 and the states it drives by up to 3.1e-9
//!   ($\dot\theta$), hence [`TOL_LAG_STATE`] = 1e-8 on
//!   $(\theta, \dot\theta, x, \dot x)$ and [`TOL_LAG_ACCEL`] = 1e-7 on $a$.
//!
//! A wrong model does not hide under these: flipping the sign of the hand
//! coupling or dropping the damping moves the trajectories by 1e-2 or more
//! (checked below). And the residual is truncation error, not a small model
//! difference: with 40 sub-steps it falls by more than 100 (RK4: 256).

use std::collections::BTreeMap;
use std::fs;
use std::path::PathBuf;

use swingup::plant::{Plant, PlantParams, PlantState};

/// Absolute tolerance on every state without hand lag.
const TOL_NO_LAG: f64 = 1e-9;
/// Absolute tolerance on $(\theta, \dot\theta, x, \dot x)$ with hand lag.
const TOL_LAG_STATE: f64 = 1e-8;
/// Absolute tolerance on the hand acceleration $a$ with hand lag.
const TOL_LAG_ACCEL: f64 = 1e-7;

/// One row: the command over the next sample (NaN in the last row) and the
/// state $(\theta, \dot\theta, x, \dot x, a)$ at the sample time.
#[derive(Debug, Clone, Copy)]
struct Row {
    u: f64,
    z: [f64; 5],
}

/// A golden file: its parameters (`# param name = value`) and its cases.
#[derive(Debug)]
struct Golden {
    params: BTreeMap<String, f64>,
    cases: BTreeMap<String, Vec<Row>>,
}

fn load(name: &str) -> Golden {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name);
    let text = fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut golden = Golden {
        params: BTreeMap::new(),
        cases: BTreeMap::new(),
    };
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let header = loop {
        let line = lines.next().expect("a header line");
        match line.strip_prefix('#') {
            Some(comment) => {
                if let Some((key, value)) = comment.trim().strip_prefix("param ").and_then(|p| p.split_once('=')) {
                    let value = value.trim().parse().expect("a numeric parameter");
                    golden.params.insert(key.trim().to_string(), value);
                }
            }
            None => break line,
        }
    };
    assert_eq!(header, "case,k,t,u,theta,theta_dot,x,x_dot,a", "{name}: header");
    for line in lines {
        let fields: Vec<&str> = line.split(',').collect();
        assert_eq!(fields.len(), 9, "{name}: {line}");
        let num = |i: usize| -> f64 { fields[i].parse().unwrap_or_else(|e| panic!("{name}: {line}: {e}")) };
        let rows = golden.cases.entry(fields[0].to_string()).or_default();
        let k: usize = fields[1].parse().expect("a sample index");
        assert_eq!(k, rows.len(), "{name}: rows out of order at {line}");
        rows.push(Row {
            u: num(3),
            z: [num(4), num(5), num(6), num(7), num(8)],
        });
    }
    golden
}

/// Checks that the file was made with these parameters (else regenerate it).
fn check_params(name: &str, golden: &Golden, params: &PlantParams) {
    let expected = [
        ("gravity", params.gravity),
        ("length", params.length),
        ("damping", params.damping),
        ("lag", params.lag),
        ("dt", params.dt),
    ];
    assert_eq!(golden.params.len(), expected.len(), "{name}: {:?}", golden.params);
    for (key, value) in expected {
        assert_eq!(
            golden.params.get(key),
            Some(&value),
            "{name}: parameter {key} differs from the Rust plant's; rerun scripts/golden/plant_golden.py"
        );
    }
}

/// Steps `plant` from `rows[0]` under the recorded commands; `mirror` runs it
/// on the negated commands from the mirrored start $(\theta, \dot\theta, -x,
/// -\dot x, -a)$ and mirrors the result back, which is exactly the plant with
/// the hand coupling's sign flipped. Returns the largest deviation from the
/// golden rows in $(\theta, \dot\theta, x, \dot x)$ and in $a$.
fn max_deviation(plant: &Plant, rows: &[Row], mirror: bool) -> (f64, f64) {
    let m = if mirror { -1.0 } else { 1.0 };
    let z0 = rows[0].z;
    let mut state = PlantState {
        s: [z0[0], z0[1], m * z0[2], m * z0[3]],
        a: m * z0[4],
    };
    let (mut dev_state, mut dev_accel) = (0.0f64, 0.0f64);
    for pair in rows.windows(2) {
        state = plant.step(&state, m * pair[0].u);
        let got = [state.s[0], state.s[1], m * state.s[2], m * state.s[3], m * state.a];
        for (i, (g, w)) in got.iter().zip(pair[1].z).enumerate() {
            let d = (g - w).abs();
            // a NaN deviation must fail, so do not let f64::max drop it
            let d = if d.is_nan() { f64::INFINITY } else { d };
            if i < 4 {
                dev_state = dev_state.max(d);
            } else {
                dev_accel = dev_accel.max(d);
            }
        }
    }
    (dev_state, dev_accel)
}

fn cases() -> [(&'static str, PlantParams, f64, f64); 3] {
    [
        ("plant_human.csv", PlantParams::human(), TOL_NO_LAG, TOL_NO_LAG),
        ("plant_robot.csv", PlantParams::robot(), TOL_NO_LAG, TOL_NO_LAG),
        (
            "plant_robot_lag.csv",
            PlantParams {
                lag: 0.05,
                ..PlantParams::robot()
            },
            TOL_LAG_STATE,
            TOL_LAG_ACCEL,
        ),
    ]
}

#[test]
fn plant_follows_the_scipy_trajectories() {
    for (name, params, tol_state, tol_accel) in cases() {
        let golden = load(name);
        check_params(name, &golden, &params);
        assert_eq!(golden.cases.len(), 2, "{name}: cases");
        for (case, rows) in &golden.cases {
            assert_eq!(rows.len(), 121, "{name} {case}: rows");
            assert!(
                rows[..rows.len() - 1].iter().all(|r| r.u.abs() < params.u_limit),
                "{name} {case}: commands must stay inside the actuator limit (no clipping)"
            );
            let (dev_state, dev_accel) = max_deviation(&Plant::new(params), rows, false);
            println!("{name} {case}: max deviation {dev_state:.2e} (state), {dev_accel:.2e} (a)");
            assert!(
                dev_state <= tol_state,
                "{name} {case}: state off by {dev_state:e} > {tol_state:e}"
            );
            assert!(
                dev_accel <= tol_accel,
                "{name} {case}: a off by {dev_accel:e} > {tol_accel:e}"
            );
        }
    }
}

#[test]
fn residual_is_rk4_truncation_error() {
    // four times the sub-steps: RK4's error falls by 4^4 = 256; a model
    // difference would not fall at all
    for (name, params, tol_state, tol_accel) in cases() {
        let golden = load(name);
        let fine = Plant::new(PlantParams { substeps: 40, ..params });
        for (case, rows) in &golden.cases {
            let (dev_state, dev_accel) = max_deviation(&fine, rows, false);
            assert!(
                dev_state <= tol_state / 100.0,
                "{name} {case}: state off by {dev_state:e} with 40 sub-steps"
            );
            assert!(
                dev_accel <= tol_accel / 100.0,
                "{name} {case}: a off by {dev_accel:e} with 40 sub-steps"
            );
        }
    }
}

#[test]
fn golden_data_catch_wrong_coupling_sign_and_damping() {
    for (name, params, tol_state, _) in cases() {
        let golden = load(name);
        for (case, rows) in &golden.cases {
            let (flipped, _) = max_deviation(&Plant::new(params), rows, true);
            let undamped = Plant::new(PlantParams { damping: 0.0, ..params });
            let (no_damping, _) = max_deviation(&undamped, rows, false);
            println!("{name} {case}: coupling sign flipped {flipped:.2e}, no damping {no_damping:.2e}");
            assert!(
                flipped > 1e6 * tol_state,
                "{name} {case}: a flipped coupling moves it by only {flipped:e}"
            );
            assert!(
                no_damping > 1e5 * tol_state,
                "{name} {case}: dropping damping moves it by only {no_damping:e}"
            );
        }
    }
}
