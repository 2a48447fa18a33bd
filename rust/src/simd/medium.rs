//! AVX-512 diagnostics for rows of three to eight vectors (f32 rows of
//! 33-128 sensors, f64 rows of 17-64): the `V` vectors of acceptance
//! intervals stay in registers for the whole block (3V of the 32 vector
//! registers), the per-sensor counts are masked adds of the *accepting*
//! sensors into `V` register counters (rejections = rows - acceptances: no
//! complement per vector), a row's accepting sensors are one or two 64-bit
//! words (violation count = popcount of their complement), and "falsified
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
//! and 73-75 -> 139-152. f32 rows of 65-128 took the long-row kernel until
//! session 36, where typical rows of 65 with diagnostics ran at a third of the
//! speed of rows of 64 alone on one core, and at 0.63 of the read floor
//! through `falsify` (section "session 36: f32 rows of 65-128" of
//! `benches/results-long-rows.txt`).

use super::prefetch::Prefetch;
use super::checksum::RowsRead;
use crate::kernel::{Prediction, SensorBounds, Tally};
use crate::matrix::Matrix;
use std::arch::x86_64::*;

/// Rows per pass between two flushes of the 32-bit register counters (far
/// below 2^32, so they never wrap).
const FLUSH_ROWS: usize = 1 << 20;

/// Most vectors a row of this kernel has: with three registers each (the
/// two bounds and the counter), eight leave eight of the 32 for the work.
const MAX_VECTORS: usize = 8;

/// Vectors per row of `k` sensors if this kernel takes them: more than two
/// vectors (rows of one or two go to `ShortRows`) and at most
/// [`MAX_VECTORS`] (so at most 128 lanes: a row's string fits two u64).
pub fn vectors<T: Prediction>(k: usize) -> Option<usize> {
    let v = k.div_ceil(T::W512);
    (v > 2 && v <= MAX_VECTORS).then_some(v)
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
    assert!((V - 1) * w < k && k <= V * w && V <= MAX_VECTORS);
    let all = u32::MAX >> (32 - w);
    // Every vector but the last is whole: loaded unmasked, tested unmasked.
    let last = all >> (w - (k - (V - 1) * w));
    // The row's string: bits 0-63 in word 0, 64-127 in word 1 (for rows of
    // up to 64 lanes a constant zero, which the compiler drops).
    let two_words = V * w > 64;
    let row_lanes = [u64::MAX >> (64 - k.min(64)), if two_words { u64::MAX >> (128 - k) } else { 0 }];
    let low: [T::V512; V] = std::array::from_fn(|v| T::load512(all, accept[0].as_ptr().add(v * w)));
    let high: [T::V512; V] = std::array::from_fn(|v| T::load512(all, accept[1].as_ptr().add(v * w)));
    // "Falsified only by": counted at the row's lowest rejecting sensor when
    // it has exactly one (index 64 or 128: none, never counted), in
    // memory rather than in V more vector counters.
    let mut only_by = [0u64; 129];
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
            let rejects = [!inside[0] & row_lanes[0], !inside[1] & row_lanes[1]];
            let n = rejects[0].count_ones() + rejects[1].count_ones();
            // Without a branch (a row's first rejecting sensor is random);
            // past the row (64 or 128) when none rejects.
            let lowest = if !two_words || rejects[0] != 0 {
                rejects[0].trailing_zeros()
            } else {
                64 + rejects[1].trailing_zeros()
            };
            only_by[lowest as usize] += u64::from(n == 1);
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

/// The accepting sensors (bit `v * W512 + l` for lane `l` of vector `v`, in
/// two words: bits 0-63 and 64-127) and
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
) -> ([u64; 2], u32) {
    let w = T::W512;
    let all = u32::MAX >> (32 - w);
    let ones = _mm512_set1_epi32(1);
    let (mut inside, mut sum) = ([0u64; 2], T::zero512());
    unrolled!(V, |v| {
        let lanes = if v + 1 < V { all } else { last };
        let x = T::load512(lanes, p.add(v * w));
        let accepted = T::inside512(lanes, x, low[v], high[v]);
        sum = T::add512(sum, x);
        // `v` is a constant here: so are the word and the shift.
        inside[v * w / 64] |= u64::from(accepted) << (v * w % 64);
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
