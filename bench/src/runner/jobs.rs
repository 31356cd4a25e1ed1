//! The benchmark's runs in their fixed order (instance by instance, the
//! solvers in the settings' order, those that apply), run one at a time
//! so that the timings do not share the cores: all of them
//! ([`crate::runner::execute`]) or a shard's ([`crate::shard`]).

use super::RunnerSettings;
use crate::error::Result;
use crate::instance::Instance;
use crate::open::BenchSolver;
use crate::record::{RunKey, RunRecord};

/// The key of the run of `solver` on `instance`.
fn job_key(instance: &Instance, solver: &dyn BenchSolver) -> RunKey {
    (
        instance.set.to_string(),
        instance.problem.clone(),
        instance.scale.to_bits(),
        solver.name().to_string(),
    )
}

/// Every run of `settings` on `instances`, in order: (instance, solver),
/// as indices.
fn order(settings: &RunnerSettings, instances: &[Instance]) -> Vec<(usize, usize)> {
    instances
        .iter()
        .enumerate()
        .flat_map(|(i, instance)| {
            settings
                .solvers
                .iter()
                .enumerate()
                .filter(|(_, s)| s.applies_to(instance))
                .map(move |(k, _)| (i, k))
        })
        .collect()
}

/// The keys of the runs of `settings`, in their order (a run's position
/// is its index).
pub(crate) fn planned_runs(settings: &RunnerSettings) -> Result<Vec<RunKey>> {
    let instances = settings.set.instances(settings.filter.as_deref())?;
    Ok(order(settings, &instances)
        .into_iter()
        .map(|(i, k)| job_key(&instances[i], settings.solvers[k].as_ref()))
        .collect())
}

/// Every run of `settings`, with progress on stderr.
pub(crate) fn run_all(settings: &RunnerSettings) -> Result<Vec<RunRecord>> {
    let mut runs = Vec::new();
    run_jobs(settings, &|_, _| true, &mut |run| {
        runs.push(run);
        Ok(())
    })?;
    Ok(runs)
}

/// Makes, one at a time, the runs of [`planned_runs`] for which `wanted`
/// (position, key) holds, handing each to `each` as it finishes (which may
/// save it, and stop the loop with an error).
pub(crate) fn run_jobs(
    settings: &RunnerSettings,
    wanted: &dyn Fn(usize, &RunKey) -> bool,
    each: &mut dyn FnMut(RunRecord) -> Result<()>,
) -> Result<()> {
    let instances = settings.set.instances(settings.filter.as_deref())?;
    for (position, (i, k)) in order(settings, &instances).into_iter().enumerate() {
        let (instance, solver) = (&instances[i], &settings.solvers[k]);
        if !wanted(position, &job_key(instance, solver.as_ref())) {
            continue;
        }
        let run = solver.run(instance, &settings.budget, settings.repeats)?;
        progress(format_args!(
            "[{}/{}] {:?} {:<20} f = {:.6e} evals = {:>7} {:.2e} s {}",
            i + 1,
            instances.len(),
            instance,
            run.solver,
            run.f,
            run.evals,
            run.time_s,
            run.status
        ));
        each(run)?;
    }
    Ok(())
}

/// A progress line on standard error; a closed stderr loses it, never
/// the work.
fn progress(line: std::fmt::Arguments<'_>) {
    use std::io::Write as _;
    let _ = writeln!(std::io::stderr(), "{line}");
}
