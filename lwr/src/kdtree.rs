//! A k-d tree over the database's inputs, with leaf buckets that split when
//! full and subtrees rebuilt when they become unbalanced.
//!
//! Distances are diagonal, $d^2(x, q) = \sum_j m_j^2 (x_j - q_j)^2$ with
//! per-dimension scales $m_j \ge 0$ (a zero scale ignores the dimension), or
//! full, $d^2 = |A (x - q)|^2$ (see [`Metric`]). Every node keeps the tight
//! bounding box of its points, so a query prunes a node when a lower bound
//! on the box's smallest possible distance (exact for the diagonal metric)
//! already exceeds the radius (or the current k-th distance). Points are
//! indices into the flat, row-major input array owned by
//! [`Database`](crate::Database).
//!
//! Leaves keep a copy of their points' coordinates, so a query scans them
//! contiguously instead of gathering rows from the database (2-3 times
//! faster for random 5-D queries on $10^5$ points on a busy 2-core machine;
//! the inputs are stored twice). Leaves hold up to [`BUCKET`] = 32 points,
//! which measured faster than 8 or 16 in 5-D and the same in 2-D.
//!
//! Insertion descends to a leaf and appends; a leaf holding more than
//! [`BUCKET`] points splits at the median of its widest dimension (a leaf of
//! identical points cannot split and simply grows). An inner node whose
//! subtree has at least doubled since it was built and whose larger child
//! holds more than [`ALPHA`] of its points is rebuilt balanced, so the
//! rebuild cost is amortised over the inserts that caused it (as in a
//! scapegoat tree).

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use crate::metric::{Metric, diag_dist2};

/// Largest number of points in a leaf that can still be split.
pub(crate) const BUCKET: usize = 32;
/// Largest fraction of an inner node's points that one child may hold before
/// the node is rebuilt.
pub(crate) const ALPHA: f64 = 0.75;

#[derive(Debug, Clone)]
struct Bounds {
    lo: Vec<f64>,
    hi: Vec<f64>,
}

impl Bounds {
    fn of_point(x: &[f64]) -> Self {
        Self {
            lo: x.to_vec(),
            hi: x.to_vec(),
        }
    }

    fn expand(&mut self, x: &[f64]) {
        for ((lo, hi), &v) in self.lo.iter_mut().zip(&mut self.hi).zip(x) {
            if v < *lo {
                *lo = v;
            }
            if v > *hi {
                *hi = v;
            }
        }
    }

    /// Lower bound (exact for a diagonal metric) on the squared distance
    /// from `q` to any point of the box.
    #[inline]
    fn min_dist2(&self, q: &[f64], metric: &Metric) -> f64 {
        metric.min_dist2_with(q.len(), |j| (self.lo[j] - q[j], self.hi[j] - q[j]))
    }

    /// Lower bound (exact for a diagonal metric) on the squared distance
    /// between any point of this box and any point of the box `[lo, hi]`.
    #[inline]
    fn min_dist2_box(&self, lo: &[f64], hi: &[f64], metric: &Metric) -> f64 {
        metric.min_dist2_with(lo.len(), |j| (self.lo[j] - hi[j], self.hi[j] - lo[j]))
    }

    /// Widest dimension and its spread.
    fn widest(&self) -> (usize, f64) {
        let mut best = (0, -1.0);
        for j in 0..self.lo.len() {
            let w = self.hi[j] - self.lo[j];
            if w > best.1 {
                best = (j, w);
            }
        }
        best
    }
}

/// Appends `(index, d^2)` for every point of a leaf with $d^2 <$ `r2`.
#[inline]
fn scan_leaf(indices: &[usize], coords: &[f64], q: &[f64], metric: &Metric, r2: f64, out: &mut Vec<(usize, f64)>) {
    fn scan(
        indices: &[usize],
        coords: &[f64],
        d: usize,
        r2: f64,
        out: &mut Vec<(usize, f64)>,
        dist2: impl Fn(&[f64]) -> f64,
    ) {
        for (&i, x) in indices.iter().zip(coords.chunks_exact(d)) {
            let d2 = dist2(x);
            if d2 < r2 {
                out.push((i, d2));
            }
        }
    }
    match metric {
        Metric::Diagonal(scales) => scan(indices, coords, q.len(), r2, out, |x| diag_dist2(x, q, scales)),
        Metric::Full(f) => scan(indices, coords, q.len(), r2, out, |x| f.dist2(x, q)),
    }
}

