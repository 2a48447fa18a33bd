//! `RowDigest`: the block checksums a checkpoint records of the rows a run
//! has done (see `edmf_core::digest`), fed chunk by chunk like the `Falsifier`.

use crate::{detached, pool, views::matrix_view};
use numpy::PyReadonlyArray2;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;

fn hex(d: u128) -> String {
    format!("{d:032x}")
}

/// Checksums of the rows fed so far, one per fixed block of instances.
#[pyclass(module = "edmf_rs._core")]
pub struct RowDigest {
    pub(crate) inner: edmf_core::digest::RowDigest,
}

#[pymethods]
impl RowDigest {
    #[new]
    fn new() -> Self {
        RowDigest {
            inner: edmf_core::digest::RowDigest::new(),
        }
    }

    /// Name and version of the block checksum (recorded in checkpoints).
    #[classattr]
    fn algorithm() -> &'static str {
        edmf_core::digest::ALGORITHM
    }

    /// Instances per block (block k: instances k*block_rows ..).
    #[classattr]
    fn block_rows() -> usize {
        edmf_core::digest::BLOCK_ROWS
    }

    /// Feeds the next rows (a 2-D float64 or float32 array, any positive strides).
    fn update(&mut self, py: Python<'_>, chunk: &Bound<'_, PyAny>) -> PyResult<()> {
        let pool = pool::current()?;
        let inner = &mut self.inner;
        if let Ok(a) = chunk.extract::<PyReadonlyArray2<'_, f64>>() {
            let view = matrix_view(&a, "rows")?;
            detached(py, |_| inner.update(view, &pool))
        } else if let Ok(a) = chunk.extract::<PyReadonlyArray2<'_, f32>>() {
            let view = matrix_view(&a, "rows")?;
            detached(py, |_| inner.update(view, &pool))
        } else {
            Err(PyTypeError::new_err(
                "rows: expected a 2-D float64 or float32 NumPy array",
            ))
        }
    }

    #[getter]
    fn n_rows(&self) -> u64 {
        self.inner.n_rows()
    }

    /// Hex digests of the completed blocks, from block `start` on.
    #[pyo3(signature = (start=0))]
    fn blocks(&self, start: usize) -> Vec<String> {
        let all = self.inner.blocks();
        all[start.min(all.len())..].iter().map(|&d| hex(d)).collect()
    }

    #[getter]
    fn n_blocks(&self) -> usize {
        self.inner.blocks().len()
    }

    /// Hex digest of the rows after the last complete block (None if none).
    fn partial(&self) -> Option<String> {
        self.inner.partial().map(hex)
    }
}
