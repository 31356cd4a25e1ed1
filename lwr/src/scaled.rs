//! The metric's own coordinates, and the model's neighbour index in them.
//!
//! Under the diagonal metric $d^2(x, q) = \sum_j m_j^2 (x_j - q_j)^2$, and
//! under the full one $d^2 = |A (x - q)|^2$ with $A = \operatorname{diag}(m) M$
//! (see [`Metric`]), the distance is Euclidean in the scaled coordinates
//! $y = S x$, where $S$ holds the rows of $\operatorname{diag}(m)$ (or of
//! $A$) that are not zero: $d(x, q) = |S x - S q|$. A row of zeros (an input
//! with scale 0, or a zero row of $M$) adds nothing to any distance and is
//! left out, so $y$ has $k \le d$ coordinates.
//!
//! The database's own tree is built in the inputs' units. Once tuning has
//! set a scale to 0 (or small), every neighbourhood is a slab through the
//! whole data set along that input; that tree splits on the input all the
//! same (it is wide in its own units) and cannot prune on it, so a query
//! visits many times its neighbours. A tree over $y$ splits and prunes only
//! where the metric does, and its boxes are as tight in the metric as the
//! data allow.
//!
//! [`ScaledIndex`] is that tree for a model's current metric: a search in it
//! is Euclidean with the support radius inflated by a relative
//! [`CANDIDATE_SLACK`] (and that much of the coordinates' magnitude, against
//! the rounding of $S x$), which yields a superset of the neighbours; each
//! candidate's distance is then computed from its inputs exactly as the
//! database's tree computes it, and the candidates outside the support are
//! dropped. The neighbours and their distances are therefore bitwise those of
//! [`Database`]'s search, so the fits are bitwise the same; only the work to
//! find them changes.

use crate::database::Database;
use crate::kdtree::KdTree;
use crate::metric::Metric;

/// Relative slack of a search in scaled coordinates against rounding (far
/// above the $O(d \epsilon)$ rounding of $S x$ and of the distances).
pub(crate) const CANDIDATE_SLACK: f64 = 1e-9;

/// The map $x \mapsto S x$ to a metric's scaled coordinates.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum ScaledMap {
    /// $y_t = m_j x_j$ for the inputs $j$ with $m_j > 0$, as `(j, m_j)`.
    Diagonal(Vec<(usize, f64)>),
    /// $y_t = a_t^\top x$ for the nonzero rows $a_t$ of $A$ (row-major,
    /// `n_inputs` per row).
    Full {
        /// The kept rows.
        rows: Vec<f64>,
        /// $d$.
        n_inputs: usize,
    },
}

impl ScaledMap {
    /// The map of `metric` over `n_inputs` inputs.
    pub(crate) fn new(metric: &Metric, n_inputs: usize) -> Self {
        match metric {
            Metric::Diagonal(scales) => {
                ScaledMap::Diagonal(scales.iter().copied().enumerate().filter(|&(_, m)| m != 0.0).collect())
            }
            Metric::Full(full) => ScaledMap::Full {
                rows: full
                    .rows()
                    .filter(|row| row.iter().any(|&a| a != 0.0))
                    .flatten()
                    .copied()
                    .collect(),
                n_inputs,
            },
        }
    }

    /// Number $k$ of scaled coordinates.
    pub(crate) fn dim(&self) -> usize {
        match self {
            ScaledMap::Diagonal(kept) => kept.len(),
            ScaledMap::Full { rows, n_inputs } => rows.len() / n_inputs,
        }
    }

    /// Appends $S x$ to `out` and returns the magnitude of the terms summed
    /// in it, $\max_t \sum_j |s_{tj} x_j|$ (what its rounding scales with).
    pub(crate) fn push(&self, x: &[f64], out: &mut Vec<f64>) -> f64 {
        let mut magnitude = 0.0f64;
        match self {
            ScaledMap::Diagonal(kept) => {
                for &(j, m) in kept {
                    let v = m * x[j];
                    magnitude = magnitude.max(v.abs());
                    out.push(v);
                }
            }
            ScaledMap::Full { rows, n_inputs } => {
                for row in rows.chunks_exact(*n_inputs) {
                    let (mut v, mut size) = (0.0, 0.0);
                    for (a, x) in row.iter().zip(x) {
                        v += a * x;
                        size += (a * x).abs();
                    }
                    magnitude = magnitude.max(size);
                    out.push(v);
                }
            }
        }
        magnitude
    }

