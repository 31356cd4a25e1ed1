//! `least_squares`: `trajopt::LeastSquares` over Python callables, behind
//! `nprl.least_squares` (scipy's signature is the Python wrapper's).

use std::cell::{Cell, RefCell};

use numpy::{IntoPyArray, PyArray1, PyArrayMethods, PyReadonlyArray1, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use trajopt::derivative_free::Difference;
use trajopt::faer::sparse::SymbolicSparseRowMat;
use trajopt::fit::Loss;
use trajopt::{
    DampingScale, FitStatus, GaussNewtonSettings, GaussNewtonStatus, LeastSquares, Method, PowellSettings,
    PowellStatus, StepControl,
};

use crate::errors::least_squares_error;

/// Calls a Python function of `x` that returns `len` numbers, writing them
/// into `out`; the first exception is kept (the solver then sees NaN, and
/// the exception is raised when the solve returns).
struct Callback<'py> {
    f: Bound<'py, PyAny>,
    len: usize,
    what: &'static str,
    calls: Cell<usize>,
    error: RefCell<Option<PyErr>>,
    /// The value at the start, computed by the wrapper: the first call at
    /// exactly that point returns it without calling Python again.
    cached: RefCell<Option<(Vec<f64>, Vec<f64>)>>,
}

impl<'py> Callback<'py> {
    fn new(f: Bound<'py, PyAny>, len: usize, what: &'static str) -> Self {
        Self {
            f,
            len,
            what,
            calls: Cell::new(0),
            error: RefCell::new(None),
            cached: RefCell::new(None),
        }
    }

    fn call(&self, x: &[f64], out: &mut [f64]) {
        if let Some((_, v0)) = self.cached.borrow_mut().take_if(|(x0, _)| x0.as_slice() == x) {
            out.copy_from_slice(&v0);
            return;
        }
        if self.error.borrow().is_some() {
            out.fill(f64::NAN);
            return;
        }
        self.calls.set(self.calls.get() + 1);
        let py = self.f.py();
        let result = self
            .f
            .call1((PyArray1::from_slice(py, x),))
            .and_then(|v| self.copy(&v, out));
        if let Err(e) = result {
            out.fill(f64::NAN);
            *self.error.borrow_mut() = Some(e);
        }
    }

    /// Copies a float64 array of `len` numbers (any shape, C order) into `out`.
    fn copy(&self, v: &Bound<'py, PyAny>, out: &mut [f64]) -> PyResult<()> {
        let array = v.cast::<PyArray1<f64>>().ok().cloned().map(Ok).unwrap_or_else(|| {
            let np = v.py().import("numpy")?;
            let flat = np
                .call_method1("ascontiguousarray", (v, "float64"))?
                .call_method0("ravel")?;
            flat.cast_into::<PyArray1<f64>>().map_err(PyErr::from)
        })?;
        let view: PyReadonlyArray1<'_, f64> = array.readonly();
        if view.len() != self.len {
            return Err(PyValueError::new_err(format!(
                "{} returned {} values, expected {}",
                self.what,
                view.len(),
                self.len
            )));
        }
        match view.as_slice() {
            Ok(s) => out.copy_from_slice(s),
            Err(_) => {
                for (o, v) in out.iter_mut().zip(view.as_array().iter()) {
                    *o = *v;
                }
            }
        }
        Ok(())
    }
}

/// scipy's status code of a solver's status: 1 gradient, 2 cost, 3 step
/// (scipy's gtol, ftol, xtol tests), 0 a budget, -2 a failure (stalled or
/// numerical), -3 stopped or out of time.
fn scipy_status(status: FitStatus) -> i32 {
    match status {
        FitStatus::GaussNewton(s) => match s {
            GaussNewtonStatus::ConvergedGradient => 1,
            GaussNewtonStatus::ConvergedCost => 2,
            GaussNewtonStatus::ConvergedStep => 3,
            GaussNewtonStatus::MaxIterations | GaussNewtonStatus::MaxEvaluations => 0,
            GaussNewtonStatus::Stalled | GaussNewtonStatus::NumericalError => -2,
            _ => -3,
        },
        FitStatus::Powell(s) => match s {
            PowellStatus::ConvergedCost | PowellStatus::ReachedStopCost => 2,
            PowellStatus::ConvergedStep => 3,
            PowellStatus::MaxIterations | PowellStatus::MaxEvaluations => 0,
            _ => -3,
        },
        _ => -3,
    }
}

