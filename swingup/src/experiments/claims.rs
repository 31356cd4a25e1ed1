//! The claims table (C1-C8 of the project's design): each claim of the
//! paper, what the grid's runs say of it, and whether it was reproduced.

use super::*;

fn rate(v: Option<&VariantSummary>) -> Option<f64> {
    v.filter(|v| v.runs > 0).map(|v| v.successes as f64 / v.runs as f64)
}

/// A variant's outcome in words: successes over runs and the median trial.
pub fn describe(v: Option<&VariantSummary>) -> String {
    match v {
        Some(v) => format!(
            "{}/{} succeeded{}",
            v.successes,
            v.runs,
            v.median_trials.map_or(String::new(), |m| format!(", median trial {m}"))
        ),
        None => "not run".into(),
    }
}

/// Relative tolerance within which a derivative-free plan's criterion
/// counts as Gauss-Newton's on the same problem.
pub const SAME_OPTIMUM: f64 = 1e-3;

/// How a derivative-free variant's plans compare with Gauss-Newton's on the
/// same problems: (plans, converged by the solver's own test, converged
/// and within [`SAME_OPTIMUM`] of Gauss-Newton's criterion or below it,
/// plans compared).
pub fn plan_agreement(runs: &[RunSummary], experiment: &str, variant: &str) -> (usize, usize, usize, usize) {
    let (mut plans, mut converged, mut same, mut compared) = (0, 0, 0, 0);
    for r in runs
        .iter()
        .filter(|r| r.experiment == experiment && r.variant == variant)
    {
        for (k, status) in r.plan_statuses.iter().enumerate() {
            plans += 1;
            let ok = status.is_converged();
            converged += usize::from(ok);
            if let (Some(&cost), Some(Some(gn))) = (r.plan_costs.get(k), r.plan_gauss_newton_costs.get(k)) {
                compared += 1;
                same += usize::from(ok && cost <= gn * (1.0 + SAME_OPTIMUM));
            }
        }
    }
    (plans, converged, same, compared)
}

/// [`plan_agreement`] in words.
fn describe_plans(runs: &[RunSummary], variant: &str) -> String {
    let (plans, converged, same, compared) = plan_agreement(runs, "learning", variant);
    if plans == 0 {
        return String::new();
    }
    let mut text = format!(" ({converged}/{plans} plans converged");
    if compared > 0 {
        text += &format!(
            ", {same}/{compared} converged at most {SAME_OPTIMUM:e} above Gauss-Newton's criterion on the same problem (or below it)"
        );
    }
    text + ")"
}

