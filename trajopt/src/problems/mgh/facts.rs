//! What the paper says about each function besides its formula: the sizes
//! it allows, the standard sizes used here, the starting points, and the
//! minima it lists.

use super::{KnownMinimum, MghFunction};
use crate::error::{Result, TrajoptError};

use MghFunction as F;

/// The standard $(n, m)$ (see the module docs for the choices).
pub(super) fn standard_size(f: MghFunction) -> (usize, usize) {
    match f {
        F::Rosenbrock | F::FreudensteinRoth | F::PowellBadlyScaled => (2, 2),
        F::BrownBadlyScaled | F::Beale => (2, 3),
        F::JennrichSampson => (2, 10),
        F::HelicalValley => (3, 3),
        F::Bard | F::Gaussian => (3, 15),
        F::Meyer => (3, 16),
        F::Gulf => (3, 99),
        F::Box3d => (3, 10),
        F::PowellSingular => (4, 4),
        F::Wood => (4, 6),
        F::KowalikOsborne => (4, 11),
        F::BrownDennis => (4, 20),
        F::Osborne1 => (5, 33),
        F::BiggsExp6 => (6, 13),
        F::Osborne2 => (11, 65),
        F::Watson => (6, 31),
        F::ExtendedRosenbrock => (10, 10),
        F::ExtendedPowellSingular => (12, 12),
        F::PenaltyI => (10, 11),
        F::PenaltyII => (10, 20),
        F::VariablyDimensioned => (10, 12),
        F::Trigonometric
        | F::BrownAlmostLinear
        | F::DiscreteBoundaryValue
        | F::DiscreteIntegralEquation
        | F::BroydenTridiagonal
        | F::BroydenBanded
        | F::Chebyquad => (10, 10),
        F::LinearFullRank | F::LinearRank1 | F::LinearRank1ZeroColumnsRows => (5, 10),
    }
}

/// The number of residuals that goes with `n` parameters: the one the
/// paper fixes, or for a free $m$ the standard ratio ($m = 2n$ for the
/// linear functions, $m = n$ for Chebyquad); functions of fixed $n$ accept
/// only their $n$ and take their standard $m$.
pub(super) fn residuals_for(f: MghFunction, n: usize) -> Result<usize> {
    let m = implied_residuals(f, n);
    check_size(f, n, m)?;
    Ok(m)
}

/// The problems whose size $n$ is free and whose residuals number $m = n$.
fn square_any_size(f: MghFunction) -> bool {
    matches!(
        f,
        F::ExtendedRosenbrock
            | F::ExtendedPowellSingular
            | F::Trigonometric
            | F::BrownAlmostLinear
            | F::DiscreteBoundaryValue
            | F::DiscreteIntegralEquation
            | F::BroydenTridiagonal
            | F::BroydenBanded
    )
}

/// [`residuals_for`] without the check.
fn implied_residuals(f: MghFunction, n: usize) -> usize {
    match f {
        F::Watson => 31,
        F::PenaltyI => n + 1,
        F::VariablyDimensioned => n + 2,
        F::PenaltyII | F::LinearFullRank | F::LinearRank1 | F::LinearRank1ZeroColumnsRows => 2 * n,
        F::Chebyquad => n,
        f if square_any_size(f) => n,
        _ => standard_size(f).1,
    }
}

/// Checks that the paper allows $(n, m)$ for `f`.
pub(super) fn check_size(f: MghFunction, n: usize, m: usize) -> Result<()> {
    let (n_std, m_std) = standard_size(f);
    let bad = |name: &'static str, rule: &str, got: usize| {
        Err(TrajoptError::InvalidParameter {
            name,
            reason: format!("the {} needs {rule}, got {got}", f.name()),
        })
    };
    // n first
    // (the extended problems among the square ones have their own rule below)
    let variable = square_any_size(f)
        || matches!(
            f,
            F::PenaltyI | F::PenaltyII | F::VariablyDimensioned | F::LinearFullRank | F::LinearRank1 | F::Chebyquad
        );
    let (n_ok, n_rule) = match f {
        F::Watson => ((2..=31).contains(&n), "2 <= n <= 31".to_string()),
        F::ExtendedRosenbrock => (n > 0 && n.is_multiple_of(2), "an even n >= 2".to_string()),
        F::ExtendedPowellSingular => (n > 0 && n.is_multiple_of(4), "n a positive multiple of 4".to_string()),
        F::LinearRank1ZeroColumnsRows => (n >= 3, "n >= 3".to_string()),
        _ if variable => (n >= 1, "n >= 1".to_string()),
        _ => (n == n_std, format!("n = {n_std}")),
    };
    if !n_ok {
        return bad("n", &n_rule, n);
    }
    // then m
    let ok = match f {
        F::JennrichSampson | F::Box3d | F::BrownDennis | F::BiggsExp6 => m >= n,
        F::Gulf => (n..=100).contains(&m),
        F::Watson => m == 31,
        F::PenaltyI => m == n + 1,
        F::PenaltyII => m == 2 * n,
        F::VariablyDimensioned => m == n + 2,
        F::LinearFullRank | F::LinearRank1 | F::LinearRank1ZeroColumnsRows | F::Chebyquad => m >= n,
        f if square_any_size(f) => m == n,
        _ => m == m_std,
    };
    if !ok {
        let rule = match f {
            F::Gulf => format!("{n} <= m <= 100"),
            F::JennrichSampson
            | F::Box3d
            | F::BrownDennis
            | F::BiggsExp6
            | F::LinearFullRank
            | F::LinearRank1
            | F::LinearRank1ZeroColumnsRows
            | F::Chebyquad => format!("m >= n = {n}"),
            _ => format!("m = {} for n = {n}", implied_residuals(f, n)),
        };
        return bad("m", &rule, m);
    }
    Ok(())
}

