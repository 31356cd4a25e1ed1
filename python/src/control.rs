//! `ddp`: `ddp::Ddp` over a model given as Python callables or over a
//! built-in system, with a quadratic cost; behind `nprl.ddp`.

use std::cell::{Cell, RefCell};

use ddp::faer::Mat;
use ddp::{Ddp, DdpMethod, DdpProblem, DdpResult, DdpSettings, Dynamics, ModelError, ModelResult, QuadraticCost};
use numpy::{IntoPyArray, PyArray1, PyArrayMethods, PyReadonlyArray1, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use systems::System;

use crate::errors::ddp_error;

/// $x' = f(x, u)$ by Python: `step(x, u)` returns $x'$, and `jac(x, u)`,
/// if given, returns $(f_x, f_u)$. The first exception is kept and raised
/// when the solve returns; every later call then fails at once.
struct PyDynamics<'py> {
    step: Bound<'py, PyAny>,
    jac: Option<Bound<'py, PyAny>>,
    n: usize,
    m: usize,
    calls: Cell<usize>,
    error: RefCell<Option<PyErr>>,
}

impl<'py> PyDynamics<'py> {
    fn fail(&self, e: PyErr) -> ModelError {
        let message = e.to_string();
        self.error.borrow_mut().get_or_insert(e);
        ModelError::new(message)
    }

    /// Copies the float64 numbers of `v` (any shape, C order; `len` of
    /// them) into `out`.
    fn copy(v: &Bound<'py, PyAny>, out: &mut [f64], what: &str) -> PyResult<()> {
        let np = v.py().import("numpy")?;
        let flat = np
            .call_method1("ascontiguousarray", (v, "float64"))?
            .call_method0("ravel")?;
        let array = flat.cast_into::<PyArray1<f64>>().map_err(PyErr::from)?;
        let view: PyReadonlyArray1<'_, f64> = array.readonly();
        if view.len() != out.len() {
            return Err(PyValueError::new_err(format!(
                "{what} returned {} values, expected {}",
                view.len(),
                out.len()
            )));
        }
        out.copy_from_slice(view.as_slice()?);
        Ok(())
    }

    fn args(&self, x: &[f64], u: &[f64]) -> Bound<'py, PyTuple> {
        let py = self.step.py();
        PyTuple::new(py, [PyArray1::from_slice(py, x), PyArray1::from_slice(py, u)]).expect("a tuple of two arrays")
    }
}

impl Dynamics for PyDynamics<'_> {
    fn state_dim(&self) -> usize {
        self.n
    }

    fn control_dim(&self) -> usize {
        self.m
    }

    fn step(&self, x: &[f64], u: &[f64], next: &mut [f64]) -> ModelResult<()> {
        if let Some(e) = self.error.borrow().as_ref() {
            return Err(ModelError::new(e.to_string()));
        }
        self.calls.set(self.calls.get() + 1);
        self.step
            .call1(self.args(x, u))
            .and_then(|v| Self::copy(&v, next, "step"))
            .map_err(|e| self.fail(e))
    }

    fn jacobians(&self, x: &[f64], u: &[f64], fx: &mut [f64], fu: &mut [f64]) -> ModelResult<bool> {
        let Some(jac) = &self.jac else {
            return Ok(false);
        };
        if let Some(e) = self.error.borrow().as_ref() {
            return Err(ModelError::new(e.to_string()));
        }
        let result = jac.call1(self.args(x, u)).and_then(|v| {
            let (a, b): (Bound<'_, PyAny>, Bound<'_, PyAny>) = v.extract()?;
            Self::copy(&a, fx, "jac (f_x)")?;
            Self::copy(&b, fu, "jac (f_u)")
        });
        result.map(|()| true).map_err(|e| self.fail(e))
    }
}

fn matrix(v: &[f64], k: usize, what: &str) -> PyResult<Mat<f64>> {
    if v.len() != k * k {
        return Err(PyValueError::new_err(format!(
            "{what} must be {k} x {k}, got {} entries",
            v.len()
        )));
    }
    Ok(Mat::from_fn(k, k, |i, j| v[i * k + j]))
}

/// The result as a dict of numpy arrays.
fn result_dict<'py>(py: Python<'py>, r: &DdpResult, evals: usize) -> PyResult<Bound<'py, PyDict>> {
    let (n, m, steps) = (
        r.states[0].len(),
        r.controls.first().map_or(0, Vec::len),
        r.controls.len(),
    );
    let flat = |rows: &[Vec<f64>]| rows.iter().flatten().copied().collect::<Vec<f64>>();
    let out = PyDict::new(py);
    out.set_item("states", flat(&r.states).into_pyarray(py).reshape([steps + 1, n])?)?;
    out.set_item("controls", flat(&r.controls).into_pyarray(py).reshape([steps, m])?)?;
    let gains: Vec<f64> = r
        .gains
        .iter()
        .flat_map(|k| (0..m).flat_map(move |i| (0..n).map(move |j| k[(i, j)])))
        .collect();
    out.set_item("gains", gains.into_pyarray(py).reshape([steps, m, n])?)?;
    out.set_item("value", r.value.clone().into_pyarray(py))?;
    out.set_item(
        "value_gradient",
        flat(&r.value_gradient)
            .into_pyarray(py)
            .reshape([r.value_gradient.len(), n])?,
    )?;
    let hessians: Vec<f64> = r
        .value_hessian
        .iter()
        .flat_map(|h| (0..n).flat_map(move |i| (0..n).map(move |j| h[(i, j)])))
        .collect();
    out.set_item(
        "value_hessian",
        hessians.into_pyarray(py).reshape([r.value_hessian.len(), n, n])?,
    )?;
    out.set_item("cost", r.cost)?;
    out.set_item("initial_cost", r.initial_cost)?;
    out.set_item("cost_history", r.cost_history.clone())?;
    out.set_item("iterations", r.iterations)?;
    out.set_item("status", format!("{:?}", r.status))?;
    out.set_item("success", r.status.is_converged())?;
    out.set_item("nfev", evals)?;
    out.set_item("solve_time", r.solve_time.as_secs_f64())?;
    Ok(out)
}

