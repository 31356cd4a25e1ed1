//! Which inputs the LWR sees, chosen by cross-validation over whole trials.
//!
//! Leave-one-out cross-validation, which tunes the LWR's metric, cannot
//! tell whether an input helps the model *generalise to the next trial*:
//! at 60 Hz a trajectory's neighbouring samples are near-duplicates, so a
//! sample left out is predicted from its neighbours in time, whatever
//! inputs the model uses. The planner, though, asks the model about the
//! next trial, which goes elsewhere; an input that varies from trial to
//! trial but does not drive the dynamics (the hand's position) then adds
//! a local slope that extrapolates wildly there.
//!
//! So the inputs are chosen by *grouped* cross-validation: every trial is
//! cut into `blocks` contiguous blocks, and each block is predicted by the
//! model (prior and LWR, both refitted) made from all the other blocks.
//! (Whole trials as the groups were tried first: a trial that spun the
//! pendulum over the top holds angles no other trial has, its error then
//! dominates, and the selection dropped the angle itself.) Backward
//! elimination starts from all five inputs and drops, one at a time, the
//! input whose removal gives the lowest grouped error, as long as that
//! error is no higher than with the input (ties drop it: the simpler model
//! wins). It uses the untuned metric (each input divided by its spread
//! times `ModelConfig::input_scales`); the LOO tuning of the chosen inputs'
//! metric follows.
//!
//! Nothing here knows the pendulum: it is the paper's remark that cross
//! validation finds the hand's position and velocity irrelevant (claim C7),
//! made with a criterion that measures what the planner needs.

use lwr::LwrSettings;

use crate::models::{LwrRegression, PendulumRegression};

/// A regression fitted to data on a subset of the inputs: the prior of the
/// LWR in [`grouped_cv`] (refitted for every group left out).
pub type FitPrior<'a> =
    dyn Fn(&[[f64; 5]], &[[f64; 1]], &[usize]) -> crate::Result<Box<dyn PendulumRegression + Send + Sync>> + 'a;

/// One step of the backward elimination: the inputs and their grouped
/// cross-validation error.
#[derive(Debug, Clone, PartialEq)]
pub struct SelectionStep {
    /// The inputs (indices into $(\theta, \dot\theta, x, \dot x, u)$).
    pub inputs: Vec<usize>,
    /// Grouped cross-validation error, normalised by the outputs' variance.
    pub cv_nmse: f64,
}

/// The group of each of the training points of trials with `lengths`
/// points each: every trial is cut into `blocks` contiguous blocks, and
/// each block of each trial is a group.
pub fn trial_groups(lengths: &[usize], blocks: usize) -> Vec<usize> {
    let mut groups = Vec::with_capacity(lengths.iter().sum());
    let mut first = 0;
    for &n in lengths {
        let b = blocks.clamp(1, n.max(1));
        groups.extend((0..n).map(|i| first + i * b / n));
        first += b;
    }
    groups
}

/// The normalised error of predicting each group's points by the model
/// (the prior from `fit_prior`, corrected by an LWR with `settings`, on the
/// inputs `inputs`) made from the other groups' points. Where the LWR has
/// no data the prior alone predicts (as in planning).
///
/// # Errors
/// [`Error::Data`](crate::Error::Data) when the points and groups differ
/// in number, fewer than two groups are given, or a fit fails.
pub fn grouped_cv(
    xs: &[[f64; 5]],
    ys: &[[f64; 1]],
    groups: &[usize],
    inputs: &[usize],
    settings: &LwrSettings,
    fit_prior: &FitPrior<'_>,
) -> crate::Result<f64> {
    crate::error::ensure_data!(
        xs.len() == ys.len() && xs.len() == groups.len(),
        "{} inputs, {} outputs and {} groups",
        xs.len(),
        ys.len(),
        groups.len()
    );
    let n_groups = groups.iter().max().map_or(0, |g| g + 1);
    crate::error::ensure_data!(n_groups >= 2, "grouped cross-validation needs two groups or more");
    let n = ys.len() as f64;
    let mean = ys.iter().map(|y| y[0]).sum::<f64>() / n;
    let variance = ys.iter().map(|y| (y[0] - mean).powi(2)).sum::<f64>() / n;
    let mut sse = 0.0;
    for g in 0..n_groups {
        let (mut train_x, mut train_y, mut test) = (Vec::new(), Vec::new(), Vec::new());
        for ((x, y), &gi) in xs.iter().zip(ys).zip(groups) {
            if gi == g {
                test.push((x, y[0]));
            } else {
                train_x.push(*x);
                train_y.push(*y);
            }
        }
        if test.is_empty() || train_x.is_empty() {
            continue;
        }
        let prior = fit_prior(&train_x, &train_y, inputs)?;
        let model = LwrRegression::fit_on(&train_x, &train_y, inputs, settings.clone(), prior, "prior")?;
        sse += test
            .iter()
            .map(|(x, y)| (y - model.delta_omega(x, None)).powi(2))
            .sum::<f64>();
    }
    Ok(if variance > 0.0 { sse / n / variance } else { f64::NAN })
}