#[derive(Debug, Clone)]
enum Node {
    Leaf {
        bounds: Bounds,
        indices: Vec<usize>,
        /// The points' coordinates, row-major, in `indices` order: queries
        /// scan them contiguously instead of gathering from the database.
        coords: Vec<f64>,
    },
    Inner {
        bounds: Bounds,
        dim: usize,
        /// Points with `x[dim] < split` go left, the others right.
        split: f64,
        left: Box<Node>,
        right: Box<Node>,
        count: usize,
        /// `count` when this subtree was last built.
        built: usize,
    },
}

fn point(points: &[f64], d: usize, i: usize) -> &[f64] {
    &points[i * d..(i + 1) * d]
}

impl Node {
    fn count(&self) -> usize {
        match self {
            Node::Leaf { indices, .. } => indices.len(),
            Node::Inner { count, .. } => *count,
        }
    }

    fn bounds(&self) -> &Bounds {
        match self {
            Node::Leaf { bounds, .. } | Node::Inner { bounds, .. } => bounds,
        }
    }

    fn depth(&self) -> usize {
        match self {
            Node::Leaf { .. } => 1,
            Node::Inner { left, right, .. } => 1 + left.depth().max(right.depth()),
        }
    }

    fn collect(&self, out: &mut Vec<usize>) {
        match self {
            Node::Leaf { indices, .. } => out.extend_from_slice(indices),
            Node::Inner { left, right, .. } => {
                left.collect(out);
                right.collect(out);
            }
        }
    }

    /// Builds a balanced subtree over `indices` (nonempty).
    fn build(mut indices: Vec<usize>, points: &[f64], d: usize) -> Node {
        debug_assert!(!indices.is_empty());
        let mut bounds = Bounds::of_point(point(points, d, indices[0]));
        for &i in &indices[1..] {
            bounds.expand(point(points, d, i));
        }
        let (dim, spread) = bounds.widest();
        if indices.len() <= BUCKET || spread <= 0.0 {
            let mut coords = Vec::with_capacity(indices.len() * d);
            for &i in &indices {
                coords.extend_from_slice(point(points, d, i));
            }
            return Node::Leaf {
                bounds,
                indices,
                coords,
            };
        }
        let coord = |i: usize| points[i * d + dim];
        let mid = indices.len() / 2;
        indices.select_nth_unstable_by(mid, |&a, &b| coord(a).total_cmp(&coord(b)));
        let mut split = coord(indices[mid]);
        if split <= bounds.lo[dim] {
            // the median is the minimum: split just above it instead
            split = indices
                .iter()
                .map(|&i| coord(i))
                .filter(|&v| v > split)
                .fold(f64::INFINITY, f64::min);
        }
        let (left, right): (Vec<usize>, Vec<usize>) = indices.into_iter().partition(|&i| coord(i) < split);
        debug_assert!(!left.is_empty() && !right.is_empty());
        let count = left.len() + right.len();
        Node::Inner {
            bounds,
            dim,
            split,
            left: Box::new(Node::build(left, points, d)),
            right: Box::new(Node::build(right, points, d)),
            count,
            built: count,
        }
    }

    fn insert(&mut self, i: usize, points: &[f64], d: usize) {
        let x = point(points, d, i);
        let rebuild = match self {
            Node::Leaf {
                bounds,
                indices,
                coords,
            } => {
                bounds.expand(x);
                indices.push(i);
                coords.extend_from_slice(x);
                indices.len() > BUCKET && bounds.widest().1 > 0.0
            }
            Node::Inner {
                bounds,
                dim,
                split,
                left,
                right,
                count,
                built,
            } => {
                bounds.expand(x);
                *count += 1;
                if x[*dim] < *split {
                    left.insert(i, points, d);
                } else {
                    right.insert(i, points, d);
                }
                let big = left.count().max(right.count()) as f64;
                *count >= 2 * *built && big > ALPHA * *count as f64
            }
        };
        if rebuild {
            let mut indices = Vec::with_capacity(self.count());
            self.collect(&mut indices);
            *self = Node::build(indices, points, d);
        }
    }