/// The settings: method and iteration cap over the defaults.
fn settings(method: &str, max_iterations: Option<usize>) -> PyResult<DdpSettings> {
    let method = match method {
        "ilqr" => DdpMethod::Ilqr,
        "ddp" => DdpMethod::Ddp,
        other => {
            return Err(PyValueError::new_err(format!(
                "method must be 'ilqr' or 'ddp', got {other:?}"
            )));
        }
    };
    let defaults = DdpSettings::default();
    Ok(DdpSettings {
        method,
        max_iterations: max_iterations.unwrap_or(defaults.max_iterations),
        ..defaults
    })
}

/// The built-in systems' names.
fn builtin(name: &str) -> PyResult<System> {
    System::ALL
        .into_iter()
        .find(|s| s.name() == name)
        .ok_or_else(|| PyValueError::new_err(format!("unknown system {name:?}: 'pendulum', 'cartpole' or 'acrobot'")))
}

/// The cost weights, target and start of a built-in swing-up, as a dict
/// (`q`, `r`, `qf` diagonals, `target`, `x0`, `dt`).
#[pyfunction]
pub(crate) fn swingup_defaults<'py>(py: Python<'py>, system: &str) -> PyResult<Bound<'py, PyDict>> {
    let w = builtin(system)?.weights();
    let out = PyDict::new(py);
    out.set_item("q", w.state)?;
    out.set_item("r", w.control)?;
    out.set_item("qf", w.terminal)?;
    out.set_item("target", w.target)?;
    out.set_item("x0", w.initial_state)?;
    out.set_item("dt", systems::DT)?;
    Ok(out)
}

/// Solves; the arguments are the Python wrapper's, already shaped there
/// (weights as full row-major matrices, controls as rows).
#[pyfunction]
#[pyo3(name = "ddp", signature = (model, x0, horizon, n_controls, jac, q, r, qf, target, u_init, lower, upper, method, max_iterations))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn solve_ddp<'py>(
    py: Python<'py>,
    model: Bound<'py, PyAny>,
    x0: Vec<f64>,
    horizon: usize,
    n_controls: usize,
    jac: Option<Bound<'py, PyAny>>,
    q: Vec<f64>,
    r: Vec<f64>,
    qf: Vec<f64>,
    target: Vec<f64>,
    u_init: Option<Vec<Vec<f64>>>,
    lower: Option<Vec<f64>>,
    upper: Option<Vec<f64>>,
    method: &str,
    max_iterations: Option<usize>,
) -> PyResult<Bound<'py, PyDict>> {
    let (n, m) = (x0.len(), n_controls);
    let cost = QuadraticCost::new(&matrix(&q, n, "Q")?, &matrix(&r, m, "R")?, &matrix(&qf, n, "Qf")?)
        .and_then(|c| c.with_state_target(&target))
        .map_err(ddp_error)?;
    let solver = Ddp::new(settings(method, max_iterations)?).map_err(ddp_error)?;
    fn setup<D: Dynamics>(
        problem: ddp::Result<DdpProblem<D, QuadraticCost>>,
        u_init: Option<Vec<Vec<f64>>>,
        limits: Option<(Vec<f64>, Vec<f64>)>,
    ) -> ddp::Result<DdpProblem<D, QuadraticCost>> {
        let mut problem = problem?;
        if let Some(u) = u_init {
            problem = problem.with_initial_controls(u)?;
        }
        if let Some((l, u)) = limits {
            problem = problem.with_control_limits(&l, &u)?;
        }
        Ok(problem)
    }
    let limits = lower.zip(upper);
    if let Ok(name) = model.extract::<String>() {
        let system = builtin(&name)?.model();
        let problem = setup(DdpProblem::new(system, cost, &x0, horizon), u_init, limits).map_err(ddp_error)?;
        let result = py.detach(|| solver.solve(&problem)).map_err(ddp_error)?;
        return result_dict(py, &result, result.evals);
    }
    let dynamics = PyDynamics {
        step: model,
        jac,
        n,
        m,
        calls: Cell::new(0),
        error: RefCell::new(None),
    };
    let problem = setup(DdpProblem::new(&dynamics, cost, &x0, horizon), u_init, limits).map_err(ddp_error);
    let result = problem.and_then(|p| solver.solve(&p).map_err(ddp_error));
    if let Some(e) = dynamics.error.borrow_mut().take() {
        return Err(e);
    }
    result_dict(py, &result?, dynamics.calls.get())
}