/// The paper's standard starting point $x_0$ for `n` parameters (a valid
/// `n`).
pub(super) fn start_point(f: MghFunction, n: usize) -> Vec<f64> {
    let nf = n as f64;
    // t_j = j h with h = 1 / (n + 1), correctly rounded
    let t = |j: usize| j as f64 / (nf + 1.0);
    match f {
        F::Rosenbrock => vec![-1.2, 1.0],
        F::FreudensteinRoth => vec![0.5, -2.0],
        F::PowellBadlyScaled => vec![0.0, 1.0],
        F::BrownBadlyScaled | F::Beale => vec![1.0, 1.0],
        F::JennrichSampson => vec![0.3, 0.4],
        F::HelicalValley => vec![-1.0, 0.0, 0.0],
        F::Bard => vec![1.0, 1.0, 1.0],
        F::Gaussian => vec![0.4, 1.0, 0.0],
        F::Meyer => vec![0.02, 4000.0, 250.0],
        F::Gulf => vec![5.0, 2.5, 0.15],
        F::Box3d => vec![0.0, 10.0, 20.0],
        F::PowellSingular => vec![3.0, -1.0, 0.0, 1.0],
        F::Wood => vec![-3.0, -1.0, -3.0, -1.0],
        F::KowalikOsborne => vec![0.25, 0.39, 0.415, 0.39],
        F::BrownDennis => vec![25.0, 5.0, -5.0, -1.0],
        F::Osborne1 => vec![0.5, 1.5, -1.0, 0.01, 0.02],
        F::BiggsExp6 => vec![1.0, 2.0, 1.0, 1.0, 1.0, 1.0],
        F::Osborne2 => vec![1.3, 0.65, 0.65, 0.7, 0.6, 3.0, 5.0, 7.0, 2.0, 4.5, 5.5],
        F::Watson => vec![0.0; n],
        F::ExtendedRosenbrock => (0..n).map(|j| if j % 2 == 0 { -1.2 } else { 1.0 }).collect(),
        F::ExtendedPowellSingular => (0..n).map(|j| [3.0, -1.0, 0.0, 1.0][j % 4]).collect(),
        F::PenaltyI => (1..=n).map(|j| j as f64).collect(),
        F::PenaltyII | F::BrownAlmostLinear => vec![0.5; n],
        F::VariablyDimensioned => (1..=n).map(|j| 1.0 - j as f64 / nf).collect(),
        F::Trigonometric => vec![1.0 / nf; n],
        F::DiscreteBoundaryValue | F::DiscreteIntegralEquation => (1..=n).map(|j| t(j) * (t(j) - 1.0)).collect(),
        F::BroydenTridiagonal | F::BroydenBanded => vec![-1.0; n],
        F::LinearFullRank | F::LinearRank1 | F::LinearRank1ZeroColumnsRows => vec![1.0; n],
        F::Chebyquad => (1..=n).map(t).collect(),
    }
}

/// A minimum the paper gives as exact (a closed-form value).
fn exact(value: f64, minimiser: Option<Vec<f64>>, global: bool) -> KnownMinimum {
    KnownMinimum {
        value,
        tolerance: 0.0,
        minimiser,
        global,
    }
}

/// A value the paper prints to the digit of size `unit`; the tolerance is a
/// whole unit, since some printed values are truncated rather than rounded
/// (Meyer's 87.9458 for 87.945855...).
fn printed(value: f64, unit: f64, global: bool) -> KnownMinimum {
    KnownMinimum {
        value,
        tolerance: unit,
        minimiser: None,
        global,
    }
}

