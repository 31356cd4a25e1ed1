//! Powell's method on the Moré-Garbow-Hillstrom set: the 35 problems at
//! their standard sizes from $x_0$, $10 x_0$ and $100 x_0$ (105 instances).
//!
//! Two tables:
//!
//! - **honesty** (`PowellSettings::default()`): every instance's status and
//!   final cost beside the reference minimum $f_\text{ref}$; a converged
//!   status with $f > f_\text{ref} + 10^{-6} (1 + |f_\text{ref}|)$ that is
//!   at none of the other minima the paper lists is a *false convergence*.
//! - **effort** (tight tolerances, `tol_cost = tol_step = 0`, budget
//!   $2000 (n + 1)$): the evaluations until the best value first reaches
//!   $f_\text{ref} + 10^{-8} (1 + |f_\text{ref}|)$.
//!
//! The reference $f_\text{ref}$ of an instance, the best minimum known:
//! the lowest cost that Gauss-Newton (tight tolerances) reaches from the
//! same start, from the paper's minimiser where it gives one, and from the
//! end of a long Powell run ($20000 (n + 1)$ evaluations, which also
//! counts), when it matches the paper's $f^*$ to the paper's printed
//! precision; else the lowest of that and the paper's $f^*$.
//!
//! `cargo run --release -p nprl-trajopt --example powell_mgh [honesty|effort] [--list] [--principal-axes=N]`
//! (`--principal-axes=N`: the effort table with `principal_axes: N`).

use std::cell::Cell;

use trajopt::problems::mgh::{self, MghProblem};
use trajopt::{DampingScale, GaussNewton, GaussNewtonSettings, Powell, PowellSettings, TrajoptError};

/// One problem from one start, with its reference minimum.
struct Instance {
    problem: MghProblem,
    scale: f64,
    x0: Vec<f64>,
    f_ref: f64,
}

/// Gauss-Newton (Levenberg-Marquardt damping, MINPACK's scaling) with tight
/// tolerances; `None` when it does not converge to a finite cost.
fn gauss_newton_cost(p: &MghProblem, x0: &[f64]) -> Option<f64> {
    let gn = GaussNewton::new(GaussNewtonSettings {
        max_iterations: 20_000,
        tol_grad: 1e-14,
        tol_step: 1e-15,
        tol_cost: 1e-16,
        damping_scale: DampingScale::RunningMax,
        ..GaussNewtonSettings::default()
    })
    .ok()?;
    let r = gn.solve(p, x0).ok()?;
    r.cost.is_finite().then_some(r.cost)
}

fn instances() -> Vec<Instance> {
    let mut out = Vec::new();
    for problem in mgh::all() {
        let paper = problem.known_minima().first().cloned();
        for scale in [1.0, 10.0, 100.0] {
            let x0 = problem.start(scale);
            if !problem.cost(&x0).is_ok_and(f64::is_finite) {
                continue;
            }
            // Gauss-Newton from the start, the paper's minimiser, and the end
            // of a long Powell run (which finds lower minima on Chebyquad)
            let long = Powell::new(PowellSettings {
                tol_cost: 0.0,
                tol_step: 0.0,
                max_evals: Some(20_000 * (problem.n() + 1)),
                max_iterations: Some(usize::MAX),
                ..PowellSettings::default()
            })
            .and_then(|powell| powell.solve(&problem, &x0))
            .ok();
            let mut gn: Vec<f64> = [
                Some(x0.clone()),
                problem.minimiser(),
                long.as_ref().map(|r| r.x.clone()),
            ]
            .into_iter()
            .flatten()
            .filter_map(|x| gauss_newton_cost(&problem, &x))
            .collect();
            gn.extend(long.map(|r| r.cost));
            gn.sort_by(f64::total_cmp);
            let f_ref = match (&paper, gn.first()) {
                (Some(k), Some(&g)) if k.matches(g, 1e-6) => g,
                (Some(k), Some(&g)) => k.value.min(g),
                (Some(k), None) => k.value,
                (None, Some(&g)) => g,
                (None, None) => continue,
            };
            out.push(Instance {
                problem,
                scale,
                x0,
                f_ref,
            });
        }
    }
    out
}

/// Where a final cost `f` is: at the reference minimum (within
/// $10^{-6} (1 + |f_\text{ref}|)$), at another minimum the paper lists
/// (within its printed precision or $10^{-6}$ relative), or elsewhere.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Place {
    Best,
    ListedLocal,
    /// A local minimum the paper does not list: Gauss-Newton started there
    /// lowers $f$ by at most $10^{-6} (1 + |f|)$.
    OtherLocal,
    Elsewhere,
}

fn place(inst: &Instance, x: &[f64], f: f64) -> Place {
    if f <= inst.f_ref + 1e-6 * (1.0 + inst.f_ref.abs()) {
        Place::Best
    } else if inst.problem.known_minima().iter().any(|k| k.matches(f, 1e-6)) {
        Place::ListedLocal
    } else if gauss_newton_cost(&inst.problem, x).is_some_and(|g| g >= f - 1e-6 * (1.0 + f.abs())) {
        Place::OtherLocal
    } else {
        Place::Elsewhere
    }
}

