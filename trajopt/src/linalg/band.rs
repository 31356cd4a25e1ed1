//! Symmetric band matrices: storage, Cholesky factorisation, solves.
//!
//! A symmetric $n \times n$ matrix $A$ with half-bandwidth $k$
//! ($A_{ij} = 0$ for $|i - j| > k$) is stored as its lower band, column by
//! column: entry $(i, j)$, $j \le i \le j + k$, at `j * (k + 1) + (i - j)`
//! (LAPACK's `dpbtrf` layout with `uplo = 'L'`). The Cholesky factor
//! $A = LL^\top$ has the same band, so it is computed in place in
//! $O(n k^2)$ time: for trajectory problems, whose normal equations are
//! banded once the parameters are ordered by time, that is linear in the
//! horizon with a small constant (no fill-reducing ordering, no symbolic
//! phase, contiguous inner loops).
//!
//! [`BandLayout`] tells a solver where each parameter of a
//! [`LeastSquaresProblem`](crate::LeastSquaresProblem) sits in the band
//! matrix, and [`GaussNewton`](crate::GaussNewton) uses it when the problem
//! can form its normal equations in band form
//! ([`BandForm`](crate::BandForm)).

use std::sync::atomic::AtomicBool;

use crate::error::{Result, TrajoptError};
use crate::linalg::kernels::CholeskyKernel;

/// Where the parameters go in a band matrix: parameter `i` is row and
/// column `position[i]`, and the matrix has half-bandwidth
/// `half_bandwidth`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BandLayout {
    /// Row (and column) of each parameter; a permutation of $0..n$.
    pub position: Vec<usize>,
    /// The half-bandwidth $k$.
    pub half_bandwidth: usize,
}

impl BandLayout {
    /// Checks that `position` is a permutation of $0..n$ for `n` parameters.
    pub fn validate(&self, n: usize) -> Result<()> {
        if self.position.len() != n {
            return Err(TrajoptError::DimensionMismatch {
                what: "band layout positions",
                expected: n,
                actual: self.position.len(),
            });
        }
        let mut seen = vec![false; n];
        for (i, &p) in self.position.iter().enumerate() {
            if p >= n || std::mem::replace(&mut seen[p], true) {
                return Err(TrajoptError::InvalidParameter {
                    name: "band layout",
                    reason: format!("position {p} of parameter {i} is out of range or taken twice"),
                });
            }
        }
        Ok(())
    }
}

/// A symmetric band matrix (lower band stored); see the [module docs](self).
#[derive(Debug, Clone, PartialEq)]
pub struct BandedSym {
    n: usize,
    kd: usize,
    /// Column-major lower band, `kd + 1` entries per column (the entries
    /// below row $n - 1$ are padding and stay zero).
    ab: Vec<f64>,
}

impl BandedSym {
    /// The zero matrix of size `n` and half-bandwidth `kd`.
    pub fn zeros(n: usize, kd: usize) -> Self {
        Self {
            n,
            kd,
            ab: vec![0.0; n * (kd + 1)],
        }
    }

    /// Its size $n$.
    pub fn size(&self) -> usize {
        self.n
    }

    /// Its half-bandwidth $k$.
    pub fn half_bandwidth(&self) -> usize {
        self.kd
    }

    /// The stored lower band (see the [module docs](self) for the layout).
    pub fn band(&self) -> &[f64] {
        &self.ab
    }

    /// Sets every entry to zero.
    pub fn clear(&mut self) {
        self.ab.fill(0.0);
    }

    /// Copies the values of `other` (same size and bandwidth).
    ///
    /// # Panics
    /// If the shapes differ (a programming error inside the solver).
    pub fn copy_from(&mut self, other: &Self) {
        assert_eq!((self.n, self.kd), (other.n, other.kd), "band shapes differ");
        self.ab.copy_from_slice(&other.ab);
    }

    /// The index of entry $(i, j)$ in the band, $j \le i \le j + k$.
    #[inline]
    fn index(&self, i: usize, j: usize) -> usize {
        debug_assert!(j <= i && i - j <= self.kd && i < self.n);
        j * (self.kd + 1) + (i - j)
    }

