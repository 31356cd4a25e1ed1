//! Cross-check with Crocoddyl's SolverDDP on the pendulum swing-up (golden
//! data from `scripts/golden/crocoddyl_golden.py`).

use ddp::problems::pendulum_swingup;
use ddp::{Ddp, DdpMethod, DdpSettings, DdpStatus};

fn golden() -> serde_json::Value {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/crocoddyl_pendulum.json");
    let text = std::fs::read_to_string(path).expect("golden file");
    serde_json::from_str(&text).expect("json")
}

#[test]
fn pendulum_swingup_matches_crocoddyl() {
    let g = golden();
    let horizon = g["horizon"].as_u64().expect("horizon") as usize;
    let croc_cost = g["cost"].as_f64().expect("cost");
    let croc_controls: Vec<Vec<f64>> = g["controls"]
        .as_array()
        .expect("controls")
        .iter()
        .map(|u| vec![u.as_f64().expect("control")])
        .collect();
    assert_eq!(croc_controls.len(), horizon);
    let problem = pendulum_swingup(horizon).expect("problem");
    assert_eq!(g["dt"].as_f64(), Some(ddp::problems::DT));

    // same problem: our cost of Crocoddyl's controls is Crocoddyl's cost
    let ours_of_theirs = problem.rollout_cost(&croc_controls).expect("rollout");
    assert!(
        (ours_of_theirs - croc_cost).abs() <= 1e-10 * croc_cost,
        "{ours_of_theirs} vs {croc_cost}"
    );

    for method in [DdpMethod::Ddp, DdpMethod::Ilqr] {
        let settings = DdpSettings {
            method,
            ..DdpSettings::default()
        };
        let r = Ddp::new(settings).expect("settings").solve(&problem).expect("solve");
        assert_eq!(r.status, DdpStatus::Converged);
        assert!(
            (r.cost - croc_cost).abs() <= 1e-6 * croc_cost,
            "{method:?}: {} vs Crocoddyl {croc_cost}",
            r.cost
        );
        let du = r
            .controls
            .iter()
            .zip(&croc_controls)
            .map(|(a, b)| (a[0] - b[0]).abs())
            .fold(0.0, f64::max);
        assert!(du < 1e-3, "max control difference {du}");
    }
}
