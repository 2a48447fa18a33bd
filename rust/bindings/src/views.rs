//! NumPy array -> core `Matrix` view, in place for any non-negative strides.
//! The Python layer copies arrays with negative strides or misaligned data
//! before they get here; this re-checks and refuses rather than guess.

use edmf_core::Matrix;
use numpy::{Element, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

pub fn matrix_view<'a, T: Element + Copy>(
    array: &'a PyReadonlyArray2<'_, T>,
    name: &'static str,
) -> PyResult<Matrix<'a, T>> {
    let view = array.as_array();
    let (rows, cols) = view.dim();
    let strides = view.strides();
    if strides.iter().any(|&s| s < 0) {
        return Err(PyValueError::new_err(format!(
            "{name}: expected non-negative strides, got {strides:?}"
        )));
    }
    if !array.is_aligned() {
        return Err(PyValueError::new_err(format!("{name}: expected aligned data")));
    }
    let (row_stride, col_stride) = (strides[0] as usize, strides[1] as usize);
    let span = if rows == 0 || cols == 0 {
        0
    } else {
        (rows - 1) * row_stride + (cols - 1) * col_stride + 1
    };
    // SAFETY: the array is borrowed read-only for 'a, its data is aligned, and
    // every element the view can address lies within `span` elements of the
    // first one, all inside the array's buffer (NumPy guarantees the strides).
    let data: &'a [T] = if span == 0 {
        &[]
    } else {
        unsafe { std::slice::from_raw_parts(view.as_ptr(), span) }
    };
    Matrix::new(data, rows, cols, row_stride, col_stride)
        .map_err(|e| PyValueError::new_err(e.to_string()))
}