/// `settings` (one scale per input of all five) restricted to `inputs`;
/// an input without a scale in `settings` gets 1.
pub fn restrict(settings: &LwrSettings, inputs: &[usize]) -> LwrSettings {
    LwrSettings {
        scales: inputs
            .iter()
            .map(|&j| settings.scales.get(j).copied().unwrap_or(1.0))
            .collect(),
        ..settings.clone()
    }
}

/// Backward elimination of inputs by [`grouped_cv`], from all five, with
/// the metric of `settings` (one scale per input of all five); see the
/// [module docs](self). Returns the steps taken, the chosen inputs last.
///
/// # Errors
/// As [`grouped_cv`].
pub fn select_inputs(
    xs: &[[f64; 5]],
    ys: &[[f64; 1]],
    groups: &[usize],
    settings: &LwrSettings,
    fit_prior: &FitPrior<'_>,
) -> crate::Result<Vec<SelectionStep>> {
    let score = |inputs: &[usize]| grouped_cv(xs, ys, groups, inputs, &restrict(settings, inputs), fit_prior);
    let mut current: Vec<usize> = (0..5).collect();
    let mut steps = vec![SelectionStep {
        cv_nmse: score(&current)?,
        inputs: current.clone(),
    }];
    while current.len() > 1 {
        let mut best: Option<SelectionStep> = None;
        for drop in 0..current.len() {
            let inputs: Vec<usize> = current
                .iter()
                .enumerate()
                .filter(|&(k, _)| k != drop)
                .map(|(_, &j)| j)
                .collect();
            let cv_nmse = score(&inputs)?;
            if best.as_ref().is_none_or(|b| cv_nmse < b.cv_nmse) {
                best = Some(SelectionStep { inputs, cv_nmse });
            }
        }
        let last = steps.last().map_or(f64::INFINITY, |s| s.cv_nmse);
        match best {
            // a NaN error never wins; ties drop the input
            Some(b) if b.cv_nmse <= last || last.is_nan() && b.cv_nmse.is_finite() => {
                current.clone_from(&b.inputs);
                steps.push(b);
            }
            _ => break,
        }
    }
    Ok(steps)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::LinearRegression;

    fn linear_prior(
        xs: &[[f64; 5]],
        ys: &[[f64; 1]],
        inputs: &[usize],
    ) -> crate::Result<Box<dyn PendulumRegression + Send + Sync>> {
        Ok(Box::new(LinearRegression::fit_inputs(xs, ys, inputs)?))
    }

    #[test]
    fn groups_are_trials_or_blocks() {
        assert_eq!(trial_groups(&[2, 3], 1), vec![0, 0, 1, 1, 1]);
        assert_eq!(trial_groups(&[4, 2], 2), vec![0, 0, 1, 1, 2, 3]);
        assert_eq!(trial_groups(&[1, 4], 2), vec![0, 1, 1, 2, 2]);
        assert_eq!(trial_groups(&[10], 5), vec![0, 0, 1, 1, 2, 2, 3, 3, 4, 4]);
        assert_eq!(trial_groups(&[3], 5), vec![0, 1, 2]);
        assert!(trial_groups(&[], 5).is_empty());
    }

    /// Three trajectories ("trials") of a target that depends on theta and
    /// u alone, with theta_dot, x and x_dot drawn at random (irrelevant
    /// inputs that only dilute the neighbourhoods). The elimination must
    /// drop the three and keep theta and u, its error never rising.
    #[test]
    fn drops_irrelevant_inputs_and_keeps_the_relevant_ones() {
        let mut seed = 11u64;
        let mut rand = move || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let (mut xs, mut ys, mut lengths) = (Vec::new(), Vec::new(), Vec::new());
        for trial in 0..3 {
            let n = 150;
            for k in 0..n {
                let t = k as f64 / n as f64;
                let theta = (6.0 * t + trial as f64).sin() * 2.0;
                let u = (9.0 * t + 0.7 * trial as f64).cos() * 3.0;
                xs.push([theta, rand(), rand(), rand(), u]);
                ys.push([theta.sin() + 0.2 * u * theta.cos()]);
            }
            lengths.push(n);
        }
        let groups = trial_groups(&lengths, 5);
        let settings = LwrSettings {
            kernel: lwr::Kernel::Tricube,
            bandwidth: 1.0,
            scales: vec![1.0 / 1.4, 1.7, 1.7, 1.7, 1.0 / 2.1],
            ..LwrSettings::default()
        };
        let steps = select_inputs(&xs, &ys, &groups, &settings, &linear_prior).expect("selection");
        assert_eq!(steps.last().expect("a step").inputs, vec![0, 4], "{steps:?}");
        assert!(steps.windows(2).all(|w| w[1].cv_nmse <= w[0].cv_nmse), "{steps:?}");
    }

    /// Along a smooth trajectory, leaving out single points (each its own
    /// group: leave-one-out) sees far less error than leaving out blocks,
    /// since a point's neighbours in time stand in for it: the reason the
    /// selection groups by blocks.
    #[test]
    fn blocks_see_more_error_than_single_points_along_a_trajectory() {
        let n = 300;
        let (xs, ys): (Vec<[f64; 5]>, Vec<[f64; 1]>) = (0..n)
            .map(|k| {
                let t = k as f64 / n as f64;
                let theta = (7.0 * t).sin() * 2.5;
                let u = (11.0 * t).cos() * 3.0;
                let x = 0.5 * (3.0 * t).sin();
                ([theta, 0.0, x, 0.0, u], [theta.sin() + 0.2 * u * theta.cos()])
            })
            .unzip();
        let settings = LwrSettings {
            kernel: lwr::Kernel::Tricube,
            bandwidth: 0.6,
            scales: vec![0.6, 1.0, 2.0, 1.0, 0.5],
            ..LwrSettings::default()
        };
        let inputs = [0, 2, 4];
        let s = restrict(&settings, &inputs);
        let single: Vec<usize> = (0..n).collect();
        let loo = grouped_cv(&xs, &ys, &single, &inputs, &s, &linear_prior).expect("loo");
        let blocked = grouped_cv(&xs, &ys, &trial_groups(&[n], 5), &inputs, &s, &linear_prior).expect("blocks");
        assert!(blocked > 10.0 * loo, "blocks {blocked} vs single points {loo}");
    }

    #[test]
    fn mismatched_groups_are_an_error() {
        let xs = vec![[0.0; 5]; 4];
        let ys = vec![[0.0]; 4];
        let settings = LwrSettings::default();
        let err = grouped_cv(&xs, &ys, &[0, 1], &[0], &settings, &linear_prior).expect_err("lengths");
        assert!(err.to_string().contains("4 inputs, 4 outputs and 2 groups"), "{err}");
        let err = grouped_cv(&xs, &ys, &[0; 4], &[0], &settings, &linear_prior).expect_err("one group");
        assert!(err.to_string().contains("two groups"), "{err}");
    }
}
