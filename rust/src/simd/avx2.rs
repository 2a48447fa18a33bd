//! AVX2: four sensors per vector; the last `k % 4` sensors use the portable loop.

use crate::kernel::{
    diagnose_impl, outside, screen_impl, Prediction, ScreenPlan, SensorBounds, Tally, UNKNOWN,
};
use crate::matrix::Matrix;
use std::arch::x86_64::*;

/// All-ones lanes where sensors `j..j+4` reject the prediction (Eq. 8; NaN rejects).
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn outside4(p: __m256d, b: &SensorBounds, j: usize) -> __m256d {
    let r = _mm256_sub_pd(p, _mm256_loadu_pd(b.measured.as_ptr().add(j)));
    let ge = _mm256_cmp_pd::<_CMP_GE_OQ>(r, _mm256_loadu_pd(b.low.as_ptr().add(j)));
    let le = _mm256_cmp_pd::<_CMP_LE_OQ>(r, _mm256_loadu_pd(b.high.as_ptr().add(j)));
    _mm256_xor_pd(_mm256_and_pd(ge, le), _mm256_castsi256_pd(_mm256_set1_epi64x(-1)))
}

/// Rejecting-sensor count, NaN flag and first rejecting sensor of a row; adds
/// every rejection to `counts`.
#[inline]
#[target_feature(enable = "avx2")]
fn diagnose_row<T: Prediction>(row: &[T], b: &SensorBounds, counts: &mut [u64]) -> (u32, bool, usize) {
    let k = row.len();
    assert!(b.len() >= k && counts.len() >= k);
    super::prefetch_ahead(row);
    let whole = k - k % 4;
    // SAFETY: AVX2 is enabled; every index below `whole` is within `row`, `b` and `counts`.
    let mut first = UNKNOWN;
    let (mut n, mut nan) = unsafe {
        let mut n = _mm256_setzero_si256();
        let mut nan = _mm256_setzero_pd();
        for j in (0..whole).step_by(4) {
            let p = T::load4(row.as_ptr().add(j));
            let rejects = outside4(p, b, j);
            let bits = _mm256_movemask_pd(rejects);
            let found = j + bits.trailing_zeros() as usize;
            first = if first == UNKNOWN && bits != 0 {
                found
            } else {
                first
            };
            let out = _mm256_castpd_si256(rejects);
            // An all-ones lane is -1: subtracting it counts one rejection.
            let c = counts.as_mut_ptr().add(j) as *mut __m256i;
            _mm256_storeu_si256(c, _mm256_sub_epi64(_mm256_loadu_si256(c), out));
            n = _mm256_sub_epi64(n, out);
            nan = _mm256_or_pd(nan, _mm256_cmp_pd::<_CMP_UNORD_Q>(p, p));
        }
        let mut lanes = [0u64; 4];
        _mm256_storeu_si256(lanes.as_mut_ptr() as *mut __m256i, n);
        (lanes.iter().sum::<u64>() as u32, _mm256_movemask_pd(nan) != 0)
    };
    for j in whole..k {
        let p = row[j].to_f64();
        let v = outside(p, b.measured[j], b.low[j], b.high[j]);
        if v && first == UNKNOWN {
            first = j;
        }
        counts[j] += v as u64;
        n += v as u32;
        nan |= p.is_nan();
    }
    (n, nan, first)
}

/// True if any sensor rejects the row; one branch per eight sensors.
#[inline]
#[target_feature(enable = "avx2")]
fn row_rejected<T: Prediction>(row: &[T], b: &SensorBounds) -> bool {
    let k = row.len();
    assert!(b.len() >= k);
    super::prefetch_ahead(row);
    let whole = k - k % 4;
    let mut j = 0;
    // SAFETY: AVX2 is enabled; every index below `whole` is within `row` and `b`.
    unsafe {
        while j + 8 <= whole {
            let a = outside4(T::load4(row.as_ptr().add(j)), b, j);
            let c = outside4(T::load4(row.as_ptr().add(j + 4)), b, j + 4);
            if _mm256_movemask_pd(_mm256_or_pd(a, c)) != 0 {
                return true;
            }
            j += 8;
        }
        if j < whole {
            if _mm256_movemask_pd(outside4(T::load4(row.as_ptr().add(j)), b, j)) != 0 {
                return true;
            }
            j += 4;
        }
    }
    (j..k).any(|j| outside(row[j].to_f64(), b.measured[j], b.low[j], b.high[j]))
}

#[target_feature(enable = "avx2")]
pub fn diagnose<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, out: &mut [u32], t: &mut Tally) {
    diagnose_impl(m, b, out, t, |row, b, counts| diagnose_row(row, b, counts))
}

#[target_feature(enable = "avx2")]
pub fn screen<T: Prediction>(m: Matrix<'_, T>, plan: &ScreenPlan, out: &mut [u32]) {
    screen_impl(m, plan, out, |row, b| row_rejected(row, b))
}
