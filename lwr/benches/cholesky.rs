//! The Cholesky factorisation and solves of one local fit, on the sizes a
//! local fit has ($p$ = 3 to 10 coefficients: linear in 2 to 9 inputs,
//! quadratic in 2 or 3), by three implementations with preallocated
//! buffers:
//!
//! - `hand`: the crate's own loop (`lwr/src/factor.rs`, row-major), reached
//!   through the hidden `lwr::bench`;
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

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::{Conj, MatMut, MatRef, Par};
use lwr::bench::{chol_solve, cholesky};
use lwr::strategies::uniform;
use nalgebra::{DMatrix, DVectorViewMut};

mod common;
use common::new_group;

/// Coefficients of a local fit: linear in 2, 5, 9 inputs; quadratic in 2, 3.
const SIZES: [usize; 5] = [3, 6, 10, 4, 8];

/// A symmetric positive definite $p \times p$ matrix $Z^\top K Z + \lambda I'$
/// from 40 seeded design rows, row-major.
fn normal_matrix(p: usize) -> Vec<f64> {
    lwr::strategies::normal_matrix(p, 40, (0.5, 0.5), 1e-6, &mut uniform(7 + p as u64))
}

/// What `fit_found` does with a factor per query: solves for one output
/// (`b` from `rhs`) and for $s = P e_0$, with `solve` solving in place.
fn solve_both(rhs: &[f64], b: &mut [f64], s: &mut [f64], mut solve: impl FnMut(&mut [f64])) {
    b.copy_from_slice(rhs);
    solve(b);
    s.fill(0.0);
    s[0] = 1.0;
    solve(s);
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
    let mut group = new_group(c, "cholesky", 30, 300, 1);
    for p in SIZES {
        let a = normal_matrix(p);
        let rhs: Vec<f64> = (0..p).map(|i| (i as f64).sin()).collect();

        let mut l = vec![0.0; p * p];
        let (mut b, mut s) = (vec![0.0; p], vec![0.0; p]);
        group.bench_function(BenchmarkId::new("hand", p), |bench| {
            bench.iter(|| {
                l.copy_from_slice(black_box(&a));
                let piv = cholesky(&mut l, p).expect("positive definite");
                solve_both(&rhs, &mut b, &mut s, |x| chol_solve(&l, p, x));
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
                solve_both(&rhs, &mut b, &mut s, |x| {
                    chol.solve_mut(&mut DVectorViewMut::from_slice(x, p))
                });
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
                solve_both(&rhs, &mut b, &mut s, |x| {
                    let x = MatMut::from_column_major_slice_mut(x, p, 1);
                    llt::solve::solve_in_place_with_conj(lr, Conj::No, x, Par::Seq, &mut *stack);
                });
                black_box((piv, &b, &s));
            })
        });
    }
    group.finish();
}

criterion_group!(benches, factor_and_solve);
criterion_main!(benches);
