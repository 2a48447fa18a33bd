//! NumPy array -> core `Matrix` view, in place for any non-negative strides.
//! The Python layer copies arrays with negative strides or misaligned data
//! before they get here; this re-checks and refuses rather than guess.

use edmf_core::Matrix;
use numpy::{Element, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

pub fn matrix_view<'a, T: Element + Copy>(
    array: &'a PyReadonlyArray2<'_, T>,
    name: &'static str,
) -> PyResult<Matrix<'a, T>> {
    let (shape, strides) = (array.shape(), array.strides());
    let item = std::mem::size_of::<T>() as isize;
    if !array.is_aligned() {
        return Err(PyValueError::new_err(format!("{name}: expected aligned data")));
    }
    if strides.iter().any(|&s| s < 0 || s % item != 0) {
        return Err(PyValueError::new_err(format!(
            "{name}: expected non-negative strides that are whole elements, got {strides:?} bytes"
        )));
    }
    let (rows, cols) = (shape[0], shape[1]);
    let (row_stride, col_stride) = ((strides[0] / item) as usize, (strides[1] / item) as usize);
    let span = if rows == 0 || cols == 0 {
        0
    } else {
        (rows - 1) * row_stride + (cols - 1) * col_stride + 1
    };
    // SAFETY: the array is borrowed read-only for 'a and its data is aligned;
    // every element the view can address lies within `span` elements of the
    // first one, inside the array's buffer for any array NumPy made itself
    // (`as_strided` can lie about that, as it can to NumPy). Another Python
    // thread writing the array while the GIL is released is a data race the
    // caller owns, as with any NumPy call that releases the GIL.
    let data: &'a [T] = if span == 0 {
        &[]
    } else {
        unsafe { std::slice::from_raw_parts(array.data() as *const T, span) }
    };
    Matrix::new(data, rows, cols, row_stride, col_stride).map_err(|e| PyValueError::new_err(e.to_string()))
}
