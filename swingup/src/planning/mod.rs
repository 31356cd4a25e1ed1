//! Planning: the swing-up's task cost, the penalty on leaving the data,
//! and the planners (Eq. 3 by Gauss-Newton or Powell, and DDP).

pub mod cost;
pub mod ddp;
pub mod eq3;
pub mod mpc;
pub mod support;

use std::sync::Arc;

use crate::config::{Config, Solver};
use crate::models::{KnownHand, PendulumRegression};
use crate::planning::support::DataSupport;
use crate::plant::demo::Demonstration;
use crate::record::PlanSummary;

/// Plans with the configured planner, and with
/// [`Config::feedback`] the time-varying LQR gains along the plan (from
/// the same model). `previous`, the last trial's plan, is the warm start of
/// the Eq. 3 planners with
/// [`PlannerConfig::warm_start`](crate::config::PlannerConfig::warm_start).
pub fn plan_and_gains<G: PendulumRegression>(
    cfg: &Config,
    demo: &Demonstration,
    model: &KnownHand<G>,
    support: Option<Arc<DataSupport>>,
    previous: Option<&PlanSummary>,
) -> crate::Result<(PlanSummary, Option<Vec<[f64; 4]>>)> {
    let plan = plan_with(cfg, demo, model, support, previous)?;
    let gains = match cfg.feedback {
        [q0, q1, q2, q3, r]
            if [q0, q1, q2, q3].iter().any(|&q| q > 0.0) && plan.states.len() == plan.controls.len() + 1 =>
        {
            crate::plant::lqr::tracking_gains(model, &plan.states, &plan.controls, [q0, q1, q2, q3], r)
        }
        _ => None,
    };
    Ok((plan, gains))
}

/// Plans with the configured planner ([`PlannerConfig::solver`](crate::config::PlannerConfig::solver)); the
/// Eq. 3 planners with the penalty on leaving `support` (DDP without),
/// warm-started from `previous` when
/// [`PlannerConfig::warm_start`](crate::config::PlannerConfig::warm_start)
/// is on and it spans the demonstration's horizon.
pub fn plan_with<G: PendulumRegression>(
    cfg: &Config,
    demo: &Demonstration,
    model: &KnownHand<G>,
    support: Option<Arc<DataSupport>>,
    previous: Option<&PlanSummary>,
) -> crate::Result<PlanSummary> {
    let n = demo.horizon();
    let warm = previous.filter(|p| cfg.planner.warm_start && p.states.len() == n + 1 && p.controls.len() == n);
    // DDP plans the model as a hard constraint; every other solver plans
    // Eq. 3 (a solver added to the Eq. 3 planner needs no arm here)
    match cfg.planner.solver {
        Solver::Ddp => ddp::plan_ddp(cfg, demo, model),
        _ => eq3::plan_from(cfg, demo, model, support, warm),
    }
}
