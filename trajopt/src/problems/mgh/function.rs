//! The 35 functions of the set, numbered as in the paper, with their
//! definitions; indices in the formulas are 1-based as in the paper.

/// One function of the Moré-Garbow-Hillstrom set, numbered as in the paper
/// (Moré, Garbow and Hillstrom 1981, section 3). Each is a sum of squares
/// $f(x) = \sum_{i=1}^m f_i(x)^2$; the residuals $f_i$ are given below with
/// 1-based indices, the *standard size* is the one [`MghProblem::new`]
/// uses (see the [module docs](super) for where the sizes come from), and
/// $f^*$ is the paper's value. "$f^* = 0$" with a point means the paper gives
/// that minimiser in closed form ([`MghProblem::known_minima`]).
///
/// [`MghProblem::new`]: super::MghProblem::new
/// [`MghProblem::known_minima`]: super::MghProblem::known_minima
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MghFunction {
    /// (1) Rosenbrock: $f_1 = 10(x_2 - x_1^2)$, $f_2 = 1 - x_1$.
    /// $n = m = 2$, $x_0 = (-1.2, 1)$, $f^* = 0$ at $(1, 1)$.
    Rosenbrock,
    /// (2) Freudenstein and Roth:
    /// $f_1 = -13 + x_1 + ((5 - x_2) x_2 - 2) x_2$,
    /// $f_2 = -29 + x_1 + ((x_2 + 1) x_2 - 14) x_2$.
    /// $n = m = 2$, $x_0 = (0.5, -2)$, $f^* = 0$ at $(5, 4)$; a local
    /// minimum $f = 48.9842$ at $(11.41\ldots, -0.8968\ldots)$.
    FreudensteinRoth,
    /// (3) Powell badly scaled: $f_1 = 10^4 x_1 x_2 - 1$,
    /// $f_2 = e^{-x_1} + e^{-x_2} - 1.0001$.
    /// $n = m = 2$, $x_0 = (0, 1)$, $f^* = 0$ at
    /// $(1.098\ldots \cdot 10^{-5}, 9.106\ldots)$.
    PowellBadlyScaled,
    /// (4) Brown badly scaled: $f_1 = x_1 - 10^6$, $f_2 = x_2 - 2 \cdot 10^{-6}$,
    /// $f_3 = x_1 x_2 - 2$.
    /// $n = 2$, $m = 3$, $x_0 = (1, 1)$, $f^* = 0$ at $(10^6, 2 \cdot 10^{-6})$.
    BrownBadlyScaled,
    /// (5) Beale: $f_i = y_i - x_1 (1 - x_2^i)$, $y = (1.5, 2.25, 2.625)$.
    /// $n = 2$, $m = 3$, $x_0 = (1, 1)$, $f^* = 0$ at $(3, 0.5)$.
    Beale,
    /// (6) Jennrich and Sampson: $f_i = 2 + 2i - (e^{i x_1} + e^{i x_2})$.
    /// $n = 2$, $m \ge n$ (standard $m = 10$), $x_0 = (0.3, 0.4)$,
    /// $f^* = 124.362$ at $x_1 = x_2 = 0.2578$ for $m = 10$.
    JennrichSampson,
    /// (7) Helical valley: $f_1 = 10 (x_3 - 10 \theta(x_1, x_2))$,
    /// $f_2 = 10 (\sqrt{x_1^2 + x_2^2} - 1)$, $f_3 = x_3$, with
    /// $\theta = \frac{1}{2\pi} \arctan(x_2 / x_1)$ for $x_1 > 0$ and
    /// $\frac{1}{2\pi} \arctan(x_2 / x_1) + \frac12$ for $x_1 < 0$ (so
    /// $\theta \in (-\frac14, \frac34)$, not `atan2`'s range). On $x_1 = 0$,
    /// where the paper leaves $\theta$ undefined, $\theta = \frac14$ for
    /// $x_2 \ge 0$ and $-\frac14$ for $x_2 < 0$ (MINPACK's choice); at
    /// $x_1 = x_2 = 0$ the derivatives of $\theta$ and of the radius are
    /// undefined and the Jacobian takes them as 0.
    /// $n = m = 3$, $x_0 = (-1, 0, 0)$, $f^* = 0$ at $(1, 0, 0)$.
    HelicalValley,
    /// (8) Bard: $f_i = y_i - \left(x_1 + \frac{u_i}{v_i x_2 + w_i x_3}\right)$,
    /// $u_i = i$, $v_i = 16 - i$, $w_i = \min(u_i, v_i)$,
    /// $y = (0.14, 0.18, 0.22, 0.25, 0.29, 0.32, 0.35, 0.39, 0.37, 0.58,
    /// 0.73, 0.96, 1.34, 2.10, 4.39)$.
    /// $n = 3$, $m = 15$, $x_0 = (1, 1, 1)$, $f^* = 8.21487 \cdot 10^{-3}$;
    /// also $f = 17.4286$ at $(0.8406\ldots, -\infty, -\infty)$.
    Bard,
    /// (9) Gaussian: $f_i = x_1 \exp(-x_2 (t_i - x_3)^2 / 2) - y_i$,
    /// $t_i = (8 - i)/2$, $y = (0.0009, 0.0044, 0.0175, 0.0540, 0.1295,
    /// 0.2420, 0.3521, 0.3989, 0.3521, 0.2420, 0.1295, 0.0540, 0.0175, 0.0044,
    /// 0.0009)$ (symmetric).
    /// $n = 3$, $m = 15$, $x_0 = (0.4, 1, 0)$, $f^* = 1.12793 \cdot 10^{-8}$.
    Gaussian,
    /// (10) Meyer: $f_i = x_1 \exp\left(\frac{x_2}{t_i + x_3}\right) - y_i$,
    /// $t_i = 45 + 5i$, $y = (34780, 28610, 23650, 19630, 16370, 13720,
    /// 11540, 9744, 8261, 7030, 6005, 5147, 4427, 3820, 3307, 2872)$.
    /// $n = 3$, $m = 16$, $x_0 = (0.02, 4000, 250)$, $f^* = 87.9458$.
    Meyer,
    /// (11) Gulf research and development:
    /// $f_i = \exp\left(-\frac{|y_i - x_2|^{x_3}}{x_1}\right) - t_i$,
    /// $t_i = i / 100$, $y_i = 25 + (-50 \ln t_i)^{2/3}$ (the paper prints
    /// $|y_i m i x_2|$, a typesetting slip for $|y_i - x_2|$, as the authors'
    /// code has it). Where $y_i = x_2$ the derivatives in $x_2, x_3$ are taken
    /// as 0 (their limits for $x_3 > 1$).
    /// $n = 3$, $3 \le m \le 100$ (standard $m = 99$), $x_0 = (5, 2.5, 0.15)$,
    /// $f^* = 0$ at $(50, 25, 1.5)$ for every $m$.
    Gulf,
    /// (12) Box three-dimensional:
    /// $f_i = e^{-t_i x_1} - e^{-t_i x_2} - x_3 (e^{-t_i} - e^{-10 t_i})$,
    /// $t_i = 0.1 i$.
    /// $n = 3$, $m \ge n$ (standard $m = 10$), $x_0 = (0, 10, 20)$,
    /// $f^* = 0$ at $(1, 10, 1)$, at $(10, 1, -1)$ and wherever
    /// $x_1 = x_2$, $x_3 = 0$.
    Box3d,
    /// (13) Powell singular: $f_1 = x_1 + 10 x_2$, $f_2 = \sqrt5 (x_3 - x_4)$,
    /// $f_3 = (x_2 - 2 x_3)^2$, $f_4 = \sqrt{10} (x_1 - x_4)^2$.
    /// $n = m = 4$, $x_0 = (3, -1, 0, 1)$, $f^* = 0$ at the origin (where
    /// $J^\top J$ is singular).
    PowellSingular,
    /// (14) Wood: $f_1 = 10 (x_2 - x_1^2)$, $f_2 = 1 - x_1$,
    /// $f_3 = \sqrt{90} (x_4 - x_3^2)$, $f_4 = 1 - x_3$,
    /// $f_5 = \sqrt{10} (x_2 + x_4 - 2)$, $f_6 = (x_2 - x_4) / \sqrt{10}$.
    /// $n = 4$, $m = 6$, $x_0 = (-3, -1, -3, -1)$, $f^* = 0$ at $(1, 1, 1, 1)$.
    Wood,
    /// (15) Kowalik and Osborne:
    /// $f_i = y_i - \frac{x_1 (u_i^2 + u_i x_2)}{u_i^2 + u_i x_3 + x_4}$,
    /// $y = (0.1957, 0.1947, 0.1735, 0.1600, 0.0844, 0.0627, 0.0456, 0.0342,
    /// 0.0323, 0.0235, 0.0246)$,
    /// $u = (4, 2, 1, 0.5, 0.25, 0.167, 0.125, 0.1, 0.0833, 0.0714, 0.0625)$.
    /// $n = 4$, $m = 11$, $x_0 = (0.25, 0.39, 0.415, 0.39)$,
    /// $f^* = 3.07505 \cdot 10^{-4}$; also $f = 1.02734 \cdot 10^{-3}$ at
    /// $(+\infty, -14.07\ldots, -\infty, -\infty)$.
    KowalikOsborne,
    /// (16) Brown and Dennis: $f_i = (x_1 + t_i x_2 - e^{t_i})^2 +
    /// (x_3 + x_4 \sin t_i - \cos t_i)^2$, $t_i = i / 5$.
    /// $n = 4$, $m \ge n$ (standard $m = 20$), $x_0 = (25, 5, -5, -1)$,
    /// $f^* = 85822.2$ for $m = 20$.
    BrownDennis,
    /// (17) Osborne 1:
    /// $f_i = y_i - (x_1 + x_2 e^{-t_i x_4} + x_3 e^{-t_i x_5})$,
    /// $t_i = 10 (i - 1)$, 33 data $y_i$ from 0.844 to 0.406 (see the source).
    /// $n = 5$, $m = 33$, $x_0 = (0.5, 1.5, -1, 0.01, 0.02)$,
    /// $f^* = 5.46489 \cdot 10^{-5}$.
    Osborne1,
    /// (18) Biggs EXP6:
    /// $f_i = x_3 e^{-t_i x_1} - x_4 e^{-t_i x_2} + x_6 e^{-t_i x_5} - y_i$,
    /// $t_i = 0.1 i$, $y_i = e^{-t_i} - 5 e^{-10 t_i} + 3 e^{-4 t_i}$.
    /// $n = 6$, $m \ge n$ (standard $m = 13$), $x_0 = (1, 2, 1, 1, 1, 1)$,
    /// $f^* = 0$ at $(1, 10, 1, 5, 4, 3)$ (the data are exact), and the
    /// paper's $f = 5.65565 \cdot 10^{-3}$ for $m = 13$, a local minimum.
    BiggsExp6,
    /// (19) Osborne 2: $f_i = y_i - (x_1 e^{-t_i x_5} +
    /// x_2 e^{-(t_i - x_9)^2 x_6} + x_3 e^{-(t_i - x_{10})^2 x_7} +
    /// x_4 e^{-(t_i - x_{11})^2 x_8})$, $t_i = (i - 1)/10$, 65 data $y_i$
    /// from 1.366 to 0.054 (see the source).
    /// $n = 11$, $m = 65$, $x_0 = (1.3, 0.65, 0.65, 0.7, 0.6, 3, 5, 7, 2,
    /// 4.5, 5.5)$, $f^* = 4.01377 \cdot 10^{-2}$.
    Osborne2,
    /// (20) Watson: for $1 \le i \le 29$, $t_i = i / 29$,
    /// $f_i = \sum_{j=2}^n (j - 1) x_j t_i^{j-2} - \left(\sum_{j=1}^n x_j
    /// t_i^{j-1}\right)^2 - 1$; $f_{30} = x_1$, $f_{31} = x_2 - x_1^2 - 1$.
    /// $2 \le n \le 31$ (standard $n = 6$), $m = 31$, $x_0 = 0$ (scaled
    /// starts: see [`MghProblem::start`](super::MghProblem::start)),
    /// $f^* = 2.28767 \cdot 10^{-3}$ ($n = 6$), $1.39976 \cdot 10^{-6}$
    /// ($n = 9$), $4.72238 \cdot 10^{-10}$ ($n = 12$).
    Watson,
    /// (21) Extended Rosenbrock: $f_{2i-1} = 10 (x_{2i} - x_{2i-1}^2)$,
    /// $f_{2i} = 1 - x_{2i-1}$.
    /// $n$ even (standard $n = 10$), $m = n$, $x_0 = (-1.2, 1, \ldots,
    /// -1.2, 1)$, $f^* = 0$ at $(1, \ldots, 1)$.
    ExtendedRosenbrock,
    /// (22) Extended Powell singular: $f_{4i-3} = x_{4i-3} + 10 x_{4i-2}$,
    /// $f_{4i-2} = \sqrt5 (x_{4i-1} - x_{4i})$,
    /// $f_{4i-1} = (x_{4i-2} - 2 x_{4i-1})^2$,
    /// $f_{4i} = \sqrt{10} (x_{4i-3} - x_{4i})^2$.
    /// $n$ a multiple of 4 (standard $n = 12$), $m = n$,
    /// $x_0 = (3, -1, 0, 1, \ldots)$, $f^* = 0$ at the origin.
    ExtendedPowellSingular,
    /// (23) Penalty I: $f_i = \sqrt{a} (x_i - 1)$ for $i \le n$,
    /// $f_{n+1} = \sum_j x_j^2 - \frac14$, $a = 10^{-5}$.
    /// $n \ge 1$ (standard $n = 10$), $m = n + 1$, $x_0 = (1, 2, \ldots, n)$,
    /// $f^* = 2.24997 \cdot 10^{-5}$ ($n = 4$), $7.08765 \cdot 10^{-5}$
    /// ($n = 10$).
    PenaltyI,
    /// (24) Penalty II: $f_1 = x_1 - 0.2$;
    /// $f_i = \sqrt{a} (e^{x_i/10} + e^{x_{i-1}/10} - y_i)$ for
    /// $2 \le i \le n$, $y_i = e^{i/10} + e^{(i-1)/10}$;
    /// $f_i = \sqrt{a} (e^{x_{i-n+1}/10} - e^{-1/10})$ for $n < i < 2n$;
    /// $f_{2n} = \sum_{j=1}^n (n - j + 1) x_j^2 - 1$; $a = 10^{-5}$.
    /// $n \ge 1$ (standard $n = 10$), $m = 2n$, $x_0 = (\frac12, \ldots,
    /// \frac12)$, $f^* = 9.37629 \cdot 10^{-6}$ ($n = 4$),
    /// $2.93660 \cdot 10^{-4}$ ($n = 10$).
    PenaltyII,
    /// (25) Variably dimensioned: $f_i = x_i - 1$ for $i \le n$,
    /// $f_{n+1} = \sum_j j (x_j - 1)$, $f_{n+2} = \left(\sum_j j (x_j -
    /// 1)\right)^2$.
    /// $n \ge 1$ (standard $n = 10$), $m = n + 2$, $x_0 = (1 - j/n)_j$,
    /// $f^* = 0$ at $(1, \ldots, 1)$.
    VariablyDimensioned,
    /// (26) Trigonometric: $f_i = n - \sum_j \cos x_j + i (1 - \cos x_i) -
    /// \sin x_i$.
    /// $n \ge 1$ (standard $n = 10$), $m = n$, $x_0 = (1/n, \ldots, 1/n)$,
    /// $f^* = 0$ (no closed-form minimiser; from $x_0$ with $n = 10$ the
    /// usual solvers stop at a local minimum $f \approx 2.79506 \cdot
    /// 10^{-5}$, which the paper does not list).
    Trigonometric,
    /// (27) Brown almost-linear: $f_i = x_i + \sum_j x_j - (n + 1)$ for
    /// $i < n$, $f_n = \prod_j x_j - 1$.
    /// $n \ge 1$ (standard $n = 10$), $m = n$, $x_0 = (\frac12, \ldots,
    /// \frac12)$, $f^* = 0$ at $(\alpha, \ldots, \alpha, \alpha^{1-n})$
    /// with $n \alpha^n - (n + 1) \alpha^{n-1} + 1 = 0$, in particular at
    /// $(1, \ldots, 1)$; also $f = 1$ at $(0, \ldots, 0, n + 1)$.
    BrownAlmostLinear,
    /// (28) Discrete boundary value: $f_i = 2 x_i - x_{i-1} - x_{i+1} +
    /// h^2 (x_i + t_i + 1)^3 / 2$, $h = 1/(n + 1)$, $t_i = i h$,
    /// $x_0 = x_{n+1} = 0$ (the boundary values, not the start).
    /// $n \ge 1$ (standard $n = 10$), $m = n$, start $\xi_j = t_j (t_j - 1)$,
    /// $f^* = 0$.
    DiscreteBoundaryValue,
    /// (29) Discrete integral equation: $f_i = x_i + \frac{h}{2}\left[(1 -
    /// t_i) \sum_{j=1}^i t_j (x_j + t_j + 1)^3 + t_i \sum_{j=i+1}^n (1 - t_j)
    /// (x_j + t_j + 1)^3\right]$, $h = 1/(n + 1)$, $t_i = i h$.
    /// $n \ge 1$ (standard $n = 10$), $m = n$, start $\xi_j = t_j (t_j - 1)$,
    /// $f^* = 0$.
    DiscreteIntegralEquation,
    /// (30) Broyden tridiagonal: $f_i = (3 - 2 x_i) x_i - x_{i-1} -
    /// 2 x_{i+1} + 1$, $x_0 = x_{n+1} = 0$ (boundary values).
    /// $n \ge 1$ (standard $n = 10$), $m = n$, start $(-1, \ldots, -1)$,
    /// $f^* = 0$.
    BroydenTridiagonal,
    /// (31) Broyden banded: $f_i = x_i (2 + 5 x_i^2) + 1 - \sum_{j \in J_i}
    /// x_j (1 + x_j)$, $J_i = \{j \ne i : \max(1, i - 5) \le j \le \min(n,
    /// i + 1)\}$.
    /// $n \ge 1$ (standard $n = 10$), $m = n$, start $(-1, \ldots, -1)$,
    /// $f^* = 0$.
    BroydenBanded,
    /// (32) Linear function, full rank: $f_i = x_i - \frac2m \sum_j x_j - 1$
    /// for $i \le n$, $f_i = -\frac2m \sum_j x_j - 1$ for $i > n$.
    /// $m \ge n \ge 1$ (standard $n = 5$, $m = 10$), $x_0 = (1, \ldots, 1)$,
    /// $f^* = m - n$ at $(-1, \ldots, -1)$.
    LinearFullRank,
    /// (33) Linear function, rank 1: $f_i = i \sum_j j x_j - 1$.
    /// $m \ge n \ge 1$ (standard $n = 5$, $m = 10$), $x_0 = (1, \ldots, 1)$,
    /// $f^* = \frac{m (m - 1)}{2 (2m + 1)}$ at every point with
    /// $\sum_j j x_j = \frac{3}{2m + 1}$.
    LinearRank1,
    /// (34) Linear function, rank 1 with zero columns and rows:
    /// $f_1 = f_m = -1$, $f_i = (i - 1) \sum_{j=2}^{n-1} j x_j - 1$ for
    /// $2 \le i \le m - 1$.
    /// $m \ge n \ge 3$ (standard $n = 5$, $m = 10$), $x_0 = (1, \ldots, 1)$,
    /// $f^* = \frac{m^2 + 3m - 6}{2 (2m - 3)}$ at every point with
    /// $\sum_{j=2}^{n-1} j x_j = \frac{3}{2m - 3}$.
    LinearRank1ZeroColumnsRows,
    /// (35) Chebyquad: $f_i = \frac1n \sum_{j=1}^n T_i(x_j) - \int_0^1
    /// T_i(t)\,dt$, $T_i$ the Chebyshev polynomial shifted to $[0, 1]$
    /// ($T_i(t) = \cos(i \arccos(2t - 1))$); the integral is 0 for odd $i$
    /// and $-1/(i^2 - 1)$ for even $i$.
    /// $m \ge n \ge 1$ (standard $n = m = 10$), $x_0 = (j / (n + 1))_j$,
    /// $f^* = 0$ for $m = n$, $1 \le n \le 7$ and $n = 9$;
    /// $3.51687 \cdot 10^{-3}$ for $m = n = 8$; $6.50395 \cdot 10^{-3}$ for
    /// $m = n = 10$.
    Chebyquad,
}

