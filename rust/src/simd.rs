//! AVX2 row kernels for x86-64, chosen at run time (see `kernel.rs`).
//!
//! The portable loops in `kernel.rs` reach about half the speed of these on
//! current CPUs: LLVM does not fuse the compare, count and NaN tracking into
//! one vector pass by itself. Four sensors per vector; residuals in f64 (f32
//! predictions are widened first), exactly as in the portable code.

use crate::kernel::SensorBounds;
use std::arch::x86_64::*;

/// Element types that load four predictions as f64 lanes.
pub trait Lanes: Copy {
    /// # Safety
    /// `p` must point to four readable values; the CPU must support AVX2.
    unsafe fn load4(p: *const Self) -> __m256d;
}

impl Lanes for f64 {
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn load4(p: *const f64) -> __m256d {
        _mm256_loadu_pd(p)
    }
}

impl Lanes for f32 {
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn load4(p: *const f32) -> __m256d {
        _mm256_cvtps_pd(_mm_loadu_ps(p))
    }
}

/// All-ones lanes where sensor `j..j+4` rejects the prediction (Eq. 8; NaN rejects).
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn outside4(p: __m256d, b: &SensorBounds, j: usize) -> __m256d {
    let r = _mm256_sub_pd(p, _mm256_loadu_pd(b.measured.as_ptr().add(j)));
    let ge = _mm256_cmp_pd::<_CMP_GE_OQ>(r, _mm256_loadu_pd(b.low.as_ptr().add(j)));
    let le = _mm256_cmp_pd::<_CMP_LE_OQ>(r, _mm256_loadu_pd(b.high.as_ptr().add(j)));
    _mm256_xor_pd(_mm256_and_pd(ge, le), _mm256_castsi256_pd(_mm256_set1_epi64x(-1)))
}

/// Whole 4-lane groups of a row of `k` sensors.
#[inline(always)]
fn whole4(k: usize) -> usize {
    k - k % 4
}

/// Like `kernel::diagnose_row`: rejecting-sensor count and NaN flag of a row;
/// adds every rejection to `counts`. Returns the first sensor not handled
/// (the caller finishes the last `k % 4` sensors).
///
/// # Safety
/// The CPU must support AVX2; `b` and `counts` hold at least `row.len()` sensors.
#[inline]
#[target_feature(enable = "avx2")]
pub unsafe fn diagnose_row<T: Lanes>(row: &[T], b: &SensorBounds, counts: &mut [u64]) -> (u32, bool, usize) {
    let k = row.len();
    debug_assert!(b.len() >= k && counts.len() >= k);
    let mut n = _mm256_setzero_si256();
    let mut nan = _mm256_setzero_pd();
    let mut j = 0;
    while j < whole4(k) {
        let p = T::load4(row.as_ptr().add(j));
        let out = _mm256_castpd_si256(outside4(p, b, j));
        // An all-ones lane is -1: subtracting it counts one rejection.
        let c = counts.as_mut_ptr().add(j) as *mut __m256i;
        _mm256_storeu_si256(c, _mm256_sub_epi64(_mm256_loadu_si256(c), out));
        n = _mm256_sub_epi64(n, out);
        nan = _mm256_or_pd(nan, _mm256_cmp_pd::<_CMP_UNORD_Q>(p, p));
        j += 4;
    }
    let mut lanes = [0u64; 4];
    _mm256_storeu_si256(lanes.as_mut_ptr() as *mut __m256i, n);
    (lanes.iter().sum::<u64>() as u32, _mm256_movemask_pd(nan) != 0, j)
}

/// True if any of the sensors in the whole 4-lane groups rejects the row;
/// checks eight sensors per branch. Returns (rejected, first sensor not handled).
///
/// # Safety
/// The CPU must support AVX2; `b` holds at least `row.len()` sensors.
#[inline]
#[target_feature(enable = "avx2")]
pub unsafe fn row_rejected(row: &[impl Lanes], b: &SensorBounds) -> (bool, usize) {
    let k = row.len();
    debug_assert!(b.len() >= k);
    let mut j = 0;
    while j + 8 <= k {
        let a = outside4(Lanes::load4(row.as_ptr().add(j)), b, j);
        let c = outside4(Lanes::load4(row.as_ptr().add(j + 4)), b, j + 4);
        if _mm256_movemask_pd(_mm256_or_pd(a, c)) != 0 {
            return (true, j);
        }
        j += 8;
    }
    if j < whole4(k) {
        if _mm256_movemask_pd(outside4(Lanes::load4(row.as_ptr().add(j)), b, j)) != 0 {
            return (true, j);
        }
        j += 4;
    }
    (false, j)
}
