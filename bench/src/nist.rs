//! The NIST StRD nonlinear regression set: the 27 problems of the
//! Statistical Reference Datasets, each from its two certified starts,
//! judged as Ceres judges them, by the **log relative error of the
//! parameters** against NIST's certified values.
//!
//! **Data**: `bench/data/nist/*.dat`, NIST's files byte for byte (public
//! domain, <https://www.itl.nist.gov/div898/strd/nls/nls_main.shtml>), as
//! Ceres Solver ships them in `data/nist/` (copied from
//! ceres-solver@fe351d5; see `bench/data/nist/SOURCE.md`). They are
//! compiled into the binary ([`all`]) and parsed here ([`parse`]): the
//! two starts, the certified parameters (11 significant digits), the
//! certified residual sum of squares and the observations.
//!
//! **Problem**: residuals $r_i(b) = y_i - f(x_i; b)$ (Nelson: $\ln y_i -
//! f$, as NIST certifies it), so that $\lVert r \rVert^2$ is the residual
//! sum of squares; the Jacobian is analytic ([`Model`]), checked against
//! central differences by the tests.
//!
//! **Criterion**: the log relative error of a parameter,
//! $$\mathrm{LRE}(b_j) = -\log_{10} \frac{\lvert b_j - c_j \rvert}{\lvert c_j \rvert},$$
//! capped at 11 (the certified digits; an exact match is 11), and of a run
//! the smallest over its parameters ([`lre`]). A run is solved at $k$
//! digits when its final point's LRE is at least $k$; the headline counts
//! use $k = 4$ ([`HEADLINE_DIGITS`], Ceres's threshold) and the tables
//! also report $k = 6$.
//!
//! ```
//! let problems = bench::nist::all()?;
//! assert_eq!(problems.len(), 27);
//! let misra = problems.iter().find(|p| p.name == "Misra1a").expect("in the set");
//! // f at the certified parameters is the certified residual sum of squares
//! let f = misra.cost(&misra.certified);
//! assert!((f - misra.certified_rss).abs() < 1e-9 * misra.certified_rss);
//! assert!(bench::nist::lre(&misra.certified, &misra.certified) >= 11.0);
//! # Ok::<(), bench::BenchError>(())
//! ```

use std::f64::consts::PI;

use faer::sparse::SymbolicSparseRowMat;
use trajopt::{LeastSquaresProblem, TrajoptError};

use crate::error::{BenchError, Result};

/// The set's name on the command line and in the records.
pub const SET: &str = "nist";

/// The digits of the headline counts: LRE $\ge 4$, as Ceres counts.
pub const HEADLINE_DIGITS: f64 = 4.0;

/// The digits reported besides the headline's.
pub const DIGITS: [f64; 2] = [4.0, 6.0];

/// The LRE of an exact match: the certified values have 11 significant
/// digits.
pub const MAX_LRE: f64 = 11.0;

/// NIST's difficulty rating of a problem.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, serde::Serialize)]
pub enum Difficulty {
    /// "Lower Level of Difficulty".
    Lower,
    /// "Average Level of Difficulty".
    Average,
    /// "Higher Level of Difficulty".
    Higher,
}

