//! A borrowed, strided 2-D view (rows = model instances, columns = sensors).
//!
//! NumPy hands us C-ordered, Fortran-ordered or sliced arrays; this view reads
//! all of them in place, so predictions are never copied to be falsified.

use crate::error::{EdmfError, Result};

#[derive(Debug, Clone, Copy)]
pub struct Matrix<'a, T> {
    data: &'a [T],
    rows: usize,
    cols: usize,
    row_stride: usize,
    col_stride: usize,
}

impl<'a, T: Copy> Matrix<'a, T> {
    /// A view of `rows x cols` elements where element (i, j) is
    /// `data[i * row_stride + j * col_stride]`. Fails if that would read past `data`.
    pub fn new(
        data: &'a [T],
        rows: usize,
        cols: usize,
        row_stride: usize,
        col_stride: usize,
    ) -> Result<Self> {
        if rows > 0 && cols > 0 {
            let last = (rows - 1)
                .checked_mul(row_stride)
                .and_then(|a| (cols - 1).checked_mul(col_stride).and_then(|b| a.checked_add(b)));
            match last {
                Some(last) if last < data.len() => {}
                _ => {
                    return Err(EdmfError::invalid(
                        "predictions",
                        format!(
                            "a {rows}x{cols} view with strides ({row_stride}, {col_stride}) \
                             does not fit in {} elements",
                            data.len()
                        ),
                    ))
                }
            }
        }
        Ok(Matrix {
            data,
            rows,
            cols,
            row_stride,
            col_stride,
        })
    }

    /// A C-ordered (row-major, contiguous) view.
    pub fn row_major(data: &'a [T], rows: usize, cols: usize) -> Result<Self> {
        if rows.checked_mul(cols) != Some(data.len()) {
            return Err(EdmfError::invalid(
                "predictions",
                format!("{} elements for a {rows}x{cols} matrix", data.len()),
            ));
        }
        Self::new(data, rows, cols, cols, 1)
    }

    /// A Fortran-ordered (column-major, contiguous) view.
    pub fn col_major(data: &'a [T], rows: usize, cols: usize) -> Result<Self> {
        if rows.checked_mul(cols) != Some(data.len()) {
            return Err(EdmfError::invalid(
                "predictions",
                format!("{} elements for a {rows}x{cols} matrix", data.len()),
            ));
        }
        Self::new(data, rows, cols, 1, rows)
    }

    pub fn rows(&self) -> usize {
        self.rows
    }

    pub fn cols(&self) -> usize {
        self.cols
    }

    #[inline(always)]
    pub fn get(&self, i: usize, j: usize) -> T {
        self.data[i * self.row_stride + j * self.col_stride]
    }

    /// Asks the CPU to start loading the cache line of element (i, j), for
    /// rows read in an order the hardware prefetcher cannot guess. A hint only:
    /// out-of-range indices and other architectures do nothing.
    #[inline(always)]
    pub fn prefetch(&self, i: usize, j: usize) {
        #[cfg(target_arch = "x86_64")]
        if let Some(p) = self.data.get(i * self.row_stride + j * self.col_stride) {
            // SAFETY: a prefetch never faults and `p` points into `data`.
            #[allow(unused_unsafe)]
            unsafe {
                std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
                    p as *const T as *const i8,
                )
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = (i, j);
    }

    /// Elements from the start of one row to the start of the next.
    pub fn row_stride(&self) -> usize {
        self.row_stride
    }

    /// Whether each row is contiguous (C order).
    pub fn rows_contiguous(&self) -> bool {
        self.col_stride == 1
    }

    /// Row `i` as a slice when rows are contiguous (C order), else `None`.
    #[inline(always)]
    pub fn row_slice(&self, i: usize) -> Option<&'a [T]> {
        if self.col_stride == 1 {
            let start = i * self.row_stride;
            Some(&self.data[start..start + self.cols])
        } else {
            None
        }
    }

    /// All elements in row-major order as one slice when the view is
    /// C-contiguous (so it can be read as one run of memory), else `None`.
    pub fn contiguous(&self) -> Option<&'a [T]> {
        let n = self.rows * self.cols;
        let c_order = self.col_stride == 1 && (self.row_stride == self.cols || self.rows <= 1);
        (c_order || n == 0).then(|| &self.data[..n.min(self.data.len())])
    }

    /// All rows as one slice when they follow each other with no gap (C order,
    /// row stride = width), else `None`: short rows are then packed several
    /// to a vector.
    #[inline]
    pub fn packed_rows(&self) -> Option<&'a [T]> {
        self.contiguous()
    }

    /// Rows `start..end` as a view of their own.
    pub fn slice_rows(&self, start: usize, end: usize) -> Matrix<'a, T> {
        assert!(start <= end && end <= self.rows, "row range out of bounds");
        let rows = end - start;
        let data = if rows == 0 || self.cols == 0 {
            &self.data[..0]
        } else {
            &self.data[start * self.row_stride..]
        };
        Matrix {
            data,
            rows,
            cols: self.cols,
            row_stride: self.row_stride,
            col_stride: self.col_stride,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layouts_read_the_same_elements() {
        let c = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]; // 2x3 C order
        let f = [1.0, 4.0, 2.0, 5.0, 3.0, 6.0]; // same matrix, F order
        let mc = Matrix::row_major(&c, 2, 3).unwrap();
        let mf = Matrix::col_major(&f, 2, 3).unwrap();
        for i in 0..2 {
            for j in 0..3 {
                assert_eq!(mc.get(i, j), mf.get(i, j));
            }
        }
        assert_eq!(mc.slice_rows(1, 2).get(0, 2), 6.0);
        assert_eq!(mf.slice_rows(1, 2).get(0, 0), 4.0);
    }

    #[test]
    fn a_view_that_overruns_its_data_is_an_error() {
        let d = [0.0f64; 5];
        assert!(Matrix::new(&d, 2, 3, 3, 1).is_err());
        assert!(Matrix::row_major(&d, 2, 3).is_err());
        assert!(Matrix::new(&d, 0, 3, 3, 1).is_ok());
    }
}
