//! The growing database of (input, output) pairs and its neighbour queries.

use serde::{Deserialize, Serialize};

use crate::error::{LwrError, Result, check_finite, check_len};
use crate::kdtree::KdTree;
use crate::metric::{Metric, diag_dist2};

/// A stored point found by a query: its index in the database and its scaled
/// distance $d = \sqrt{\sum_j m_j^2 (x_j - q_j)^2}$ to the query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Neighbor {
    /// Index of the point (insertion order, starting at 0).
    pub index: usize,
    /// Scaled distance to the query.
    pub distance: f64,
}

/// A database of points $(x_i, y_i)$, $x_i \in \mathbb{R}^{d}$,
/// $y_i \in \mathbb{R}^{o}$, indexed by a k-d tree.
///
/// Points are appended with [`insert`](Self::insert) or
/// [`insert_many`](Self::insert_many) at any time; the tree grows by
/// splitting full leaf buckets and rebuilds only subtrees that became
/// unbalanced, never the whole tree on every insert. Queries use a diagonal
/// metric with per-dimension scales $m_j \ge 0$; a zero scale ignores its
/// dimension.
///
/// ```
/// use lwr::Database;
/// let mut db = Database::new(2, 1)?;
/// db.insert(&[0.0, 0.0], &[1.0])?;
/// db.insert(&[1.0, 0.0], &[2.0])?;
/// db.insert(&[0.0, 3.0], &[3.0])?;
/// // the second input is ignored (scale 0): two points within 0.5 of (0, 10)
/// let near = db.within_radius(&[0.0, 10.0], &[1.0, 0.0], 0.5)?;
/// assert_eq!(near.len(), 2);
/// let nn = db.nearest(&[0.9, 0.0], &[1.0, 1.0], 1)?;
/// assert_eq!(nn[0].index, 1);
/// # Ok::<(), lwr::LwrError>(())
/// ```
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(try_from = "DatabaseData", into = "DatabaseData")]
pub struct Database {
    n_inputs: usize,
    n_outputs: usize,
    inputs: Vec<f64>,
    outputs: Vec<f64>,
    tree: KdTree,
}

/// The serialised form: the points only; the tree is rebuilt on load.
#[derive(Serialize, Deserialize)]
pub(crate) struct DatabaseData {
    n_inputs: usize,
    n_outputs: usize,
    inputs: Vec<f64>,
    outputs: Vec<f64>,
}

impl From<Database> for DatabaseData {
    fn from(db: Database) -> Self {
        Self {
            n_inputs: db.n_inputs,
            n_outputs: db.n_outputs,
            inputs: db.inputs,
            outputs: db.outputs,
        }
    }
}

impl TryFrom<DatabaseData> for Database {
    type Error = LwrError;

    fn try_from(data: DatabaseData) -> Result<Self> {
        Database::from_flat(data.n_inputs, data.n_outputs, data.inputs, data.outputs)
    }
}

impl Database {
    /// An empty database for `n_inputs`-dimensional inputs and
    /// `n_outputs`-dimensional outputs (both at least 1).
    pub fn new(n_inputs: usize, n_outputs: usize) -> Result<Self> {
        if n_inputs == 0 {
            return Err(LwrError::InvalidParameter {
                name: "n_inputs",
                reason: "must be at least 1".into(),
            });
        }
        if n_outputs == 0 {
            return Err(LwrError::InvalidParameter {
                name: "n_outputs",
                reason: "must be at least 1".into(),
            });
        }
        Ok(Self {
            n_inputs,
            n_outputs,
            inputs: Vec::new(),
            outputs: Vec::new(),
            tree: KdTree::default(),
        })
    }

    /// A database over row-major flat arrays (`inputs.len() = n d`,
    /// `outputs.len() = n o`), with the tree built balanced in one go.
    pub fn from_flat(n_inputs: usize, n_outputs: usize, inputs: Vec<f64>, outputs: Vec<f64>) -> Result<Self> {
        let mut db = Self::new(n_inputs, n_outputs)?;
        if !inputs.len().is_multiple_of(n_inputs) {
            return Err(LwrError::DimensionMismatch {
                what: "flat inputs (a multiple of n_inputs)",
                expected: inputs.len() / n_inputs * n_inputs,
                actual: inputs.len(),
            });
        }
        let n = inputs.len() / n_inputs;
        check_len("flat outputs", n * n_outputs, outputs.len())?;
        check_finite("inputs", &inputs)?;
        check_finite("outputs", &outputs)?;
        db.tree = KdTree::build(&inputs, n_inputs);
        db.inputs = inputs;
        db.outputs = outputs;
        Ok(db)
    }