/// The model function $f(x; b)$ of a problem (several problems share one).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Model {
    /// Misra1a, BoxBOD: $b_1 (1 - e^{-b_2 x})$.
    Misra1a,
    /// Chwirut1, Chwirut2: $e^{-b_1 x} / (b_2 + b_3 x)$.
    Chwirut,
    /// DanWood: $b_1 x^{b_2}$.
    DanWood,
    /// Misra1b: $b_1 (1 - (1 + b_2 x / 2)^{-2})$.
    Misra1b,
    /// Misra1c: $b_1 (1 - (1 + 2 b_2 x)^{-1/2})$.
    Misra1c,
    /// Misra1d: $b_1 b_2 x / (1 + b_2 x)$.
    Misra1d,
    /// Gauss1-3: $b_1 e^{-b_2 x} + b_3 e^{-(x - b_4)^2 / b_5^2} + b_6 e^{-(x - b_7)^2 / b_8^2}$.
    Gauss,
    /// Lanczos1-3: $b_1 e^{-b_2 x} + b_3 e^{-b_4 x} + b_5 e^{-b_6 x}$.
    Lanczos,
    /// Kirby2: $(b_1 + b_2 x + b_3 x^2) / (1 + b_4 x + b_5 x^2)$.
    Kirby2,
    /// Hahn1, Thurber: $(b_1 + b_2 x + b_3 x^2 + b_4 x^3) / (1 + b_5 x + b_6 x^2 + b_7 x^3)$.
    CubicRational,
    /// MGH09: $b_1 (x^2 + x b_2) / (x^2 + x b_3 + b_4)$.
    Mgh09,
    /// MGH10: $b_1 e^{b_2 / (x + b_3)}$.
    Mgh10,
    /// MGH17: $b_1 + b_2 e^{-x b_4} + b_3 e^{-x b_5}$.
    Mgh17,
    /// Eckerle4: $(b_1 / b_2) e^{-((x - b_3) / b_2)^2 / 2}$.
    Eckerle4,
    /// Rat42: $b_1 / (1 + e^{b_2 - b_3 x})$.
    Rat42,
    /// Rat43: $b_1 / (1 + e^{b_2 - b_3 x})^{1 / b_4}$.
    Rat43,
    /// Bennett5: $b_1 (b_2 + x)^{-1 / b_3}$.
    Bennett5,
    /// Roszman1: $b_1 - b_2 x - \arctan(b_3 / (x - b_4)) / \pi$, the
    /// arctangent taken in $(0, \pi)$ as NIST's certified values need it
    /// (`atan2(b3, x - b4)`).
    Roszman1,
    /// ENSO: $b_1 + b_2 \cos(2\pi x/12) + b_3 \sin(2\pi x/12) + b_5 \cos(2\pi x/b_4) + b_6 \sin(2\pi x/b_4) + b_8 \cos(2\pi x/b_7) + b_9 \sin(2\pi x/b_7)$.
    Enso,
    /// Nelson: $\ln y = b_1 - b_2 x_1 e^{-b_3 x_2}$ (two predictors).
    Nelson,
}

impl Model {
    /// The model of the problem named `name` (NIST's file name without
    /// `.dat`).
    pub fn of(name: &str) -> Option<Self> {
        Some(match name {
            "Misra1a" | "BoxBOD" => Self::Misra1a,
            "Chwirut1" | "Chwirut2" => Self::Chwirut,
            "DanWood" => Self::DanWood,
            "Misra1b" => Self::Misra1b,
            "Misra1c" => Self::Misra1c,
            "Misra1d" => Self::Misra1d,
            "Gauss1" | "Gauss2" | "Gauss3" => Self::Gauss,
            "Lanczos1" | "Lanczos2" | "Lanczos3" => Self::Lanczos,
            "Kirby2" => Self::Kirby2,
            "Hahn1" | "Thurber" => Self::CubicRational,
            "MGH09" => Self::Mgh09,
            "MGH10" => Self::Mgh10,
            "MGH17" => Self::Mgh17,
            "Eckerle4" => Self::Eckerle4,
            "Rat42" => Self::Rat42,
            "Rat43" => Self::Rat43,
            "Bennett5" => Self::Bennett5,
            "Roszman1" => Self::Roszman1,
            "ENSO" => Self::Enso,
            "Nelson" => Self::Nelson,
            _ => return None,
        })
    }

    /// Number of parameters.
    pub fn n(self) -> usize {
        match self {
            Self::Misra1a | Self::DanWood | Self::Misra1b | Self::Misra1c | Self::Misra1d => 2,
            Self::Chwirut | Self::Mgh10 | Self::Eckerle4 | Self::Rat42 | Self::Bennett5 | Self::Nelson => 3,
            Self::Mgh09 | Self::Rat43 | Self::Roszman1 => 4,
            Self::Kirby2 | Self::Mgh17 => 5,
            Self::Lanczos => 6,
            Self::CubicRational => 7,
            Self::Gauss => 8,
            Self::Enso => 9,
        }
    }

