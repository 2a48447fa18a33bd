//! The package's own rayon pool (never the global one, so edmf_rs does not
//! fight other rayon users in the same process). Sized by `set_num_threads`,
//! else `EDMF_RS_NUM_THREADS`, else the number of cores.

use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyInt};
use rayon::{ThreadPool, ThreadPoolBuilder};
use std::sync::{Arc, Mutex};

/// The pool and the process that started its threads: a child forked from
/// that process inherits the pool but none of its threads, and would wait on
/// them forever.
static POOL: Mutex<Option<(u32, Arc<ThreadPool>)>> = Mutex::new(None);

/// The pool if this process started it. An inherited one is leaked, not
/// dropped: its threads never existed here to be told to stop.
fn own(slot: &mut Option<(u32, Arc<ThreadPool>)>) -> Option<&Arc<ThreadPool>> {
    if slot.as_ref().is_some_and(|(pid, _)| *pid != std::process::id()) {
        std::mem::forget(slot.take());
    }
    slot.as_ref().map(|(_, pool)| pool)
}

const ENV: &str = "EDMF_RS_NUM_THREADS";

fn build(threads: usize) -> PyResult<Arc<ThreadPool>> {
    ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("edmf-rs-{i}"))
        .build()
        .map(Arc::new)
        .map_err(|e| PyRuntimeError::new_err(format!("could not start {threads} threads: {e}")))
}

fn default_threads() -> PyResult<usize> {
    match std::env::var(ENV) {
        Ok(v) => match v.trim().parse::<usize>() {
            Ok(n) if n > 0 && n <= max_threads() => Ok(n),
            _ => Err(PyValueError::new_err(format!(
                "{ENV}: expected an integer from 1 to {}, got {v:?}",
                max_threads()
            ))),
        },
        Err(_) => Ok(std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1)),
    }
}

/// The pool to run on, created on first use.
pub fn current() -> PyResult<Arc<ThreadPool>> {
    let mut guard = POOL.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(pool) = own(&mut guard) {
        return Ok(Arc::clone(pool));
    }
    let pool = build(default_threads()?)?;
    *guard = Some((std::process::id(), Arc::clone(&pool)));
    Ok(pool)
}

/// Most threads a pool may have: far beyond any use (64 per core, at least
/// 1024), short of what would exhaust the process (2**40 never returned).
fn max_threads() -> usize {
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    cores.saturating_mul(64).max(1024)
}

/// Sets how many threads edmf_rs uses from now on.
///
/// The package runs its Rust work (falsification, shortest intervals) on a
/// pool of its own, sized by this call, else by the environment variable
/// ``EDMF_RS_NUM_THREADS``, else by the number of cores. Results do not
/// depend on the thread count.
///
/// Parameters
/// ----------
/// n : int
///     Number of threads, at least 1.
///
/// Returns
/// -------
/// None
///
/// Raises
/// ------
/// ValueError
///     If ``n`` is less than 1.
/// RuntimeError
///     If the operating system cannot start the threads.
///
/// Examples
/// --------
/// >>> import edmf_rs
/// >>> before = edmf_rs.get_num_threads()
/// >>> edmf_rs.set_num_threads(1)
/// >>> edmf_rs.get_num_threads()
/// 1
/// >>> edmf_rs.set_num_threads(before)
#[pyfunction]
pub fn set_num_threads(n: &Bound<'_, PyAny>) -> PyResult<()> {
    let max = max_threads();
    let given = n.str().map(|s| s.to_string()).unwrap_or_default(); // as given, however large
    // An int or what converts like one (NumPy integers); not a bool, float or string.
    let integer = n.is_instance_of::<PyInt>() || n.call_method0("__index__").is_ok();
    if !integer || n.is_instance_of::<PyBool>() {
        let kind = n.get_type().name().map(|s| s.to_string()).unwrap_or_default();
        return Err(PyTypeError::new_err(format!(
            "n: expected an integer number of threads from 1 to {max}, got {kind}"
        )));
    }
    let n: i64 = match n.extract::<i64>() {
        Ok(v) => v,
        Err(_) => i64::MAX, // an integer beyond i64: refused below as too many
    };
    if n < 1 || n as u64 > max as u64 {
        return Err(PyValueError::new_err(format!(
            "n: expected a number of threads from 1 to {max}, got {given}"
        )));
    }
    let mut guard = POOL.lock().unwrap_or_else(|e| e.into_inner());
    if own(&mut guard).is_some_and(|p| p.current_num_threads() == n as usize) {
        return Ok(()); // keep the running threads (and their warm caches)
    }
    *guard = Some((std::process::id(), build(n as usize)?));
    Ok(())
}

/// How many threads edmf_rs uses.
///
/// Starts the pool on first use (see ``set_num_threads``).
///
/// Returns
/// -------
/// int
///     The number of threads of edmf_rs's own pool.
///
/// Raises
/// ------
/// ValueError
///     If ``EDMF_RS_NUM_THREADS`` is set to something other than a positive
///     integer (and ``set_num_threads`` was not called).
///
/// Examples
/// --------
/// >>> import edmf_rs
/// >>> edmf_rs.get_num_threads() >= 1
/// True
#[pyfunction]
pub fn get_num_threads() -> PyResult<usize> {
    Ok(current()?.current_num_threads())
}