    /// Entry $(i, j)$ (either triangle; zero outside the band).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        if i >= self.n || i - j > self.kd {
            return 0.0;
        }
        self.ab[self.index(i, j)]
    }

    /// Adds `v` to entry $(i, j)$ and, off the diagonal, to $(j, i)$.
    ///
    /// # Errors
    /// [`TrajoptError::InvalidParameter`] if $(i, j)$ lies outside the band.
    pub fn add(&mut self, i: usize, j: usize, v: f64) -> Result<()> {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        if i >= self.n || i - j > self.kd {
            return Err(TrajoptError::InvalidParameter {
                name: "band matrix",
                reason: format!(
                    "entry ({i}, {j}) is outside a band of half-width {} and size {}",
                    self.kd, self.n
                ),
            });
        }
        let p = self.index(i, j);
        self.ab[p] += v;
        Ok(())
    }

    /// Adds `v` to the lower-band entry $(i, j)$, $j \le i \le j + k$,
    /// unchecked beyond a debug assertion (for assembly loops that know
    /// their indices are in the band).
    #[inline]
    pub fn add_lower(&mut self, i: usize, j: usize, v: f64) {
        let p = self.index(i, j);
        self.ab[p] += v;
    }

    /// The diagonal entry $(j, j)$.
    #[inline]
    pub fn diagonal(&self, j: usize) -> f64 {
        self.ab[j * (self.kd + 1)]
    }

    /// Adds `v[j]` to each diagonal entry $(j, j)$.
    pub fn add_to_diagonal(&mut self, v: &[f64]) {
        let w = self.kd + 1;
        for (j, &d) in v.iter().enumerate().take(self.n) {
            self.ab[j * w] += d;
        }
    }

    /// Adds `scale * other` entrywise (same size and bandwidth).
    ///
    /// # Panics
    /// If the shapes differ (a programming error inside the solver).
    pub fn add_scaled(&mut self, scale: f64, other: &Self) {
        assert_eq!((self.n, self.kd), (other.n, other.kd), "band shapes differ");
        for (a, b) in self.ab.iter_mut().zip(&other.ab) {
            *a += scale * b;
        }
    }

    /// Adds `other`'s columns from `first` on (same size and bandwidth):
    /// [`add_scaled`](Self::add_scaled) with scale 1 for a matrix known
    /// to be zero in its first `first` columns.
    pub(crate) fn add_from_column(&mut self, other: &Self, first: usize) {
        assert_eq!((self.n, self.kd), (other.n, other.kd), "band shapes differ");
        let start = (first * (self.kd + 1)).min(self.ab.len());
        for (a, b) in self.ab[start..].iter_mut().zip(&other.ab[start..]) {
            *a += b;
        }
    }

    /// The first column with a nonzero entry ($n$ if there is none).
    pub(crate) fn first_nonzero_column(&self) -> usize {
        self.ab
            .iter()
            .position(|&v| v != 0.0)
            .map_or(self.n, |i| i / (self.kd + 1))
    }

    /// $y = A x$.
    ///
    /// # Panics
    /// If `x` or `y` does not have length $n$.
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) {
        assert!(
            x.len() == self.n && y.len() == self.n,
            "vector length differs from the matrix size"
        );
        self.mul_vec_leading(self.n, x, y);
    }

    /// [`mul_vec`](Self::mul_vec) for a matrix known to be zero beyond its
    /// first `end` rows and columns: only those columns are visited.
    pub(crate) fn mul_vec_leading(&self, end: usize, x: &[f64], y: &mut [f64]) {
        y.fill(0.0);
        let w = self.kd + 1;
        for j in 0..end.min(self.n) {
            let kn = self.kd.min(self.n - 1 - j);
            let col = &self.ab[j * w..j * w + kn + 1];
            let xj = x[j];
            let mut acc = col[0] * xj;
            for (i, &a) in col.iter().enumerate().skip(1) {
                y[j + i] += a * xj;
                acc += a * x[j + i];
            }
            y[j] += acc;
        }
    }

    /// Overwrites the matrix with its Cholesky factor $L$ ($A = LL^\top$,
    /// lower band) and returns it, or returns `None` (leaving the matrix
    /// partly overwritten) if a pivot is not positive and finite: the matrix
    /// is not numerically positive definite.
    pub fn cholesky_in_place(mut self) -> std::result::Result<BandCholesky, Self> {
        if self.eliminate_leading(self.n, None) {
            Ok(BandCholesky { factor: self })
        } else {
            Err(self)
        }
    }

    /// Eliminates the first `columns` rows and columns in place: afterwards
    /// columns `0..columns` hold those columns of the Cholesky factor $L$
    /// and the trailing block (rows and columns `columns..`) holds the Schur
    /// complement $A_{22} - A_{21} A_{11}^{-1} A_{12}$. False (the matrix
    /// partly overwritten) if a pivot is not positive and finite: $A_{11}$
    /// is not numerically positive definite. With `columns = n` it is
    /// [`cholesky_in_place`](Self::cholesky_in_place), with the same
    /// arithmetic.
    ///
    /// With `abort`, shared with the eliminations of other parts of one
    /// matrix: a failure sets it, and once it is set (by any of them) this
    /// one gives up too, within a few columns, as the whole matrix is then
    /// not positive definite. The columns it does eliminate are the same
    /// bits either way.
    pub(crate) fn eliminate_leading(&mut self, columns: usize, abort: Option<&AtomicBool>) -> bool {
        pulp::Arch::new().dispatch(CholeskyKernel {
            n: self.n,
            columns,
            kd: self.kd,
            ab: &mut self.ab,
            abort,
        })
    }

    /// Forward substitution with the first `columns` columns of a factor
    /// from [`eliminate_leading`](Self::eliminate_leading): `x[..columns]`
    /// becomes $y = L_{11}^{-1} b_1$ and `x[columns..]` becomes
    /// $b_2 - L_{21} y$.
    pub(crate) fn forward_leading(&self, columns: usize, x: &mut [f64]) {
        let w = self.kd + 1;
        for j in 0..columns.min(self.n) {
            let kn = self.kd.min(self.n - 1 - j);
            let col = &self.ab[j * w..j * w + kn + 1];
            let yj = x[j] / col[0];
            x[j] = yj;
            for (xi, &l) in x[j + 1..=j + kn].iter_mut().zip(&col[1..]) {
                *xi -= l * yj;
            }
        }
    }

    /// Back substitution with the first `columns` columns of a factor
    /// from [`eliminate_leading`](Self::eliminate_leading), given the
    /// trailing unknowns `x[columns..]`: `x[..columns]` (holding $y$ from
    /// [`forward_leading`](Self::forward_leading)) becomes
    /// $L_{11}^{-\top} (y - L_{21}^\top x_2)$.
    pub(crate) fn backward_leading(&self, columns: usize, x: &mut [f64]) {
        let w = self.kd + 1;
        for j in (0..columns.min(self.n)).rev() {
            let kn = self.kd.min(self.n - 1 - j);
            let col = &self.ab[j * w..j * w + kn + 1];
            let s: f64 = x[j + 1..=j + kn].iter().zip(&col[1..]).map(|(a, b)| a * b).sum();
            x[j] = (x[j] - s) / col[0];
        }
    }

    /// Copies the columns `0..end` of `other` (same size and bandwidth),
    /// all their band entries.
    pub(crate) fn copy_leading_columns(&mut self, other: &Self, end: usize) {
        assert_eq!((self.n, self.kd), (other.n, other.kd), "band shapes differ");
        let stop = (end.min(self.n)) * (self.kd + 1);
        self.ab[..stop].copy_from_slice(&other.ab[..stop]);
    }

    /// In one pass over the band: the first column and the last row with
    /// a nonzero (or NaN) entry, if any, and whether every entry is finite.
    /// (The split solve scans each part after every assembly: one pass,
    /// whose tests vectorise, instead of three searches.)
    pub(crate) fn nonzero_extent_and_finite(&self) -> (Option<(usize, usize)>, bool) {
        let w = self.kd + 1;
        let mut finite = true;
        let (mut first, mut last) = (None, None);
        for (j, col) in self.ab.chunks_exact(w).enumerate() {
            // without early exits, so that the tests run on whole vectors
            let (nonzero, col_finite) = col
                .iter()
                .fold((false, true), |(nz, fin), &v| (nz | (v != 0.0), fin & v.is_finite()));
            finite &= col_finite;
            if nonzero {
                first.get_or_insert(j);
                last = Some(j);
            }
        }
        let (Some(first), Some(last_col)) = (first, last) else {
            return (None, finite);
        };
        // only the kd columns before the last nonzero one can reach further down
        let last_row = (last_col.saturating_sub(self.kd)..=last_col)
            .filter_map(|j| {
                self.ab[j * w..(j + 1) * w]
                    .iter()
                    .rposition(|&v| v != 0.0)
                    .map(|d| j + d)
            })
            .max()
            .unwrap_or(last_col);
        (Some((first, last_row)), finite)
    }
}