    /// Number of predictors (columns of $x$): 2 for Nelson, else 1.
    pub fn predictors(self) -> usize {
        if self == Self::Nelson { 2 } else { 1 }
    }

    /// $f(x; b)$, and its gradient in $b$ written into `g` (length
    /// [`n`](Self::n)).
    pub fn eval(self, x: &[f64], b: &[f64], g: &mut [f64]) -> f64 {
        let t = x[0];
        match self {
            Self::Misra1a => {
                let e = (-b[1] * t).exp();
                g[0] = 1.0 - e;
                g[1] = b[0] * t * e;
                b[0] * (1.0 - e)
            }
            Self::Chwirut => {
                let (e, d) = ((-b[0] * t).exp(), b[1] + b[2] * t);
                g[0] = -t * e / d;
                g[1] = -e / (d * d);
                g[2] = -t * e / (d * d);
                e / d
            }
            Self::DanWood => {
                let p = t.powf(b[1]);
                g[0] = p;
                g[1] = b[0] * p * t.ln();
                b[0] * p
            }
            Self::Misra1b => {
                let u = 1.0 + b[1] * t / 2.0;
                g[0] = 1.0 - u.powi(-2);
                g[1] = b[0] * t * u.powi(-3);
                b[0] * g[0]
            }
            Self::Misra1c => {
                let u = 1.0 + 2.0 * b[1] * t;
                g[0] = 1.0 - u.powf(-0.5);
                g[1] = b[0] * t * u.powf(-1.5);
                b[0] * g[0]
            }
            Self::Misra1d => {
                let u = 1.0 + b[1] * t;
                g[0] = b[1] * t / u;
                g[1] = b[0] * t / (u * u);
                b[0] * g[0]
            }
            Self::Gauss => {
                let e = (-b[1] * t).exp();
                g[0] = e;
                g[1] = -b[0] * t * e;
                let mut f = b[0] * e;
                for k in [2, 5] {
                    let (a, c, w) = (b[k], b[k + 1], b[k + 2]);
                    let d = t - c;
                    let bump = (-d * d / (w * w)).exp();
                    g[k] = bump;
                    g[k + 1] = a * bump * 2.0 * d / (w * w);
                    g[k + 2] = a * bump * 2.0 * d * d / (w * w * w);
                    f += a * bump;
                }
                f
            }
            Self::Lanczos => {
                let mut f = 0.0;
                for k in [0, 2, 4] {
                    let e = (-b[k + 1] * t).exp();
                    g[k] = e;
                    g[k + 1] = -t * b[k] * e;
                    f += b[k] * e;
                }
                f
            }
            Self::Kirby2 => rational(t, &b[..3], &b[3..], g),
            Self::CubicRational => rational(t, &b[..4], &b[4..], g),
            Self::Mgh09 => {
                let (num, den) = (t * t + t * b[1], t * t + t * b[2] + b[3]);
                g[0] = num / den;
                g[1] = b[0] * t / den;
                g[2] = -b[0] * num * t / (den * den);
                g[3] = -b[0] * num / (den * den);
                b[0] * num / den
            }
            Self::Mgh10 => {
                let u = t + b[2];
                let e = (b[1] / u).exp();
                g[0] = e;
                g[1] = b[0] * e / u;
                g[2] = -b[0] * e * b[1] / (u * u);
                b[0] * e
            }
            Self::Mgh17 => {
                let (e4, e5) = ((-t * b[3]).exp(), (-t * b[4]).exp());
                g[0] = 1.0;
                g[1] = e4;
                g[2] = e5;
                g[3] = -t * b[1] * e4;
                g[4] = -t * b[2] * e5;
                b[0] + b[1] * e4 + b[2] * e5
            }
            Self::Eckerle4 => {
                let z = (t - b[2]) / b[1];
                let e = (-0.5 * z * z).exp();
                g[0] = e / b[1];
                g[1] = b[0] * e * (z * z - 1.0) / (b[1] * b[1]);
                g[2] = b[0] * e * z / (b[1] * b[1]);
                b[0] / b[1] * e
            }
            Self::Rat42 => {
                let e = (b[1] - b[2] * t).exp();
                let d = 1.0 + e;
                g[0] = 1.0 / d;
                g[1] = -b[0] * e / (d * d);
                g[2] = b[0] * t * e / (d * d);
                b[0] / d
            }
            Self::Rat43 => {
                let e = (b[1] - b[2] * t).exp();
                let d = 1.0 + e;
                let p = d.powf(-1.0 / b[3]);
                g[0] = p;
                g[1] = -b[0] * p / d * e / b[3];
                g[2] = b[0] * p / d * t * e / b[3];
                g[3] = b[0] * p * d.ln() / (b[3] * b[3]);
                b[0] * p
            }
            Self::Bennett5 => {
                let u = b[1] + t;
                let p = u.powf(-1.0 / b[2]);
                g[0] = p;
                g[1] = -b[0] * p / (u * b[2]);
                g[2] = b[0] * p * u.ln() / (b[2] * b[2]);
                b[0] * p
            }
            Self::Roszman1 => {
                let v = t - b[3];
                let q = b[2] / v;
                let datan = 1.0 / (1.0 + q * q);
                g[0] = 1.0;
                g[1] = -t;
                g[2] = -datan / (v * PI);
                g[3] = -datan * b[2] / (v * v * PI);
                // NIST's arctan takes its value in (0, pi) here (the data
                // lie at x < b4): atan2, not atan, reproduces the certified
                // residual sum of squares
                b[0] - b[1] * t - b[2].atan2(v) / PI
            }
            Self::Enso => {
                let a = 2.0 * PI * t / 12.0;
                g[0] = 1.0;
                g[1] = a.cos();
                g[2] = a.sin();
                let mut f = b[0] + b[1] * g[1] + b[2] * g[2];
                for k in [3, 6] {
                    let (period, c, s) = (b[k], b[k + 1], b[k + 2]);
                    let th = 2.0 * PI * t / period;
                    let (sin, cos) = th.sin_cos();
                    g[k + 1] = cos;
                    g[k + 2] = sin;
                    g[k] = (-c * sin + s * cos) * (-2.0 * PI * t / (period * period));
                    f += c * cos + s * sin;
                }
                f
            }
            Self::Nelson => {
                let (x1, x2) = (x[0], x[1]);
                let e = (-b[2] * x2).exp();
                g[0] = 1.0;
                g[1] = -x1 * e;
                g[2] = b[1] * x1 * x2 * e;
                b[0] - b[1] * x1 * e
            }
        }
    }
}