    fn within(&self, q: &[f64], metric: &Metric, r2: f64, out: &mut Vec<(usize, f64)>) {
        if self.bounds().min_dist2(q, metric) >= r2 {
            return;
        }
        match self {
            Node::Leaf { indices, coords, .. } => scan_leaf(indices, coords, q, metric, r2, out),
            Node::Inner { left, right, .. } => {
                left.within(q, metric, r2, out);
                right.within(q, metric, r2, out);
            }
        }
    }

    fn leaves<'a>(&'a self, out: &mut Vec<Leaf<'a>>) {
        match self {
            Node::Leaf {
                bounds,
                indices,
                coords,
            } => out.push(Leaf {
                indices,
                coords,
                lo: &bounds.lo,
                hi: &bounds.hi,
            }),
            Node::Inner { left, right, .. } => {
                left.leaves(out);
                right.leaves(out);
            }
        }
    }

    fn within_box(&self, d: usize, lo: &[f64], hi: &[f64], metric: &Metric, r2: f64, out: &mut Vec<usize>) {
        if self.bounds().min_dist2_box(lo, hi, metric) >= r2 {
            return;
        }
        match self {
            Node::Leaf { indices, coords, .. } => {
                for (&i, x) in indices.iter().zip(coords.chunks_exact(d)) {
                    // offsets x - q over the queries q in [lo, hi]
                    if metric.min_dist2_with(d, |j| (x[j] - hi[j], x[j] - lo[j])) < r2 {
                        out.push(i);
                    }
                }
            }
            Node::Inner { left, right, .. } => {
                left.within_box(d, lo, hi, metric, r2, out);
                right.within_box(d, lo, hi, metric, r2, out);
            }
        }
    }

    fn nearest(&self, d: usize, q: &[f64], metric: &Metric, k: usize, heap: &mut BinaryHeap<Candidate>) {
        match self {
            Node::Leaf { indices, coords, .. } => {
                for (&i, x) in indices.iter().zip(coords.chunks_exact(d)) {
                    let d2 = metric.dist2(x, q);
                    if heap.len() < k {
                        heap.push(Candidate { d2, index: i });
                    } else if heap.peek().is_some_and(|w| d2 < w.d2) {
                        heap.pop();
                        heap.push(Candidate { d2, index: i });
                    }
                }
            }
            Node::Inner { left, right, .. } => {
                let dl = left.bounds().min_dist2(q, metric);
                let dr = right.bounds().min_dist2(q, metric);
                let (first, df, second, ds) = if dl <= dr {
                    (left, dl, right, dr)
                } else {
                    (right, dr, left, dl)
                };
                for (child, dc) in [(first, df), (second, ds)] {
                    let worst = if heap.len() < k {
                        f64::INFINITY
                    } else {
                        heap.peek().map_or(f64::INFINITY, |w| w.d2)
                    };
                    if dc < worst {
                        child.nearest(d, q, metric, k, heap);
                    }
                }
            }
        }
    }
}

/// A leaf of the tree: its points (indices and row-major coordinates) and
/// their bounding box.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Leaf<'a> {
    pub(crate) indices: &'a [usize],
    pub(crate) coords: &'a [f64],
    pub(crate) lo: &'a [f64],
    pub(crate) hi: &'a [f64],
}

/// A heap entry ordered by squared distance, then index.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Candidate {
    pub(crate) d2: f64,
    pub(crate) index: usize,
}

impl Eq for Candidate {}

impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Candidate {
    fn cmp(&self, other: &Self) -> Ordering {
        self.d2.total_cmp(&other.d2).then(self.index.cmp(&other.index))
    }
}

/// The tree: `None` while the database is empty.
#[derive(Debug, Clone, Default)]
pub(crate) struct KdTree {
    root: Option<Node>,
}

