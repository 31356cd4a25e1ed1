//! `Plant`: the swing-up's simulated pendulum on a moving hand
//! (`swingup::plant::Plant`), behind `nprl.envs.HandPendulum`.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use swingup::plant::{Plant as RustPlant, PlantParams, PlantState};

/// The plant: state $(\theta, \dot\theta, x, \dot x)$ and the hand's
/// actual acceleration; see `swingup::plant`.
#[pyclass(module = "nprl._nprl", frozen)]
pub(crate) struct Plant {
    plant: RustPlant,
}

#[pymethods]
impl Plant {
    /// The paper's `"robot"` (l = 0.6 m, b = 0.2/s) or `"human"`
    /// (l = 0.5 m, b = 0.05/s), with an optional hand lag (s).
    #[new]
    #[pyo3(signature = (which = "robot", lag = 0.0))]
    fn new(which: &str, lag: f64) -> PyResult<Self> {
        let base = match which {
            "robot" => PlantParams::robot(),
            "human" => PlantParams::human(),
            other => {
                return Err(PyValueError::new_err(format!(
                    "plant must be 'robot' or 'human', got {other:?}"
                )));
            }
        };
        let params = PlantParams { lag, ..base };
        params.validate().map_err(PyValueError::new_err)?;
        Ok(Self {
            plant: RustPlant::new(params),
        })
    }

    /// One 60 Hz sample under the command `u` (clipped to the actuator
    /// limit): the next `(theta, theta_dot, x, x_dot)` and hand
    /// acceleration from `state` and `a`.
    fn step(&self, state: [f64; 4], a: f64, u: f64) -> ([f64; 4], f64) {
        let next = self.plant.step(&PlantState { s: state, a }, u);
        (next.s, next.a)
    }

    /// The parameters: gravity, length, damping, lag, dt, substeps,
    /// x_limit, u_limit.
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let p = &self.plant.params;
        let d = PyDict::new(py);
        d.set_item("gravity", p.gravity)?;
        d.set_item("length", p.length)?;
        d.set_item("damping", p.damping)?;
        d.set_item("lag", p.lag)?;
        d.set_item("dt", p.dt)?;
        d.set_item("substeps", p.substeps)?;
        d.set_item("x_limit", p.x_limit)?;
        d.set_item("u_limit", p.u_limit)?;
        Ok(d)
    }
}

/// The robot's sensor noise standard deviations on
/// `(theta, theta_dot, x, x_dot)`, the swing-up's default configuration.
#[pyfunction]
pub(crate) fn sensor_noise() -> [f64; 4] {
    swingup::config::Config::default().sensor_noise
}