/// $N(t) / D(t)$ with $N = \sum_k a_k t^k$, $D = 1 + \sum_k d_k t^{k+1}$,
/// and its gradient in $(a, d)$.
fn rational(t: f64, a: &[f64], d: &[f64], g: &mut [f64]) -> f64 {
    let num: f64 = a.iter().rev().fold(0.0, |acc, c| acc * t + c);
    let den = 1.0 + d.iter().rev().fold(0.0, |acc, c| acc * t + c) * t;
    let mut power = 1.0;
    for gk in g.iter_mut().take(a.len()) {
        *gk = power / den;
        power *= t;
    }
    let mut power = t;
    for gk in g.iter_mut().skip(a.len()).take(d.len()) {
        *gk = -num * power / (den * den);
        power *= t;
    }
    num / den
}

/// One NIST StRD problem: data, starts and certified values.
#[derive(Debug, Clone)]
pub struct NistProblem {
    /// NIST's name (`Misra1a`), the file's stem.
    pub name: String,
    /// NIST's difficulty rating.
    pub difficulty: Difficulty,
    /// The model function.
    pub model: Model,
    /// The two certified starting points, "Start 1" and "Start 2".
    pub starts: [Vec<f64>; 2],
    /// The certified parameters (11 significant digits).
    pub certified: Vec<f64>,
    /// Their certified standard deviations.
    pub standard_deviations: Vec<f64>,
    /// The certified residual sum of squares.
    pub certified_rss: f64,
    /// The predictors, one row of [`Model::predictors`] values per observation.
    pub x: Vec<Vec<f64>>,
    /// The responses (Nelson: $\ln y$).
    pub y: Vec<f64>,
}