    /// The squared radius of a Euclidean search in scaled coordinates that
    /// finds every point within `radius` in the metric (over `n_inputs`
    /// inputs) despite rounding, when no coordinate term of a point or of
    /// the query exceeds `magnitude` in size.
    pub(crate) fn inflated_r2(radius: f64, magnitude: f64, n_inputs: usize) -> f64 {
        let r = radius * (1.0 + CANDIDATE_SLACK) + CANDIDATE_SLACK * magnitude * n_inputs as f64;
        r * r
    }
}

/// A k-d tree over the scaled coordinates of a database's points under one
/// metric, kept in step with the database by [`extend`](Self::extend).
#[derive(Debug, Clone)]
pub(crate) struct ScaledIndex {
    map: ScaledMap,
    /// Number of points indexed.
    n: usize,
    /// Scaled coordinates, row-major $n \times k$.
    coords: Vec<f64>,
    /// Largest magnitude of the stored points' coordinate terms.
    magnitude: f64,
    tree: KdTree,
    /// The Euclidean metric of the scaled coordinates.
    euclidean: Metric,
}

impl ScaledIndex {
    /// The index of `db`'s points under `metric`.
    pub(crate) fn new(db: &Database, metric: &Metric) -> Self {
        let map = ScaledMap::new(metric, db.n_inputs());
        let k = map.dim();
        let mut index = Self {
            euclidean: Metric::Diagonal(vec![1.0; k]),
            map,
            n: 0,
            coords: Vec::new(),
            magnitude: 0.0,
            tree: KdTree::default(),
        };
        index.extend(db);
        index
    }

    /// Whether this index is of `metric` (else it must be rebuilt).
    pub(crate) fn is_of(&self, metric: &Metric, n_inputs: usize) -> bool {
        self.map == ScaledMap::new(metric, n_inputs)
    }

    /// Indexes the points `db` holds beyond those already indexed: one by
    /// one into the tree, or by a balanced rebuild when they outnumber the
    /// indexed ones (as [`Database::insert_many`] does).
    pub(crate) fn extend(&mut self, db: &Database) {
        let d = db.n_inputs();
        let k = self.map.dim();
        let n_new = db.len() - self.n;
        let inputs = db.inputs();
        self.coords.reserve(n_new * k);
        for x in inputs[self.n * d..].chunks_exact(d) {
            let size = self.map.push(x, &mut self.coords);
            self.magnitude = self.magnitude.max(size);
        }
        if k == 0 {
            self.n = db.len();
            return;
        }
        if n_new > self.n {
            self.tree = KdTree::build(&self.coords, k);
        } else {
            for i in self.n..db.len() {
                self.tree.insert(i, &self.coords, k);
            }
        }
        self.n = db.len();
    }

    /// Appends `(index, d^2)` for every point of `db` with
    /// $d^2 <$ `radius`$^2$ under `metric` (the index's), with $d^2$ computed
    /// as [`Database`]'s tree search computes it: the same points and bitwise
    /// the same distances, in another order.
    /// Every point with $d^2 <$ `radius`$^2$, as `(index, d^2)` appended in
    /// increasing index order, by one pass over the database: the distances
    /// are those [`within`](Self::within) computes, so the neighbours are
    /// bitwise the same, without the tree's descent or a sort. Cheaper than
    /// the search once the support holds a large part of the data.
    pub(crate) fn scan(db: &Database, metric: &Metric, q: &[f64], radius: f64, out: &mut Vec<(usize, f64)>) {
        let r2 = radius * radius;
        let d = db.n_inputs();
        let inputs = db.inputs();
        out.extend(
            (0..db.len())
                .map(|i| (i, metric.dist2(&inputs[i * d..(i + 1) * d], q)))
                .filter(|&(_, d2)| d2 < r2),
        );
    }

