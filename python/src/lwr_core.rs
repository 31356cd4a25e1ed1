//! `LwrCore`: the fitted model behind `nprl.LWRRegressor` (`lwr::LwrModel`).

use lwr::{Degree, FitSettings, Kernel, LwrModel, TuneMethod};
use numpy::{IntoPyArray, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};

use crate::errors::lwr_error;

/// The rows of a C-contiguous `n x d` array as slices, read in place.
fn rows<'a>(x: &'a PyReadonlyArray2<'_, f64>, what: &str) -> PyResult<Vec<&'a [f64]>> {
    let d = x.shape()[1];
    let flat = x
        .as_slice()
        .map_err(|_| pyo3::exceptions::PyValueError::new_err(format!("{what} must be a C-contiguous float64 array")))?;
    if d == 0 {
        return Err(pyo3::exceptions::PyValueError::new_err(format!(
            "{what} has no columns"
        )));
    }
    Ok(flat.chunks_exact(d).collect())
}

fn kernel(name: &str) -> PyResult<Kernel> {
    Ok(match name {
        "gaussian" => Kernel::Gaussian,
        "tricube" => Kernel::Tricube,
        "epanechnikov" => Kernel::Epanechnikov,
        "bisquare" => Kernel::Bisquare,
        other => {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "kernel must be 'gaussian', 'tricube', 'epanechnikov' or 'bisquare', got {other:?}"
            )));
        }
    })
}

fn degree(name: &str) -> PyResult<Degree> {
    Ok(match name {
        "constant" => Degree::Constant,
        "linear" => Degree::Linear,
        "quadratic" => Degree::Quadratic,
        other => {
            return Err(pyo3::exceptions::PyValueError::new_err(format!(
                "degree must be 'constant', 'linear' or 'quadratic', got {other:?}"
            )));
        }
    })
}