impl NistProblem {
    /// Number of parameters.
    pub fn n(&self) -> usize {
        self.certified.len()
    }

    /// Number of observations (residuals).
    pub fn m(&self) -> usize {
        self.y.len()
    }

    /// The residual sum of squares at `b` (NaN for `b` of the wrong length).
    pub fn cost(&self, b: &[f64]) -> f64 {
        let mut r = vec![0.0; self.m()];
        match LeastSquaresProblem::residuals(self, b, &mut r) {
            Ok(()) => r.iter().map(|v| v * v).sum(),
            Err(_) => f64::NAN,
        }
    }

    fn check(&self, what: &'static str, expected: usize, actual: usize) -> trajopt::Result<()> {
        if expected != actual {
            return Err(TrajoptError::DimensionMismatch { what, expected, actual });
        }
        Ok(())
    }
}

/// The residuals $y_i - f(x_i; b)$ and their dense Jacobian.
impl LeastSquaresProblem for NistProblem {
    fn n_params(&self) -> usize {
        self.n()
    }

    fn n_residuals(&self) -> usize {
        self.m()
    }

    fn residuals(&self, theta: &[f64], r: &mut [f64]) -> trajopt::Result<()> {
        self.check("parameters", self.n(), theta.len())?;
        self.check("residuals", self.m(), r.len())?;
        let mut g = vec![0.0; self.n()];
        for ((ri, x), y) in r.iter_mut().zip(&self.x).zip(&self.y) {
            *ri = y - self.model.eval(x, theta, &mut g);
        }
        Ok(())
    }

    /// Every entry: $m \times n$, row-major.
    fn jacobian_pattern(&self) -> SymbolicSparseRowMat<usize> {
        trajopt::dense_pattern(self.m(), self.n())
    }

    fn jacobian_values(&self, theta: &[f64], values: &mut [f64]) -> trajopt::Result<()> {
        self.check("parameters", self.n(), theta.len())?;
        self.check("Jacobian values", self.m() * self.n(), values.len())?;
        for (row, x) in values.chunks_exact_mut(self.n()).zip(&self.x) {
            self.model.eval(x, theta, row);
            for v in row.iter_mut() {
                *v = -*v;
            }
        }
        Ok(())
    }
}

/// The log relative error of `x` against `certified`, the smallest over
/// the parameters, in $[0, 11]$ ([`MAX_LRE`]); 0 for a point of another
/// length or with a non-finite entry.
pub fn lre(x: &[f64], certified: &[f64]) -> f64 {
    if x.len() != certified.len() || x.iter().any(|v| !v.is_finite()) {
        return 0.0;
    }
    x.iter()
        .zip(certified)
        .map(|(v, c)| {
            let rel = (v - c).abs() / c.abs();
            if rel == 0.0 {
                MAX_LRE
            } else {
                // + 0.0: no -0 where no digit agrees
                (-rel.log10()).clamp(0.0, MAX_LRE) + 0.0
            }
        })
        .fold(MAX_LRE, f64::min)
}

