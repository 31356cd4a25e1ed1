//! The Cholesky factorisation and solves of one local fit, on the sizes a
//! local fit has ($p$ = 3 to 10 coefficients: linear in 2 to 9 inputs,
//! quadratic in 2 or 3), by three implementations with preallocated
//! buffers:
//!
//! - `hand`: the loop in `lwr/src/fit.rs` (row-major, copied here verbatim
//!   since it is private; keep the two identical);
//! - `nalgebra`: `Cholesky::new_unchecked` on a reused `DMatrix`, then
//!   `solve_mut` on views of the right-hand sides;
//! - `faer`: `llt::factor::cholesky_in_place` with its scratch allocated
//!   once, then `llt::solve::solve_in_place_with_conj`.
//!
//! Each iteration does what `fit_found` does per query: copy the normal
//! matrix into the factor's buffer, factorise, read the smallest and largest
//! pivots (the condition estimate), and solve for one output and for
//! $s = P e_0$. `cargo bench -p lwr --bench cholesky -- --quick`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::{Conj, MatMut, MatRef, Par};
use nalgebra::{DMatrix, DVectorViewMut};

/// Coefficients of a local fit: linear in 2, 5, 9 inputs; quadratic in 2, 3.
const SIZES: [usize; 5] = [3, 6, 10, 4, 8];

/// A symmetric positive definite $p \times p$ matrix $Z^\top K Z + \lambda I$
/// from 40 seeded design rows, row-major.
fn normal_matrix(p: usize) -> Vec<f64> {
    let mut seed = 7u64 + p as u64;
    let mut rand = move || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let mut a = vec![0.0; p * p];
    for _ in 0..40 {
        let z: Vec<f64> = (0..p).map(|c| if c == 0 { 1.0 } else { rand() }).collect();
        let k = 0.5 + 0.5 * rand();
        for r in 0..p {
            for c in 0..p {
                a[r * p + c] += k * z[r] * z[c];
            }
        }
    }
    for r in 1..p {
        a[r * p + r] += 1e-6;
    }
    a
}

/// The hand loop of `lwr/src/fit.rs`.
fn cholesky(a: &mut [f64], p: usize) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for j in 0..p {
        let mut djj = a[j * p + j];
        for k in 0..j {
            djj -= a[j * p + k] * a[j * p + k];
        }
        if !(djj > 0.0 && djj.is_finite()) {
            return None;
        }
        let ljj = djj.sqrt();
        lo = lo.min(ljj);
        hi = hi.max(ljj);
        a[j * p + j] = ljj;
        for i in j + 1..p {
            let mut v = a[i * p + j];
            for k in 0..j {
                v -= a[i * p + k] * a[j * p + k];
            }
            a[i * p + j] = v / ljj;
        }
    }
    Some((lo, hi))
}

/// The hand solve of `lwr/src/fit.rs`.
fn chol_solve(l: &[f64], p: usize, b: &mut [f64]) {
    for i in 0..p {
        let mut v = b[i];
        for k in 0..i {
            v -= l[i * p + k] * b[k];
        }
        b[i] = v / l[i * p + i];
    }
    for i in (0..p).rev() {
        let mut v = b[i];
        for k in i + 1..p {
            v -= l[k * p + i] * b[k];
        }
        b[i] = v / l[i * p + i];
    }
}

/// Smallest and largest diagonal entries of a factor, `None` unless all
/// are positive and finite.
fn pivots(diag: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for d in diag {
        if !(d > 0.0 && d.is_finite()) {
            return None;
        }
        lo = lo.min(d);
        hi = hi.max(d);
    }
    Some((lo, hi))
}

fn factor_and_solve(c: &mut Criterion) {
    let mut group = c.benchmark_group("cholesky");
    group
        .sample_size(30)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1));
    for p in SIZES {
        let a = normal_matrix(p);
        let rhs: Vec<f64> = (0..p).map(|i| (i as f64).sin()).collect();

        let mut l = vec![0.0; p * p];
        let (mut b, mut s) = (vec![0.0; p], vec![0.0; p]);
        group.bench_function(BenchmarkId::new("hand", p), |bench| {
            bench.iter(|| {
                l.copy_from_slice(black_box(&a));
                let piv = cholesky(&mut l, p).expect("positive definite");
                b.copy_from_slice(&rhs);
                chol_solve(&l, p, &mut b);
                s.fill(0.0);
                s[0] = 1.0;
                chol_solve(&l, p, &mut s);
                black_box((piv, &b, &s));
            })
        });

        let mut m = Some(DMatrix::<f64>::zeros(p, p));
        group.bench_function(BenchmarkId::new("nalgebra", p), |bench| {
            bench.iter(|| {
                let mut buf = m.take().expect("buffer");
                // symmetric: row-major equals column-major
                buf.as_mut_slice().copy_from_slice(black_box(&a));
                let chol = nalgebra::Cholesky::new_unchecked(buf);
                let piv = pivots(chol.l_dirty().diagonal().iter().copied()).expect("positive definite");
                b.copy_from_slice(&rhs);
                chol.solve_mut(&mut DVectorViewMut::from_slice(&mut b, p));
                s.fill(0.0);
                s[0] = 1.0;
                chol.solve_mut(&mut DVectorViewMut::from_slice(&mut s, p));
                black_box((piv, &b, &s));
                m = Some(chol.unpack_dirty());
            })
        });

        let mut fl = vec![0.0; p * p];
        let mut mem = MemBuffer::new(llt::factor::cholesky_in_place_scratch::<f64>(
            p,
            Par::Seq,
            Default::default(),
        ));
        group.bench_function(BenchmarkId::new("faer", p), |bench| {
            bench.iter(|| {
                fl.copy_from_slice(black_box(&a));
                let stack = MemStack::new(&mut mem);
                let mut lm = MatMut::from_column_major_slice_mut(&mut fl, p, p);
                llt::factor::cholesky_in_place(lm.as_mut(), Default::default(), Par::Seq, stack, Default::default())
                    .expect("positive definite");
                let lr: MatRef<'_, f64> = lm.as_ref();
                let piv = pivots((0..p).map(|i| lr[(i, i)])).expect("positive definite");
                b.copy_from_slice(&rhs);
                llt::solve::solve_in_place_with_conj(
                    lr,
                    Conj::No,
                    MatMut::from_column_major_slice_mut(&mut b, p, 1),
                    Par::Seq,
                    stack,
                );
                s.fill(0.0);
                s[0] = 1.0;
                llt::solve::solve_in_place_with_conj(
                    lr,
                    Conj::No,
                    MatMut::from_column_major_slice_mut(&mut s, p, 1),
                    Par::Seq,
                    stack,
                );
                black_box((piv, &b, &s));
            })
        });
    }
    group.finish();
}

criterion_group!(benches, factor_and_solve);
criterion_main!(benches);