fn message(status: FitStatus) -> &'static str {
    match status {
        FitStatus::GaussNewton(s) => match s {
            GaussNewtonStatus::ConvergedGradient => "`gtol` termination condition is satisfied.",
            GaussNewtonStatus::ConvergedCost => "`ftol` termination condition is satisfied.",
            GaussNewtonStatus::ConvergedStep => "`xtol` termination condition is satisfied.",
            GaussNewtonStatus::MaxIterations => "The maximum number of iterations is exceeded.",
            GaussNewtonStatus::MaxEvaluations => "The maximum number of function evaluations is exceeded.",
            GaussNewtonStatus::Stalled => {
                "Stalled: steps kept failing while the gradient is not small (residuals not smooth, or a \
                 Jacobian that does not match them)."
            }
            GaussNewtonStatus::NumericalError => {
                "Numerical error: residuals or Jacobian not finite at every trial step."
            }
            _ => "Stopped.",
        },
        FitStatus::Powell(s) => match s {
            PowellStatus::ConvergedCost | PowellStatus::ReachedStopCost => "`ftol` termination condition is satisfied.",
            PowellStatus::ConvergedStep => "`xtol` termination condition is satisfied.",
            PowellStatus::MaxIterations => "The maximum number of iterations is exceeded.",
            PowellStatus::MaxEvaluations => "The maximum number of function evaluations is exceeded.",
            _ => "Stopped.",
        },
        _ => "Stopped.",
    }
}

fn parse_loss(name: &str) -> PyResult<Loss> {
    Ok(match name {
        "linear" => Loss::Linear,
        "soft_l1" => Loss::SoftL1,
        "huber" => Loss::Huber,
        "cauchy" => Loss::Cauchy,
        "arctan" => Loss::Arctan,
        other => {
            return Err(PyValueError::new_err(format!(
                "loss must be one of 'linear', 'soft_l1', 'huber', 'cauchy', 'arctan', got {other:?}"
            )));
        }
    })
}

/// The CSR pattern `(indptr, indices)` of an `m x n` matrix, checked.
fn pattern(m: usize, n: usize, indptr: Vec<usize>, indices: Vec<usize>) -> PyResult<SymbolicSparseRowMat<usize>> {
    let bad = |why: String| Err(PyValueError::new_err(format!("jac_sparsity: {why}")));
    if indptr.len() != m + 1 || indptr[0] != 0 || indptr[m] != indices.len() {
        return bad(format!(
            "a CSR pattern of {m} rows needs {} row pointers from 0 to the number of entries",
            m + 1
        ));
    }
    for i in 0..m {
        let row = indices.get(indptr[i]..indptr[i + 1]);
        let Some(row) = row else {
            return bad(format!("row pointers decrease at row {i}"));
        };
        if row.windows(2).any(|w| w[0] >= w[1]) || row.iter().any(|&k| k >= n) {
            return bad(format!("row {i} has column indices unsorted, repeated or beyond {n}"));
        }
    }
    Ok(SymbolicSparseRowMat::new_checked(m, n, indptr, None, indices))
}

