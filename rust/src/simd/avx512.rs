//! AVX-512F: eight sensors per vector, compares straight into mask registers,
//! and masked loads for the last `k % 8` sensors, so no scalar tail.

use crate::kernel::{diagnose_impl, screen_impl, Prediction, ScreenPlan, SensorBounds, Tally};
use crate::matrix::Matrix;
use std::arch::x86_64::*;

/// Lanes of sensors `j..j+8` (those set in `lanes`) that reject the prediction
/// (Eq. 8; NaN rejects). Bounds are loaded under the same mask.
#[inline]
#[target_feature(enable = "avx512f")]
unsafe fn outside8(p: __m512d, b: &SensorBounds, j: usize, lanes: __mmask8) -> __mmask8 {
    let y = _mm512_maskz_loadu_pd(lanes, b.measured.as_ptr().add(j));
    let lo = _mm512_maskz_loadu_pd(lanes, b.low.as_ptr().add(j));
    let hi = _mm512_maskz_loadu_pd(lanes, b.high.as_ptr().add(j));
    let r = _mm512_sub_pd(p, y);
    let inside = _mm512_mask_cmp_pd_mask::<_CMP_GE_OQ>(lanes, r, lo) & _mm512_cmp_pd_mask::<_CMP_LE_OQ>(r, hi);
    !inside & lanes
}

/// Mask of the first `n` lanes (n <= 8).
#[inline(always)]
fn prefix(n: usize) -> __mmask8 {
    ((1u16 << n) - 1) as __mmask8
}

/// Rejecting-sensor count and NaN flag of a row; adds every rejection to `counts`.
#[inline]
#[target_feature(enable = "avx512f,popcnt")]
fn diagnose_row<T: Prediction>(row: &[T], b: &SensorBounds, counts: &mut [u64]) -> (u32, bool) {
    let k = row.len();
    assert!(b.len() >= k && counts.len() >= k);
    super::prefetch_ahead(row);
    let mut n = 0u32;
    let mut nan: __mmask8 = 0;
    let mut j = 0;
    // SAFETY: AVX-512F is enabled; full groups stay below `k`, and the last
    // group reads and writes only the lanes below `k` (masked).
    unsafe {
        let ones = _mm512_set1_epi64(1);
        while j < k {
            let lanes = prefix((k - j).min(8));
            let p = if lanes == 0xFF { T::load8(row.as_ptr().add(j)) } else { T::load8_masked(lanes, row.as_ptr().add(j)) };
            let out = outside8(p, b, j, lanes);
            let c = counts.as_mut_ptr().add(j) as *mut i64;
            let total = _mm512_mask_add_epi64(_mm512_maskz_loadu_epi64(lanes, c), out, _mm512_maskz_loadu_epi64(lanes, c), ones);
            _mm512_mask_storeu_epi64(c, lanes, total);
            n += out.count_ones();
            nan |= _mm512_mask_cmp_pd_mask::<_CMP_UNORD_Q>(lanes, p, p);
            j += 8;
        }
    }
    (n, nan != 0)
}

/// True if any sensor rejects the row; one branch per eight sensors.
#[inline]
#[target_feature(enable = "avx512f")]
fn row_rejected<T: Prediction>(row: &[T], b: &SensorBounds) -> bool {
    let k = row.len();
    assert!(b.len() >= k);
    super::prefetch_ahead(row);
    let mut j = 0;
    // SAFETY: as in `diagnose_row`: masked access below `k` only.
    unsafe {
        while j < k {
            let lanes = prefix((k - j).min(8));
            let p = if lanes == 0xFF { T::load8(row.as_ptr().add(j)) } else { T::load8_masked(lanes, row.as_ptr().add(j)) };
            if outside8(p, b, j, lanes) != 0 {
                return true;
            }
            j += 8;
        }
    }
    false
}

#[target_feature(enable = "avx512f,popcnt")]
pub fn diagnose<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, out: &mut [u32], t: &mut Tally) {
    diagnose_impl(m, b, out, t, |row, b, counts| diagnose_row(row, b, counts))
}

#[target_feature(enable = "avx512f")]
pub fn screen<T: Prediction>(m: Matrix<'_, T>, plan: &ScreenPlan, out: &mut [u32]) {
    screen_impl(m, plan, out, |row, b| row_rejected(row, b))
}
