//! Bindings of `edmf_core::design` (measurement-system design). Argument
//! checking that needs Python types is in `edmf_rs.design`; the core re-checks.

use crate::{detached, pool, views::matrix_view, Vector};
use edmf_core::design::{self, PlacementOptions};
use edmf_core::{EdmfError, Matrix};
use numpy::{IntoPyArray, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;

/// Runs `$body` with `$g` bound to a float64 or float32 view of `$arr`.
macro_rules! with_view {
    ($arr:expr, |$g:ident| $body:expr) => {{
        if let Ok(a) = $arr.extract::<PyReadonlyArray2<'_, f64>>() {
            let $g = matrix_view(&a, "predictions")?;
            $body
        } else if let Ok(a) = $arr.extract::<PyReadonlyArray2<'_, f32>>() {
            let $g = matrix_view(&a, "predictions")?;
            $body
        } else {
            Err(PyTypeError::new_err(
                "predictions: expected a 2-D float64 or float32 NumPy array",
            ))
        }
    }};
}

/// Joint entropy (bits) of the binned predictions at `sensors`.
#[pyfunction]
#[pyo3(signature = (predictions, widths, sensors, nan_bin=false))]
fn design_joint_entropy(
    py: Python<'_>,
    predictions: &Bound<'_, PyAny>,
    widths: PyReadonlyArray1<'_, f64>,
    sensors: Vec<usize>,
    nan_bin: bool,
) -> PyResult<f64> {
    let widths = widths.as_array().to_vec();
    with_view!(predictions, |g| detached(py, |_| design::joint_entropy(
        g, &widths, &sensors, nan_bin
    )))
}

/// Greedy placement: `(order, entropy after each sensor, evaluations)`.
#[pyfunction]
#[pyo3(signature = (predictions, widths, k, fixed, costs=None, budget=None, tolerance=None, nan_bin=false,
                    type_of=None, max_per_type=None, exhaustive=false, bin_memory=None))]
#[allow(clippy::too_many_arguments)]
fn design_place<'py>(
    py: Python<'py>,
    predictions: &Bound<'py, PyAny>,
    widths: PyReadonlyArray1<'py, f64>,
    k: usize,
    fixed: Vec<usize>,
    costs: Option<PyReadonlyArray1<'py, f64>>,
    budget: Option<f64>,
    tolerance: Option<f64>,
    nan_bin: bool,
    type_of: Option<Vec<usize>>,
    max_per_type: Option<Vec<usize>>,
    exhaustive: bool,
    bin_memory: Option<usize>,
) -> PyResult<(Vector<'py, u64>, Vector<'py, f64>, u64)> {
    let widths = widths.as_array().to_vec();
    let opts = PlacementOptions {
        k,
        fixed,
        costs: costs.map(|c| c.as_array().to_vec()),
        budget,
        tolerance,
        nan_bin,
        type_of: type_of.unwrap_or_default(),
        max_per_type: max_per_type.unwrap_or_default(),
        exhaustive,
        bin_memory,
    };
    let pool = pool::current()?;
    let p = with_view!(predictions, |g| detached(py, |stop| design::place(
        g, &widths, &opts, &pool, stop
    )))?;
    let order: Vec<u64> = p.order.iter().map(|&i| i as u64).collect();
    Ok((order.into_pyarray(py), p.entropy.into_pyarray(py), p.evaluations))
}

/// Candidate-set size of each simulation (Eqs. 4 and 8).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
fn design_candidate_counts<'py>(
    py: Python<'py>,
    predictions: &Bound<'py, PyAny>,
    sensors: Vec<usize>,
    truth: PyReadonlyArray1<'py, u64>,
    residuals: PyReadonlyArray2<'py, f64>,
    low: PyReadonlyArray1<'py, f64>,
    high: PyReadonlyArray1<'py, f64>,
) -> PyResult<Vector<'py, u64>> {
    let truth = truth.as_array().to_vec();
    let (low, high) = (low.as_array().to_vec(), high.as_array().to_vec());
    let res: Matrix<'_, f64> = matrix_view(&residuals, "residuals")?;
    let pool = pool::current()?;
    let sizes = with_view!(predictions, |g| detached(
        py,
        |stop| -> Result<Vec<u64>, EdmfError> {
            design::candidate_counts(g, &sensors, &truth, res, &low, &high, &pool, stop)
        }
    ))?;
    Ok(sizes.into_pyarray(py))
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(design_joint_entropy, m)?)?;
    m.add_function(wrap_pyfunction!(design_place, m)?)?;
    m.add_function(wrap_pyfunction!(design_candidate_counts, m)?)?;
    Ok(())
}
