//! The trajectory set: the swing-ups of `trajopt::problems::trajectory`
//! (Eq. 3 form) with their twins of `ddp::problems` (DDP form), and the
//! learned-LWR swing-up plan of `swingup` (`pendulum-lwr`, saved in
//! `bench/data/pendulum-lwr.json`: [`crate::lwr_instance`]).
//!
//! **Figure of merit.** The Eq. 3 criterion penalises dynamic
//! inconsistency by $\lambda$ while DDP rolls out exactly, so neither
//! objective is fair to the other. Every run on a registry instance is
//! scored by [`rollout_cost`]: the controls of the solver's final point
//! rolled out from the start through the exact dynamics and scored by the
//! DDP form's task cost (stage + terminal), the cost a controller that
//! replays them open loop would pay. Eq. 3's own criterion and DDP's cost
//! go into the record's `objective`. The learned-LWR instance has no exact
//! dynamics to roll out through: it is scored by its Eq. 3 criterion
//! itself, and only the solvers of the Eq. 3 form run on it.
//!
//! **Instances.** Each registry instance `"<system>-h<N>-lambda<λ>"`
//! ([`trajopt::problems::trajectory::standard_instances`]); the DDP
//! solvers run on its twin `"<system>-h<N>"`, which does not depend on
//! $\lambda$, so their runs on the two $\lambda$ of one horizon solve the
//! same problem (timed separately).

use std::sync::Arc;

use ddp::problems as ddp_problems;

use trajopt::problems::trajectory as eq3_problems;

use crate::error::{BenchError, Result};
pub use crate::instance::{DdpSwingUp, Forms, Instance, rollout_cost};
use crate::instance::{TRAJECTORY_SET, cost_at, finite};

/// The set's name in the records.
pub const SET: &str = TRAJECTORY_SET;

/// The name of the learned-LWR instance.
pub const LWR_INSTANCE: &str = "pendulum-lwr";

/// The figure of merit of a stored final point of `instance`: the
/// rollout cost of its controls ([`rollout_cost`] for a point of the Eq. 3
/// form, of length $n$; the DDP form's rollout for stacked controls, of
/// length $N m$), `f64::MAX` for a rollout that blows up; for the
/// learned-LWR instance (no exact dynamics) its Eq. 3 criterion. `None`
/// for a point of neither length.
pub fn figure_of_merit(instance: &Instance, x: &[f64]) -> Option<f64> {
    let Some(forms) = &instance.rollout else {
        return cost_at(instance, x).map(finite);
    };
    let m = forms.ddp.initial_controls().first().map_or(0, Vec::len);
    let f = if x.len() == instance.n() {
        rollout_cost(forms, x).ok()?
    } else if m > 0 && x.len() == forms.ddp.horizon() * m {
        let controls: Vec<Vec<f64>> = x.chunks_exact(m).map(<[f64]>::to_vec).collect();
        forms.ddp.rollout_cost(&controls).ok()?
    } else {
        return None;
    };
    Some(finite(f))
}

/// Replaces every trajectory record's `f0` by the figure of merit of its
/// instance's start and, where it stored its final `x`, its `f` by that
/// of `x` ([`figure_of_merit`]), computed here; returns what did not
/// agree to $10^{-9}$ (relative). Records of other sets, and of instances
/// not in `instances`, are left untouched.
pub fn recompute(records: &mut [crate::record::RunRecord], instances: &[Instance]) -> Vec<crate::minima::Discrepancy> {
    crate::minima::recompute_by(records, instances, |set| set == SET, figure_of_merit)
}

fn model_error(reason: String) -> BenchError {
    BenchError::InvalidSetting {
        name: "trajectory instance",
        reason,
    }
}

/// The names of the set's instances, in order: the registry's, then
/// [`LWR_INSTANCE`].
pub fn names() -> Vec<String> {
    let mut names: Vec<String> = eq3_problems::standard_instances().iter().map(|i| i.name()).collect();
    names.push(LWR_INSTANCE.into());
    names
}

/// The instances whose names contain `filter` (all when `None`), built
/// only for those (the learned-LWR one runs two learning trials first).
///
/// # Errors
/// A problem that cannot be built (the message names it).
pub fn instances(filter: Option<&str>) -> Result<Vec<Instance>> {
    let keep = |name: &str| filter.is_none_or(|f| name.contains(f));
    let mut out = Vec::new();
    for spec in eq3_problems::standard_instances() {
        let name = spec.name();
        if !keep(&name) {
            continue;
        }
        let fail = |e: String| model_error(format!("{name}: {e}"));
        let (eq3, start) = spec.problem().map_err(|e| fail(e.to_string()))?;
        let ddp = ddp_problems::by_name(&spec.ddp_name())
            .and_then(|i| i.problem())
            .map_err(|e| fail(e.to_string()))?;
        let eq3 = Arc::new(eq3);
        out.push(Instance {
            set: SET,
            residuals: trajopt::LeastSquaresProblem::n_residuals(eq3.as_ref()),
            problem: name,
            scale: 1.0,
            start,
            f_star: None,
            least_squares: eq3.clone(),
            rollout: Some(Arc::new(Forms { eq3, ddp })),
        });
    }
    if keep(LWR_INSTANCE) {
        out.push(lwr_instance()?);
    }
    Ok(out)
}