pub(super) fn claims(
    which: &[Experiment],
    s: &ExperimentSettings,
    runs: &[RunSummary],
    variants: &[VariantSummary],
) -> Vec<Claim> {
    let find = |e: &str, v: &str| variants.iter().find(|x| x.experiment == e && x.variant == v);
    let claim = |id: &str, paper: &str, ours: String, reproduced: &str| Claim {
        id: id.into(),
        paper: paper.into(),
        ours,
        reproduced: reproduced.into(),
    };
    let model = match s.model {
        ModelKind::Lwr => "LWR",
        ModelKind::Parametric => "parametric",
        ModelKind::LwrParametric => "LWR on the parametric model",
        ModelKind::True => "true",
    };
    let mut out = Vec::new();

    // C1: every run's first trial is the imitation
    let firsts: Vec<f64> = runs
        .iter()
        .filter(|r| imitates(r))
        .filter_map(|r| r.max_angles.first().copied())
        .collect();
    if firsts.is_empty() {
        out.push(claim(
            "C1",
            "imitating the demonstration fails: the pendulum does not get halfway up",
            "not run".into(),
            "not run",
        ));
    } else {
        let top = firsts.iter().copied().fold(0.0, f64::max).to_degrees();
        let below = firsts.iter().all(|&a| a < std::f64::consts::FRAC_PI_2);
        out.push(claim(
            "C1",
            "imitating the demonstration fails: the pendulum does not get halfway up",
            format!(
                "imitation peaks at {top:.0} deg at most over {} runs (the noise differs by seed, the commands do not)",
                firsts.len()
            ),
            if below { "yes" } else { "no" },
        ));
    }

    if which.contains(&Experiment::Learning) {
        let gn = find("learning", super::MAIN_VARIANT);
        let r = rate(gn).unwrap_or(0.0);
        out.push(claim(
            "C2",
            "learning with LWR and the Eq. 3 planner succeeds within a few trials (trial 3)",
            format!(
                "{model} + Eq. 3 (Gauss-Newton, B-splines): {}; wavelets: {}; Powell: {}{}; derivative-free least squares: {}{} (cap {} trials)",
                describe(gn),
                describe(find("learning", "gauss-newton/wavelet")),
                describe(find("learning", "powell/bspline")),
                describe_plans(runs, "powell/bspline"),
                describe(find("learning", super::DERIVATIVE_FREE_VARIANT)),
                describe_plans(runs, super::DERIVATIVE_FREE_VARIANT),
                s.max_trials
            ),
            if r >= 0.8 && gn.and_then(|v| v.median_trials).is_some_and(|m| m <= 5.0) {
                "yes"
            } else if r > 0.0 {
                "partly"
            } else {
                "no"
            },
        ));
        // C7: tuned scale of x and x_dot relative to theta's, over all planned trials
        let scales: Vec<&Vec<f64>> = runs
            .iter()
            .filter(|r| r.experiment == "learning" && r.variant == super::MAIN_VARIANT)
            .flat_map(|r| r.scales.iter())
            .filter(|v| v.len() == 5)
            .collect();
        if scales.is_empty() {
            out.push(claim(
                "C7",
                "cross-validation finds hand position and velocity irrelevant",
                "no tuned model".into(),
                "not run",
            ));
        } else {
            let mean = |j: usize| scales.iter().map(|v| v[j]).sum::<f64>() / scales.len() as f64;
            let zero = |j: usize| scales.iter().filter(|v| v[j] == 0.0).count();
            let m: Vec<f64> = (0..5).map(mean).collect();
            let irrelevant = m[2] < 0.25 * m[0] && m[3] < 0.25 * m[0];
            out.push(claim(
                "C7",
                "cross-validation finds hand position and velocity irrelevant to the next angular velocity",
                format!(
                    "mean tuned scale (theta, theta_dot, x, x_dot, u) = ({:.2}, {:.2}, {:.2}, {:.2}, {:.2}); scale 0 in {} / {} / {} / {} / {} of {} models",
                    m[0], m[1], m[2], m[3], m[4], zero(0), zero(1), zero(2), zero(3), zero(4), scales.len()
                ),
                if irrelevant { "yes" } else { "partly" },
            ));
        }
        // C8
        let rolls: Vec<&Rollout> = runs.iter().flat_map(|r| r.rollouts.iter()).collect();
        let mut parts = Vec::new();
        let mut early_blowups = 0.0;
        for after in 1..=3 {
            let mine: Vec<&&Rollout> = rolls.iter().filter(|r| r.after_trial == after).collect();
            if mine.is_empty() {
                continue;
            }
            let left = mine.iter().filter(|r| r.left_data_at.is_some()).count();
            let blew = mine.iter().filter(|r| r.blew_up_at.is_some()).count();
            let mut at: Vec<f64> = mine.iter().filter_map(|r| r.left_data_at).map(|k| k as f64).collect();
            if after == 1 {
                early_blowups = (left + blew) as f64 / mine.len() as f64;
            }
            parts.push(format!(
                "after trial {after}: left the data in {left}/{} (median sample {}), blew up in {blew}",
                mine.len(),
                median(&mut at).map_or("-".into(), |m| format!("{m:.0}"))
            ));
        }
        out.push(claim(
            "C8",
            "integrating an early learned model forward blows up",
            if parts.is_empty() {
                "no rollouts".into()
            } else {
                parts.join("; ")
            },
            if parts.is_empty() {
                "not run"
            } else if early_blowups >= 0.5 {
                "yes"
            } else if early_blowups > 0.0 {
                "partly"
            } else {
                "no"
            },
        ));
    }

    if which.contains(&Experiment::Lambda) {
        let rates: Vec<(f64, Option<f64>, String)> = s
            .lambdas
            .iter()
            .map(|&l| {
                let v = find("lambda", &format!("lambda={l:e}"));
                (l, rate(v), describe(v))
            })
            .collect();
        let table = rates
            .iter()
            .map(|(l, _, d)| format!("{l:e}: {d}"))
            .collect::<Vec<_>>()
            .join("; ");
        let best = rates.iter().filter_map(|r| r.1).fold(0.0, f64::max);
        let mid: Vec<f64> = rates
            .iter()
            .filter(|r| (1e2..=1e5).contains(&r.0))
            .filter_map(|r| r.1)
            .collect();
        let zero = rates.iter().find(|r| r.0 == 0.0).and_then(|r| r.1);
        let top = rates
            .iter()
            .filter(|r| r.0 > 1e5)
            .filter_map(|r| r.1)
            .fold(None, |a: Option<f64>, r| Some(a.map_or(r, |a| a.min(r))));
        out.push(claim(
            "C3",
            "lambda from 100 to 100000 all work; the exact value matters little",
            format!("{model}: {table}"),
            if best > 0.0 && !mid.is_empty() && mid.iter().all(|&r| r >= 0.5 * best) {
                "yes"
            } else if mid.iter().any(|&r| r > 0.0) {
                "partly"
            } else {
                "no"
            },
        ));
        out.push(claim(
            "C4",
            "lambda = 0 fails: the learned model cannot affect the plan",
            format!("lambda = 0: {}", describe(find("lambda", &format!("lambda={:e}", 0.0)))),
            match zero {
                Some(0.0) => "yes",
                Some(_) => "no",
                None => "not run",
            },
        ));
        out.push(claim(
            "C5",
            "too large a lambda fails: the model is enforced too strongly",
            format!(
                "lowest success rate above 1e5: {}",
                top.map_or("not run".into(), |r| format!("{:.0}%", 100.0 * r))
            ),
            match top {
                Some(r) if r < 0.5 * best => "yes",
                Some(r) if r < best => "partly",
                Some(_) => "no",
                None => "not run",
            },
        ));
    }

    if which.contains(&Experiment::Planners) {
        let d = |v: &str| describe(find("planners", v));
        let ddp_lwr = rate(find("planners", "ddp/lwr"));
        let eq3_lwr = rate(find("planners", "eq3/lwr"));
        let both_param = rate(find("planners", "ddp/parametric")).is_some_and(|r| r > 0.5)
            && rate(find("planners", "eq3/parametric")).is_some_and(|r| r > 0.5);
        let modes: Vec<String> = runs
            .iter()
            .filter(|r| r.experiment == "planners" && r.variant == "ddp/lwr")
            .flat_map(|r| r.failures.iter())
            .filter_map(|f| f.split("[ddp: ").nth(1).map(|m| m.trim_end_matches(']').to_string()))
            .collect();
        let mut counts: Vec<(String, usize)> = Vec::new();
        for m in modes {
            match counts.iter_mut().find(|c| c.0 == m) {
                Some(c) => c.1 += 1,
                None => counts.push((m, 1)),
            }
        }
        let modes = counts
            .iter()
            .map(|(m, n)| format!("{m} x{n}"))
            .collect::<Vec<_>>()
            .join(", ");
        out.push(claim(
            "C6",
            "DDP fails with the learned nonparametric model; both planners work with a learned parametric model",
            format!(
                "DDP: LWR {}, parametric {}, true {}; Eq. 3: LWR {}, parametric {}, true {}; DDP statuses with LWR: {modes}",
                d("ddp/lwr"),
                d("ddp/parametric"),
                d("ddp/true"),
                d("eq3/lwr"),
                d("eq3/parametric"),
                d("eq3/true")
            ),
            match (ddp_lwr, eq3_lwr) {
                (Some(a), Some(b)) if a < b && both_param => "yes",
                (Some(_), Some(_)) if both_param => "partly",
                (Some(_), Some(_)) => "no",
                _ => "not run",
            },
        ));
    }
    out
}

/// The pairs of variants that differ only in the demonstration: (model,
/// with it, without it), where both ran.
pub fn demonstration_worth(variants: &[VariantSummary]) -> Vec<(&'static str, &VariantSummary, &VariantSummary)> {
    let find = |e: &str, v: &str| variants.iter().find(|x| x.experiment == e && x.variant == v);
    [
        ("lwr", "learning", "gauss-newton/bspline"),
        ("lwr-parametric", "beyond", "lwr-parametric"),
        ("true", "planners", "eq3/true"),
    ]
    .into_iter()
    .filter_map(|(model, e, v)| Some((model, find(e, v)?, find("beyond", &format!("{SCRATCH_PREFIX}{model}"))?)))
    .collect()
}
