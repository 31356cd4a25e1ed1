//! The cart-pole swing-up learned from scratch with the LWR and MPC, over
//! seeds: per seed the trial of first success (random trial counted) and the
//! seconds of system data to it, then the success rate after each trial.
//!
//! ```text
//! cargo run --release -p swingup --example cartpole -- [first_seed] [last_seed] [episode_s] [json_out]
//! ```
//! (defaults 1, 20, 4.0, no file).

use swingup::cartpole::{CartPoleSettings, experiment, success_rates};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let first: u64 = args.first().map_or(Ok(1), |a| a.parse())?;
    let last: u64 = args.get(1).map_or(Ok(20), |a| a.parse())?;
    let episode: f64 = args.get(2).map_or(Ok(4.0), |a| a.parse())?;
    let mut settings = CartPoleSettings {
        episode,
        ..CartPoleSettings::default()
    };
    // overrides for exploring: CARTPOLE_SETTINGS=file.json (every field),
    // then CARTPOLE_<NAME>=value
    if let Ok(path) = std::env::var("CARTPOLE_SETTINGS") {
        settings = serde_json::from_str(&std::fs::read_to_string(path)?)?;
    }
    if std::env::var("CARTPOLE_DUMP").is_ok() {
        println!("{}", serde_json::to_string_pretty(&settings)?);
        return Ok(());
    }
    let env = |name: &str| std::env::var(format!("CARTPOLE_{name}")).ok();
    if let Some(v) = env("TRUE_MODEL") {
        settings.true_model = v == "1";
    }
    if let Some(v) = env("WINDOW") {
        settings.window = v.parse()?;
    }
    if let Some(v) = env("STATE_COEFFS") {
        settings.state_coeffs = v.parse()?;
    }
    if let Some(v) = env("CONTROL_COEFFS") {
        settings.control_coeffs = v.parse()?;
    }
    if let Some(v) = env("LAMBDA") {
        settings.lambda = v.parse()?;
    }
    if let Some(v) = env("ITERS") {
        settings.replan_iterations = v.parse()?;
    }
    if let Some(v) = env("MAX_TRIALS") {
        settings.max_trials = v.parse()?;
    }
    if let Some(v) = env("TERMINAL") {
        settings.weights.terminal_factor = v.parse()?;
    }
    let seeds: Vec<u64> = (first..=last).collect();
    let started = std::time::Instant::now();
    if first == last {
        // one seed: every trial in detail
        let r = swingup::cartpole::run(&settings, first)?;
        if let Ok(path) = std::env::var("CARTPOLE_RUN_JSON") {
            std::fs::write(path, serde_json::to_string(&r)?)?;
        }
        for t in &r.trials {
            println!(
                "trial {} {}: success {} pilco cost {:.2} final distance {:.3} m data {:.1} s replan median {:.1} ms p99 {:.1} ms iters {:.1} kept {} tune {:.2} s",
                t.trial,
                t.controller,
                t.success,
                t.pilco_cost,
                t.final_distance,
                t.data_seconds,
                t.replan_median_ms,
                t.replan_p99_ms,
                t.mean_iterations,
                t.kept_previous,
                t.tune_seconds
            );
        }
    }
    let rows = experiment(&settings, &seeds)?;
    println!(
        "episode {episode} s, max {} MPC trials after 1 random",
        settings.max_trials
    );
    println!("seed | success trial | data to success (s) | trials | replan median (ms) | replan p99 (ms)");
    for r in &rows {
        println!(
            "{} | {} | {} | {} | {:.1} | {:.1}",
            r.seed,
            r.success_trial.map_or("-".into(), |t| t.to_string()),
            r.seconds_to_success.map_or("-".into(), |s| format!("{s:.1}")),
            r.trials,
            r.replan_median_ms,
            r.replan_p99_ms
        );
    }
    let rates = success_rates(&rows, settings.max_trials + 1);
    println!(
        "success rate by trial: {}",
        rates
            .iter()
            .map(|r| format!("{:.0}%", 100.0 * r))
            .collect::<Vec<_>>()
            .join(" ")
    );
    let mut secs: Vec<f64> = rows.iter().filter_map(|r| r.seconds_to_success).collect();
    secs.sort_by(f64::total_cmp);
    if !secs.is_empty() {
        println!(
            "succeeded {}/{}; data to success: median {:.1} s, mean {:.1} s (PILCO 17.5 s, GP-MPC 9 s)",
            secs.len(),
            rows.len(),
            secs[secs.len() / 2],
            secs.iter().sum::<f64>() / secs.len() as f64
        );
    } else {
        println!("succeeded 0/{}", rows.len());
    }
    if let Some(path) = args.get(3) {
        std::fs::write(path, serde_json::to_string_pretty(&rows)?)?;
    }
    eprintln!("wall time {:.1} s", started.elapsed().as_secs_f64());
    Ok(())
}