impl KdTree {
    /// Builds a balanced tree over points `0..n` of the flat array.
    pub(crate) fn build(points: &[f64], d: usize) -> Self {
        let n = points.len().checked_div(d).unwrap_or(0);
        if n == 0 {
            return Self { root: None };
        }
        Self {
            root: Some(Node::build((0..n).collect(), points, d)),
        }
    }

    /// Adds point `i` (already stored in `points`).
    pub(crate) fn insert(&mut self, i: usize, points: &[f64], d: usize) {
        match &mut self.root {
            None => {
                self.root = Some(Node::Leaf {
                    bounds: Bounds::of_point(point(points, d, i)),
                    indices: vec![i],
                    coords: point(points, d, i).to_vec(),
                });
            }
            Some(root) => root.insert(i, points, d),
        }
    }

    /// Appends `(index, d^2)` for every point with `d^2 < r2`.
    pub(crate) fn within(&self, q: &[f64], metric: &Metric, r2: f64, out: &mut Vec<(usize, f64)>) {
        if let Some(root) = &self.root {
            root.within(q, metric, r2, out);
        }
    }

    /// The `k` nearest points as `(index, d^2)`, nearest first.
    pub(crate) fn nearest(&self, d: usize, q: &[f64], metric: &Metric, k: usize) -> Vec<(usize, f64)> {
        let mut heap = BinaryHeap::with_capacity(k + 1);
        if let (Some(root), true) = (&self.root, k > 0) {
            root.nearest(d, q, metric, k, &mut heap);
        }
        heap.into_sorted_vec().into_iter().map(|c| (c.index, c.d2)).collect()
    }