impl MghFunction {
    /// The 35 functions in the paper's order.
    pub const ALL: [MghFunction; 35] = [
        Self::Rosenbrock,
        Self::FreudensteinRoth,
        Self::PowellBadlyScaled,
        Self::BrownBadlyScaled,
        Self::Beale,
        Self::JennrichSampson,
        Self::HelicalValley,
        Self::Bard,
        Self::Gaussian,
        Self::Meyer,
        Self::Gulf,
        Self::Box3d,
        Self::PowellSingular,
        Self::Wood,
        Self::KowalikOsborne,
        Self::BrownDennis,
        Self::Osborne1,
        Self::BiggsExp6,
        Self::Osborne2,
        Self::Watson,
        Self::ExtendedRosenbrock,
        Self::ExtendedPowellSingular,
        Self::PenaltyI,
        Self::PenaltyII,
        Self::VariablyDimensioned,
        Self::Trigonometric,
        Self::BrownAlmostLinear,
        Self::DiscreteBoundaryValue,
        Self::DiscreteIntegralEquation,
        Self::BroydenTridiagonal,
        Self::BroydenBanded,
        Self::LinearFullRank,
        Self::LinearRank1,
        Self::LinearRank1ZeroColumnsRows,
        Self::Chebyquad,
    ];

    /// The paper's number, 1 to 35.
    pub fn id(self) -> usize {
        // ALL lists every variant once, in order
        Self::ALL.iter().position(|&f| f == self).map_or(0, |i| i + 1)
    }

