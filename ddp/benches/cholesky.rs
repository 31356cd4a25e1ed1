//! The backward pass's dense solve at each knot, $k = -Q_{uu}^{-1} Q_u$ and
//! $K = -Q_{uu}^{-1} Q_{ux}$ ($Q_{uu}$ is $m \times m$, $Q_{ux}$ is
//! $m \times n$), by three Cholesky implementations with preallocated
//! buffers: the crate's hand loop (`src/linalg.rs`), faer's
//! `cholesky_in_place` / `solve_in_place` with a preallocated `MemBuffer`,
//! and nalgebra's `Cholesky` on a reused `DMatrix`. Sizes are those of the
//! swing-ups: control dimension $m \in \{1, 2\}$, state dimension
//! $n \in \{2, 4, 6\}$. This bench decided which one `ddp` uses.

#![allow(missing_docs)]

use std::hint::black_box;
use std::ops::{Index, IndexMut};
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt;
use faer::{Mat, Par};

#[allow(dead_code, unreachable_pub, unused_imports)]
#[path = "../src/linalg.rs"]
mod linalg;

/// A symmetric positive definite $m \times m$ matrix (row-major) and a
/// right-hand side $[Q_u, Q_{ux}]$ ($m \times (1 + n)$, row-major).
fn data(m: usize, n: usize) -> (Vec<f64>, Vec<f64>) {
    let g: Vec<f64> = (0..m * m).map(|i| ((i * 7 + 3) % 11) as f64 / 11.0 - 0.5).collect();
    let mut a = vec![0.0; m * m];
    for i in 0..m {
        for j in 0..m {
            a[i * m + j] = (0..m).map(|k| g[i * m + k] * g[j * m + k]).sum::<f64>() + if i == j { 1.0 } else { 0.0 };
        }
    }
    let rhs = (0..m * (n + 1))
        .map(|i| ((i * 5 + 1) % 13) as f64 / 13.0 - 0.5)
        .collect();
    (a, rhs)
}

/// Copies `a` ($m \times m$, row-major) into the matrix `l` and $-$`rhs`
/// ($m \times c$, row-major) into the matrix `x`, as the library solvers
/// want them (both faer's `Mat` and nalgebra's `DMatrix`); returns $c$.
#[inline(always)]
fn load<M: IndexMut<(usize, usize), Output = f64>>(a: &[f64], rhs: &[f64], m: usize, l: &mut M, x: &mut M) -> usize {
    let c = rhs.len() / m;
    for i in 0..m {
        for j in 0..m {
            l[(i, j)] = a[i * m + j];
        }
        for j in 0..c {
            x[(i, j)] = -rhs[i * c + j];
        }
    }
    c
}

/// Copies the solution matrix `x` ($m \times c$) into `out`, row-major.
#[inline(always)]
fn store<M: Index<(usize, usize), Output = f64>>(x: &M, m: usize, c: usize, out: &mut [f64]) {
    for i in 0..m {
        for j in 0..c {
            out[i * c + j] = x[(i, j)];
        }
    }
}

/// The hand loop as `backward` uses it: factor, then one solve per column.
struct Hand {
    l: Vec<f64>,
    col: Vec<f64>,
}

impl Hand {
    fn solve(&mut self, a: &[f64], rhs: &[f64], m: usize, out: &mut [f64]) -> bool {
        let c = rhs.len() / m;
        self.l.copy_from_slice(a);
        if linalg::cholesky(&mut self.l, m).is_none() {
            return false;
        }
        for j in 0..c {
            for i in 0..m {
                self.col[i] = -rhs[i * c + j];
            }
            linalg::cholesky_solve(&self.l, m, &mut self.col);
            for i in 0..m {
                out[i * c + j] = self.col[i];
            }
        }
        true
    }
}

/// faer with preallocated factor, right-hand side and scratch.
struct Faer {
    l: Mat<f64>,
    x: Mat<f64>,
    scratch: MemBuffer,
}