/// Solves; the arguments are the Python wrapper's, already checked there.
#[pyfunction]
#[pyo3(signature = (fun, x0, f0, jac, difference, sparsity, lower, upper, method, loss, f_scale, ftol, xtol, gtol, max_iterations, max_nfev))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn least_squares<'py>(
    py: Python<'py>,
    fun: Bound<'py, PyAny>,
    x0: PyReadonlyArray1<'py, f64>,
    f0: PyReadonlyArray1<'py, f64>,
    jac: Option<Bound<'py, PyAny>>,
    difference: &str,
    sparsity: Option<(Vec<usize>, Vec<usize>)>,
    lower: Option<Vec<f64>>,
    upper: Option<Vec<f64>>,
    method: &str,
    loss: &str,
    f_scale: f64,
    ftol: f64,
    xtol: f64,
    gtol: f64,
    max_iterations: usize,
    max_nfev: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let x0 = x0.as_slice()?.to_vec();
    let (n, m) = (x0.len(), f0.len());
    let residuals = Callback::new(fun, m, "fun");
    *residuals.cached.borrow_mut() = Some((x0.clone(), f0.as_slice()?.to_vec()));
    let jacobian = jac.map(|j| Callback::new(j, m * n, "jac"));
    // the trust region in the parameters' units (scipy's x_scale=1), or
    // scaled by the Jacobian's running column norms (x_scale="jac")
    let (method, step_control, damping_scale) = match method {
        "trust-region" => (Method::GaussNewton, StepControl::TrustRegion, DampingScale::Identity),
        "trust-region-jac" => (Method::GaussNewton, StepControl::TrustRegion, DampingScale::RunningMax),
        "derivative-free" => (Method::DerivativeFree, StepControl::Damping, DampingScale::Current),
        "powell" => (Method::Powell, StepControl::Damping, DampingScale::Current),
        other => return Err(PyValueError::new_err(format!("unknown method {other:?}"))),
    };
    // the trust region is for unbounded problems: with bounds, the damped
    // steps that keep them, scaled by diag(J^T J) as before
    let (step_control, damping_scale) = if lower.is_some() || upper.is_some() {
        (StepControl::Damping, DampingScale::Current)
    } else {
        (step_control, damping_scale)
    };
    let mut problem = LeastSquares::new(m, |x: &[f64], r: &mut [f64]| residuals.call(x, r))
        .method(method)
        .loss(parse_loss(loss)?, f_scale)
        .difference(match difference {
            "2-point" => Difference::Forward,
            _ => Difference::Central,
        })
        .settings(GaussNewtonSettings {
            max_iterations,
            tol_cost: ftol,
            tol_step: xtol,
            tol_grad: gtol,
            step_control,
            damping_scale,
            ..GaussNewtonSettings::default()
        })
        .powell_settings(PowellSettings {
            tol_cost: ftol,
            tol_step: xtol,
            max_evals: max_nfev,
            ..PowellSettings::default()
        });
    if let Some(j) = &jacobian {
        problem = problem.jacobian(|x: &[f64], out: &mut [f64]| j.call(x, out));
    }
    if let Some((indptr, indices)) = sparsity {
        problem = problem.pattern(pattern(m, n, indptr, indices)?);
    }
    if let (Some(l), Some(u)) = (&lower, &upper) {
        problem = problem.bounds(l, u);
    }
    let result = problem.solve(&x0);
    // a Python exception in a callback comes first: it is the cause
    if let Some(e) = residuals.error.borrow_mut().take() {
        return Err(e);
    }
    if let Some(e) = jacobian.as_ref().and_then(|j| j.error.borrow_mut().take()) {
        return Err(e);
    }
    let fit = result.map_err(least_squares_error)?;
    let out = PyDict::new(py);
    let status = scipy_status(fit.status);
    out.set_item("x", fit.x.clone().into_pyarray(py))?;
    out.set_item("cost", 0.5 * fit.cost)?;
    out.set_item("fun", fit.residuals.clone().into_pyarray(py))?;
    out.set_item("jac", fit.jacobian.clone().into_pyarray(py).reshape([m, n])?)?;
    out.set_item("nfev", residuals.calls.get())?;
    out.set_item("njev", jacobian.as_ref().map(|j| j.calls.get()))?;
    out.set_item("status", status)?;
    out.set_item("success", status > 0)?;
    out.set_item("message", message(fit.status))?;
    out.set_item("solver_status", fit.status.to_string())?;
    out.set_item("nit", fit.iterations)?;
    out.set_item("solve_time", fit.solve_time.as_secs_f64())?;
    out.set_item(
        "standard_errors",
        fit.standard_errors().ok().map(|s| s.into_pyarray(py)),
    )?;
    out.set_item(
        "covariance",
        match fit.covariance() {
            Ok(c) => Some(c.into_pyarray(py).reshape([n, n])?),
            Err(_) => None,
        },
    )?;
    Ok(out)
}
