//! The grid's runs: every experiment's variants over their seeds, each
//! as a [`Job`] with its configuration.

use super::*;

/// A change to a run's configuration that makes a variant.
type Tweak = Box<dyn Fn(&mut Config)>;

impl ExperimentSettings {
    /// The seeds and trial caps of the experiments `which` on this grid,
    /// for the header line of a grid's run.
    pub fn size_line(&self, which: &[Experiment]) -> String {
        let s = self;
        which
            .iter()
            .map(|e| match e {
                Experiment::Learning => format!(
                    "learning: {} seeds ({} with wavelets, {} with Powell, {} derivative-free, {} on the paper's basis), up to {} trials per run",
                    s.learning_seeds,
                    s.wavelet_seeds,
                    s.powell_seeds,
                    s.derivative_free_seeds,
                    s.paper_basis_seeds,
                    s.max_trials
                ),
                Experiment::Lambda | Experiment::Planners | Experiment::Beyond => format!(
                    "{}: {} seeds per variant, up to {} trials per run",
                    clap::ValueEnum::to_possible_value(e).map_or_else(String::new, |p| p.get_name().to_string()),
                    s.seeds,
                    s.max_trials
                ),
                Experiment::Mpc => format!(
                    "mpc: {} seeds per variant, up to {} trials per pendulum run, a random trial and up to {} MPC trials per cart-pole run",
                    s.mpc_seeds, s.max_trials, s.cartpole.max_trials
                ),
            })
            .collect::<Vec<_>>()
            .join("; ")
    }
}