/// The minima the paper lists for `f` at size $(n, m)$, the smallest
/// (the problem's $f^*$) first.
pub(super) fn known_minima(f: MghFunction, n: usize, m: usize) -> Vec<KnownMinimum> {
    let mf = m as f64;
    let zero_at = |x: Vec<f64>| exact(0.0, Some(x), true);
    let zero = || exact(0.0, None, true);
    match f {
        F::Rosenbrock => vec![zero_at(vec![1.0, 1.0])],
        F::FreudensteinRoth => vec![zero_at(vec![5.0, 4.0]), printed(48.9842, 1e-4, false)],
        F::PowellBadlyScaled | F::Trigonometric => vec![zero()],
        F::DiscreteBoundaryValue | F::DiscreteIntegralEquation | F::BroydenTridiagonal | F::BroydenBanded => {
            vec![zero()]
        }
        F::BrownBadlyScaled => vec![zero_at(vec![1e6, 2e-6])],
        F::Beale => vec![zero_at(vec![3.0, 0.5])],
        F::JennrichSampson if m == 10 => vec![printed(124.362, 1e-3, true)],
        F::HelicalValley => vec![zero_at(vec![1.0, 0.0, 0.0])],
        // the second minimum lies at infinity: (0.8406..., -inf, -inf)
        F::Bard => vec![printed(8.21487e-3, 1e-8, true), printed(17.4286, 1e-4, false)],
        F::Gaussian => vec![printed(1.12793e-8, 1e-13, true)],
        F::Meyer => vec![printed(87.9458, 1e-4, true)],
        F::Gulf => vec![zero_at(vec![50.0, 25.0, 1.5])],
        F::Box3d => vec![zero_at(vec![1.0, 10.0, 1.0]), zero_at(vec![10.0, 1.0, -1.0])],
        F::PowellSingular | F::ExtendedPowellSingular => vec![zero_at(vec![0.0; n])],
        F::Wood => vec![zero_at(vec![1.0; 4])],
        // the second minimum lies at infinity: (+inf, -14.07..., -inf, -inf)
        F::KowalikOsborne => vec![printed(3.07505e-4, 1e-9, true), printed(1.02734e-3, 1e-8, false)],
        F::BrownDennis if m == 20 => vec![printed(85822.2, 0.1, true)],
        F::Osborne1 => vec![printed(5.46489e-5, 1e-10, true)],
        F::BiggsExp6 if m == 13 => vec![
            zero_at(vec![1.0, 10.0, 1.0, 5.0, 4.0, 3.0]),
            printed(5.65565e-3, 1e-8, false),
        ],
        F::BiggsExp6 => vec![zero_at(vec![1.0, 10.0, 1.0, 5.0, 4.0, 3.0])],
        F::Osborne2 => vec![printed(4.01377e-2, 1e-7, true)],
        F::Watson => match n {
            6 => vec![printed(2.28767e-3, 1e-8, true)],
            9 => vec![printed(1.39976e-6, 1e-11, true)],
            12 => vec![printed(4.72238e-10, 1e-15, true)],
            _ => vec![],
        },
        F::ExtendedRosenbrock | F::VariablyDimensioned => vec![zero_at(vec![1.0; n])],
        F::PenaltyI => match n {
            4 => vec![printed(2.24997e-5, 1e-10, true)],
            10 => vec![printed(7.08765e-5, 1e-10, true)],
            _ => vec![],
        },
        F::PenaltyII => match n {
            4 => vec![printed(9.37629e-6, 1e-11, true)],
            10 => vec![printed(2.93660e-4, 1e-9, true)],
            _ => vec![],
        },
        F::BrownAlmostLinear => {
            let mut corner = vec![0.0; n];
            corner[n - 1] = n as f64 + 1.0;
            vec![zero_at(vec![1.0; n]), exact(1.0, Some(corner), false)]
        }
        F::LinearFullRank => vec![exact((m - n) as f64, Some(vec![-1.0; n]), true)],
        F::LinearRank1 => {
            // one point of the solution set sum_j j x_j = 3 / (2m + 1)
            let mut x = vec![0.0; n];
            x[0] = 3.0 / (2.0 * mf + 1.0);
            vec![exact(mf * (mf - 1.0) / (2.0 * (2.0 * mf + 1.0)), Some(x), true)]
        }
        F::LinearRank1ZeroColumnsRows => {
            // one point of the solution set sum_{j=2}^{n-1} j x_j = 3 / (2m - 3)
            let mut x = vec![0.0; n];
            x[1] = 3.0 / (2.0 * (2.0 * mf - 3.0));
            vec![exact(
                (mf * mf + 3.0 * mf - 6.0) / (2.0 * (2.0 * mf - 3.0)),
                Some(x),
                true,
            )]
        }
        F::Chebyquad if m == n => match n {
            1..=7 | 9 => vec![zero()],
            8 => vec![printed(3.51687e-3, 1e-8, true)],
            10 => vec![printed(6.50395e-3, 1e-8, true)],
            _ => vec![],
        },
        F::JennrichSampson | F::BrownDennis | F::Chebyquad => vec![],
    }
}
