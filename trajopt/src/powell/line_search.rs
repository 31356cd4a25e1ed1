//! Brent's line search along one direction, with Numerical Recipes'
//! bracketing, inside the box bounds and the evaluation budget.

/// The golden ratio, growth factor of bracketing steps.
const GOLD: f64 = 1.618_033_988_749_895;
/// $(3 - \sqrt 5) / 2$, the golden-section fraction of Brent's method.
const CGOLD: f64 = 0.381_966_011_250_105;
/// Largest parabolic extrapolation during bracketing, in last steps.
const GROW_LIMIT: f64 = 110.0;
/// Absolute floor of Brent's tolerance.
const ZEPS: f64 = 1e-11;
/// Guards the parabolic extrapolation's denominator.
const TINY: f64 = 1e-21;
/// Iteration caps of the bracketing and of Brent's search.
const MAX_BRACKET: usize = 1000;
const MAX_BRENT: usize = 500;

/// The objective along a line $x + \alpha u$, with the evaluation budget.
pub(super) struct Line<'a, F> {
    pub(super) origin: &'a [f64],
    pub(super) dir: &'a [f64],
    pub(super) bounds: Option<&'a (Vec<f64>, Vec<f64>)>,
    pub(super) trial: &'a mut Vec<f64>,
    pub(super) eval: &'a mut F,
    pub(super) evals: &'a mut usize,
    pub(super) max_evals: usize,
    /// Stop at the first value at or below this.
    pub(super) stop_cost: f64,
    /// The point that reached `stop_cost`, once one has.
    pub(super) hit: Option<(f64, f64)>,
}

/// How a bracketing ended.
enum Bracket {
    /// $\phi(b) \le \phi(a), \phi(c)$ with $b$ between $a$ and $c$.
    Interior {
        a: f64,
        b: f64,
        c: f64,
        fa: f64,
        fb: f64,
        fc: f64,
    },
    /// $\phi$ does not increase from `far` to `near`, and `near` is an end of
    /// the feasible interval (or the budget ran out).
    Edge {
        far: f64,
        near: f64,
        f_far: f64,
        f_near: f64,
    },
}

impl Bracket {
    /// [`Bracket::Interior`] through `(a, fa)`, `(b, fb)`, `(c, fc)`.
    fn interior((a, fa): (f64, f64), (b, fb): (f64, f64), (c, fc): (f64, f64)) -> Self {
        Self::Interior { a, b, c, fa, fb, fc }
    }

    /// [`Bracket::Edge`] from `(far, f_far)` to `(near, f_near)`.
    fn edge((far, f_far): (f64, f64), (near, f_near): (f64, f64)) -> Self {
        Self::Edge {
            far,
            near,
            f_far,
            f_near,
        }
    }
}

pub(super) fn fill_trial(
    trial: &mut [f64],
    origin: &[f64],
    dir: &[f64],
    alpha: f64,
    bounds: Option<&(Vec<f64>, Vec<f64>)>,
) {
    for ((t, &o), &d) in trial.iter_mut().zip(origin).zip(dir) {
        *t = o + alpha * d;
    }
    if let Some((lower, upper)) = bounds {
        for ((t, &l), &u) in trial.iter_mut().zip(lower).zip(upper) {
            *t = t.max(l).min(u);
        }
    }
}

/// The interval of $\alpha$ keeping $x + \alpha u$ in the box ($\ni 0$).
pub(super) fn feasible_interval(x: &[f64], dir: &[f64], bounds: Option<&(Vec<f64>, Vec<f64>)>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
    if let Some((lower, upper)) = bounds {
        for j in 0..x.len() {
            let d = dir[j];
            if d == 0.0 {
                continue;
            }
            let (s_lower, s_upper) = ((lower[j] - x[j]) / d, (upper[j] - x[j]) / d);
            let (s_lo, s_hi) = if d > 0.0 {
                (s_lower, s_upper)
            } else {
                (s_upper, s_lower)
            };
            lo = lo.max(s_lo);
            hi = hi.min(s_hi);
        }
    }
    (lo.min(0.0), hi.max(0.0))
}