/// The 27 files, compiled in: (name, text).
const FILES: [(&str, &str); 27] = [
    ("Misra1a", include_str!("../data/nist/Misra1a.dat")),
    ("Chwirut2", include_str!("../data/nist/Chwirut2.dat")),
    ("Chwirut1", include_str!("../data/nist/Chwirut1.dat")),
    ("Lanczos3", include_str!("../data/nist/Lanczos3.dat")),
    ("Gauss1", include_str!("../data/nist/Gauss1.dat")),
    ("Gauss2", include_str!("../data/nist/Gauss2.dat")),
    ("DanWood", include_str!("../data/nist/DanWood.dat")),
    ("Misra1b", include_str!("../data/nist/Misra1b.dat")),
    ("Kirby2", include_str!("../data/nist/Kirby2.dat")),
    ("Hahn1", include_str!("../data/nist/Hahn1.dat")),
    ("Nelson", include_str!("../data/nist/Nelson.dat")),
    ("MGH17", include_str!("../data/nist/MGH17.dat")),
    ("Lanczos1", include_str!("../data/nist/Lanczos1.dat")),
    ("Lanczos2", include_str!("../data/nist/Lanczos2.dat")),
    ("Gauss3", include_str!("../data/nist/Gauss3.dat")),
    ("Misra1c", include_str!("../data/nist/Misra1c.dat")),
    ("Misra1d", include_str!("../data/nist/Misra1d.dat")),
    ("Roszman1", include_str!("../data/nist/Roszman1.dat")),
    ("ENSO", include_str!("../data/nist/ENSO.dat")),
    ("MGH09", include_str!("../data/nist/MGH09.dat")),
    ("Thurber", include_str!("../data/nist/Thurber.dat")),
    ("BoxBOD", include_str!("../data/nist/BoxBOD.dat")),
    ("Rat42", include_str!("../data/nist/Rat42.dat")),
    ("MGH10", include_str!("../data/nist/MGH10.dat")),
    ("Eckerle4", include_str!("../data/nist/Eckerle4.dat")),
    ("Rat43", include_str!("../data/nist/Rat43.dat")),
    ("Bennett5", include_str!("../data/nist/Bennett5.dat")),
];

/// The 27 problems, in NIST's order (lower, average, higher difficulty).
///
/// # Errors
/// [`BenchError::NistData`] if a compiled-in file does not parse (a
/// build from a damaged checkout).
pub fn all() -> Result<Vec<NistProblem>> {
    let mut problems = FILES
        .iter()
        .map(|(name, text)| parse(name, text))
        .collect::<Result<Vec<_>>>()?;
    problems.sort_by_key(|p| p.difficulty);
    Ok(problems)
}

