//! AVX2 screening of rows of 9-16 f32 or 9-12 f64 sensors stored one
//! after another ([`takes`]): each row's verdict alone, 1 if any sensor
//! rejects it. The row's vectors are tested and their accepting lanes
//! AND-ed, with no branch and no bit extraction until the row's one test;
//! the last vector ends where the row does (a lane the vector before also
//! holds is tested twice, to the same verdict), so no masked load.
//!
//! Why: these rows were screened one at a time through a closure that took
//! each vector's verdict bits out of the vector and read the row's tail
//! with a masked load. Alone on a core, float32 rows of 9-31 sensors and
//! float64 rows of 9-17 screened 1.22-2.59 times as fast (AMD EPYC Zen 4;
//! `benches/results-short-rows.txt`, "session 31: the AVX2 rows of 9-32
//! sensors"); side by side through `falsify` it was not faster for rows of
//! 17 sensors and more, nor for f64 rows of 13 (session 32), so those keep
//! `avx2::row_rejected` (see [`takes`]).

use super::checksum::RowsRead;
use super::medium_avx2::vectors;
use super::medium_avx2_short::Rows;
use crate::kernel::{Prediction, SensorBounds};
use crate::matrix::Matrix;
use std::arch::x86_64::*;

/// Whether this kernel screens rows of `k` sensors: 9-16 f32 (two
/// vectors), 9-12 f64 (three). Side by side through `falsify`, against
/// `avx2::row_rejected` (AMD EPYC Zen 4; `benches/results-short-rows.txt`):
/// with it float64 rows of 11 ran 1.70-2.32 times as fast and float32 rows
/// of 9-13 1.08-1.83 ("session 32: which rows the short-row kernels take",
/// the final code), but float64 rows of 13 0.96-1.00 (same section, 'v1')
/// and rows of 17-64 0.88-1.03 ("session 31: the AVX2 rows of 9-32
/// sensors"), so those keep `row_rejected`.
pub fn takes<T: Prediction>(k: usize) -> bool {
    k > 8 && k <= if std::mem::size_of::<T>() == 8 { 12 } else { 16 }
}

/// Writes 1 to `out` for each row of `m` that a sensor rejects, else 0;
/// tells `sums` each row it has read.
///
/// # Safety
/// AVX2 is available; `takes::<T>(m.cols())`; rows are
/// contiguous (`m.row_slice` is `Some`).
#[inline]
#[target_feature(enable = "avx2")]
pub unsafe fn screen<T: Prediction, S: RowsRead>(m: Matrix<'_, T>, b: &SensorBounds, out: &mut [u32], sums: &mut S) {
    assert!(takes::<T>(m.cols()), "rows of 9-16 f32 or 9-12 f64 sensors, got {}", m.cols());
    // Only the vector counts of the widths it takes (f32 two, f64 three)
    // get a compiled loop. SAFETY: as this function's, `vectors` gave `V`.
    by_vectors!(@ T, m.cols(), V, unsafe { screen_rows::<T, V, S>(m, b, out, sums) }, 2 3)
}

/// [`screen`] for rows of `V` vectors.
///
/// # Safety
/// As [`screen`]; `vectors::<T>(m.cols()) == Some(V)`.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn screen_rows<T: Prediction, const V: usize, S: RowsRead>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    out: &mut [u32],
    sums: &mut S,
) {
    let (k, w, accept) = (m.cols(), T::W512 / 2, T::accepted(b));
    assert!(takes::<T>(k) && vectors::<T>(k) == Some(V) && out.len() == m.rows());
    assert!(k >= w && accept[0].len() >= k && accept[1].len() >= k);
    if m.rows() == 0 {
        return;
    }
    let rows = Rows {
        p: m.row_slice(0).expect("contiguous rows (checked by the caller)").as_ptr(),
        n: m.rows(),
        stride: m.row_stride(),
        k,
        intervals: (accept[0].as_ptr(), accept[1].as_ptr()),
    };
    let (mut read, mut p, ones) = (*sums, rows.p, _mm256_set1_epi32(-1));
    for flag in out.iter_mut() {
        let mut all = ones;
        unrolled!(V, |v| {
            all = _mm256_and_si256(all, rows.test::<V>(p, v).1);
        });
        read.rows_read(p.add(k) as *const u8);
        *flag = u32::from(_mm256_testc_si256(all, ones) == 0);
        // The view's bounds are checked when it is made: row i + 1 starts
        // `stride` values on (wrapping past the last row, never read).
        p = p.wrapping_add(rows.stride);
    }
    *sums = read;
}
