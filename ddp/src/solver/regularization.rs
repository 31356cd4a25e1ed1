//! Tassa's schedule for the regularisation $\mu$.

use super::work::Work;
use crate::problem::{Cost, Dynamics};

impl<D: Dynamics, C: Cost> Work<'_, D, C> {
    pub(super) fn increase(&self, mu: &mut f64, delta: &mut f64) {
        let f = self.s.reg_factor;
        *delta = (*delta * f).max(f);
        *mu = (*mu * *delta).max(self.s.reg_min);
    }

    pub(super) fn decrease(&self, mu: &mut f64, delta: &mut f64) {
        let f = self.s.reg_factor;
        *delta = (*delta / f).min(1.0 / f);
        *mu *= *delta;
        if *mu < self.s.reg_min {
            *mu = 0.0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::DdpSettings;

    #[test]
    fn tassa_schedule_grows_and_snaps_to_zero() {
        let s = DdpSettings::default();
        let problem = crate::problems::pendulum_swingup(2).expect("problem");
        let w = Work::new(&problem, &s);
        let (mut mu, mut delta) = (0.0, 1.0);
        w.increase(&mut mu, &mut delta);
        assert_eq!((mu, delta), (s.reg_min, 2.0));
        w.increase(&mut mu, &mut delta);
        assert_eq!((mu, delta), (4.0 * s.reg_min, 4.0));
        w.decrease(&mut mu, &mut delta);
        assert_eq!((mu, delta), (2.0 * s.reg_min, 0.5));
        w.decrease(&mut mu, &mut delta);
        assert_eq!((mu, delta), (0.0, 0.25));
    }
}