    pub(crate) fn within(&self, db: &Database, metric: &Metric, q: &[f64], radius: f64, out: &mut Vec<(usize, f64)>) {
        debug_assert_eq!(self.n, db.len());
        let r2 = radius * radius;
        let d = db.n_inputs();
        let inputs = db.inputs();
        let exact = |i: usize| metric.dist2(&inputs[i * d..(i + 1) * d], q);
        let k = self.map.dim();
        if k == 0 {
            // the metric ignores every input: all points are at distance 0
            out.extend((0..self.n).map(|i| (i, exact(i))).filter(|&(_, d2)| d2 < r2));
            return;
        }
        let mut yq = Vec::with_capacity(k);
        let size = self.map.push(q, &mut yq);
        let magnitude = self.magnitude.max(size);
        if !magnitude.is_finite() {
            // scaled coordinates that overflow: search in the inputs' units
            db.within_sq(q, metric, r2, out);
            return;
        }
        let start = out.len();
        let inflated = ScaledMap::inflated_r2(radius, magnitude, d);
        self.tree.within(&yq, &self.euclidean, inflated, out);
        let mut kept = start;
        for t in start..out.len() {
            let i = out[t].0;
            let d2 = exact(i);
            if d2 < r2 {
                out[kept] = (i, d2);
                kept += 1;
            }
        }
        out.truncate(kept);
    }
}

#[cfg(test)]
mod tests {
    use proptest::collection::vec;
    use proptest::prelude::*;

    use super::*;
    use crate::fit::{LocalFit, Scratch, Want, fit_found};
    use crate::metric::FullMetric;
    use crate::{Degree, Kernel, LwrModel, LwrSettings};

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    fn sorted(mut v: Vec<(usize, f64)>) -> Vec<(usize, f64)> {
        v.sort_by_key(|p| p.0);
        v
    }

    #[test]
    fn searches_equal_the_database_tree_bitwise() {
        let d = 3;
        let mut seed = 5;
        // a coarse grid (ties at the radius, duplicates), inserted in two
        // halves: the second one by one into the index
        let n = 1500;
        let xs: Vec<Vec<f64>> = (0..n)
            .map(|_| (0..d).map(|_| (lcg(&mut seed) * 16.0).floor() / 16.0 - 0.5).collect())
            .collect();
        let ys = vec![vec![0.0]; n];
        let rotation = [0.6, 0.8, 0.0, -0.8, 0.6, 0.0, 0.3, 0.0, 0.5];
        let metrics = [
            Metric::Diagonal(vec![1.0, 0.0, 2.0]),
            Metric::Diagonal(vec![0.0, 0.0, 0.0]),
            Metric::Diagonal(vec![1e-3, 3.0, 1.0]),
            Metric::Full(FullMetric::new(&[1.0, 2.0, 0.0], &rotation)),
            Metric::Full(FullMetric::new(&[1.0, 1.0, 1.0], &rotation)),
        ];
        for metric in &metrics {
            let mut db = Database::new(d, 1).expect("valid");
            db.insert_many(&xs[..n / 2], &ys[..n / 2]).expect("finite");
            let mut index = ScaledIndex::new(&db, metric);
            for (x, y) in xs[n / 2..].iter().zip(&ys[n / 2..]) {
                db.insert(x, y).expect("finite");
                index.extend(&db);
            }
            assert!(index.is_of(metric, d));
            for t in 0..40 {
                // stored points (exact ties) and random queries
                let q: Vec<f64> = if t % 2 == 0 {
                    xs[t * 31 % n].clone()
                } else {
                    (0..d).map(|_| lcg(&mut seed) - 0.5).collect()
                };
                for radius in [0.0, 1.0 / 16.0, 0.2, 3.0] {
                    let (mut got, mut want) = (Vec::new(), Vec::new());
                    index.within(&db, metric, &q, radius, &mut got);
                    db.within_sq(&q, metric, radius * radius, &mut want);
                    let (got, want) = (sorted(got), sorted(want));
                    let same = got.len() == want.len()
                        && got
                            .iter()
                            .zip(&want)
                            .all(|(a, b)| a.0 == b.0 && a.1.to_bits() == b.1.to_bits());
                    assert!(same, "{metric:?} r {radius}: {} vs {} points", got.len(), want.len());
                }
            }
        }
    }

    /// The fit at `q` from a brute-force neighbour list: every point with
    /// $d^2 <$ (support radius)$^2$, by a linear scan, in index order.
    fn brute_force_fit(model: &LwrModel, q: &[f64], want: Want) -> crate::Result<LocalFit> {
        let db = model.database();
        if db.is_empty() {
            return Err(crate::LwrError::EmptyDatabase);
        }
        let settings = model.settings();
        let metric = Metric::of_settings(settings, db.n_inputs());
        let radius = settings.support_radius();
        let mut scratch = Scratch::default();
        scratch.found = (0..db.len())
            .map(|i| (i, metric.dist2(db.input(i).expect("stored"), q)))
            .filter(|&(_, d2)| d2 < radius * radius)
            .collect();
        fit_found(db, settings, &metric, q, want, &mut scratch)
    }

