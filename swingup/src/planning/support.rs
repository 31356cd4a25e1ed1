//! Where the robot has data: a kernel density of the observed
//! (state, command) points, and the planner's penalty on leaving them.
//!
//! The data support at a query $z = (\theta, \dot\theta, x, \dot x, u)$ is
//! the sum of tricube kernel weights of the stored points,
//! $$s(z) = \sum_i K\big(\lVert \operatorname{diag}(m)(z - z_i) \rVert / h\big),
//! \qquad K(v) = (1 - v^3)^3_+ ,$$
//! with the metric scales $m_j$ relative to each input's spread in the data
//! (as the LWR's initial metric) and the bandwidth $h$. It is the LWR's
//! "effective number of points" $n_{lwr}$, but in a fixed metric: the LWR's
//! tuned metric may drop an input (scale 0), and then its support cannot
//! see a plan that leaves the data along that input.
//!
//! The planner's penalty is one residual per stage,
//! $$r_k = \sqrt{w}\,\frac{n_0}{n_0 + s(z_k)},$$
//! which is about $\sqrt w$ where there are no data and falls to 0 where
//! there are many more than $n_0$ points: a plan pays $w$ per sample it
//! spends outside the data, so it leaves them only where that gains more
//! task cost than it costs (a soft trust region around what the robot has
//! seen). Its gradient is exact; the tricube kernel is $C^1$ at the edge of
//! its support, so the penalty is continuously differentiable.

use std::sync::Arc;

use lwr::Database;

use crate::config::PlannerConfig;
use crate::record::TrialRecord;
use crate::record::training_data;

/// The data support and the penalty on leaving it; see the [module docs](self).
#[derive(Debug, Clone)]
pub struct DataSupport {
    db: Database,
    scales: Vec<f64>,
    bandwidth: f64,
    full: f64,
    sqrt_weight: f64,
}

impl DataSupport {
    /// The support of `inputs` with scales `relative` to each input's
    /// spread (0 leaves an input out), bandwidth `bandwidth`, $n_0$ = `full`
    /// and penalty weight `weight`.
    pub fn new(
        inputs: &[[f64; 5]],
        relative: &[f64; 5],
        bandwidth: f64,
        full: f64,
        weight: f64,
    ) -> crate::Result<Self> {
        crate::error::ensure_data!(!inputs.is_empty(), "the data support needs at least one point");
        crate::error::ensure_data!(
            bandwidth.is_finite() && bandwidth > 0.0,
            "support_bandwidth must be finite and positive, got {bandwidth}"
        );
        crate::error::ensure_data!(
            full.is_finite() && full > 0.0,
            "support_full must be finite and positive, got {full}"
        );
        crate::error::ensure_data!(
            weight.is_finite() && weight >= 0.0,
            "support_weight must be finite and nonnegative, got {weight}"
        );
        crate::error::ensure_data!(
            relative.iter().all(|m| m.is_finite() && *m >= 0.0) && relative.iter().any(|m| *m > 0.0),
            "support_scales must be finite and nonnegative, and not all 0, got {relative:?}"
        );
        let n = inputs.len() as f64;
        let scales: Vec<f64> = (0..5)
            .map(|c| {
                let mean = inputs.iter().map(|x| x[c]).sum::<f64>() / n;
                let sd = (inputs.iter().map(|x| (x[c] - mean).powi(2)).sum::<f64>() / n).sqrt();
                relative[c] / sd.max(1e-6)
            })
            .collect();
        let mut db = Database::new(5, 1)?;
        let zeros = vec![[0.0]; inputs.len()];
        db.insert_many(inputs, &zeros)?;
        Ok(Self {
            db,
            scales,
            bandwidth,
            full,
            sqrt_weight: weight.sqrt(),
        })
    }

    /// $s(z)$ and, when `gradient` is given, $\partial s / \partial z$ written into it.
    pub fn support(&self, z: &[f64; 5], gradient: Option<&mut [f64; 5]>) -> f64 {
        let h = self.bandwidth;
        let near = self.db.within_radius(z, &self.scales, h).unwrap_or_default();
        let mut s = 0.0;
        let mut g = [0.0; 5];
        for nb in &near {
            let v = nb.distance / h;
            if v >= 1.0 {
                continue;
            }
            let t = 1.0 - v * v * v;
            s += t * t * t;
            if gradient.is_some() {
                // dK/dz_j = -9 v (1 - v^3)^2 m_j^2 (z_j - x_j) / h^2
                let c = -9.0 * v * t * t / (h * h);
                if let Some(x) = self.db.input(nb.index) {
                    for j in 0..5 {
                        let m = self.scales[j];
                        g[j] += c * m * m * (z[j] - x[j]);
                    }
                }
            }
        }
        if let Some(out) = gradient {
            *out = g;
        }
        s
    }