pub(super) fn jobs(which: &[Experiment], s: &ExperimentSettings) -> Vec<Job> {
    let base = |seed: u64| {
        let mut c = Config {
            seed,
            max_trials: s.max_trials,
            ..Config::default()
        };
        c.model.kind = s.model;
        c.planner.powell_evals = s.powell_evals;
        c
    };
    let job = |experiment: &'static str, variant: String, seed: u64, rollouts: bool, tweak: &dyn Fn(&mut Config)| {
        let mut cfg = base(seed);
        tweak(&mut cfg);
        Job {
            experiment,
            variant,
            seed,
            task: JobTask::Pendulum {
                cfg: Box::new(cfg),
                rollouts,
            },
        }
    };
    // one variant over seeds 1..=seeds; only the main learning variant
    // keeps its rollouts (for the figures)
    let over_seeds = |out: &mut Vec<Job>, experiment, variant: String, seeds: u64, tweak: &dyn Fn(&mut Config)| {
        let rollouts = variant == MAIN_VARIANT;
        out.extend((1..=seeds).map(|seed| job(experiment, variant.clone(), seed, rollouts, tweak)));
    };
    let mut out = Vec::new();
    for &e in which {
        match e {
            Experiment::Learning => {
                over_seeds(&mut out, "learning", MAIN_VARIANT.into(), s.learning_seeds, &|_| {});
                over_seeds(
                    &mut out,
                    "learning",
                    "gauss-newton/wavelet".into(),
                    s.wavelet_seeds,
                    &|c| {
                        c.planner.basis = BasisKind::Wavelet;
                    },
                );
                // Powell: one stage at the final lambda, within its budget
                over_seeds(&mut out, "learning", "powell/bspline".into(), s.powell_seeds, &|c| {
                    c.planner.solver = Solver::Powell;
                    c.planner.lambda_start = 0.0;
                    c.planner.compare_gauss_newton = true;
                });
                // the paper's way to make Powell converge: fewer coefficients
                // (issue 33), with Gauss-Newton on the same basis beside it
                let paper_basis = |c: &mut Config| {
                    (c.planner.state_coeffs, c.planner.control_coeffs) = PAPER_BASIS;
                };
                over_seeds(
                    &mut out,
                    "learning",
                    "powell/paper-basis".into(),
                    s.paper_basis_seeds,
                    &|c| {
                        paper_basis(c);
                        c.planner.solver = Solver::Powell;
                        c.planner.lambda_start = 0.0;
                        c.planner.powell_evals = PAPER_BASIS_POWELL_EVALS;
                        c.planner.compare_gauss_newton = true;
                    },
                );
                over_seeds(
                    &mut out,
                    "learning",
                    "gauss-newton/paper-basis".into(),
                    s.paper_basis_seeds,
                    &paper_basis,
                );
                // derivative-free least squares, each plan checked against Gauss-Newton's
                over_seeds(
                    &mut out,
                    "learning",
                    DERIVATIVE_FREE_VARIANT.into(),
                    s.derivative_free_seeds,
                    &|c| {
                        c.planner.solver = Solver::DerivativeFree;
                        c.planner.compare_gauss_newton = true;
                    },
                );
            }
            Experiment::Lambda => {
                for &lambda in &s.lambdas {
                    over_seeds(&mut out, "lambda", format!("lambda={lambda:e}"), s.seeds, &|c| {
                        c.planner.lambda = lambda;
                    });
                }
            }
            Experiment::Planners => {
                for (solver, sname) in [(Solver::Ddp, "ddp"), (Solver::GaussNewton, "eq3")] {
                    for (kind, mname) in [
                        (ModelKind::Lwr, "lwr"),
                        (ModelKind::Parametric, "parametric"),
                        (ModelKind::True, "true"),
                    ] {
                        over_seeds(&mut out, "planners", format!("{sname}/{mname}"), s.seeds, &|c| {
                            c.planner.solver = solver;
                            c.model.kind = kind;
                        });
                    }
                }
            }
            Experiment::Beyond => {
                // every variant of a seed before the next seed
                let mut variants: Vec<(String, Tweak)> = vec![
                    (
                        "lwr, confidence lambda".into(),
                        Box::new(|c| {
                            c.model.kind = ModelKind::Lwr;
                            c.planner.confidence_floor = 0.01;
                        }),
                    ),
                    (
                        "lwr, lambda 1e2 x10 per trial".into(),
                        Box::new(|c| {
                            c.model.kind = ModelKind::Lwr;
                            c.planner.lambda = 1e2;
                            c.planner.lambda_growth = 10.0;
                        }),
                    ),
                    (
                        "lwr, warm start".into(),
                        Box::new(|c| {
                            c.model.kind = ModelKind::Lwr;
                            c.planner.warm_start = true;
                        }),
                    ),
                    (
                        "lwr-parametric".into(),
                        Box::new(|c| c.model.kind = ModelKind::LwrParametric),
                    ),
                ];
                for (kind, name) in SCRATCH {
                    variants.push((
                        format!("{SCRATCH_PREFIX}{name}"),
                        Box::new(move |c| {
                            c.model.kind = kind;
                            c.start = Start::Scratch;
                        }),
                    ));
                }
                for seed in 1..=s.seeds {
                    for (name, tweak) in &variants {
                        out.push(job("beyond", name.clone(), seed, false, tweak.as_ref()));
                    }
                }
            }
            Experiment::Mpc => {
                for seed in 1..=s.mpc_seeds {
                    for (controller, cname) in [(Controller::OpenLoop, "open-loop"), (Controller::Mpc, "mpc")] {
                        for (kind, mname) in SCRATCH {
                            out.push(job("mpc", format!("{cname}/{mname}"), seed, false, &|c| {
                                c.controller = controller;
                                c.model.kind = kind;
                            }));
                        }
                        out.push(job("mpc", format!("{cname}/{CONTROL_AFFINE}"), seed, false, &|c| {
                            c.controller = controller;
                            c.model.kind = ModelKind::Lwr;
                            c.model.prior = LwrPrior::ControlAffine;
                        }));
                    }
                    out.push(Job {
                        experiment: "mpc",
                        variant: CARTPOLE_VARIANT.into(),
                        seed,
                        task: JobTask::Cartpole(Box::new(s.cartpole.clone())),
                    });
                }
            }
        }
    }
    out
}