/// One line search's question to [`Line::minimise`]: minimise
/// $\phi(\alpha)$ over $[lo, hi] \ni 0$ given $\phi(0) = f_0$, the first
/// trial at `step`, perhaps an evaluated `known` point and the `curvature`
/// of the last search along the same direction, to the tolerance `tol` on
/// $\alpha$.
#[derive(Debug, Clone, Copy)]
pub(super) struct Search {
    /// $\phi(0)$.
    pub(super) f0: f64,
    /// The interval's lower end (at most 0).
    pub(super) lo: f64,
    /// The interval's upper end (at least 0).
    pub(super) hi: f64,
    /// The first trial's $\alpha$ (its sign may flip to stay inside).
    pub(super) step: f64,
    /// An already evaluated $(\alpha, \phi(\alpha))$ to reuse.
    pub(super) known: Option<(f64, f64)>,
    /// $\phi''$ from the last search along the same direction.
    pub(super) curvature: Option<f64>,
    /// Tolerance on $\alpha$.
    pub(super) tol: f64,
}

impl<F, E> Line<'_, F>
where
    F: FnMut(&Vec<f64>) -> std::result::Result<f64, E>,
{
    fn exhausted(&self) -> bool {
        *self.evals >= self.max_evals || self.hit.is_some()
    }

    /// $\phi(\alpha)$, non-finite mapped to $+\infty$; $+\infty$ without an
    /// evaluation once the budget is spent.
    fn at(&mut self, alpha: f64) -> std::result::Result<f64, E> {
        if self.exhausted() || !alpha.is_finite() {
            return Ok(f64::INFINITY);
        }
        fill_trial(self.trial, self.origin, self.dir, alpha, self.bounds);
        *self.evals += 1;
        let value = (self.eval)(self.trial)?;
        if value <= self.stop_cost {
            self.hit = Some((alpha, value));
        }
        Ok(if value.is_finite() { value } else { f64::INFINITY })
    }

    /// Approximately minimises $\phi$ over $[lo, hi] \ni 0$ given
    /// $\phi(0) = f_0$; the first trial is $\alpha = $ `step` (or $-$`step`
    /// when blocked that way, shortened to the interval); `known` is an
    /// already evaluated $(\alpha, \phi(\alpha))$ to reuse for the first
    /// trial. Returns the best $(\alpha, \phi(\alpha))$
    /// seen, $(0, f_0)$ if nothing was lower.
    ///
    /// `curvature`, if known, is $\phi''$ from the last line search along
    /// the same direction: then the parabola through $(0, f_0)$ and the
    /// first trial with that curvature proposes its vertex, and a vertex
    /// that lowers $\phi$ where the parabola said is accepted after two
    /// evaluations (PRAXIS's use of the second difference). Otherwise the
    /// search brackets and runs Brent's method. The third value returned
    /// is the curvature of the parabola through the last three points
    /// (NaN when they do not give one).
    pub(super) fn minimise(&mut self, search: Search) -> std::result::Result<(f64, f64, f64), E> {
        let Search {
            f0,
            lo,
            hi,
            step,
            known,
            curvature,
            tol,
        } = search;
        if hi <= 0.0 && lo >= 0.0 {
            return Ok((0.0, f0, f64::NAN));
        }
        let mut known = known;
        if let Some(c) = curvature.filter(|c| c.is_finite() && *c > 0.0) {
            let s = if (step > 0.0 && hi > 0.0) || lo >= 0.0 {
                hi.min(step.abs())
            } else {
                lo.max(-step.abs())
            };
            let fs = match known {
                Some((alpha, value)) if alpha == s => value,
                _ => self.at(s)?,
            };
            known = Some((s, fs));
            // phi(a) ~ f0 + g a + c a^2 / 2 through (s, fs)
            let g = (fs - f0) / s - 0.5 * c * s;
            let vertex = (-g / c).clamp(lo, hi);
            let predicted = f0 + g * vertex + 0.5 * c * vertex * vertex;
            if vertex != 0.0 && vertex != s && vertex.is_finite() {
                let fv = self.at(vertex)?;
                let best = f0.min(fs);
                // accept a vertex that lowers phi about as the model said
                if fv < best && (fv - predicted).abs() <= QUAD_TRUST * (best - predicted).abs() {
                    return Ok((vertex, fv, parabola_curvature((0.0, f0), (s, fs), (vertex, fv))));
                }
                // else: a bracket if the lowest of the three is between
                let mut pts = [(0.0, f0), (s, fs), (vertex, fv)];
                pts.sort_by(|a, b| a.0.total_cmp(&b.0));
                if pts[1].1 < pts[0].1 && pts[1].1 < pts[2].1 {
                    let bracket = Bracket::interior(pts[0], pts[1], pts[2]);
                    return self.refine(bracket, f0, tol);
                }
                if fv < fs {
                    known = None;
                }
            } else if fs < f0 && vertex == s {
                return Ok((s, fs, f64::NAN));
            }
        }
        let bracket = self.bracket(f0, lo, hi, step, known)?;
        self.refine(bracket, f0, tol)
    }

    /// [`minimise`](Self::minimise), but the point that reached the stop
    /// cost if one did.
    pub(super) fn minimise_or_hit(&mut self, search: Search) -> std::result::Result<(f64, f64, f64), E> {
        let found = self.minimise(search)?;
        Ok(match self.hit {
            Some((alpha, value)) if value < found.1 => (alpha, value, found.2),
            _ => found,
        })
    }

    /// Brent's search in a bracket; the best point and the curvature there.
    fn refine(&mut self, bracket: Bracket, f0: f64, tol: f64) -> std::result::Result<(f64, f64, f64), E> {
        let (a, b, x, w, v) = match bracket {
            Bracket::Interior { a, b, c, fa, fb, fc } => {
                let (w, v) = if fa <= fc {
                    ((a, fa), (c, fc))
                } else {
                    ((c, fc), (a, fa))
                };
                (a.min(c), a.max(c), (b, fb), w, v)
            }
            Bracket::Edge {
                far,
                near,
                f_far,
                f_near,
            } => (far.min(near), far.max(near), (near, f_near), (far, f_far), (far, f_far)),
        };
        let [x, w, v] = self.brent(a, b, x, w, v, tol)?;
        let curvature = parabola_curvature(x, w, v);
        Ok(if x.1 < f0 {
            (x.0, x.1, curvature)
        } else {
            (0.0, f0, curvature)
        })
    }

    fn bracket(
        &mut self,
        f0: f64,
        lo: f64,
        hi: f64,
        step: f64,
        known: Option<(f64, f64)>,
    ) -> std::result::Result<Bracket, E> {
        let clamp = |u: f64| u.clamp(lo, hi);
        let (mut a, mut fa) = (0.0, f0);
        // the first trial: `step`, or its mirror image when blocked that way
        let mut b = if (step > 0.0 && hi > 0.0) || lo >= 0.0 {
            hi.min(step.abs())
        } else {
            lo.max(-step.abs())
        };
        let mut fb = match known {
            Some((alpha, value)) if alpha == b => value,
            _ => self.at(b)?,
        };
        if fb > fa {
            std::mem::swap(&mut a, &mut b);
            std::mem::swap(&mut fa, &mut fb);
        }
        let mut c = clamp(b + GOLD * (b - a));
        if c == b {
            return Ok(Bracket::edge((a, fa), (b, fb)));
        }
        let mut fc = self.at(c)?;
        let mut rounds = 0;
        while fc < fb {
            rounds += 1;
            if self.exhausted() || rounds > MAX_BRACKET {
                return Ok(Bracket::edge((b, fb), (c, fc)));
            }
            // vertex of the parabola through (a, fa), (b, fb), (c, fc)
            let r = (b - a) * (fb - fc);
            let q = (b - c) * (fb - fa);
            let diff = q - r;
            let denom = 2.0 * diff.abs().max(TINY).copysign(diff);
            let mut u = b - ((b - c) * q - (b - a) * r) / denom;
            let u_limit = clamp(b + GROW_LIMIT * (c - b));
            // the value at `u` if evaluated; else `u` is the next point to
            // try (a golden step beyond c, or the growth limit)
            let mut fu = None;
            if (b - u) * (u - c) > 0.0 {
                // between b and c
                let f = self.at(u)?;
                if f < fc {
                    return Ok(Bracket::interior((b, fb), (u, f), (c, fc)));
                }
                if f > fb {
                    return Ok(Bracket::interior((a, fa), (b, fb), (u, f)));
                }
                u = clamp(c + GOLD * (c - b));
            } else if (c - u) * (u - u_limit) > 0.0 {
                // between c and the growth limit
                let f = self.at(u)?;
                if f < fc {
                    (b, fb, c, fc) = (c, fc, u, f);
                    u = clamp(c + GOLD * (c - b));
                } else {
                    fu = Some(f);
                }
            } else if (u - u_limit) * (u_limit - c) >= 0.0 {
                u = u_limit;
            } else {
                u = clamp(c + GOLD * (c - b));
            }
            let fu = match fu {
                Some(f) => f,
                // the step is blocked at c: an end of the interval
                None if u == c => return Ok(Bracket::edge((b, fb), (c, fc))),
                None => self.at(u)?,
            };
            (a, fa, b, fb, c, fc) = (b, fb, c, fc, u, fu);
        }
        Ok(Bracket::interior((a, fa), (b, fb), (c, fc)))
    }

    /// Brent's method on $[a, b]$ from the best known point $x \in [a, b]$.
    ///
    /// `w` and `v` are the second and third best points known (the other
    /// bracket points): with them the first step can be parabolic, where
    /// the textbook start ($w = v = x$, $e = 0$) spends a golden-section step.
    fn brent(
        &mut self,
        mut a: f64,
        mut b: f64,
        (mut x, mut fx): (f64, f64),
        (mut w, mut fw): (f64, f64),
        (mut v, mut fv): (f64, f64),
        tol: f64,
    ) -> std::result::Result<[Point; 3], E> {
        // the bracket width as the last two steps lets the first parabolic
        // steps through the "under half the step before last" test
        let width = if w != x && v != x && v != w { b - a } else { 0.0 };
        let (mut d, mut e) = (width, width);
        for _ in 0..MAX_BRENT {
            let xm = 0.5 * (a + b);
            let tol1 = tol * x.abs() + ZEPS;
            let tol2 = 2.0 * tol1;
            if (x - xm).abs() <= tol2 - 0.5 * (b - a) || self.exhausted() {
                break;
            }
            let mut golden = true;
            if e.abs() > tol1 {
                // parabola through x, w, v
                let r = (x - w) * (fx - fv);
                let mut q = (x - v) * (fx - fw);
                let mut p = (x - v) * q - (x - w) * r;
                q = 2.0 * (q - r);
                if q > 0.0 {
                    p = -p;
                }
                q = q.abs();
                let e_prev = e;
                // accept only a step inside (a, b) and under half the step
                // before last (false for NaN)
                if p.abs() < (0.5 * q * e_prev).abs() && p > q * (a - x) && p < q * (b - x) {
                    golden = false;
                    e = d;
                    d = p / q;
                    let u = x + d;
                    if u - a < tol2 || b - u < tol2 {
                        d = tol1.copysign(xm - x);
                    }
                }
            }
            if golden {
                e = if x >= xm { a - x } else { b - x };
                d = CGOLD * e;
            }
            let u = if d.abs() >= tol1 { x + d } else { x + tol1.copysign(d) };
            let fu = self.at(u)?;
            if fu <= fx {
                if u >= x {
                    a = x;
                } else {
                    b = x;
                }
                (v, fv, w, fw, x, fx) = (w, fw, x, fx, u, fu);
            } else {
                if u < x {
                    a = u;
                } else {
                    b = u;
                }
                if fu <= fw || w == x {
                    (v, fv, w, fw) = (w, fw, u, fu);
                } else if fu <= fv || v == x || v == w {
                    (v, fv) = (u, fu);
                }
            }
        }
        Ok([(x, fx), (w, fw), (v, fv)])
    }
}