    /// Number of stored points.
    pub fn len(&self) -> usize {
        self.inputs.len() / self.n_inputs
    }

    /// Whether no point is stored.
    pub fn is_empty(&self) -> bool {
        self.inputs.is_empty()
    }

    /// Input dimension $d$.
    pub fn n_inputs(&self) -> usize {
        self.n_inputs
    }

    /// Output dimension $o$.
    pub fn n_outputs(&self) -> usize {
        self.n_outputs
    }

    /// Input of point `i`, or `None` if out of range.
    pub fn input(&self, i: usize) -> Option<&[f64]> {
        self.inputs.get(i * self.n_inputs..(i + 1) * self.n_inputs)
    }

    /// Output of point `i`, or `None` if out of range.
    pub fn output(&self, i: usize) -> Option<&[f64]> {
        self.outputs.get(i * self.n_outputs..(i + 1) * self.n_outputs)
    }

    /// All inputs, row-major ($n \times d$).
    pub fn inputs(&self) -> &[f64] {
        &self.inputs
    }

    /// All outputs, row-major ($n \times o$).
    pub fn outputs(&self) -> &[f64] {
        &self.outputs
    }

    /// Appends one point and returns its index. Rejects wrong lengths and
    /// non-finite values, leaving the database unchanged.
    pub fn insert(&mut self, x: &[f64], y: &[f64]) -> Result<usize> {
        self.check_point(x, y)?;
        Ok(self.push(x, y))
    }

    /// Appends many points. All are checked first: on error nothing is
    /// inserted.
    pub fn insert_many<X: AsRef<[f64]>, Y: AsRef<[f64]>>(&mut self, xs: &[X], ys: &[Y]) -> Result<()> {
        check_len("outputs (one per input)", xs.len(), ys.len())?;
        for (x, y) in xs.iter().zip(ys) {
            self.check_point(x.as_ref(), y.as_ref())?;
        }
        let n_new = xs.len();
        if n_new > self.len() {
            // cheaper to rebuild balanced than to insert one by one
            for (x, y) in xs.iter().zip(ys) {
                self.inputs.extend_from_slice(x.as_ref());
                self.outputs.extend_from_slice(y.as_ref());
            }
            self.rebuild();
        } else {
            for (x, y) in xs.iter().zip(ys) {
                self.push(x.as_ref(), y.as_ref());
            }
        }
        Ok(())
    }

    fn check_point(&self, x: &[f64], y: &[f64]) -> Result<()> {
        check_len("input", self.n_inputs, x.len())?;
        check_len("output", self.n_outputs, y.len())?;
        check_finite("input", x)?;
        check_finite("output", y)
    }

    fn push(&mut self, x: &[f64], y: &[f64]) -> usize {
        let i = self.len();
        self.inputs.extend_from_slice(x);
        self.outputs.extend_from_slice(y);
        self.tree.insert(i, &self.inputs, self.n_inputs);
        i
    }

    /// Rebuilds the tree balanced (never needed for correctness).
    pub fn rebuild(&mut self) {
        self.tree = KdTree::build(&self.inputs, self.n_inputs);
    }

    /// Number of levels of the k-d tree (0 when empty).
    pub fn tree_depth(&self) -> usize {
        self.tree.depth()
    }

    /// Checks a query's length and values.
    pub(crate) fn check_point_query(&self, q: &[f64]) -> Result<()> {
        check_len("query", self.n_inputs, q.len())?;
        check_finite("query", q)
    }

    pub(crate) fn check_query(&self, q: &[f64], scales: &[f64]) -> Result<()> {
        self.check_point_query(q)?;
        check_len("metric scales", self.n_inputs, scales.len())?;
        check_finite("metric scales", scales)?;
        if let Some(j) = scales.iter().position(|&m| m < 0.0) {
            return Err(LwrError::InvalidParameter {
                name: "metric scales",
                reason: format!("scale {j} is negative ({})", scales[j]),
            });
        }
        Ok(())
    }

    /// Unchecked radius query: `(index, d^2)` with `d^2 < r2`, any order.
    pub(crate) fn within_sq(&self, q: &[f64], metric: &Metric, r2: f64, out: &mut Vec<(usize, f64)>) {
        self.tree.within(q, metric, r2, out);
    }