    /// Scales: 0 (the input ignored), tiny, or moderate.
    fn scale() -> impl Strategy<Value = f64> {
        prop_oneof![Just(0.0), Just(1e-4), 0.2..3.0f64]
    }

    /// Settings over `d` inputs: the scales, optionally a full matrix $M$.
    fn settings(d: usize) -> impl Strategy<Value = LwrSettings> {
        (
            vec(scale(), d),
            prop_oneof![Just(Vec::new()), vec(-1.0..1.0f64, d * d)],
            prop_oneof![Just(Kernel::Gaussian), Just(Kernel::Tricube)],
            prop_oneof![Just(Degree::Linear), Just(Degree::Quadratic)],
            0.1..0.8f64,
        )
            .prop_map(|(scales, metric, kernel, degree, bandwidth)| LwrSettings {
                scales,
                metric,
                kernel,
                degree,
                bandwidth,
                ridge: 1e-8,
                ..Default::default()
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        /// Every fit through the scaled index (coefficients, confidence sums,
        /// Jacobian, or the error) is bitwise the brute-force neighbours'
        /// fit: for zero, tiny and moderate scales, diagonal and full
        /// metrics, after inserting in bulk and one by one, and after a
        /// change of metric followed by more inserts.
        #[test]
        fn fits_equal_brute_force_neighbours_bitwise(
            (points, first, second) in (1usize..4).prop_flat_map(|d| (
                vec(vec(-8i32..8, d), 1..160),
                settings(d),
                settings(d),
            )),
            queries in vec(vec(-1.2..1.2f64, 3), 6),
        ) {
            let d = first.scales.len();
            // a coarse grid: duplicates and exact ties at the support's edge
            let xs: Vec<Vec<f64>> = points.iter().map(|p| p.iter().map(|&v| v as f64 / 8.0).collect()).collect();
            let ys: Vec<[f64; 2]> = xs.iter().map(|x| [x.iter().map(|v| v.sin()).sum(), x[0] * x[0]]).collect();
            let (bulk, rest) = (xs.len() / 2, xs.len() * 3 / 4);
            let mut model = LwrModel::new(d, 2, first).expect("valid settings");
            let check = |model: &LwrModel| -> std::result::Result<(), TestCaseError> {
                let stored = (0..model.len().min(5)).map(|i| model.database().input(i).expect("stored").to_vec());
                for q in queries.iter().map(|q| q[..d].to_vec()).chain(stored) {
                    for want in [
                        Want::default(),
                        Want { confidence: true, jacobian: false },
                        Want { confidence: true, jacobian: true },
                    ] {
                        let got = format!("{:?}", model.fit_with(&q, want));
                        prop_assert_eq!(got, format!("{:?}", brute_force_fit(model, &q, want)), "q {:?}", q);
                    }
                }
                Ok(())
            };
            model.insert_many(&xs[..bulk], &ys[..bulk]).expect("finite");
            for (x, y) in xs[bulk..rest].iter().zip(&ys[bulk..rest]) {
                model.insert(x, y).expect("finite");
            }
            check(&model)?;
            model.set_settings(second).expect("valid settings");
            model.insert_many(&xs[rest..], &ys[rest..]).expect("finite");
            check(&model)?;
            // and as loaded from a file (the index rebuilt from the points)
            let loaded = LwrModel::from_json(&model.to_json().expect("saves")).expect("loads");
            check(&loaded)?;
        }
    }

    #[test]
    fn zero_rows_drop_out_of_the_coordinates() {
        let map = ScaledMap::new(&Metric::Diagonal(vec![2.0, 0.0, 0.5]), 3);
        let mut y = Vec::new();
        let size = map.push(&[1.0, 7.0, -4.0], &mut y);
        assert_eq!(y, vec![2.0, -2.0]);
        assert_eq!(size, 2.0);
        let full = Metric::Full(FullMetric::new(&[0.0, 1.0], &[1.0, 2.0, 3.0, -1.0]));
        let map = ScaledMap::new(&full, 2);
        assert_eq!(map.dim(), 1);
        y.clear();
        let size = map.push(&[1.0, 2.0], &mut y);
        assert_eq!(y, vec![1.0]);
        assert_eq!(size, 5.0);
    }
}