fn honesty(list: bool) -> Result<(), TrajoptError> {
    let powell = Powell::new(PowellSettings::default())?;
    let (mut converged, mut false_conv, mut local, mut other, mut total) = (0, 0, 0, 0, 0);
    if list {
        println!("| # | problem | n | start | status | f | f_ref | evals | |");
        println!("|---|---|---|---|---|---|---|---|---|");
    }
    for inst in instances() {
        let r = powell.solve(&inst.problem, &inst.x0)?;
        total += 1;
        let at = place(&inst, &r.x, r.cost);
        let verdict = match (r.status.is_converged(), at) {
            (true, Place::Best) => "converged at the best minimum known",
            (true, Place::ListedLocal) => "converged at a local minimum the paper lists",
            (true, Place::OtherLocal) => "converged at a local minimum the paper does not list",
            (true, Place::Elsewhere) => "FALSE CONVERGENCE",
            (false, Place::Elsewhere) => "not converged",
            (false, _) => "at a minimum, not claimed",
        };
        if r.status.is_converged() {
            converged += 1;
            false_conv += usize::from(at == Place::Elsewhere);
            local += usize::from(at == Place::ListedLocal);
            other += usize::from(at == Place::OtherLocal);
        }
        if list || (r.status.is_converged() && at != Place::Best) {
            let polished = gauss_newton_cost(&inst.problem, &r.x).unwrap_or(f64::NAN);
            let grad = inst.problem.gradient(&r.x)?.iter().fold(0.0_f64, |m, g| m.max(g.abs()));
            println!(
                "| {} | {} | {} | {}x | {:?} | {:.6e} | {:.6e} | {} | {verdict} | GN from there {polished:.6e}, |g| {grad:.1e} |",
                inst.problem.id(),
                inst.problem.name(),
                inst.problem.n(),
                inst.scale,
                r.status,
                r.cost,
                inst.f_ref,
                r.evals
            );
        }
    }
    println!(
        "default settings: {total} instances, {converged} report convergence: {} at the best minimum known, {local} at a local minimum the paper lists, {other} at another local minimum, {false_conv} elsewhere (false)",
        converged - local - other - false_conv
    );
    Ok(())
}

/// Evaluations until the best value reaches `target`; the solve is stopped
/// there (an `Err` from the objective).
struct Reach<'a> {
    problem: &'a MghProblem,
    target: f64,
    evals: Cell<usize>,
    reached: Cell<Option<usize>>,
}

impl trajopt::powell::Objective for Reach<'_> {
    fn cost(&self, x: &[f64]) -> trajopt::Result<f64> {
        let f = self.problem.cost(x)?;
        self.evals.set(self.evals.get() + 1);
        if f <= self.target {
            self.reached.set(Some(self.evals.get()));
            return Err(TrajoptError::Model("target reached".into()));
        }
        Ok(f)
    }
}

fn effort(list: bool, principal_axes: usize) -> Result<(), TrajoptError> {
    let mut counts = Vec::new();
    let mut reached = 0;
    if list {
        println!("| # | problem | n | start | evals to f_ref + 1e-8 (1 + |f_ref|) | budget |");
        println!("|---|---|---|---|---|---|");
    }
    for inst in instances() {
        let n = inst.problem.n();
        let budget = 2000 * (n + 1);
        let powell = Powell::new(PowellSettings {
            tol_cost: 0.0,
            tol_step: 0.0,
            max_evals: Some(budget),
            max_iterations: Some(usize::MAX),
            principal_axes,
            ..PowellSettings::default()
        })?;
        let objective = Reach {
            problem: &inst.problem,
            target: inst.f_ref + 1e-8 * (1.0 + inst.f_ref.abs()),
            evals: Cell::new(0),
            reached: Cell::new(None),
        };
        let end = match powell.solve(&objective, &inst.x0) {
            Ok(r) => format!("{:?} {:.3e}", r.status, r.cost),
            Err(TrajoptError::Model(_)) => String::new(),
            Err(e) => return Err(e),
        };
        let evals = objective.reached.get();
        if evals.is_some() {
            reached += 1;
        }
        // not reached within the budget: counted as infinitely many
        counts.push(evals.unwrap_or(usize::MAX));
        if list {
            println!(
                "| {} | {} | {n} | {}x | {} | {budget} | {end} |",
                inst.problem.id(),
                inst.problem.name(),
                inst.scale,
                evals.map_or("-".into(), |e| e.to_string()),
            );
        }
    }
    counts.sort_unstable();
    let median = counts[counts.len() / 2];
    let median = if median == usize::MAX {
        "not reached".into()
    } else {
        median.to_string()
    };
    println!(
        "tight tolerances: {reached} of {} instances reach f_ref + 1e-8 (1 + |f_ref|) within 2000 (n + 1) evaluations; median evaluations {median} (unreached counted as infinite)",
        counts.len()
    );
    Ok(())
}

fn main() -> Result<(), TrajoptError> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let list = args.iter().any(|a| a == "--list");
    // `--principal-axes=N`: the effort mode with Brent's principal axes every N iterations
    let principal_axes = args
        .iter()
        .find_map(|a| a.strip_prefix("--principal-axes="))
        .map(|v| v.parse::<usize>())
        .transpose()
        .map_err(|e| TrajoptError::InvalidParameter {
            name: "--principal-axes",
            reason: e.to_string(),
        })?
        .unwrap_or(0);
    let which: Vec<&str> = args
        .iter()
        .filter(|a| !a.starts_with("--"))
        .map(String::as_str)
        .collect();
    if which.is_empty() || which.contains(&"honesty") {
        honesty(list)?;
    }
    if which.is_empty() || which.contains(&"effort") {
        effort(list, principal_axes)?;
    }
    Ok(())
}