/// The Cholesky factor of a [`BandedSym`], from
/// [`BandedSym::cholesky_in_place`].
#[derive(Debug, Clone)]
pub struct BandCholesky {
    factor: BandedSym,
}

impl BandCholesky {
    /// Solves $A x = b$ in place (`x` holds $b$ on entry).
    ///
    /// # Panics
    /// If `x` does not have length $n$.
    pub fn solve_in_place(&self, x: &mut [f64]) {
        let f = &self.factor;
        assert_eq!(x.len(), f.n, "vector length differs from the matrix size");
        // L y = b, then L^T x = y
        f.forward_leading(f.n, x);
        f.backward_leading(f.n, x);
    }

    /// Gives the storage back (its values are the factor's) for reuse.
    pub fn into_inner(self) -> BandedSym {
        self.factor
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::Mat;
    use faer::linalg::solvers::Solve;
    use proptest::prelude::*;
    use std::sync::atomic::Ordering;

    /// A random symmetric band matrix made positive definite by a diagonal shift.
    fn spd(n: usize, kd: usize, seed: u64, shift: f64) -> BandedSym {
        let mut a = BandedSym::zeros(n, kd);
        let mut s = seed;
        for j in 0..n {
            for i in j..(j + kd + 1).min(n) {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let v = ((s >> 11) as f64 / (1u64 << 53) as f64) - 0.5;
                a.add(i, j, v).expect("in band");
            }
        }
        a.add_to_diagonal(&vec![shift; n]);
        a
    }

    fn dense(a: &BandedSym) -> Mat<f64> {
        Mat::from_fn(a.size(), a.size(), |i, j| a.get(i, j))
    }

    proptest! {
        /// The band Cholesky solve equals faer's dense Cholesky solve, and
        /// L L^T reproduces A.
        #[test]
        fn band_cholesky_matches_dense(n in 1usize..40, kd in 0usize..8, seed in any::<u64>()) {
            let a = spd(n, kd, seed, (2 * kd + 2) as f64);
            let full = dense(&a);
            let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin()).collect();
            let chol = a.clone().cholesky_in_place().expect("positive definite");
            let mut x = b.clone();
            chol.solve_in_place(&mut x);
            let llt = full.llt(faer::Side::Lower).expect("dense llt");
            let reference = llt.solve(&Mat::from_fn(n, 1, |i, _| b[i]));
            for i in 0..n {
                prop_assert!((x[i] - reference[(i, 0)]).abs() <= 1e-10 * (1.0 + reference[(i, 0)].abs()));
            }
            let l = dense(&chol.into_inner());
            let l = Mat::from_fn(n, n, |i, j| if i >= j { l[(i, j)] } else { 0.0 });
            let rebuilt = &l * l.transpose();
            for i in 0..n {
                for j in 0..n {
                    prop_assert!((rebuilt[(i, j)] - full[(i, j)]).abs() <= 1e-12 * (kd + 2) as f64 * 4.0);
                }
            }
        }

        /// Eliminating the leading `m` columns leaves the dense Schur
        /// complement in the trailing block; forward substitution, a dense
        /// solve of the Schur system and back substitution give the
        /// solution of the whole system.
        #[test]
        fn leading_elimination_leaves_the_schur_complement(
            n in 1usize..40, kd in 0usize..8, m_frac in 0.0f64..=1.0, seed in any::<u64>()
        ) {
            let m = ((n as f64) * m_frac) as usize;
            let a = spd(n, kd, seed, (2 * kd + 2) as f64);
            let full = dense(&a);
            let mut e = a.clone();
            prop_assert!(e.eliminate_leading(m, None));
            let t = n - m;
            let (a11, a21, a22) = (
                full.submatrix(0, 0, m, m).to_owned(),
                full.submatrix(m, 0, t, m).to_owned(),
                full.submatrix(m, m, t, t).to_owned(),
            );
            let schur = if m > 0 {
                let x = a11.llt(faer::Side::Lower).expect("dense llt").solve(a21.transpose());
                &a22 - &a21 * &x
            } else {
                a22
            };
            for i in 0..t {
                for j in 0..=i {
                    prop_assert!((e.get(m + i, m + j) - schur[(i, j)]).abs() <= 1e-10, "({i}, {j})");
                }
            }
            // the split solve
            let b: Vec<f64> = (0..n).map(|i| (i as f64 * 0.7).sin()).collect();
            let mut x = b.clone();
            e.forward_leading(m, &mut x);
            if t > 0 {
                let rhs = Mat::from_fn(t, 1, |i, _| x[m + i]);
                let x2 = schur.llt(faer::Side::Lower).expect("schur llt").solve(&rhs);
                for i in 0..t {
                    x[m + i] = x2[(i, 0)];
                }
            }
            e.backward_leading(m, &mut x);
            let reference = full.llt(faer::Side::Lower).expect("dense llt").solve(&Mat::from_fn(n, 1, |i, _| b[i]));
            for i in 0..n {
                prop_assert!((x[i] - reference[(i, 0)]).abs() <= 1e-10 * (1.0 + reference[(i, 0)].abs()));
            }
            // all columns: the factorisation itself, bit for bit
            let mut whole = a.clone();
            prop_assert!(whole.eliminate_leading(n, None));
            let chol = a.cholesky_in_place().expect("positive definite");
            let factor = chol.into_inner();
            prop_assert_eq!(whole.band(), factor.band());
        }

        /// The one-pass scan finds what entry-by-entry searches find.
        #[test]
        fn nonzero_extent_and_finiteness_match_a_search(
            n in 1usize..25,
            kd in 0usize..5,
            entries in proptest::collection::vec((0usize..25, 0usize..5, 0u8..4), 0..12),
        ) {
            let mut a = BandedSym::zeros(n, kd);
            for &(j, d, kind) in &entries {
                let (j, i) = (j % n, j % n + d % (kd + 1));
                if i < n {
                    let v = [1.5, -2.0, f64::NAN, f64::INFINITY][kind as usize];
                    a.add(i, j, v).expect("in band");
                }
            }
            let cells: Vec<(usize, usize, f64)> =
                (0..n).flat_map(|j| (j..n.min(j + kd + 1)).map(move |i| (i, j))).map(|(i, j)| (i, j, a.get(i, j))).collect();
            let nonzero = || cells.iter().filter(|c| c.2 != 0.0);
            let expected = nonzero().map(|c| c.1).min().zip(nonzero().map(|c| c.0).max());
            let finite = cells.iter().all(|c| c.2.is_finite());
            prop_assert_eq!(a.nonzero_extent_and_finite(), (expected, finite));
            prop_assert_eq!(a.first_nonzero_column(), expected.map_or(n, |e| e.0));
        }

        /// Two columns at a time is one column at a time, bit for bit,
        /// including zeros inside the band (whose updates both skip) and an
        /// odd number of columns.
        #[test]
        fn paired_elimination_is_the_column_by_column_one(
            n in 1usize..40,
            kd in 0usize..8,
            m_frac in 0.0f64..=1.0,
            seed in any::<u64>(),
            zeros in proptest::collection::vec((0usize..40, 1usize..8), 0..30),
        ) {
            let m = ((n as f64) * m_frac) as usize;
            let mut a = spd(n, kd, seed, (2 * kd + 2) as f64);
            for &(j, d) in &zeros {
                let (j, i) = (j % n, j % n + d);
                if i < n && d <= kd {
                    let v = a.get(i, j);
                    a.add(i, j, -v).expect("in band");
                }
            }
            let mut paired = a.clone();
            prop_assert!(paired.eliminate_leading(m, None));
            // the reference: one column at a time
            let (w, mut ab) = (kd + 1, a.band().to_vec());
            for j in 0..m {
                let kn = kd.min(n - 1 - j);
                let l = ab[j * w].sqrt();
                ab[j * w] = l;
                for v in &mut ab[j * w + 1..=j * w + kn] {
                    *v *= 1.0 / l;
                }
                for c in 1..=kn {
                    let lc = ab[j * w + c];
                    if lc != 0.0 {
                        for r in c..=kn {
                            let (lr, t) = (ab[j * w + r], ab[(j + c) * w + r - c]);
                            ab[(j + c) * w + r - c] = (-lr).mul_add(lc, t);
                        }
                    }
                }
            }
            prop_assert_eq!(paired.band(), &ab[..]);
        }

        /// The band product equals the dense product.
        #[test]
        fn band_product_matches_dense(n in 1usize..30, kd in 0usize..6, seed in any::<u64>()) {
            let a = spd(n, kd, seed, 0.0);
            let x: Vec<f64> = (0..n).map(|i| (i as f64 * 1.3).cos()).collect();
            let mut y = vec![0.0; n];
            a.mul_vec(&x, &mut y);
            let reference = dense(&a) * Mat::from_fn(n, 1, |i, _| x[i]);
            for i in 0..n {
                prop_assert!((y[i] - reference[(i, 0)]).abs() <= 1e-12);
            }
        }
    }

