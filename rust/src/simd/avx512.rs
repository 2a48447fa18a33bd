//! AVX-512F: eight sensors per vector, compares straight into mask registers,
//! and masked loads for the last `k % 8` sensors, so no scalar tail.

use crate::kernel::{diagnose_impl, screen_impl, Prediction, ScreenPlan, SensorBounds, Tally, UNKNOWN};
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
    let inside =
        _mm512_mask_cmp_pd_mask::<_CMP_GE_OQ>(lanes, r, lo) & _mm512_cmp_pd_mask::<_CMP_LE_OQ>(r, hi);
    !inside & lanes
}

/// Mask of the first `n` lanes (n <= 8).
#[inline(always)]
fn prefix(n: usize) -> __mmask8 {
    ((1u16 << n) - 1) as __mmask8
}

/// Rejecting-sensor count, NaN flag and first rejecting sensor of a row; adds
/// every rejection to `counts`.
#[inline]
#[target_feature(enable = "avx512f,popcnt,bmi1")]
fn diagnose_row<T: Prediction>(row: &[T], b: &SensorBounds, counts: &mut [u64]) -> (u32, bool, usize) {
    let k = row.len();
    assert!(b.len() >= k && counts.len() >= k);
    super::prefetch_ahead(row);
    let mut n = 0u32;
    let mut nan: __mmask8 = 0;
    let mut first = UNKNOWN;
    let mut j = 0;
    // SAFETY: AVX-512F is enabled; full groups stay below `k`, and the last
    // group reads and writes only the lanes below `k` (masked).
    unsafe {
        let ones = _mm512_set1_epi64(1);
        while j < k {
            let lanes = prefix((k - j).min(8));
            let p = if lanes == 0xFF {
                T::load8(row.as_ptr().add(j))
            } else {
                T::load8_masked(lanes, row.as_ptr().add(j))
            };
            let out = outside8(p, b, j, lanes);
            let c = counts.as_mut_ptr().add(j) as *mut i64;
            let total = _mm512_mask_add_epi64(
                _mm512_maskz_loadu_epi64(lanes, c),
                out,
                _mm512_maskz_loadu_epi64(lanes, c),
                ones,
            );
            _mm512_mask_storeu_epi64(c, lanes, total);
            n += out.count_ones();
            let found = j + out.trailing_zeros() as usize;
            first = if first == UNKNOWN && out != 0 {
                found
            } else {
                first
            };
            nan |= _mm512_mask_cmp_pd_mask::<_CMP_UNORD_Q>(lanes, p, p);
            j += 8;
        }
    }
    (n, nan != 0, first)
}

/// True if any sensor rejects the row; one branch per sixteen sensors (a row
/// of up to 16 sensors is one predictable branch).
#[inline]
#[target_feature(enable = "avx512f")]
fn row_rejected<T: Prediction>(row: &[T], b: &SensorBounds) -> bool {
    let k = row.len();
    assert!(b.len() >= k);
    super::prefetch_ahead(row);
    let group = |j: usize| {
        // SAFETY: AVX-512F is enabled; only lanes below `k` are read (masked).
        unsafe {
            let lanes = prefix(k.saturating_sub(j).min(8));
            let p = if lanes == 0xFF {
                T::load8(row.as_ptr().add(j))
            } else {
                T::load8_masked(lanes, row.as_ptr().add(j))
            };
            outside8(p, b, j, lanes)
        }
    };
    let mut j = 0;
    while j < k {
        let rejects = if j + 8 < k {
            group(j) | group(j + 8)
        } else {
            group(j)
        };
        if rejects != 0 {
            return true;
        }
        j += 16;
    }
    false
}

/// Bounds of a row of at most 16 sensors, held in registers for a whole block
/// of rows: short rows are otherwise dominated by reloading them every row.
struct ShortRow {
    measured: [__m512d; 2],
    low: [__m512d; 2],
    high: [__m512d; 2],
    lanes: [__mmask8; 2],
    k: usize,
}

impl ShortRow {
    const MAX: usize = 16;

