//! NIST StRD Misra1a fitted through the front door for a user's own
//! least-squares problem ([`trajopt::LeastSquares`]): a residual closure
//! and a start, no Jacobian and no sparsity pattern; the standard errors
//! of the estimate beside it. Written, as a new user would, in a crate of
//! its own depending on `nprl-trajopt` by path, from the docs alone: 7
//! lines besides the data (scipy's `least_squares`: 3).
//!
//! ```text
//! cargo run --release -p nprl-trajopt --example misra1a
//! ```
//!
//! NIST's certified values: b1 = 2.3894212918E+02 (2.7070075241E+00),
//! b2 = 5.5015643181E-04 (7.2668688436E-06).

// the data's parallel arrays, indexed as the model's formula reads
#[allow(clippy::needless_range_loop)]
fn main() -> Result<(), trajopt::TrajoptError> {
    let x = [
        77.6, 114.9, 141.1, 190.8, 239.9, 289.0, 332.8, 378.4, 434.8, 477.3, 536.8, 593.1, 689.1, 760.0,
    ];
    let y = [
        10.07, 14.73, 17.94, 23.93, 29.61, 35.18, 40.02, 44.82, 50.76, 55.05, 61.01, 66.40, 75.47, 81.78,
    ];
    let model = |b: &[f64], r: &mut [f64]| {
        for i in 0..x.len() {
            r[i] = y[i] - b[0] * (1.0 - (-b[1] * x[i]).exp());
        }
    };
    for start in [[500.0, 1e-4], [250.0, 5e-4]] {
        let fit = trajopt::LeastSquares::new(x.len(), model).solve(&start)?;
        println!("{:?} +- {:?} ({})", fit.x, fit.standard_errors()?, fit.status);
    }
    Ok(())
}