    #[test]
    fn leading_columns_copy_and_the_nonzero_extent() {
        let a = spd(10, 2, 3, 1.0);
        let mut b = BandedSym::zeros(10, 2);
        assert_eq!(b.nonzero_extent_and_finite(), (None, true));
        b.copy_leading_columns(&a, 4);
        for j in 0..10 {
            for i in j..10 {
                let expected = if j < 4 { a.get(i, j) } else { 0.0 };
                assert_eq!(b.get(i, j), expected);
            }
        }
        // column 3 reaches row 5
        assert_eq!(b.nonzero_extent_and_finite(), (Some((0, 5)), true));
        let mut c = BandedSym::zeros(6, 3);
        c.add(4, 1, 1.0).expect("in band");
        assert_eq!(c.nonzero_extent_and_finite(), (Some((1, 4)), true));
        // a NaN counts as nonzero, and is not finite
        b.add(9, 8, f64::NAN).expect("in band");
        assert_eq!(b.nonzero_extent_and_finite(), (Some((0, 9)), false));
        c.add(5, 5, f64::INFINITY).expect("in band");
        assert_eq!(c.nonzero_extent_and_finite(), (Some((1, 5)), false));
        // an indefinite leading block is refused, and says so to the others
        let mut d = BandedSym::zeros(3, 1);
        d.add_to_diagonal(&[-1.0, 1.0, 1.0]);
        assert!(!d.eliminate_leading(1, None));
        let abort = AtomicBool::new(false);
        assert!(!d.eliminate_leading(1, Some(&abort)));
        assert!(abort.load(Ordering::Relaxed));
        // a set flag stops a positive definite elimination too; a clear
        // one changes nothing
        let spd_matrix = spd(40, 3, 11, 8.0);
        assert!(!spd_matrix.clone().eliminate_leading(40, Some(&abort)));
        let (mut with_flag, mut without) = (spd_matrix.clone(), spd_matrix);
        let clear = AtomicBool::new(false);
        assert!(with_flag.eliminate_leading(40, Some(&clear)));
        assert!(without.eliminate_leading(40, None));
        assert_eq!(with_flag, without);
        assert!(!clear.load(Ordering::Relaxed));
    }