/// The Eq. 3 problem of the swing-up plan with the pure LWR model learned
/// from trials 1 and 2 of seed 1, from the planner's own start (the knot
/// points fitted to the demonstration), as saved in
/// `bench/data/pendulum-lwr.json` ([`crate::lwr_instance`]).
///
/// # Errors
/// A file that does not parse or defines no valid problem (the message
/// names what).
pub fn lwr_instance() -> Result<Instance> {
    let (problem, start) = crate::lwr_instance::shared_problem()?;
    Ok(Instance {
        set: SET,
        problem: LWR_INSTANCE.into(),
        scale: 1.0,
        residuals: trajopt::LeastSquaresProblem::n_residuals(problem.as_ref()),
        start,
        f_star: None,
        least_squares: problem,
        rollout: None,
    })
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use trajopt::problems::trajectory::{System, parameters_of};

    use super::*;

    /// The pendulum over 2 steps, both forms.
    fn tiny() -> Forms {
        let (eq3, _) = System::Pendulum.problem(2, 1.0).expect("eq3");
        let ddp = ddp_problems::System::Pendulum.problem(2).expect("ddp");
        Forms {
            eq3: Arc::new(eq3),
            ddp,
        }
    }

    #[test]
    fn the_rollout_cost_is_the_hand_computed_task_cost_of_the_controls() {
        let forms = tiny();
        let (u0, u1) = (3.0, -2.0);
        // states that are not the rollout's: they must not matter
        let states = vec![vec![0.3, -1.0], vec![1.0, 2.0], vec![-0.5, 4.0]];
        let theta = parameters_of(&forms.eq3, &states, &[vec![u0], vec![u1]]).expect("theta");
        // semi-implicit Euler from rest hanging down, dt = 0.01, g / l = 9.81
        let (dt, g) = (0.01, 9.81);
        let w1 = dt * u0;
        let t1 = dt * w1;
        let w2 = w1 + dt * (u1 - g * t1.sin());
        let t2 = t1 + dt * w2;
        let running = |t: f64, w: f64, u: f64| dt * (0.5 * (t - PI).powi(2) + 0.05 * w * w + 0.005 * u * u);
        let want = running(0.0, 0.0, u0) + running(t1, w1, u1) + 50.0 * (t2 - PI).powi(2) + 5.0 * w2 * w2;
        let got = rollout_cost(&forms, &theta).expect("rollout");
        assert!((got - want).abs() < 1e-12 * want, "{got} vs {want}");
        assert!(rollout_cost(&forms, &theta[1..]).is_err());
    }

    #[test]
    fn a_stored_point_is_scored_the_same_as_coefficients_or_as_controls() {
        let mut inst = instances(Some("pendulum-h50-lambda1e2")).expect("builds").remove(0);
        let forms = inst.rollout.clone().expect("forms");
        let controls: Vec<Vec<f64>> = (0..50).map(|k| vec![3.0 * (0.1 * k as f64).sin()]).collect();
        let states = vec![vec![0.0, 0.0]; 51];
        let theta = parameters_of(&forms.eq3, &states, &controls).expect("theta");
        let by_theta = figure_of_merit(&inst, &theta).expect("n entries");
        let by_controls = figure_of_merit(&inst, &controls.concat()).expect("N m entries");
        assert_eq!(by_theta, by_controls);
        assert_eq!(by_controls, forms.ddp.rollout_cost(&controls).expect("rollout"));
        assert_eq!(figure_of_merit(&inst, &[1.0; 7]), None);
        // a record whose f is not that of its x is corrected and reported
        let mut record = crate::record::tests::run("ddp-ilqr", &inst.problem, 1.0, 10);
        record.set = SET.into();
        record.x = Some(controls.concat());
        inst.scale = record.scale;
        let mut records = vec![record];
        let found = recompute(&mut records, std::slice::from_ref(&inst));
        assert_eq!(records[0].f, by_controls);
        assert_eq!(records[0].f0, figure_of_merit(&inst, &inst.start).expect("start"));
        assert_eq!(found.len(), 2, "{found:?}");
        assert!(found[1].what.starts_with("f 1e0 recorded"), "{found:?}");
    }

    #[test]
    fn the_registry_instances_come_with_both_forms() {
        let names = names();
        assert_eq!(names.len(), eq3_problems::standard_instances().len() + 1);
        assert_eq!(names.last().map(String::as_str), Some(LWR_INSTANCE));
        let picked = instances(Some("pendulum-h50-lambda1e2")).expect("builds");
        assert_eq!(picked.len(), 1);
        let inst = &picked[0];
        let forms = inst.rollout.as_ref().expect("forms");
        assert_eq!(forms.ddp.horizon(), 50);
        // the start has zero controls: its rollout cost is DDP's warm start cost
        let zero = forms.ddp.rollout_cost(&vec![vec![0.0]; 50]).expect("rollout");
        assert_eq!(rollout_cost(forms, &inst.start).expect("rollout"), zero);
    }
}
