//! The Rust error types as Python exceptions, each a `ValueError` (bad
//! input to a numerical routine) carrying the Rust error's message.

use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

create_exception!(
    _nprl,
    LwrError,
    PyValueError,
    "An error of the locally weighted regression (Rust `lwr::LwrError`): bad data, a query no data \
     weighs, invalid settings."
);
create_exception!(
    _nprl,
    LeastSquaresError,
    PyValueError,
    "An error of the least-squares solvers (Rust `trajopt::TrajoptError`): sizes, bounds, a start \
     where the residuals are not finite, invalid settings."
);
create_exception!(
    _nprl,
    DdpError,
    PyValueError,
    "An error of DDP (Rust `ddp::DdpError`): sizes, limits, a model that fails on the warm start."
);

pub(crate) fn lwr_error(e: lwr::LwrError) -> PyErr {
    LwrError::new_err(e.to_string())
}

pub(crate) fn least_squares_error(e: trajopt::TrajoptError) -> PyErr {
    LeastSquaresError::new_err(e.to_string())
}

pub(crate) fn ddp_error(e: ddp::DdpError) -> PyErr {
    DdpError::new_err(e.to_string())
}

/// Adds the exception types to the module.
pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("LwrError", py.get_type::<LwrError>())?;
    m.add("LeastSquaresError", py.get_type::<LeastSquaresError>())?;
    m.add("DdpError", py.get_type::<DdpError>())?;
    Ok(())
}