    /// The penalty residual $r = \sqrt w\, n_0 / (n_0 + s(z))$ and, when
    /// `gradient` is given, $\partial r / \partial z$.
    pub fn residual(&self, z: &[f64; 5], gradient: Option<&mut [f64; 5]>) -> f64 {
        let want = gradient.is_some();
        let mut ds = [0.0; 5];
        let s = self.support(z, want.then_some(&mut ds));
        let d = self.full + s;
        if let Some(out) = gradient {
            let c = -self.sqrt_weight * self.full / (d * d);
            *out = std::array::from_fn(|j| c * ds[j]);
        }
        self.sqrt_weight * self.full / d
    }

    /// Whether the penalty has any weight.
    pub fn is_active(&self) -> bool {
        self.sqrt_weight > 0.0
    }
}

/// The support of the data of `trials` for the planner's penalty on
/// leaving them ([`PlannerConfig::support_weight`](crate::config::PlannerConfig::support_weight)); `None` when it is off.
pub fn data_support(p: &PlannerConfig, trials: &[TrialRecord]) -> crate::Result<Option<Arc<DataSupport>>> {
    if p.support_weight == 0.0 {
        return Ok(None);
    }
    let (xs, _) = training_data(trials);
    Ok(Some(Arc::new(DataSupport::new(
        &xs,
        &p.support_scales,
        p.support_bandwidth,
        p.support_full,
        p.support_weight,
    )?)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cloud() -> Vec<[f64; 5]> {
        (0..200)
            .map(|i| {
                let t = i as f64 * 0.05;
                [
                    t.sin(),
                    t.cos() * 2.0,
                    0.1 * t,
                    0.3 * (2.0 * t).sin(),
                    5.0 * (0.7 * t).cos(),
                ]
            })
            .collect()
    }

    /// The support equals a brute-force sum of kernel weights, and the
    /// residual's gradient equals central differences.
    #[test]
    fn support_and_gradient_match_brute_force_and_differences() {
        let data = cloud();
        let sup = DataSupport::new(&data, &[1.0, 1.0, 0.0, 0.5, 1.0], 0.6, 2.0, 100.0).expect("support");
        for q in [
            [0.3, 1.5, 0.2, 0.1, 3.0],
            [0.9, -0.5, 0.4, -0.2, -2.0],
            [3.0, 3.0, 3.0, 3.0, 30.0],
        ] {
            let brute: f64 = data
                .iter()
                .map(|x| {
                    let d2: f64 = (0..5).map(|j| (sup.scales[j] * (q[j] - x[j])).powi(2)).sum();
                    let v = d2.sqrt() / 0.6;
                    if v < 1.0 { (1.0 - v * v * v).powi(3) } else { 0.0 }
                })
                .sum();
            assert!((sup.support(&q, None) - brute).abs() < 1e-10, "{q:?}");
            let mut g = [0.0; 5];
            let r = sup.residual(&q, Some(&mut g));
            assert!(r > 0.0 && r <= 10.0 + 1e-12);
            let worst =
                ddp::strategies::check_jacobian(|z| vec![sup.residual(&z.try_into().expect("5 inputs"), None)], &q, &g)
                    .expect("check");
            assert!(worst.max_rel_error < 1e-5, "at {q:?}: {worst:?}");
        }
        // far from all data the penalty is its full weight; on the data, less
        let far = sup.residual(&[30.0, 30.0, 30.0, 30.0, 300.0], None);
        assert!((far - 10.0).abs() < 1e-12);
        assert!(sup.residual(&data[50], None) < 0.5 * far);
    }

    /// Bad settings are refused with the field's name.
    #[test]
    fn bad_settings_are_named() {
        let data = cloud();
        let e = DataSupport::new(&data, &[1.0; 5], 0.0, 1.0, 1.0)
            .expect_err("h")
            .to_string();
        assert!(e.contains("support_bandwidth"), "{e}");
        let e = DataSupport::new(&data, &[0.0; 5], 1.0, 1.0, 1.0)
            .expect_err("m")
            .to_string();
        assert!(e.contains("support_scales"), "{e}");
        assert!(DataSupport::new(&[], &[1.0; 5], 1.0, 1.0, 1.0).is_err());
    }
}