impl Faer {
    fn new(m: usize, c: usize) -> Self {
        let req = llt::factor::cholesky_in_place_scratch::<f64>(m, Par::Seq, Default::default())
            .or(llt::solve::solve_in_place_scratch::<f64>(m, c, Par::Seq));
        Self {
            l: Mat::zeros(m, m),
            x: Mat::zeros(m, c),
            scratch: MemBuffer::new(req),
        }
    }

    fn solve(&mut self, a: &[f64], rhs: &[f64], m: usize, out: &mut [f64]) -> bool {
        let c = load(a, rhs, m, &mut self.l, &mut self.x);
        let stack = MemStack::new(&mut self.scratch);
        if llt::factor::cholesky_in_place(self.l.as_mut(), Default::default(), Par::Seq, stack, Default::default())
            .is_err()
        {
            return false;
        }
        llt::solve::solve_in_place(
            self.l.as_ref(),
            self.x.as_mut(),
            Par::Seq,
            MemStack::new(&mut self.scratch),
        );
        store(&self.x, m, c, out);
        true
    }
}

/// nalgebra's `Cholesky` on a reused `DMatrix` (taken and given back, so
/// nothing is allocated per call).
struct Nalgebra {
    l: nalgebra::DMatrix<f64>,
    x: nalgebra::DMatrix<f64>,
}

impl Nalgebra {
    fn solve(&mut self, a: &[f64], rhs: &[f64], m: usize, out: &mut [f64]) -> bool {
        let c = load(a, rhs, m, &mut self.l, &mut self.x);
        let l = std::mem::replace(&mut self.l, nalgebra::DMatrix::zeros(0, 0));
        let Some(chol) = nalgebra::linalg::Cholesky::new(l) else {
            self.l = nalgebra::DMatrix::zeros(m, m);
            return false;
        };
        chol.solve_mut(&mut self.x);
        self.l = chol.unpack_dirty();
        store(&self.x, m, c, out);
        true
    }
}

fn benches(c: &mut Criterion) {
    let mut group = c.benchmark_group("knot_solve");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(1))
        .warm_up_time(Duration::from_millis(300));
    for m in [1, 2] {
        for n in [2, 4, 6] {
            let (a, rhs) = data(m, n);
            let cols = n + 1;
            let mut out = vec![0.0; m * cols];
            let id = format!("m{m}_n{n}");
            let mut hand = Hand {
                l: vec![0.0; m * m],
                col: vec![0.0; m],
            };
            group.bench_function(BenchmarkId::new("hand", &id), |b| {
                b.iter(|| hand.solve(black_box(&a), black_box(&rhs), m, &mut out))
            });
            let mut fa = Faer::new(m, cols);
            group.bench_function(BenchmarkId::new("faer", &id), |b| {
                b.iter(|| fa.solve(black_box(&a), black_box(&rhs), m, &mut out))
            });
            let mut na = Nalgebra {
                l: nalgebra::DMatrix::zeros(m, m),
                x: nalgebra::DMatrix::zeros(m, cols),
            };
            group.bench_function(BenchmarkId::new("nalgebra", &id), |b| {
                b.iter(|| na.solve(black_box(&a), black_box(&rhs), m, &mut out))
            });
            // the three agree
            let (mut o1, mut o2, mut o3) = (out.clone(), out.clone(), out.clone());
            assert!(
                hand.solve(&a, &rhs, m, &mut o1) && fa.solve(&a, &rhs, m, &mut o2) && na.solve(&a, &rhs, m, &mut o3)
            );
            for ((x, y), z) in o1.iter().zip(&o2).zip(&o3) {
                assert!((x - y).abs() <= 1e-12 * (1.0 + x.abs()) && (x - z).abs() <= 1e-12 * (1.0 + x.abs()));
            }
        }
    }
    group.finish();
}

criterion_group!(cholesky_benches, benches);
criterion_main!(cholesky_benches);