    /// Unchecked k-nearest query: `(index, d^2)`, nearest first.
    pub(crate) fn nearest_sq(&self, q: &[f64], metric: &Metric, k: usize) -> Vec<(usize, f64)> {
        self.tree.nearest(self.n_inputs, q, metric, k)
    }

    /// All points with scaled distance $d < r$ from `q` (tree search),
    /// sorted by distance, then index.
    pub fn within_radius(&self, q: &[f64], scales: &[f64], radius: f64) -> Result<Vec<Neighbor>> {
        self.check_query(q, scales)?;
        check_radius(radius)?;
        let mut out = Vec::new();
        self.within_sq(q, &Metric::Diagonal(scales.to_vec()), radius * radius, &mut out);
        Ok(to_neighbors(out))
    }

    /// The `k` points nearest to `q` (tree search), nearest first (fewer if
    /// the database holds fewer). Ties at the $k$-th distance are broken
    /// arbitrarily.
    pub fn nearest(&self, q: &[f64], scales: &[f64], k: usize) -> Result<Vec<Neighbor>> {
        self.check_query(q, scales)?;
        Ok(to_neighbors(self.nearest_sq(q, &Metric::Diagonal(scales.to_vec()), k)))
    }

    /// [`within_radius`](Self::within_radius) by a linear scan: the
    /// reference for tests.
    pub fn within_radius_brute(&self, q: &[f64], scales: &[f64], radius: f64) -> Result<Vec<Neighbor>> {
        self.check_query(q, scales)?;
        check_radius(radius)?;
        let r2 = radius * radius;
        let out = (0..self.len())
            .map(|i| (i, diag_dist2(&self.inputs[i * self.n_inputs..], q, scales)))
            .filter(|&(_, d2)| d2 < r2)
            .collect();
        Ok(to_neighbors(out))
    }

    /// [`nearest`](Self::nearest) by a linear scan: the reference for tests.
    pub fn nearest_brute(&self, q: &[f64], scales: &[f64], k: usize) -> Result<Vec<Neighbor>> {
        self.check_query(q, scales)?;
        let all = (0..self.len())
            .map(|i| (i, diag_dist2(&self.inputs[i * self.n_inputs..], q, scales)))
            .collect();
        let mut all = to_neighbors(all);
        all.truncate(k);
        Ok(all)
    }
}

fn check_radius(radius: f64) -> Result<()> {
    if radius.is_nan() || radius < 0.0 {
        return Err(LwrError::InvalidParameter {
            name: "radius",
            reason: format!("must be nonnegative, got {radius}"),
        });
    }
    Ok(())
}

fn to_neighbors(mut v: Vec<(usize, f64)>) -> Vec<Neighbor> {
    v.sort_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
    v.into_iter()
        .map(|(index, d2)| Neighbor {
            index,
            distance: d2.sqrt(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bad_points_atomically() {
        let mut db = Database::new(2, 1).expect("valid");
        assert!(matches!(
            db.insert(&[1.0], &[0.0]),
            Err(LwrError::DimensionMismatch {
                expected: 2,
                actual: 1,
                ..
            })
        ));
        assert!(matches!(
            db.insert(&[1.0, f64::NAN], &[0.0]),
            Err(LwrError::NotFinite { index: 1, .. })
        ));
        let xs = [[0.0, 0.0], [1.0, f64::INFINITY]];
        let ys = [[0.0], [1.0]];
        assert!(db.insert_many(&xs, &ys).is_err());
        assert!(db.is_empty());
        assert!(Database::new(0, 1).is_err());
    }

    #[test]
    fn insert_many_then_query() {
        let mut db = Database::new(1, 1).expect("valid");
        let xs: Vec<[f64; 1]> = (0..100).map(|i| [i as f64]).collect();
        let ys: Vec<[f64; 1]> = (0..100).map(|i| [2.0 * i as f64]).collect();
        db.insert_many(&xs, &ys).expect("valid");
        db.insert_many(&xs[..10], &ys[..10]).expect("valid");
        assert_eq!(db.len(), 110);
        let near = db.within_radius(&[5.0], &[1.0], 1.5).expect("valid");
        assert_eq!(near.len(), 6); // 4, 5, 6 twice each
        assert_eq!(db.output(105), Some(&[10.0][..]));
        assert!(db.within_radius(&[5.0], &[-1.0], 1.0).is_err());
    }
}
