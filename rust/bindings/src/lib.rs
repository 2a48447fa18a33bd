//! `edmf_rs._core`: the thin PyO3 layer over `edmf-core`.
//!
//! It only converts NumPy arrays into core views (no copies), releases the GIL
//! around all core work, polls for Ctrl-C between slabs and maps core errors to
//! `ValueError`. Argument checking that needs Python types lives in the Python
//! package; the core re-checks everything it relies on.

mod design;
mod digest;
mod pool;
mod screening;
mod views;

use edmf_core::candidates::Segment;
use edmf_core::{EdmfError, Mode, Thresholds};
use numpy::{IntoPyArray, PyArray1, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyKeyboardInterrupt, PyMemoryError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyList;
use views::matrix_view;

/// A NumPy vector handed back to Python.
type Vector<'py, T> = Bound<'py, PyArray1<T>>;

/// Runs `work` with the GIL released; `work` gets a stop check that re-attaches
/// briefly to let Python run its signal handlers (Ctrl-C -> KeyboardInterrupt).
fn detached<R: Send>(
    py: Python<'_>,
    work: impl FnOnce(&mut dyn FnMut() -> bool) -> Result<R, EdmfError> + Send,
) -> PyResult<R> {
    let mut raised: Option<PyErr> = None;
    let result = py.detach(|| {
        let mut stop = || match Python::attach(|py| py.check_signals()) {
            Ok(()) => false,
            Err(err) => {
                raised = Some(err);
                true
            }
        };
        work(&mut stop)
    });
    result.map_err(|err| match err {
        EdmfError::Interrupted => raised
            .take()
            .unwrap_or_else(|| PyKeyboardInterrupt::new_err("interrupted")),
        EdmfError::OutOfMemory { .. } => PyMemoryError::new_err(err.to_string()),
        other => PyValueError::new_err(other.to_string()),
    })
}

fn core_err(err: EdmfError) -> PyErr {
    PyValueError::new_err(err.to_string())
}

/// Shortest intervals holding `probability` of each column of `samples` (Eq. 5).
#[pyfunction]
fn shortest_intervals<'py>(
    py: Python<'py>,
    samples: PyReadonlyArray2<'py, f64>,
    probability: f64,
) -> PyResult<(Vector<'py, f64>, Vector<'py, f64>)> {
    let view = matrix_view(&samples, "combined")?;
    let pool = pool::current()?;
    let thresholds = detached(py, |stop| {
        edmf_core::shortest_intervals(view, probability, &pool, stop)
    })?;
    Ok((
        thresholds.low().to_vec().into_pyarray(py),
        thresholds.high().to_vec().into_pyarray(py),
    ))
}

/// Fewest Monte Carlo samples that resolve `probability`: ceil(1/(1-p)).
#[pyfunction]
fn min_samples(probability: f64) -> PyResult<usize> {
    edmf_core::min_samples(probability).map_err(core_err)
}

/// Squared Mahalanobis distance of every row of `points` (Eq. 9).
#[pyfunction]
fn mahalanobis_squared<'py>(
    py: Python<'py>,
    points: PyReadonlyArray2<'py, f64>,
    mean: PyReadonlyArray1<'py, f64>,
    covariance: PyReadonlyArray2<'py, f64>,
) -> PyResult<Vector<'py, f64>> {
    let view = matrix_view(&points, "points")?;
    let mean = mean.as_array().to_vec();
    let cov: Vec<f64> = covariance.as_array().iter().copied().collect();
    let pool = pool::current()?;
    let d = detached(py, |_| {
        edmf_core::ellipse::mahalanobis_squared(view, &mean, &cov, &pool)
    })?;
    Ok(d.into_pyarray(py))
}

/// The prefetch of the AVX-512 short-row kernels (rows of up to two
/// vectors, and back-to-back rows whose pattern repeats within eight):
/// ``"nta:4096"`` (non-temporal, 4 KiB ahead), ``"t1:8192"`` (into L2, 8 KiB
/// ahead), ... or ``"off"``. Chosen for this CPU, or named by the environment
/// variable ``EDMF_RS_PREFETCH``. (The other kernels always use
/// ``"t1:6144"``, into L2 6 KiB ahead.)
#[pyfunction]
fn prefetch() -> String {
    #[cfg(target_arch = "x86_64")]
    return edmf_core::Prefetch::current().name();
    #[cfg(not(target_arch = "x86_64"))]
    return "off".into();
}

/// Uses the prefetch ``name`` (as `prefetch` gives it) from now on, to
/// compare them side by side; the candidates do not depend on it. A name it
/// cannot read raises ``ValueError``.
#[pyfunction]
fn set_prefetch(name: &str) -> PyResult<()> {
    #[cfg(target_arch = "x86_64")]
    if let Some(p) = edmf_core::Prefetch::from_name(name) {
        p.set();
        return Ok(());
    }
    #[cfg(not(target_arch = "x86_64"))]
    if name == "off" {
        return Ok(());
    }
    Err(PyValueError::new_err(format!(
        "name: expected 't0', 't1', 't2' or 'nta', ':' and bytes ahead (a multiple of 64 up to 1048576), or 'off'; got {name:?}"
    )))
}

/// Streaming falsification (Eq. 8): feed chunks in order, read the results.
#[pyclass(module = "edmf_rs._core")]
struct Falsifier {
    inner: edmf_core::Falsifier,
}

