//! AVX-512 diagnostics for rows of a few vectors (f32 rows of 33-64
//! sensors, f64 rows of 17-64): the `V` vectors of acceptance intervals stay
//! in registers for the whole block, the per-sensor counts are masked adds of
//! the *accepting* sensors into `V` register counters (rejections = rows -
//! acceptances: no complement per vector), a row's accepting sensors are one
//! 64-bit word (violation count = popcount of its complement), and "falsified
//! only by" is one add in memory at the row's lowest rejecting sensor.
//!
//! Why: the long-row loop (then `avx512::diagnose_row`, now `long`) reloads the intervals and
//! updates the counts in memory for every vector of every row, and finds the
//! first rejecting sensor with a chain of minimums: about 110 cycles per row
//! of 50 f32 sensors (AMD EPYC Zen 4), a third of the read floor. Counting
//! "falsified only by" in `V` more register counters (a masked add per vector
//! of every row) and building each row's rejections from complemented masks
//! cost rows of 50 sensors half their speed again: kernel alone, one thread,
//! `cargo bench -- long_rows` (section "session 12: rows of up to 64
//! sensors" of `benches/results-long-rows.txt`), f64 rows of 50 with every
//! row a candidate 51-57 -> 83-90 M rows/s, with 1.2 % of values outside each
//! interval (45 % of the rows rejected) 40-42 -> 84-89; f32 105-106 -> 134-157
//! and 73-75 -> 139-152.

use super::prefetch::Prefetch;
use super::checksum::RowsRead;
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
/// the rows' diagnostics to `t`, for rows of `V` vectors (see [`vectors`]);
/// tells `sums` each row it has read (the checkpoint checksum, if any).
///
/// # Safety
/// AVX-512F, POPCNT and BMI1 are available; `vectors::<T>(m.cols()) == Some(V)`;
/// rows are contiguous (`m.row_slice` is `Some`); the acceptance intervals
/// of `b` are padded to whole vectors (as `SensorBounds` pads them).
#[inline]
#[target_feature(enable = "avx512f,popcnt,bmi1")]
pub unsafe fn diagnose<T: Prediction, const V: usize, S: RowsRead>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    out: &mut [u32],
    (t, sums): (&mut Tally, &mut S),
) {
    let (k, w, accept) = (m.cols(), T::W512, T::accepted(b));
    assert!(out.len() == m.rows() && t.per_sensor.len() == k && accept[0].len() >= V * w);
    let all = u32::MAX >> (32 - w);
    // Every vector but the last is whole: loaded unmasked, tested unmasked.
    let last = all >> (w - (k - (V - 1) * w));
    let row_lanes = u64::MAX >> (64 - k);
    let low: [T::V512; V] = std::array::from_fn(|v| T::load512(all, accept[0].as_ptr().add(v * w)));
    let high: [T::V512; V] = std::array::from_fn(|v| T::load512(all, accept[1].as_ptr().add(v * w)));
    // "Falsified only by": counted at the row's lowest rejecting sensor when
    // it has exactly one (index 64: no rejecting sensor, never counted), in
    // memory rather than in V more vector counters.
    let mut only_by = [0u64; 65];
    let mut read = *sums;
    let pf = Prefetch::FIXED; // see `Prefetch::now` for which kernels choose
    for first in (0..m.rows()).step_by(FLUSH_ROWS) {
        let end = (first + FLUSH_ROWS).min(m.rows());
        let mut accepting = [_mm512_setzero_si512(); V];
        let mut invalid = 0u64;
        for (i, n_out) in (first..end).zip(&mut out[first..end]) {
            let row = m.row_slice(i).expect("contiguous rows (checked by the caller)");
            // One line ahead per vector, unrolled (the row's own loop of
            // prefetches cost a tenth of the time).
            for v in 0..V {
                pf.line(row.as_ptr().wrapping_add(v * w));
            }
            let (inside, nan) = visit_row(row.as_ptr(), &low, &high, last, &mut accepting);
            read.rows_read(row.as_ptr_range().end as *const u8);
            let rejects = !inside & row_lanes;
            let n = rejects.count_ones();
            only_by[rejects.trailing_zeros() as usize] += u64::from(n == 1);
            // A NaN sum: a NaN value, or (rarely) infinities that cancel.
            invalid += u64::from(nan != 0 && row.iter().any(|x| x.to_f64().is_nan()));
            *n_out = n;
        }
        add_rejections::<T, V>(&accepting, (end - first) as u64, &mut t.per_sensor);
        t.invalid += invalid;
    }
    for (total, &c) in t.only_by.iter_mut().zip(&only_by[..k]) {
        *total += c;
    }
    *sums = read;
}

/// The accepting sensors (bit `v * W512 + l` for lane `l` of vector `v`) and
/// the NaN lanes of the sum of the `V` vectors of predictions at `p` (nonzero
/// if a value is NaN, or rarely if infinities cancel: the caller then looks
/// at the row; one add a vector rather than a comparison and a mask move:
/// alone on one core, f64 rows of 17-64 sensors ran 1.06-1.27 times as fast
/// and f32 rows of 33-64 0.90-1.12, AMD EPYC Zen 4,
/// `benches/results-long-rows.txt`, "session 34"),
/// adding one to `accepting`'s lane for every accepting sensor. Vectors but
/// the last are whole; the last has the lanes in `last`.
///
/// # Safety
/// AVX-512F is available; the lanes read lie within the row at `p`.
#[inline(always)]
unsafe fn visit_row<T: Prediction, const V: usize>(
    p: *const T,
    low: &[T::V512; V],
    high: &[T::V512; V],
    last: u32,
    accepting: &mut [__m512i; V],
) -> (u64, u32) {
    let w = T::W512;
    let all = u32::MAX >> (32 - w);
    let ones = _mm512_set1_epi32(1);
    let (mut inside, mut sum) = (0u64, T::zero512());
    unrolled!(V, |v| {
        let lanes = if v + 1 < V { all } else { last };
        let x = T::load512(lanes, p.add(v * w));
        let accepted = T::inside512(lanes, x, low[v], high[v]);
        sum = T::add512(sum, x);
        inside |= u64::from(accepted) << (v * w);
        // Accepting sensors are counted: no complement per vector.
        accepting[v] = _mm512_mask_add_epi32(accepting[v], accepted as __mmask16, accepting[v], ones);
    });
    (inside, T::nan512(all, sum))
}

/// Adds to `per_sensor` (one per sensor of the vectors, from the first) the
/// rejections of `rows` rows whose accepting sensors `accepting` counted.
///
/// # Safety
/// AVX-512F is available.
#[inline(always)]
unsafe fn add_rejections<T: Prediction, const V: usize>(accepting: &[__m512i; V], rows: u64, per_sensor: &mut [u64]) {
    let mut lanes_out = [0u32; 16];
    for (v, acc) in accepting.iter().enumerate() {
        _mm512_storeu_si512(lanes_out.as_mut_ptr() as *mut __m512i, *acc);
        let sensors = per_sensor.iter_mut().skip(v * T::W512).take(T::W512);
        for (total, &c) in sensors.zip(&lanes_out) {
            *total += rows - u64::from(c);
        }
    }
}