/// A point $(\alpha, \phi(\alpha))$ of a line search.
type Point = (f64, f64);

/// How closely the two-evaluation step must match the parabola: the value
/// at the vertex within this fraction of the decrease the parabola
/// predicts there (from the lower of the two points before it). On the
/// Moré-Garbow-Hillstrom runs of `examples/powell_mgh.rs`, 1 was better
/// than 0.1, 0.25 and 0.5 in evaluations and in minima reached, and about
/// the same as no check.
const QUAD_TRUST: f64 = 1.0;

/// $\phi''$ of the parabola through three points (NaN if two coincide).
fn parabola_curvature((x0, f0): (f64, f64), (x1, f1): (f64, f64), (x2, f2): (f64, f64)) -> f64 {
    if x0 == x1 || x1 == x2 || x0 == x2 || !(f0.is_finite() && f1.is_finite() && f2.is_finite()) {
        return f64::NAN;
    }
    2.0 * ((f2 - f0) / (x2 - x0) - (f1 - f0) / (x1 - x0)) / (x2 - x1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::error::Result;

    /// One line search along $\phi(\alpha) = f(\alpha)$ from 0: the
    /// minimiser, its value, the curvature returned, and the evaluations.
    fn search(f: impl Fn(&[f64]) -> f64, question: Search) -> (f64, f64, f64, usize) {
        let (origin, dir, mut trial, mut evals) = ([0.0], [1.0], vec![0.0], 0);
        let mut eval = |x: &Vec<f64>| -> Result<f64> { Ok(f(x)) };
        let mut line = Line {
            origin: &origin,
            dir: &dir,
            bounds: None,
            trial: &mut trial,
            eval: &mut eval,
            evals: &mut evals,
            max_evals: 10_000,
            stop_cost: f64::NEG_INFINITY,
            hit: None,
        };
        let (alpha, value, curvature) = line.minimise(question).expect("line search");
        (alpha, value, curvature, evals)
    }

    fn run(f: impl Fn(&[f64]) -> f64, lo: f64, hi: f64, first: Option<(f64, f64)>) -> (f64, f64, usize) {
        let f0 = f(&[0.0]);
        let question = Search {
            f0,
            lo,
            hi,
            step: 1.0,
            known: first,
            curvature: None,
            tol: 1e-8,
        };
        let (alpha, value, _, evals) = search(f, question);
        (alpha, value, evals)
    }

    #[test]
    fn line_search_finds_parabola_minimum() {
        let (alpha, value, evals) = run(|x| (x[0] - 3.7).powi(2) + 1.0, f64::NEG_INFINITY, f64::INFINITY, None);
        assert!((alpha - 3.7).abs() < 1e-6, "{alpha}");
        assert!((value - 1.0).abs() < 1e-12);
        // bracketing 3 (the third point is the vertex), Brent 3 (its first
        // step is parabolic, then the two tolerance-sized probes)
        assert!(evals <= 6, "{evals}");
        let (alpha, _, _) = run(|x| (x[0] + 12.0).powi(2), f64::NEG_INFINITY, f64::INFINITY, None);
        assert!((alpha + 12.0).abs() < 1e-6, "{alpha}");
    }

    #[test]
    fn line_search_stops_on_bounds() {
        let (alpha, value, _) = run(|x| (x[0] - 3.7).powi(2), -1.0, 2.0, None);
        assert_eq!(alpha, 2.0);
        assert!((value - 1.7_f64.powi(2)).abs() < 1e-12);
        let (alpha, _, _) = run(|x| (x[0] + 3.7).powi(2), -0.5, 2.0, None);
        assert_eq!(alpha, -0.5);
        // blocked on the downhill side
        let (alpha, value, _) = run(|x| x[0], 0.0, 2.0, None);
        assert_eq!((alpha, value), (0.0, 0.0));
        let (alpha, _, evals) = run(|x| x[0], 0.0, 0.0, None);
        assert_eq!((alpha, evals), (0.0, 0));
    }

    #[test]
    fn line_search_reuses_the_known_first_trial() {
        let f = |x: &[f64]| (x[0] - 0.3).powi(2);
        let (_, _, with) = run(f, f64::NEG_INFINITY, f64::INFINITY, Some((1.0, f(&[1.0]))));
        let (_, _, without) = run(f, f64::NEG_INFINITY, f64::INFINITY, None);
        assert_eq!(with + 1, without);
    }

    #[test]
    fn known_curvature_takes_two_evaluations_on_a_parabola() {
        // phi(a) = 3 (a - 0.4)^2 + 1: phi'' = 6
        let f = |x: &[f64]| 3.0 * (x[0] - 0.4).powi(2) + 1.0;
        let known = Search {
            f0: f(&[0.0]),
            lo: f64::NEG_INFINITY,
            hi: f64::INFINITY,
            step: 1.0,
            known: None,
            curvature: Some(6.0),
            tol: 1e-8,
        };
        let (alpha, value, curvature, evals) = search(f, known);
        assert!(
            (alpha - 0.4).abs() < 1e-12 && (value - 1.0).abs() < 1e-12,
            "{alpha} {value}"
        );
        assert!((curvature - 6.0).abs() < 1e-9, "{curvature}");
        assert_eq!(evals, 2);
        // a wrong curvature: the vertex misses, and the search still finds 0.4
        let wrong = Search {
            curvature: Some(0.1),
            ..known
        };
        let (alpha, _, _, _) = search(f, wrong);
        assert!((alpha - 0.4).abs() < 1e-6, "{alpha}");
    }

    #[test]
    fn line_search_survives_non_finite_values() {
        let f = |x: &[f64]| if x[0] > 1.5 { f64::NAN } else { (x[0] - 1.4).powi(2) };
        let (alpha, _, _) = run(f, f64::NEG_INFINITY, f64::INFINITY, None);
        assert!((alpha - 1.4).abs() < 1e-6, "{alpha}");
    }
}