    #[test]
    fn an_indefinite_matrix_is_refused() {
        let mut a = BandedSym::zeros(3, 1);
        a.add_to_diagonal(&[1.0, 1.0, 1.0]);
        a.add(1, 0, 2.0).expect("in band");
        assert!(a.cholesky_in_place().is_err());
        let mut nan = BandedSym::zeros(2, 1);
        nan.add_to_diagonal(&[f64::NAN, 1.0]);
        assert!(nan.cholesky_in_place().is_err());
    }

    #[test]
    fn entries_outside_the_band_are_an_error_and_layouts_are_checked() {
        let mut a = BandedSym::zeros(4, 1);
        assert!(a.add(3, 1, 1.0).is_err());
        assert!(a.add(1, 3, 1.0).is_err());
        assert!(a.add(2, 1, 1.0).is_ok());
        assert_eq!(a.get(1, 2), 1.0);
        assert_eq!(a.get(3, 0), 0.0);
        let ok = BandLayout {
            position: vec![2, 0, 1],
            half_bandwidth: 1,
        };
        assert!(ok.validate(3).is_ok());
        assert!(ok.validate(4).is_err());
        let twice = BandLayout {
            position: vec![0, 0, 1],
            half_bandwidth: 1,
        };
        assert!(twice.validate(3).is_err());
    }

    #[test]
    fn adding_from_the_first_nonzero_column_adds_everything() {
        let a = spd(12, 3, 7, 1.0);
        let mut late = BandedSym::zeros(12, 3);
        assert_eq!(late.first_nonzero_column(), 12);
        late.add(9, 7, 2.5).expect("in the band");
        late.add(11, 11, -1.0).expect("in the band");
        assert_eq!(late.first_nonzero_column(), 7);
        let (mut whole, mut from) = (a.clone(), a.clone());
        whole.add_scaled(1.0, &late);
        from.add_from_column(&late, late.first_nonzero_column());
        assert_eq!(whole, from);
        assert_eq!(from.get(7, 9), a.get(7, 9) + 2.5);
    }
}
