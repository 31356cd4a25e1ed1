//! What a leave-one-out tuning will cost, said before it starts: a pass
//! timed on a sample of the rows and scaled by $(n/m)^2$, and the lines
//! `lwr-fit` prints (with a warning naming `--tune-points` past an hour).

use crate::{LwrError, LwrModel};

/// The `--tune-points` a warning about a tuning of hours suggests.
const LARGE_TUNE_POINTS: usize = 2000;

/// Rows of the sample [`estimate_loo_seconds`] times.
const SAMPLE_ROWS: usize = 256;

/// An upper estimate of the seconds one leave-one-out pass of `model`
/// (holding the rows `xs`, `ys`) takes: a pass over a sample of at most
/// [`SAMPLE_ROWS`] rows (every `n / 256`-th), timed, times $(n/m)^2$, the
/// growth of a pass whose neighbourhoods hold a fixed share of the rows.
pub(super) fn estimate_loo_seconds(model: &LwrModel, xs: &[Vec<f64>], ys: &[Vec<f64>]) -> Result<f64, LwrError> {
    let n = xs.len();
    let step = n.div_ceil(SAMPLE_ROWS).max(1);
    let db = model.database();
    let mut sample = LwrModel::new(db.n_inputs(), db.n_outputs(), model.settings().clone())?;
    let picked: Vec<usize> = (0..n).step_by(step).collect();
    sample.insert_many(
        &picked.iter().map(|&i| xs[i].clone()).collect::<Vec<_>>(),
        &picked.iter().map(|&i| ys[i].clone()).collect::<Vec<_>>(),
    )?;
    let started = std::time::Instant::now();
    // a sample too small for the model's fits is no estimate: a pass then
    // costs what the sample's did not show, taken as nothing
    let _ = sample.loo();
    let ratio = n as f64 / picked.len() as f64;
    Ok(started.elapsed().as_secs_f64() * ratio * ratio)
}

/// What the tuning will cost, said before it starts: `n` rows, of which
/// `tune_points` (0: all) are cross-validated per evaluation, at most
/// `tune_evals` evaluations, `pass` seconds for a pass over every row
/// ([`estimate_loo_seconds`]); a second line warns, naming
/// `--tune-points`, when the whole may take more than an hour.
pub(super) fn tuning_plan(n: usize, tune_points: usize, tune_evals: usize, pass: f64) -> Vec<String> {
    let points = if tune_points == 0 { n } else { tune_points.min(n) };
    let per_eval = pass * points as f64 / n.max(1) as f64;
    // the search's evaluations, and a pass over every row at each end
    let total = per_eval * tune_evals as f64 + 2.0 * pass;
    let mut lines = vec![format!(
        "tuning the metric: up to {tune_evals} leave-one-out evaluations over {points} of {n} rows, each about {} \
         (up to {} in all, estimated on a sample)",
        duration_words(per_eval),
        duration_words(total)
    )];
    if total > 3600.0 {
        let suggested = LARGE_TUNE_POINTS.min(points);
        lines.push(format!(
            "warning: the tuning may take {}; --tune-points {suggested} makes each evaluation {}x cheaper \
             (--tune-evals caps their number)",
            duration_words(total),
            (points / suggested.max(1)).max(1)
        ));
    }
    lines
}

/// `seconds` in words: `0.3 s`, `4 min`, `2.5 h`.
pub(super) fn duration_words(seconds: f64) -> String {
    if seconds < 90.0 {
        format!("{seconds:.1} s")
    } else if seconds < 5400.0 {
        format!("{:.0} min", seconds / 60.0)
    } else {
        format!("{:.1} h", seconds / 3600.0)
    }
}

#[cfg(test)]
mod tests {
    /// The plan says the cost, and warns with `--tune-points` past an hour.
    #[test]
    fn the_tuning_plan_estimates_and_warns_past_an_hour() {
        let quick = super::tuning_plan(1000, 0, 300, 0.01);
        assert_eq!(quick.len(), 1);
        assert!(
            quick[0].contains("over 1000 of 1000 rows, each about 0.0 s (up to 3.0 s in all"),
            "{quick:?}"
        );
        // a million rows at 9000 s a pass (the 2.5 h)
        let slow = super::tuning_plan(1_000_000, 0, 300, 9000.0);
        assert_eq!(slow.len(), 2);
        assert!(slow[0].contains("each about 2.5 h"), "{slow:?}");
        assert!(
            slow[1].contains("--tune-points 2000 makes each evaluation 500x cheaper"),
            "{slow:?}"
        );
        // capped: 2000 points per evaluation
        let capped = super::tuning_plan(1_000_000, 2000, 300, 9000.0);
        assert!(
            capped[0].contains("over 2000 of 1000000 rows, each about 18.0 s"),
            "{capped:?}"
        );
        assert_eq!(super::duration_words(150.0), "2 min");
    }
}