    /// Every leaf, left to right.
    pub(crate) fn leaves(&self) -> Vec<Leaf<'_>> {
        let mut out = Vec::new();
        if let Some(root) = &self.root {
            root.leaves(&mut out);
        }
        out
    }

    /// Appends the index of every point whose squared scaled distance to the
    /// box `[lo, hi]` is below `r2`: a superset of the points within
    /// $\sqrt{r_2}$ of any query in the box. The box distance of a point is
    /// at most its distance to any query in the box also in floating point
    /// (rounding is monotone), so no neighbour of such a query is missed.
    pub(crate) fn within_box(&self, d: usize, lo: &[f64], hi: &[f64], metric: &Metric, r2: f64, out: &mut Vec<usize>) {
        if let Some(root) = &self.root {
            root.within_box(d, lo, hi, metric, r2, out);
        }
    }

    /// Number of levels (0 for an empty tree).
    pub(crate) fn depth(&self) -> usize {
        self.root.as_ref().map_or(0, Node::depth)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metric::FullMetric;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (*seed >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn sorted_inserts_stay_shallow() {
        let d = 1;
        let n = 20_000;
        let points: Vec<f64> = (0..n).map(|i| i as f64).collect();
        let mut tree = KdTree::default();
        for i in 0..n {
            tree.insert(i, &points, d);
        }
        // a balanced tree has about log2(n / BUCKET) + 1 = 11 levels; sorted
        // inserts (the worst case for a plain k-d tree: depth n / BUCKET)
        // stay within a few levels of it
        let balanced = KdTree::build(&points, d).depth();
        assert!(tree.depth() <= balanced + 8, "depth {} vs {balanced}", tree.depth());
        let mut out = Vec::new();
        tree.within(&[100.0], &Metric::Diagonal(vec![1.0]), 2.5 * 2.5, &mut out);
        out.sort_by_key(|p| p.0);
        let idx: Vec<usize> = out.iter().map(|p| p.0).collect();
        assert_eq!(idx, vec![98, 99, 100, 101, 102]);
    }

    #[test]
    fn duplicates_do_not_split_forever() {
        let d = 2;
        let points = vec![1.0; 2 * 500];
        let mut tree = KdTree::default();
        for i in 0..500 {
            tree.insert(i, &points, d);
        }
        assert_eq!(tree.depth(), 1);
        let near = tree.nearest(d, &[0.0, 0.0], &Metric::Diagonal(vec![1.0, 1.0]), 3);
        assert_eq!(near.len(), 3);
    }

    #[test]
    fn box_candidates_contain_every_neighbour_of_the_leaf() {
        let d = 3;
        let mut seed = 11;
        let n = 2000;
        // a coarse grid with duplicates and a zero scale: ties at the radius
        let points: Vec<f64> = (0..n * d).map(|_| (lcg(&mut seed) * 8.0).floor() / 8.0).collect();
        let tree = KdTree::build(&points, d);
        // a diagonal metric with a zero scale, and a full one of rank 2
        let rotation = [0.6, 0.8, 0.0, -0.8, 0.6, 0.0, 0.3, 0.0, 0.5];
        for metric in [
            Metric::Diagonal(vec![1.0, 0.0, 2.0]),
            Metric::Full(FullMetric::new(&[1.0, 2.0, 0.0], &rotation)),
        ] {
            for r2 in [0.0, 0.125 * 0.125, 0.25 * 0.25, 1.0] {
                for leaf in tree.leaves() {
                    let mut cands = Vec::new();
                    tree.within_box(d, leaf.lo, leaf.hi, &metric, r2, &mut cands);
                    cands.sort_unstable();
                    for q in leaf.coords.chunks_exact(d) {
                        for i in 0..n {
                            if metric.dist2(&points[i * d..(i + 1) * d], q) < r2 {
                                assert!(cands.binary_search(&i).is_ok(), "point {i} missed at r2 {r2}");
                            }
                        }
                    }
                }
            }
        }
        let total: usize = tree.leaves().iter().map(|l| l.indices.len()).sum();
        assert_eq!(total, n);
    }

    #[test]
    fn random_knn_matches_brute_force() {
        let d = 3;
        let mut seed = 7;
        let points: Vec<f64> = (0..3000).map(|_| lcg(&mut seed)).collect();
        let mut tree = KdTree::default();
        for i in 0..1000 {
            tree.insert(i, &points, d);
        }
        let q = [0.3, 0.9, 0.5];
        let matrix = [1.0, 2.0, 0.5, -0.3, 1.0, 0.0, 0.2, 0.1, 3.0];
        for metric in [
            Metric::Diagonal(vec![1.0, 0.0, 2.0]),
            Metric::Full(FullMetric::new(&[1.0, 0.5, 2.0], &matrix)),
            Metric::Full(FullMetric::new(&[1.0, 0.0, 2.0], &matrix)),
        ] {
            let got = tree.nearest(d, &q, &metric, 10);
            let mut all: Vec<f64> = (0..1000)
                .map(|i| metric.dist2(&points[i * d..(i + 1) * d], &q))
                .collect();
            all.sort_by(f64::total_cmp);
            let got_d: Vec<f64> = got.iter().map(|p| p.1).collect();
            assert_eq!(got_d, all[..10].to_vec());
        }
    }

    #[test]
    fn full_metric_radius_queries_match_brute_force() {
        let mut seed = 21;
        for d in [2, 3, 5] {
            let n = 1500;
            let points: Vec<f64> = (0..n * d).map(|_| lcg(&mut seed)).collect();
            let tree = KdTree::build(&points, d);
            for trial in 0..6 {
                let matrix: Vec<f64> = (0..d * d).map(|_| 2.0 * lcg(&mut seed) - 1.0).collect();
                // trial 0..2 full rank, then a zero scale (singular A)
                let scales: Vec<f64> = (0..d)
                    .map(|j| {
                        if trial >= 3 && j == 1 {
                            0.0
                        } else {
                            0.5 + lcg(&mut seed)
                        }
                    })
                    .collect();
                let metric = Metric::Full(FullMetric::new(&scales, &matrix));
                for _ in 0..20 {
                    let q: Vec<f64> = (0..d).map(|_| lcg(&mut seed)).collect();
                    let r2 = 0.3 * lcg(&mut seed);
                    let mut got = Vec::new();
                    tree.within(&q, &metric, r2, &mut got);
                    got.sort_by_key(|p| p.0);
                    let want: Vec<(usize, f64)> = (0..n)
                        .map(|i| (i, metric.dist2(&points[i * d..(i + 1) * d], &q)))
                        .filter(|p| p.1 < r2)
                        .collect();
                    assert_eq!(got, want, "d {d} trial {trial}");
                }
            }
        }
    }
}
