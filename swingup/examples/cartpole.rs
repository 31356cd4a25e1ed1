//! One cart-pole run through the library: PILCO's cart-pole learned from
//! scratch with the LWR and model-predictive control
//! ([`swingup::cartpole::run`]), every trial printed.
//!
//! ```text
//! cargo run --release -p swingup --example cartpole -- [seed]
//! ```
//! (seed 1 by default). The 20-seed table against PILCO and GP-MPC is the
//! `mpc` experiment's: `swingup experiments mpc --variant cartpole`.

use swingup::cartpole::{CartPoleSettings, run};

fn main() -> anyhow::Result<()> {
    let seed: u64 = std::env::args().nth(1).map_or(Ok(1), |a| a.parse())?;
    let settings = CartPoleSettings::default();
    let r = run(&settings, seed)?;
    for t in &r.trials {
        println!(
            "trial {:>2} {:<6}: {}, tip {:.2} m from the target at the end, {:.0} s of data; replans {:.1} ms median, {:.1} ms p99",
            t.trial,
            t.controller,
            if t.success { "success" } else { "failed" },
            t.final_distance,
            t.data_seconds,
            t.replan_median_ms,
            t.replan_p99_ms
        );
    }
    match (r.success_trial, r.seconds_to_success) {
        (Some(t), Some(s)) => println!("success at trial {t} after {s:.1} s of system data (PILCO 17.5 s, GP-MPC 9 s)"),
        _ => println!("no success within {} trials", r.trials.len()),
    }
    Ok(())
}