#[pymethods]
impl Falsifier {
    #[new]
    #[pyo3(signature = (measurements, low, high, *, diagnostics=true, keep_violations=true))]
    fn new(
        measurements: PyReadonlyArray1<'_, f64>,
        low: PyReadonlyArray1<'_, f64>,
        high: PyReadonlyArray1<'_, f64>,
        diagnostics: bool,
        keep_violations: bool,
    ) -> PyResult<Self> {
        // Copies of n_m values: any layout works (e.g. arrays unpickled on a Dask worker).
        let vector = |a: PyReadonlyArray1<'_, f64>| a.as_array().to_vec();
        let thresholds = Thresholds::new(vector(low), vector(high)).map_err(core_err)?;
        let mode = if diagnostics { Mode::Diagnose } else { Mode::Screen };
        let inner = edmf_core::Falsifier::new(&vector(measurements), &thresholds, mode, keep_violations)
            .map_err(core_err)?;
        Ok(Falsifier { inner })
    }

    /// Falsifies the next chunk (float64 or float32, any positive strides);
    /// with `digest` (a `RowDigest`), also feeds the chunk to it in the same
    /// pass, as `digest.update(chunk)` would (the chunk is taken by both or
    /// by neither).
    #[pyo3(signature = (chunk, digest=None))]
    fn update(
        &mut self,
        py: Python<'_>,
        chunk: &Bound<'_, PyAny>,
        digest: Option<PyRefMut<'_, digest::RowDigest>>,
    ) -> PyResult<()> {
        let pool = pool::current()?;
        let inner = &mut self.inner;
        let mut digest = digest;
        let rows = digest.as_deref_mut().map(|d| &mut d.inner);
        if let Ok(a) = chunk.extract::<PyReadonlyArray2<'_, f64>>() {
            let view = matrix_view(&a, "predictions")?;
            detached(py, |stop| match rows {
                Some(d) => inner.update_digested(view, &pool, stop, d),
                None => inner.update(view, &pool, stop),
            })
        } else if let Ok(a) = chunk.extract::<PyReadonlyArray2<'_, f32>>() {
            let view = matrix_view(&a, "predictions")?;
            detached(py, |stop| match rows {
                Some(d) => inner.update_digested(view, &pool, stop, d),
                None => inner.update(view, &pool, stop),
            })
        } else {
            Err(pyo3::exceptions::PyTypeError::new_err(
                "predictions: expected a 2-D float64 or float32 NumPy array chunk",
            ))
        }
    }

    #[getter]
    fn n_instances(&self) -> u64 {
        self.inner.n_instances()
    }

    #[getter]
    fn n_sensors(&self) -> usize {
        self.inner.n_sensors()
    }

    #[getter]
    fn n_candidates(&self) -> u64 {
        self.inner.n_candidates()
    }

    /// The candidates, moved out (no copy; the accumulator keeps none), as a
    /// list of segments in instance order: a uint64 array of candidate
    /// indices, or `(first, rows, words)` for a bitmap of instances
    /// `first .. first + rows` (bit `i % 64` of `words[i // 64]` set iff
    /// instance `first + i` is a candidate).
    fn take_candidate_segments<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let segments = self.inner.take_candidates().into_iter().map(|s| -> PyResult<Bound<'py, PyAny>> {
            Ok(match s {
                Segment::Indices(v) => v.into_pyarray(py).into_any(),
                Segment::Bits { first, rows, words } => (first, rows, words.into_pyarray(py)).into_pyobject(py)?.into_any(),
            })
        });
        PyList::new(py, segments.collect::<PyResult<Vec<_>>>()?)
    }

    /// The candidates among instances `since .. since + rows` as uint64
    /// words: bit `i % 64` of word `i // 64` set iff instance `since + i` is one.
    fn candidate_bitmap<'py>(&self, py: Python<'py>, since: u64, rows: u64) -> Vector<'py, u64> {
        let inner = &self.inner;
        py.detach(|| inner.candidate_bitmap(since, rows)).into_pyarray(py)
    }

    /// Indices of the candidates at instance `since` or later, ascending.
    #[pyo3(signature = (since=0))]
    fn candidates_since<'py>(&self, py: Python<'py>, since: u64) -> Vector<'py, u64> {
        let inner = &self.inner;
        py.detach(|| inner.candidates_since(since)).into_pyarray(py)
    }

    /// `(per_sensor_falsified, falsified_only_by, n_invalid)`, or None when screening.
    fn tally<'py>(&self, py: Python<'py>) -> Option<(Vector<'py, u64>, Vector<'py, u64>, u64)> {
        self.inner.tally().map(|t| {
            (
                t.per_sensor.clone().into_pyarray(py),
                t.only_by.clone().into_pyarray(py),
                t.invalid,
            )
        })
    }

    /// The per-instance rejecting-sensor counts (moved out, not copied), if kept.
    fn take_violations<'py>(&mut self, py: Python<'py>) -> PyResult<Option<Vector<'py, u32>>> {
        // Kept narrow during the run, widened here (an error if memory runs out).
        let taken = self.inner.take_violations().map_err(|e| PyMemoryError::new_err(e.to_string()))?;
        Ok(taken.map(|v| v.into_pyarray(py)))
    }
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(shortest_intervals, m)?)?;
    m.add_function(wrap_pyfunction!(min_samples, m)?)?;
    m.add_function(wrap_pyfunction!(mahalanobis_squared, m)?)?;
    m.add_function(wrap_pyfunction!(pool::set_num_threads, m)?)?;
    m.add_function(wrap_pyfunction!(pool::get_num_threads, m)?)?;
    m.add_function(wrap_pyfunction!(prefetch, m)?)?;
    m.add_function(wrap_pyfunction!(set_prefetch, m)?)?;
    m.add_class::<Falsifier>()?;
    m.add_function(wrap_pyfunction!(screening::screen_emulator, m)?)?;
    m.add_class::<digest::RowDigest>()?;
    design::register(m)?;
    Ok(())
}