    /// The function with the paper's number `id` (1 to 35).
    pub fn from_id(id: usize) -> Option<Self> {
        id.checked_sub(1).and_then(|i| Self::ALL.get(i)).copied()
    }

    /// The paper's name, e.g. `"Freudenstein and Roth function"`.
    pub fn name(self) -> &'static str {
        self.names().0
    }

    /// A short snake-case key, e.g. `"freudenstein_roth"`.
    pub fn key(self) -> &'static str {
        self.names().1
    }

    fn names(self) -> (&'static str, &'static str) {
        match self {
            Self::Rosenbrock => ("Rosenbrock function", "rosenbrock"),
            Self::FreudensteinRoth => ("Freudenstein and Roth function", "freudenstein_roth"),
            Self::PowellBadlyScaled => ("Powell badly scaled function", "powell_badly_scaled"),
            Self::BrownBadlyScaled => ("Brown badly scaled function", "brown_badly_scaled"),
            Self::Beale => ("Beale function", "beale"),
            Self::JennrichSampson => ("Jennrich and Sampson function", "jennrich_sampson"),
            Self::HelicalValley => ("Helical valley function", "helical_valley"),
            Self::Bard => ("Bard function", "bard"),
            Self::Gaussian => ("Gaussian function", "gaussian"),
            Self::Meyer => ("Meyer function", "meyer"),
            Self::Gulf => ("Gulf research and development function", "gulf"),
            Self::Box3d => ("Box three-dimensional function", "box3d"),
            Self::PowellSingular => ("Powell singular function", "powell_singular"),
            Self::Wood => ("Wood function", "wood"),
            Self::KowalikOsborne => ("Kowalik and Osborne function", "kowalik_osborne"),
            Self::BrownDennis => ("Brown and Dennis function", "brown_dennis"),
            Self::Osborne1 => ("Osborne 1 function", "osborne1"),
            Self::BiggsExp6 => ("Biggs EXP6 function", "biggs_exp6"),
            Self::Osborne2 => ("Osborne 2 function", "osborne2"),
            Self::Watson => ("Watson function", "watson"),
            Self::ExtendedRosenbrock => ("Extended Rosenbrock function", "extended_rosenbrock"),
            Self::ExtendedPowellSingular => ("Extended Powell singular function", "extended_powell_singular"),
            Self::PenaltyI => ("Penalty function I", "penalty1"),
            Self::PenaltyII => ("Penalty function II", "penalty2"),
            Self::VariablyDimensioned => ("Variably dimensioned function", "variably_dimensioned"),
            Self::Trigonometric => ("Trigonometric function", "trigonometric"),
            Self::BrownAlmostLinear => ("Brown almost-linear function", "brown_almost_linear"),
            Self::DiscreteBoundaryValue => ("Discrete boundary value function", "discrete_boundary_value"),
            Self::DiscreteIntegralEquation => ("Discrete integral equation function", "discrete_integral_equation"),
            Self::BroydenTridiagonal => ("Broyden tridiagonal function", "broyden_tridiagonal"),
            Self::BroydenBanded => ("Broyden banded function", "broyden_banded"),
            Self::LinearFullRank => ("Linear function - full rank", "linear_full_rank"),
            Self::LinearRank1 => ("Linear function - rank 1", "linear_rank1"),
            Self::LinearRank1ZeroColumnsRows => (
                "Linear function - rank 1 with zero columns and rows",
                "linear_rank1_zero",
            ),
            Self::Chebyquad => ("Chebyquad function", "chebyquad"),
        }
    }

    /// The function whose [`name`](Self::name) or [`key`](Self::key) is
    /// `name`, compared without regard to case, spaces, hyphens and
    /// underscores (`"Box three-dimensional function"`, `"box3d"`,
    /// `"BIGGS_EXP6"` all work).
    pub fn from_name(name: &str) -> Option<Self> {
        let norm = |s: &str| -> String {
            s.chars()
                .filter(|c| c.is_alphanumeric())
                .flat_map(char::to_lowercase)
                .collect()
        };
        let wanted = norm(name);
        Self::ALL
            .into_iter()
            .find(|f| norm(f.name()) == wanted || norm(f.key()) == wanted)
    }
}
