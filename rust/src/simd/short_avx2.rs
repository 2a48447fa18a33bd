//! AVX2 block kernel for rows of at most 8 sensors: two vectors of four
//! f64 lanes per row (f32 widened), masked loads instead of a scalar tail,
//! the acceptance intervals in registers for the whole block, and a row's
//! verdict as the bits of a movemask. Diagnostics come from the same bits,
//! as in `short` (AVX-512): per-sensor and only-by counts in vector lanes.

use super::prefetch::Prefetch;
use crate::kernel::{Prediction, SensorBounds, Tally};
use crate::matrix::Matrix;
use std::arch::x86_64::*;

/// Longest row this kernel takes.
pub const MAX_SENSORS: usize = 8;

pub struct ShortRows4 {
    low: [__m256d; 2],
    high: [__m256d; 2],
    /// All-ones in the lanes holding a sensor (f64 lanes, and 32-bit lanes).
    m64: [__m256i; 2],
    m32: [__m128i; 2],
    /// Bit l of lane l: turns row bits back into lane masks.
    bit: [__m256i; 2],
    k: usize,
}

impl ShortRows4 {
    /// # Safety
    /// AVX2 is available; `1 <= b.len() <= MAX_SENSORS`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn new(b: &SensorBounds) -> Self {
        let k = b.len();
        assert!((1..=MAX_SENSORS).contains(&k));
        let on = |l: usize| if l < k { -1i64 } else { 0 };
        let m64 = [0, 4].map(|g| _mm256_setr_epi64x(on(g), on(g + 1), on(g + 2), on(g + 3)));
        let m32 = [0, 4]
            .map(|g| _mm_setr_epi32(on(g) as i32, on(g + 1) as i32, on(g + 2) as i32, on(g + 3) as i32));
        // The acceptance vectors are padded with NaN to 16 values.
        let a = &b.accept64;
        ShortRows4 {
            low: [0, 4].map(|g| _mm256_loadu_pd(a[0].as_ptr().add(g))),
            high: [0, 4].map(|g| _mm256_loadu_pd(a[1].as_ptr().add(g))),
            m64,
            m32,
            bit: [0, 4].map(|g| _mm256_setr_epi64x(1 << g, 2 << g, 4 << g, 8 << g)),
            k,
        }
    }

    /// (rejecting sensors, NaN sensors) of `row` as bits, and the rejecting
    /// lanes of each vector as all-ones lanes.
    ///
    /// # Safety
    /// AVX2 is available; `row` holds `k` values.
    #[inline(always)]
    unsafe fn row<T: Prediction>(&self, row: &[T]) -> (u32, u32, [__m256i; 2]) {
        let (mut bits, mut nan) = (0u32, 0u32);
        let mut out = [_mm256_setzero_si256(); 2];
        #[allow(clippy::needless_range_loop)] // g also offsets the row and shifts the bits
        for g in 0..2 {
            // `wrapping_add`: lanes past the row are masked off, never read.
            let p = T::maskload4(self.m64[g], self.m32[g], row.as_ptr().wrapping_add(4 * g));
            let inside = _mm256_and_pd(
                _mm256_cmp_pd::<_CMP_GE_OQ>(p, self.low[g]),
                _mm256_cmp_pd::<_CMP_LE_OQ>(p, self.high[g]),
            );
            out[g] = _mm256_andnot_si256(_mm256_castpd_si256(inside), self.m64[g]);
            bits |= (_mm256_movemask_pd(_mm256_castsi256_pd(out[g])) as u32) << (4 * g);
            nan |= (_mm256_movemask_pd(_mm256_cmp_pd::<_CMP_UNORD_Q>(p, p)) as u32) << (4 * g);
        }
        (bits, nan, out)
    }

    /// As `short::ShortRows::screen`. # Safety: AVX2 and POPCNT are
    /// available; rows of `m` are contiguous; `out` has one value per row.
    #[inline]
    #[target_feature(enable = "avx2,popcnt")]
    pub unsafe fn screen<T: Prediction>(&self, m: Matrix<'_, T>, out: &mut [u32]) -> usize {
        assert!(out.len() == m.rows() && m.cols() == self.k);
        let (mut candidates, pf) = (0, Prefetch::FIXED);
        for (i, v) in out.iter_mut().enumerate() {
            let row = m.row_slice(i).expect("contiguous rows");
            super::prefetch_ahead(pf, row);
            let rejected = self.row(row).0 != 0;
            *v = rejected as u32;
            candidates += !rejected as usize;
        }
        candidates
    }

    /// As `short::ShortRows::diagnose`. # Safety: as [`Self::screen`]; `t`
    /// has `k` sensors.
    #[inline]
    #[target_feature(enable = "avx2,popcnt")]
    pub unsafe fn diagnose<T: Prediction>(&self, m: Matrix<'_, T>, out: &mut [u32], t: &mut Tally) -> usize {
        assert!(out.len() == m.rows() && m.cols() == self.k && t.per_sensor.len() == self.k);
        let (mut per, mut only) = ([_mm256_setzero_si256(); 2], [_mm256_setzero_si256(); 2]);
        let (mut candidates, mut invalid, pf) = (0usize, 0u64, Prefetch::FIXED);
        for (i, v) in out.iter_mut().enumerate() {
            let row = m.row_slice(i).expect("contiguous rows");
            super::prefetch_ahead(pf, row);
            let (bits, nan, lanes) = self.row(row);
            let count = bits.count_ones();
            *v = count;
            candidates += (count == 0) as usize;
            invalid += (nan != 0) as u64;
            // The one rejecting sensor's bit, for rows rejected by one only.
            let single = _mm256_set1_epi64x((bits & ((count == 1) as u32).wrapping_neg()) as i64);
            for g in 0..2 {
                // An all-ones lane is -1: subtracting it counts one.
                per[g] = _mm256_sub_epi64(per[g], lanes[g]);
                let one = _mm256_cmpeq_epi64(_mm256_and_si256(single, self.bit[g]), self.bit[g]);
                only[g] = _mm256_sub_epi64(only[g], one);
            }
        }
        let mut lanes = [[0u64; 4]; 4];
        for (dst, v) in lanes.iter_mut().zip(per.iter().chain(&only)) {
            _mm256_storeu_si256(dst.as_mut_ptr() as *mut __m256i, *v);
        }
        for j in 0..self.k {
            t.per_sensor[j] += lanes[j / 4][j % 4];
            t.only_by[j] += lanes[2 + j / 4][j % 4];
        }
        t.invalid += invalid;
        candidates
    }
}

/// Whether the AVX2 short-row kernel takes `m`: rows of at most eight
/// sensors, each contiguous.
pub fn takes<T: Prediction>(m: &Matrix<'_, T>) -> bool {
    (1..=MAX_SENSORS).contains(&m.cols()) && (m.rows() == 0 || m.row_slice(0).is_some())
}