    #[inline]
    #[target_feature(enable = "avx512f")]
    fn new(b: &SensorBounds) -> ShortRow {
        let k = b.len();
        assert!(k <= Self::MAX);
        let lanes = [prefix(k.min(8)), prefix(k.saturating_sub(8))];
        // SAFETY: AVX-512F is enabled; masked loads read only sensors below `k`.
        // `wrapping_add`: group 1 of a row of fewer than 8 sensors points past the
        // slice; its mask is empty, so nothing is read there.
        let load =
            |v: &[f64], g: usize| unsafe { _mm512_maskz_loadu_pd(lanes[g], v.as_ptr().wrapping_add(8 * g)) };
        ShortRow {
            measured: [load(&b.measured, 0), load(&b.measured, 1)],
            low: [load(&b.low, 0), load(&b.low, 1)],
            high: [load(&b.high, 0), load(&b.high, 1)],
            lanes,
            k,
        }
    }

    /// (predictions, rejecting lanes) of lane group `g` (sensors 8g..8g+8).
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn group<T: Prediction>(&self, row: &[T], g: usize) -> (__m512d, __mmask8) {
        assert!(row.len() == self.k);
        let lanes = self.lanes[g];
        // SAFETY: AVX-512F is enabled; only the lanes below `k` are read.
        unsafe {
            let at = row.as_ptr().wrapping_add(8 * g);
            let p = if lanes == 0xFF {
                T::load8(at)
            } else {
                T::load8_masked(lanes, at)
            };
            let r = _mm512_sub_pd(p, self.measured[g]);
            let inside = _mm512_mask_cmp_pd_mask::<_CMP_GE_OQ>(lanes, r, self.low[g])
                & _mm512_cmp_pd_mask::<_CMP_LE_OQ>(r, self.high[g]);
            (p, !inside & lanes)
        }
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    fn rejected<T: Prediction>(&self, row: &[T]) -> bool {
        super::prefetch_ahead(row);
        let rejects = self.group(row, 0).1 | if self.k > 8 { self.group(row, 1).1 } else { 0 };
        rejects != 0
    }

    /// Like `diagnose_row`, but the per-sensor counts stay in registers
    /// (`counts`, one lane per sensor) until the block is done.
    #[inline]
    #[target_feature(enable = "avx512f,popcnt,bmi1")]
    fn diagnose<T: Prediction>(&self, row: &[T], counts: &mut [__m512i; 2]) -> (u32, bool, usize) {
        super::prefetch_ahead(row);
        let (mut n, mut nan, mut first) = (0u32, 0 as __mmask8, UNKNOWN);
        let groups = 1 + (self.k > 8) as usize;
        for (g, count) in counts.iter_mut().enumerate().take(groups) {
            let (p, out) = self.group(row, g);
            *count = _mm512_mask_add_epi64(*count, out, *count, _mm512_set1_epi64(1));
            nan |= _mm512_mask_cmp_pd_mask::<_CMP_UNORD_Q>(self.lanes[g], p, p);
            let found = 8 * g + out.trailing_zeros() as usize;
            first = if first == UNKNOWN && out != 0 {
                found
            } else {
                first
            };
            n += out.count_ones();
        }
        (n, nan != 0, first)
    }
}

#[target_feature(enable = "avx512f,popcnt,bmi1")]
pub fn diagnose<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, out: &mut [u32], t: &mut Tally) {
    if b.len() <= ShortRow::MAX {
        let short = ShortRow::new(b);
        let mut counts = [_mm512_setzero_si512(); 2];
        diagnose_impl(m, b, out, t, |row, _, _| short.diagnose(row, &mut counts));
        let mut lanes = [0u64; 16];
        // SAFETY: AVX-512F is enabled; `lanes` holds the two vectors.
        unsafe {
            _mm512_storeu_epi64(lanes.as_mut_ptr() as *mut i64, counts[0]);
            _mm512_storeu_epi64(lanes.as_mut_ptr().add(8) as *mut i64, counts[1]);
        }
        for (total, add) in t.per_sensor.iter_mut().zip(lanes) {
            *total += add;
        }
    } else {
        diagnose_impl(m, b, out, t, |row, b, counts| diagnose_row(row, b, counts))
    }
}

#[target_feature(enable = "avx512f")]
pub fn screen<T: Prediction>(m: Matrix<'_, T>, plan: &ScreenPlan, out: &mut [u32]) {
    if plan.all.len() <= ShortRow::MAX {
        let short = ShortRow::new(&plan.all);
        screen_impl(m, plan, out, |row, _| short.rejected(row))
    } else {
        screen_impl(m, plan, out, |row, b| row_rejected(row, b))
    }
}