/// Parses NIST's file `text` of the problem `name`.
///
/// # Errors
/// [`BenchError::NistData`] naming the file, the line (none for the file
/// as a whole) and what is wrong: an unknown problem, a missing or
/// malformed section, a parameter count or observation count that does
/// not match.
pub fn parse(name: &str, text: &str) -> Result<NistProblem> {
    let bad = |line: usize, reason: String| BenchError::NistData {
        file: format!("{name}.dat"),
        line: (line > 0).then_some(line),
        reason,
    };
    let model = Model::of(name).ok_or_else(|| bad(0, "not a problem of the NIST StRD nonlinear set".into()))?;
    let number = |line: usize, s: &str| -> Result<f64> {
        s.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| bad(line, format!("`{s}` is not a finite number")))
    };
    let (mut difficulty, mut rss, mut observations) = (None, None, None);
    let mut params: Vec<[f64; 4]> = Vec::new();
    let (mut x, mut y) = (Vec::new(), Vec::new());
    let mut in_data = false;
    for (k, raw) in text.lines().enumerate() {
        let (no, line) = (k + 1, raw.trim());
        if in_data {
            if line.is_empty() {
                continue;
            }
            let values = line
                .split_whitespace()
                .map(|s| number(no, s))
                .collect::<Result<Vec<f64>>>()?;
            if values.len() != 1 + model.predictors() {
                return Err(bad(
                    no,
                    format!("{} columns, expected {}", values.len(), 1 + model.predictors()),
                ));
            }
            let response = if model == Model::Nelson {
                if values[0] <= 0.0 {
                    return Err(bad(no, format!("y = {} has no logarithm", values[0])));
                }
                values[0].ln()
            } else {
                values[0]
            };
            y.push(response);
            x.push(values[1..].to_vec());
        } else if let Some(rest) = line.strip_prefix("Data:") {
            // the header's "Data: 1 Response Variable" is not the table's
            in_data = rest.trim_start().starts_with('y');
        } else if line.contains("Level of Difficulty") {
            difficulty = Some(match line.split_whitespace().next() {
                Some("Lower") => Difficulty::Lower,
                Some("Average") => Difficulty::Average,
                Some("Higher") => Difficulty::Higher,
                other => return Err(bad(no, format!("unknown difficulty {other:?}"))),
            });
        } else if let Some(rest) = line.strip_prefix("Residual Sum of Squares:") {
            rss = Some(number(no, rest.trim())?);
        } else if let Some(rest) = line.strip_prefix("Number of Observations:") {
            observations = Some(
                rest.trim()
                    .parse::<usize>()
                    .map_err(|_| bad(no, format!("`{}` is not a count", rest.trim())))?,
            );
        } else if let Some((label, rest)) = line.split_once('=')
            && let Some(index) = label.trim().strip_prefix('b')
            && let Ok(index) = index.parse::<usize>()
        {
            if index != params.len() + 1 {
                return Err(bad(no, format!("parameter b{index} out of order")));
            }
            let v = rest
                .split_whitespace()
                .map(|s| number(no, s))
                .collect::<Result<Vec<f64>>>()?;
            let v: [f64; 4] = v.try_into().map_err(|v: Vec<f64>| {
                bad(
                    no,
                    format!("{} numbers, expected 4 (two starts, value, deviation)", v.len()),
                )
            })?;
            params.push(v);
        }
    }
    let difficulty = difficulty.ok_or_else(|| bad(0, "no \"Level of Difficulty\" line".into()))?;
    let certified_rss = rss.ok_or_else(|| bad(0, "no \"Residual Sum of Squares:\" line".into()))?;
    let observations = observations.ok_or_else(|| bad(0, "no \"Number of Observations:\" line".into()))?;
    if params.len() != model.n() {
        return Err(bad(
            0,
            format!("{} parameters, the model has {}", params.len(), model.n()),
        ));
    }
    if y.len() != observations {
        return Err(bad(
            0,
            format!("{} observations in the table, the header says {observations}", y.len()),
        ));
    }
    let column = |j: usize| params.iter().map(|p| p[j]).collect::<Vec<f64>>();
    Ok(NistProblem {
        name: name.into(),
        difficulty,
        model,
        starts: [column(0), column(1)],
        certified: column(2),
        standard_deviations: column(3),
        certified_rss,
        x,
        y,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_file_parses_with_the_sizes_nist_lists() {
        let all = all().expect("parses");
        assert_eq!(all.len(), 27);
        let sizes: Vec<(&str, usize, usize)> = all.iter().map(|p| (p.name.as_str(), p.n(), p.m())).collect();
        // NIST's table of the nonlinear regression datasets
        for expected in [
            ("Misra1a", 2, 14),
            ("Chwirut1", 3, 214),
            ("Lanczos3", 6, 24),
            ("Gauss1", 8, 250),
            ("Kirby2", 5, 151),
            ("Hahn1", 7, 236),
            ("Nelson", 3, 128),
            ("ENSO", 9, 168),
            ("Thurber", 7, 37),
            ("BoxBOD", 2, 6),
            ("Rat42", 3, 9),
            ("Rat43", 4, 15),
            ("Bennett5", 3, 154),
            ("MGH09", 4, 11),
            ("MGH10", 3, 16),
            ("Eckerle4", 3, 35),
        ] {
            assert!(sizes.contains(&expected), "{expected:?} not in {sizes:?}");
        }
        let count = |d| all.iter().filter(|p| p.difficulty == d).count();
        assert_eq!(
            (
                count(Difficulty::Lower),
                count(Difficulty::Average),
                count(Difficulty::Higher)
            ),
            (8, 11, 8)
        );
        // in difficulty order
        assert!(all.windows(2).all(|w| w[0].difficulty <= w[1].difficulty));
        let misra = &all[0];
        assert_eq!(misra.starts, [vec![500.0, 1e-4], vec![250.0, 5e-4]]);
        assert_eq!(misra.certified, vec![2.3894212918e2, 5.5015643181e-4]);
    }

    /// The models and data against NIST's own numbers: the residual sum
    /// of squares at the certified parameters is the certified one, to the
    /// accuracy the 11-digit parameters allow.
    #[test]
    fn the_certified_parameters_give_the_certified_residual_sum_of_squares() {
        for p in all().expect("parses") {
            let f = p.cost(&p.certified);
            // rounding b to 11 digits moves r by about 1e-11 |b| |J|; the
            // RSS by twice r times that (Lanczos1's RSS is 1.4e-25)
            let slack = 1e-9 * p.certified_rss + 1e-20;
            assert!(
                (f - p.certified_rss).abs() <= slack,
                "{}: RSS {f:e} at the certified parameters, certified {:e}",
                p.name,
                p.certified_rss
            );
        }
    }

    #[test]
    fn the_analytic_jacobian_matches_central_differences_at_both_starts_and_the_solution() {
        for p in all().expect("parses") {
            let (m, n) = (p.m(), p.n());
            for b in [&p.starts[0], &p.starts[1], &p.certified] {
                let mut jac = vec![0.0; m * n];
                p.jacobian_values(b, &mut jac).expect("sizes");
                for j in 0..n {
                    let h = 1e-6 * b[j].abs().max(1e-8);
                    let (mut up, mut down) = (b.clone(), b.clone());
                    up[j] += h;
                    down[j] -= h;
                    let (mut ru, mut rd) = (vec![0.0; m], vec![0.0; m]);
                    p.residuals(&up, &mut ru).expect("sizes");
                    p.residuals(&down, &mut rd).expect("sizes");
                    for i in 0..m {
                        let fd = (ru[i] - rd[i]) / (2.0 * h);
                        let exact = jac[i * n + j];
                        // truncation, and the rounding of r (sums of terms larger than r) over 2h
                        let rounding = 1024.0 * f64::EPSILON * ru[i].abs().max(rd[i].abs()).max(1.0) / h;
                        assert!(
                            (fd - exact).abs() <= 1e-5 * exact.abs().max(fd.abs()) + rounding,
                            "{} at {b:?}: dr{i}/db{} = {exact:e}, differences {fd:e}",
                            p.name,
                            j + 1
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn lre_counts_the_digits_that_agree() {
        let c = [2.0, -300.0];
        assert_eq!(lre(&c, &c), MAX_LRE);
        // 2.0002 agrees to 4 digits, -300.00003 to 7: the smallest is 4
        let x = [2.0002, -300.00003];
        assert!((lre(&x, &c) - 4.0).abs() < 1e-6, "{}", lre(&x, &c));
        // far off: 0, never negative; a wrong length or NaN: 0
        assert_eq!(lre(&[20.0, -300.0], &c), 0.0);
        assert_eq!(lre(&[2.0], &c), 0.0);
        assert_eq!(lre(&[f64::NAN, -300.0], &c), 0.0);
    }

    #[test]
    fn malformed_files_are_refused_with_the_file_and_line() {
        let text = include_str!("../data/nist/Misra1a.dat");
        let err = |t: &str| parse("Misra1a", t).expect_err("refused").to_string();
        let e = err(&text.replace("5.5015643181E-04", "5.5O15E-04"));
        assert!(e.starts_with("Misra1a.dat: line 42: `5.5O15E-04`"), "{e}");
        // a data row with a third column
        let e = err(&text.replace("      10.07E0      77.6E0", "      10.07E0      77.6E0  1.0"));
        assert!(e.contains("3 columns"), "{e}");
        // a missing observation
        let e = err(&text.replace("      81.78E0     760.0E0", ""));
        assert!(e.starts_with("Misra1a.dat: 13 observations"), "{e}");
        let e = parse("Misra9", text).expect_err("unknown").to_string();
        assert!(e.starts_with("Misra9.dat"), "{e}");
    }
}
