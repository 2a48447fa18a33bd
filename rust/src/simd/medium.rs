//! AVX-512 diagnostics for rows of a few vectors (f32 rows of 33-64
//! sensors, f64 rows of 17-64): the `V` vectors of acceptance intervals stay
//! in registers for the whole block, the per-sensor and "falsified only by"
//! counts are masked adds into `V` register counters, and a row's rejecting
//! sensors are one 64-bit word (violation count = its popcount).
//!
//! Why: the long-row loop (`avx512::diagnose_row`) reloads the intervals and
//! updates the counts in memory for every vector of every row, and finds the
//! first rejecting sensor with a chain of minimums: about 110 cycles per row
//! of 50 f32 sensors (AMD EPYC Zen 4), a third of the read floor. Here the
//! work per row is the loads, two comparisons and two masked adds per vector.

use crate::kernel::{Prediction, SensorBounds, Tally};
use crate::matrix::Matrix;
use std::arch::x86_64::*;

/// Rows per pass between two flushes of the 32-bit register counters (far
/// below 2^32, so they never wrap).
const FLUSH_ROWS: usize = 1 << 20;

/// Vectors per row of `k` sensors if this kernel takes them: whole rows in at
/// most 64 lanes (a row's rejections fit one u64), and more than two vectors
/// (rows of one or two vectors go to `ShortRows`).
pub fn vectors<T: Prediction>(k: usize) -> Option<usize> {
    let v = k.div_ceil(T::W512);
    (k <= 64 && v > 2).then_some(v)
}

/// Writes the rejecting-sensor count of every row of `m` to `out` and adds
/// the rows' diagnostics to `t`, for rows of `V` vectors (see [`vectors`]).
///
/// # Safety
/// AVX-512F and POPCNT are available; `vectors::<T>(m.cols()) == Some(V)`;
/// rows are contiguous (`m.row_slice` is `Some`); the acceptance intervals
/// of `b` are padded to whole vectors (as `SensorBounds` pads them).
#[inline]
#[target_feature(enable = "avx512f,popcnt")]
pub unsafe fn diagnose<T: Prediction, const V: usize>(m: Matrix<'_, T>, b: &SensorBounds, out: &mut [u32], t: &mut Tally) {
    let (k, w, accept) = (m.cols(), T::W512, T::accepted(b));
    assert!(out.len() == m.rows() && t.per_sensor.len() == k && accept[0].len() >= V * w);
    let all = u32::MAX >> (32 - w);
    let lanes: [u32; V] = std::array::from_fn(|v| all >> (w - (k - v * w).min(w)));
    let low: [T::V512; V] = std::array::from_fn(|v| T::load512(all, accept[0].as_ptr().add(v * w)));
    let high: [T::V512; V] = std::array::from_fn(|v| T::load512(all, accept[1].as_ptr().add(v * w)));
    let ones = _mm512_set1_epi32(1);
    for first in (0..m.rows()).step_by(FLUSH_ROWS) {
        let last = (first + FLUSH_ROWS).min(m.rows());
        let mut per_sensor = [_mm512_setzero_si512(); V];
        let mut only_by = [_mm512_setzero_si512(); V];
        let mut invalid = 0u64;
        for (i, n_out) in (first..last).zip(&mut out[first..last]) {
            let row = m.row_slice(i).expect("contiguous rows (checked by the caller)");
            super::prefetch_ahead(row);
            let (mut rejects, mut nan) = (0u64, 0u32);
            let mut outs = [0u32; V];
            for v in 0..V {
                let p = T::load512(lanes[v], row.as_ptr().add(v * w));
                outs[v] = !T::inside512(lanes[v], p, low[v], high[v]) & lanes[v]; // NaN is outside
                nan |= T::nan512(lanes[v], p);
                rejects |= u64::from(outs[v]) << (v * w);
                per_sensor[v] = _mm512_mask_add_epi32(per_sensor[v], outs[v] as __mmask16, per_sensor[v], ones);
            }
            let n = rejects.count_ones();
            // Rejected by exactly one sensor: count it for that sensor, branch-free.
            let single = ((n == 1) as u32).wrapping_neg();
            for v in 0..V {
                only_by[v] = _mm512_mask_add_epi32(only_by[v], (outs[v] & single) as __mmask16, only_by[v], ones);
            }
            invalid += (nan != 0) as u64;
            *n_out = n;
        }
        let mut lanes_out = [0u32; 16];
        for v in 0..V {
            for (counts, acc) in [(&mut t.per_sensor, per_sensor[v]), (&mut t.only_by, only_by[v])] {
                _mm512_storeu_si512(lanes_out.as_mut_ptr() as *mut __m512i, acc);
                for (l, &c) in lanes_out.iter().enumerate().take(w.min(k - v * w)) {
                    counts[v * w + l] += u64::from(c);
                }
            }
        }
        t.invalid += invalid;
    }
}