/// What `__reduce__` returns: the constructor and its arguments.
type Reduced<'py> = (Bound<'py, PyAny>, (Bound<'py, PyBytes>, usize, Option<f64>));

/// A fitted locally weighted regression (`lwr::LwrModel`).
#[pyclass(module = "nprl._nprl")]
pub(crate) struct LwrCore {
    model: LwrModel,
    tune_evals: usize,
    tune_objective: Option<f64>,
}

#[pymethods]
impl LwrCore {
    /// Fits `y` (n x o) on `x` (n x d): scales 1/sd, bandwidth and scales
    /// tuned by leave-one-out (`lwr::LwrModel::fit_multi`), without the GIL.
    #[staticmethod]
    #[pyo3(signature = (x, y, kernel_name, degree_name, bandwidth, tune_evals, tune_points, confidence_level, tune_method))]
    #[allow(clippy::too_many_arguments)]
    fn fit(
        py: Python<'_>,
        x: PyReadonlyArray2<'_, f64>,
        y: PyReadonlyArray2<'_, f64>,
        kernel_name: &str,
        degree_name: &str,
        bandwidth: Option<f64>,
        tune_evals: usize,
        tune_points: usize,
        confidence_level: f64,
        tune_method: &str,
    ) -> PyResult<Self> {
        let settings = FitSettings {
            kernel: kernel(kernel_name)?,
            degree: degree(degree_name)?,
            bandwidth,
            tune_evals,
            tune_points,
            confidence_level,
            tune_method: match tune_method {
                "lm" => TuneMethod::LevenbergMarquardt,
                "compass" => TuneMethod::Compass,
                other => {
                    return Err(pyo3::exceptions::PyValueError::new_err(format!(
                        "tune_method must be 'lm' or 'compass', got {other:?}"
                    )));
                }
            },
        };
        let xs = rows(&x, "X")?;
        let ys = rows(&y, "y")?;
        let (model, tuned) = py
            .detach(|| LwrModel::fit_multi(&xs, &ys, &settings))
            .map_err(lwr_error)?;
        Ok(Self {
            model,
            tune_evals: tuned.as_ref().map_or(0, |t| t.evals),
            tune_objective: tuned.map(|t| t.objective),
        })
    }

    /// Predictions at the rows of `x`: mean, standard error of the mean,
    /// noise variance, and the half widths of the confidence and
    /// prediction intervals, each n x o.
    #[allow(clippy::type_complexity)]
    fn predict<'py>(
        &self,
        py: Python<'py>,
        x: PyReadonlyArray2<'_, f64>,
    ) -> PyResult<(
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray2<f64>>,
    )> {
        let xs = rows(&x, "X")?;
        let predictions = py.detach(|| self.model.predict_many(&xs)).map_err(lwr_error)?;
        let (n, o) = (predictions.len(), self.model.database().n_outputs());
        let column = |f: &dyn Fn(&lwr::Prediction) -> &Vec<f64>| -> Vec<f64> {
            predictions.iter().flat_map(|p| f(p).iter().copied()).collect()
        };
        let shape = |v: Vec<f64>| -> PyResult<Bound<'py, PyArray2<f64>>> { v.into_pyarray(py).reshape([n, o]) };
        Ok((
            shape(column(&|p| &p.mean))?,
            shape(column(&|p| &p.std_error))?,
            shape(column(&|p| &p.noise_variance))?,
            shape(column(&|p| &p.confidence_half_width))?,
            shape(column(&|p| &p.prediction_half_width))?,
        ))
    }

    /// The exact Jacobians of the mean at the rows of `x`: n x o x d.
    fn jacobian<'py>(&self, py: Python<'py>, x: PyReadonlyArray2<'_, f64>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let xs = rows(&x, "X")?;
        let (n, o, d) = (
            xs.len(),
            self.model.database().n_outputs(),
            self.model.database().n_inputs(),
        );
        let results = py.detach(|| self.model.predict_batch_with_jacobian(&xs));
        let mut out = Vec::with_capacity(n * o * d);
        for (i, r) in results.into_iter().enumerate() {
            let (_, j) = r.map_err(|e| {
                lwr_error(lwr::LwrError::InvalidParameter {
                    name: "query",
                    reason: format!("row {i}: {e}"),
                })
            })?;
            for a in 0..o {
                for b in 0..d {
                    out.push(j[(a, b)]);
                }
            }
        }
        out.into_pyarray(py).reshape([n, o, d])
    }

    /// The settings after tuning: kernel, degree, bandwidth, scales (one
    /// per input; 0 drops it), ridge, confidence level, and the tuning's
    /// evaluations and leave-one-out objective.
    fn settings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = self.model.settings();
        let d = PyDict::new(py);
        d.set_item("kernel", format!("{:?}", s.kernel).to_lowercase())?;
        d.set_item("degree", format!("{:?}", s.degree).to_lowercase())?;
        d.set_item("bandwidth", s.bandwidth)?;
        d.set_item("scales", s.scales_for(self.model.database().n_inputs()))?;
        d.set_item("ridge", s.ridge)?;
        d.set_item("confidence_level", s.confidence_level)?;
        d.set_item("tune_evals", self.tune_evals)?;
        d.set_item("tune_objective", self.tune_objective)?;
        Ok(d)
    }

    /// Inserts the rows of `x` with targets `y` (online learning, no
    /// tuning).
    fn insert(&mut self, x: PyReadonlyArray2<'_, f64>, y: PyReadonlyArray2<'_, f64>) -> PyResult<()> {
        let (xs, ys) = (rows(&x, "X")?, rows(&y, "y")?);
        self.model.insert_many(&xs, &ys).map_err(lwr_error)
    }

    /// The number of inputs.
    #[getter]
    fn n_inputs(&self) -> usize {
        self.model.database().n_inputs()
    }

    /// The number of outputs.
    #[getter]
    fn n_outputs(&self) -> usize {
        self.model.database().n_outputs()
    }

    /// The number of stored points.
    #[getter]
    fn n_points(&self) -> usize {
        self.model.len()
    }

    /// The model as JSON bytes (pickling).
    fn to_json<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let bytes = serde_json::to_vec(&self.model).map_err(|e| lwr_error(lwr::LwrError::Serde(e.to_string())))?;
        Ok(PyBytes::new(py, &bytes))
    }

    /// A model from [`to_json`](Self::to_json)'s bytes.
    #[staticmethod]
    fn from_json(bytes: &[u8], tune_evals: usize, tune_objective: Option<f64>) -> PyResult<Self> {
        let model: LwrModel =
            serde_json::from_slice(bytes).map_err(|e| lwr_error(lwr::LwrError::Serde(e.to_string())))?;
        Ok(Self {
            model,
            tune_evals,
            tune_objective,
        })
    }

    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<Reduced<'py>> {
        let py = slf.py();
        let this = slf.borrow();
        let ctor = slf.getattr("from_json")?;
        Ok((ctor, (this.to_json(py)?, this.tune_evals, this.tune_objective)))
    }
}
