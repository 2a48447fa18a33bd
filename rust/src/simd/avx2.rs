//! AVX2: four sensors per vector, predictions widened to f64 and compared
//! with the f64 acceptance intervals; the last `k % 4` sensors of a row (and
//! of a block) are tested one by one.

use super::short_avx2::{takes, ShortRows4};
use crate::kernel::{diagnose_impl, screen_impl, Prediction, ScreenPlan, SensorBounds, Tally};
use crate::matrix::Matrix;
use std::arch::x86_64::*;

/// All-ones lanes where sensors `j..j+4` reject the prediction (NaN rejects).
///
/// # Safety
/// AVX2 is available and the acceptance vectors hold four values from `j`.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn outside4(p: __m256d, accept: &[Vec<f64>; 2], j: usize) -> __m256d {
    let ge = _mm256_cmp_pd::<_CMP_GE_OQ>(p, _mm256_loadu_pd(accept[0].as_ptr().add(j)));
    let le = _mm256_cmp_pd::<_CMP_LE_OQ>(p, _mm256_loadu_pd(accept[1].as_ptr().add(j)));
    _mm256_xor_pd(_mm256_and_pd(ge, le), _mm256_castsi256_pd(_mm256_set1_epi64x(-1)))
}

/// The scalar form of `outside4`, for the last sensors of a row.
#[inline(always)]
fn outside1(p: f64, accept: &[Vec<f64>; 2], j: usize) -> bool {
    !(accept[0][j] <= p && p <= accept[1][j])
}

/// Rejecting-sensor count, NaN flag and first rejecting sensor of a row (the
/// last sensor when none rejects); adds every rejection to `counts`.
#[inline]
#[target_feature(enable = "avx2")]
fn diagnose_row<T: Prediction>(row: &[T], b: &SensorBounds, counts: &mut [u64]) -> (u32, bool, usize) {
    let (k, accept) = (row.len(), &b.accept64);
    assert!(accept[0].len() >= k && counts.len() >= k);
    let whole = k - k % 4;
    // The lowest rejecting position, or past the row: branch-free, since which
    // sensor rejects varies at random from row to row.
    let mut first = usize::MAX;
    // SAFETY: AVX2 is enabled; every index below `whole` is within `row`,
    // the acceptance vectors and `counts`.
    let (mut n, mut nan) = unsafe {
        let mut n = _mm256_setzero_si256();
        let mut nan = _mm256_setzero_pd();
        for j in (0..whole).step_by(4) {
            super::prefetch_spread(row, j, 4, j + 4 >= whole);
            let p = T::load4(row.as_ptr().add(j));
            let rejects = outside4(p, accept, j);
            let bits = _mm256_movemask_pd(rejects);
            // Past the row when this vector has none (not j + 32: a later
            // vector's rejection would then be attributed to the wrong sensor).
            let none = ((bits == 0) as usize).wrapping_neg(); // all ones if none rejects
            first = first.min((j + bits.trailing_zeros() as usize) | none);
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
        let v = outside1(p, accept, j);
        first = first.min(if v { j } else { usize::MAX });
        counts[j] += v as u64;
        n += v as u32;
        nan |= p.is_nan();
    }
    (n, nan, first.min(k.saturating_sub(1)))
}

/// True if any sensor rejects the row: every vector, in column order,
/// without a branch, one prefetch per line spread over the row, as the
/// AVX-512 kernel does (see `avx512::any_rejecting` for why). Side by side
/// through `falsify` with `EDMF_RS_ISA=avx2` (AMD EPYC Zen 4,
/// `benches/results-short-rows.txt`, section "session 14: side by side,
/// AVX2"), screening f64 rows of 200 sensors went from 0.76-0.79 to
/// 1.01-1.05 of the read floor and f32 rows of 50, most falsified, from
/// 0.68-0.73 to 0.85-0.89.
#[inline]
#[target_feature(enable = "avx2")]
fn row_rejected<T: Prediction>(row: &[T], b: &SensorBounds) -> bool {
    let (k, accept) = (row.len(), &b.accept64);
    assert!(accept[0].len() >= k);
    let whole = k - k % 4;
    // SAFETY: AVX2 is enabled; every index below `whole` is within `row` and
    // the acceptance vectors.
    let vector = unsafe {
        let mut any = _mm256_setzero_pd();
        for j in (0..whole).step_by(4) {
            super::prefetch_spread(row, j, 4, j + 4 >= whole);
            any = _mm256_or_pd(any, outside4(T::load4(row.as_ptr().add(j)), accept, j));
        }
        _mm256_movemask_pd(any) != 0
    };
    vector | (whole..k).fold(false, |any, j| any | outside1(row[j].to_f64(), accept, j))
}

#[target_feature(enable = "avx2,popcnt")]
pub fn diagnose<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, out: &mut [u32], t: &mut Tally) {
    if takes(&m) {
        // SAFETY: AVX2 and POPCNT are enabled; `takes` checked the row width
        // and that rows are contiguous.
        unsafe { ShortRows4::new(b).diagnose(m, out, t) };
    } else {
        diagnose_impl(m, b, out, t, |row, b, counts| diagnose_row(row, b, counts))
    }
}

#[target_feature(enable = "avx2,popcnt")]
pub fn screen<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, plan: &ScreenPlan, out: &mut [u32]) {
    if takes(&m) {
        // SAFETY: as in `diagnose`.
        unsafe { ShortRows4::new(b).screen(m, out) };
    } else {
        screen_impl(m, b, plan, out, |row| row_rejected(row, b))
    }
}
