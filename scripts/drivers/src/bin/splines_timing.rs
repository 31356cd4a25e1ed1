//! Timings for the side-by-side comparison with scipy and PyWavelets
//! (`scripts/compare_splines.py` runs this and prints ratios). Prints one
//! JSON object per line: size, median seconds per call and a checksum of the
//! result that the script recomputes from the Python libraries' output.
//!
//! The inputs are deterministic formulas that the script reproduces:
//! times $t_k = \mathrm{clip}((k + 0.5 + 0.3 \sin 1.7k) / n, 0, 1)$ and a
//! clamped cubic basis with $\max(n / 10, 4)$ coefficients on $[0, 1]$;
//! the signal $x_k = \sin(0.37 k) + 0.1 \cos(1.7 k)$.
//!
//! `cargo run --release -p nprl-drivers --bin splines_timing -- 100 1000 10000 100000`

use std::hint::black_box;
use std::time::Instant;

use splines::wavelet::{Boundary, Wavelet, WaveletTransform, wavedec};
use splines::{BSplineBasis, TrajectoryBasis};

/// Median seconds per call over 7 batches of at least ~20 ms each.
fn median_time<R>(mut f: impl FnMut() -> R) -> f64 {
    let mut iters = 1usize;
    loop {
        let start = Instant::now();
        for _ in 0..iters {
            black_box(f());
        }
        if start.elapsed().as_secs_f64() > 0.02 {
            break;
        }
        iters *= 2;
    }
    let mut samples: Vec<f64> = (0..7)
        .map(|_| {
            let start = Instant::now();
            for _ in 0..iters {
                black_box(f());
            }
            start.elapsed().as_secs_f64() / iters as f64
        })
        .collect();
    samples.sort_by(f64::total_cmp);
    samples[3]
}

fn print_line(kind: &str, n: usize, seconds: f64, checksum: f64) {
    println!("{{\"kind\": \"{kind}\", \"n\": {n}, \"seconds\": {seconds:e}, \"checksum\": {checksum:e}}}");
}

fn main() -> anyhow::Result<()> {
    let sizes: Vec<usize> = std::env::args().skip(1).map(|a| a.parse()).collect::<Result<_, _>>()?;
    let sizes = if sizes.is_empty() {
        vec![100, 1_000, 10_000, 100_000]
    } else {
        sizes
    };
    for n in sizes {
        let times: Vec<f64> = (0..n)
            .map(|k| ((k as f64 + 0.5 + 0.3 * (1.7 * k as f64).sin()) / n as f64).clamp(0.0, 1.0))
            .collect();
        let basis = BSplineBasis::clamped_uniform((n / 10).max(4), 3, 0.0, 1.0)?;
        let design_s = median_time(|| basis.design_matrix_rows(&times, 0));
        let phi = basis.design_matrix_rows(&times, 0)?;
        let mut design_checksum = 0.0;
        for k in 0..n {
            for (&j, &v) in phi.symbolic().col_idx_of_row_raw(k).iter().zip(phi.val_of_row(k)) {
                design_checksum += v * (j + 1) as f64 * (k % 7 + 1) as f64;
            }
        }
        print_line("bspline_design_matrix", n, design_s, design_checksum);

        // wavelets: db4, symmetric mode, PyWavelets' default (maximal) level
        let signal: Vec<f64> = (0..n)
            .map(|k| (0.37 * k as f64).sin() + 0.1 * (1.7 * k as f64).cos())
            .collect();
        let (w, b) = (Wavelet::Db4, Boundary::Symmetric);
        let dec = wavedec(&signal, w, b, None)?;
        let flat = dec.to_flat();
        let weigh = |v: &[f64]| -> f64 { v.iter().enumerate().map(|(i, x)| x * (i % 5 + 1) as f64).sum() };
        print_line("wavedec", n, median_time(|| wavedec(&signal, w, b, None)), weigh(&flat));
        let rec = dec.reconstruct()?;
        print_line("waverec", n, median_time(|| dec.reconstruct()), weigh(&rec));

        // the planned, allocation-free transform
        let mut plan = WaveletTransform::new(w, b, n, Some(dec.level()))?;
        let mut coeffs = vec![0.0; plan.n_coeffs()];
        let analyse_s = median_time(|| plan.analyse_into(&signal, &mut coeffs));
        print_line("wavedec:planned", n, analyse_s, weigh(&coeffs));
        let mut out = vec![0.0; n];
        let synth_s = median_time(|| plan.synthesise_into(&flat, &mut out));
        print_line("waverec:planned", n, synth_s, weigh(&out));
    }
    Ok(())
}
