//! Binding of `edmf_core::screening`: emulator screening for adaptive EDMF.

use crate::{detached, pool, views::matrix_view, Vector};
use numpy::{IntoPyArray, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::prelude::*;

/// Indices of the rows of `mu`/`sigma` (N x n_m) kept by the screening rule
/// `low - c sigma <= mu - y <= high + c sigma` at every sensor, and the
/// sensor order used. The GIL is released; Ctrl-C stops it between slabs.
#[pyfunction]
#[pyo3(signature = (mu, sigma, measurements, low, high, c))]
pub fn screen_emulator<'py>(
    py: Python<'py>,
    mu: PyReadonlyArray2<'py, f64>,
    sigma: PyReadonlyArray2<'py, f64>,
    measurements: PyReadonlyArray1<'py, f64>,
    low: PyReadonlyArray1<'py, f64>,
    high: PyReadonlyArray1<'py, f64>,
    c: f64,
) -> PyResult<(Vector<'py, u64>, Vec<usize>)> {
    let (mu, sigma) = (matrix_view(&mu, "mu")?, matrix_view(&sigma, "sigma")?);
    let vector = |a: PyReadonlyArray1<'_, f64>| a.as_array().to_vec();
    let (y, low, high) = (vector(measurements), vector(low), vector(high));
    let pool = pool::current()?;
    let out = detached(py, |stop| {
        edmf_core::screen(mu, sigma, &y, &low, &high, c, &pool, stop)
    })?;
    Ok((out.kept.into_pyarray(py), out.order))
}
