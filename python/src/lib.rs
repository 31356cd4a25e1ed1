//! The native module `nprl._nprl` behind the Python package `nprl`; see
//! `python/README.md`. Each submodule binds one crate's front door: the
//! Python package shapes scipy's and scikit-learn's conventions around it.

use pyo3::prelude::*;

mod control;
mod errors;
mod fit;
mod lwr_core;
mod plant;

#[pymodule]
fn _nprl(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    errors::register(m)?;
    m.add_class::<lwr_core::LwrCore>()?;
    m.add_class::<plant::Plant>()?;
    m.add_function(wrap_pyfunction!(fit::least_squares, m)?)?;
    m.add_function(wrap_pyfunction!(control::solve_ddp, m)?)?;
    m.add_function(wrap_pyfunction!(control::swingup_defaults, m)?)?;
    m.add_function(wrap_pyfunction!(plant::sensor_noise, m)?)?;
    Ok(())
}
