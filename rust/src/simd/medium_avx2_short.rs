//! AVX2 diagnostics for the shorter rows `medium_avx2` takes: rows of
//! 9-32 f32 sensors (two to four vectors of eight) and 9-12 f64 sensors
//! (three vectors of four), stored one after another ([`takes`]), which
//! count "falsified only by" in vector lanes (as `medium_avx2::counts_alone`
//! says for its rows of four and five f64 vectors). The row test is
//! `medium_avx2`'s; the work around it is cut to what short rows can pay:
//! - the violation count from the accepting lanes packed to bytes: one
//!   `movemask` and one popcount for up to four vectors (the packing mixes
//!   the lanes' order, which a count does not need; the first rejecting
//!   sensor is needed only for "falsified only by", counted in lanes);
//! - each sensor's acceptances and "falsified only by" in the two 16-bit
//!   halves of one 32-bit lane, so half the counter registers, flushed
//!   every 65,535 rows, and both counted by one OR and one subtraction a
//!   vector (the row's single-rejection halves loaded from a table, not
//!   broadcast: alone on a core, with diagnostics, the rows not all
//!   candidates ran 0.95-1.23 times as fast, session 32); the intervals
//!   read from memory (a load beside each comparison), so the counters
//!   keep AVX2's sixteen registers: held in registers, the intervals pushed
//!   counters to the stack, stored and reloaded on every row;
//! - NaN looked for once every [`BLOCK_ROWS`] rows, not on every row;
//! - the rows walked by a pointer, with no bounds check a row (the view's
//!   bounds are checked when it is made);
//! - a candidate row costs its verdict only: after a block of candidates
//!   (or when a call's first four rows are candidates) the next block is
//!   tested for its verdicts alone, and diagnosed only if a row is rejected.
//!
//! Why: at AVX2, short rows with diagnostics ran well below what a core
//! reads from memory, and through memory below the read floor (0.57-0.76 of
//! it at the start of session 31). Alone on a core, against that code,
//! these rows with diagnostics ran 1.92-3.05 times as fast in the worst case
//! and 0.93-1.19 in the others (AMD EPYC Zen 4; `benches/results-short-rows.txt`,
//! "session 31: the AVX2 rows of 9-32 sensors").

use super::checksum::RowsRead;
use super::medium_avx2::{pair_lanes, sensor_counts, vectors};
use super::prefetch::Prefetch;
use crate::kernel::{Prediction, SensorBounds, Tally};
use crate::matrix::Matrix;
use std::arch::x86_64::*;

/// Rows of a block: each row adds its values to one sum, tested for NaN
/// once a block; a NaN sum (a NaN value, or rarely infinities that cancel)
/// has the block's rows tested one by one. After a block of candidates,
/// the next block's rows are first tested for their verdicts alone: if
/// every sensor accepts all of them, their diagnostics are none.
pub(super) const BLOCK_ROWS: usize = 128;

/// Whether this kernel diagnoses rows of `v` vectors: up to four f32
/// (rows of 9-32 sensors) or three f64 (9-12). Rows of four and five f64
/// vectors (13-20 sensors) count "falsified only by" in lanes in
/// `medium_avx2`'s loop: side by side through `falsify`, with this kernel
/// float64 rows of 17 ran 0.90-0.92 times as fast with diagnostics
/// (AMD EPYC Zen 4; `benches/results-short-rows.txt`, "session 31: the AVX2
/// rows of 9-32 sensors"), and rows of 13 0.92-0.97 in the worst case, in
/// all five runs ("session 32: which rows the short-row kernels take", 'v1').
pub(super) fn takes<T: Prediction>(v: usize) -> bool {
    v <= if std::mem::size_of::<T>() == 8 { 3 } else { 4 }
}

/// Writes the rejecting-sensor count of every row of `m` (rows of `V`
/// vectors) to `out` and adds the rows' diagnostics to `t`, the counters
/// flushed every `pass_rows` rows or 65,535, whichever is fewer; tells
/// `sums` each row it has read.
///
/// # Safety
/// As `medium_avx2::diagnose_in_passes`; `vectors::<T>(m.cols()) ==
/// Some(V)` and `takes::<T>(V)`.
#[inline]
#[target_feature(enable = "avx2,popcnt")]
pub(super) unsafe fn diagnose_rows<T: Prediction, const V: usize, S: RowsRead>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    out: &mut [u32],
    (t, sums): (&mut Tally, &mut S),
    pass_rows: usize,
) {
    let (k, w, accept) = (m.cols(), T::W512 / 2, T::accepted(b));
    assert!(vectors::<T>(k) == Some(V) && takes::<T>(V));
    assert!(out.len() == m.rows() && t.per_sensor.len() == k);
    assert!(k >= w && accept[0].len() >= k && accept[1].len() >= k);
    let mut read = *sums;
    let mut alone_total = [0u64; 64];
    let pass_rows = pass_rows.min(u16::MAX as usize);
    assert!(pass_rows > 0);
    let rows_at = |first: usize, end: usize| Rows::of(m, first..end, accept);
    // Whether the last block's rows were all candidates; before the first
    // block, whether the first four rows are (calls are often of a few
    // blocks: a block tested twice in each would cost rows of few candidates).
    let mut quiet = m.rows() > 0 && all_candidates::<T, V>(rows_at(0, m.rows().min(4)));
    for first in (0..m.rows()).step_by(pass_rows) {
        let end = (first + pass_rows).min(m.rows());
        // Counter c: acceptances in the low half of each 32-bit lane, rows
        // falsified only by that lane's sensor in the high half (f64:
        // vectors 2c and 2c + 1, see `pair_lanes`).
        let mut both = [_mm256_setzero_si256(); V];
        let (mut invalid, mut candidates) = (0u64, 0u64);
        for block in (first..end).step_by(BLOCK_ROWS) {
            let block_end = (block + BLOCK_ROWS).min(end);
            let rows = rows_at(block, block_end);
            if candidates_first::<T, V, S>(quiet, rows, &mut out[block..block_end], &mut read) {
                candidates += rows.n as u64;
                continue;
            }
            if diagnose_block::<T, V, S>(rows, &mut out[block..block_end], &mut both, &mut read) {
                invalid += (block..block_end)
                    .filter(|&i| m.row_slice(i).is_some_and(|row| row.iter().any(|x| x.to_f64().is_nan())))
                    .count() as u64;
            }
            quiet = out[block..block_end].iter().all(|&n| n == 0);
        }
        let rows = (end - first) as u64;
        let low_halves = _mm256_set1_epi32(0xFFFF);
        let accepting = both.map(|c| _mm256_and_si256(c, low_halves));
        let alone = both.map(|c| _mm256_srli_epi32::<16>(c));
        for (total, c) in t.per_sensor.iter_mut().zip(sensor_counts::<T, V>(&accepting, k)) {
            *total += rows - candidates - c;
        }
        for (total, c) in alone_total.iter_mut().zip(sensor_counts::<T, V>(&alone, k)) {
            *total += c;
        }
        t.invalid += invalid;
    }
    for (total, &c) in t.only_by.iter_mut().zip(&alone_total[..k]) {
        *total += c;
    }
    *sums = read;
}

/// `n` rows of `k` values from `p`, `stride` values apart, and the
/// acceptance intervals (lower and upper bounds, padded to whole vectors);
/// also the screening kernel's (`medium_avx2_screen`).
#[derive(Clone, Copy)]
pub(super) struct Rows<T> {
    pub(super) p: *const T,
    pub(super) n: usize,
    pub(super) stride: usize,
    pub(super) k: usize,
    pub(super) intervals: (*const T, *const T),
}

impl<T: Prediction> Rows<T> {
    /// The rows `range` of `m` and the acceptance intervals `accept`.
    ///
    /// # Panics
    /// If the rows are not contiguous (the callers check) or `range.start` is
    /// not a row of `m`.
    pub(super) fn of(m: Matrix<'_, T>, range: std::ops::Range<usize>, accept: &[Vec<T>; 2]) -> Rows<T> {
        Rows {
            p: m.row_slice(range.start).expect("contiguous rows (checked by the caller)").as_ptr(),
            n: range.len(),
            stride: m.row_stride(),
            k: m.cols(),
            intervals: (accept[0].as_ptr(), accept[1].as_ptr()),
        }
    }

    /// Vector `v` of the row at `row`, and its accepting lanes, all ones
    /// (the last vector ends where the row does: see `medium_avx2`).
    ///
    /// # Safety
    /// AVX2 is available; the rows are readable; `v < V`.
    #[inline(always)]
    pub(super) unsafe fn test<const V: usize>(&self, row: *const T, v: usize) -> (T::V256, __m256i) {
        let w = T::W512 / 2;
        let j = if v + 1 < V { v * w } else { self.k - w };
        if v % 2 == 0 {
            // A line ahead every 64 bytes of the row.
            Prefetch::FIXED.line(row.wrapping_add(v * w));
        }
        let x = T::load256(row.add(j));
        // The intervals read from memory beside each comparison, not held in
        // registers: the counters need them more.
        (x, T::inside_lanes256(x, T::load256(self.intervals.0.add(j)), T::load256(self.intervals.1.add(j))))
    }
}

/// What a row adds to its rejecting lanes' high halves: 0xFFFF0000 in every
/// lane if the row has one rejecting sensor (index 1), else zero (index 0).
#[repr(align(32))]
struct SingleHalves([[u32; 8]; 2]);
static SINGLE: SingleHalves = SingleHalves([[0; 8], [0xFFFF_0000; 8]]);

/// Diagnoses `rows` into `out` (their rejecting-sensor counts) and the
/// counters `both`; tells `read` each row read; whether the rows' values
/// sum to NaN. Not inlined into [`diagnose_rows`], whose blocks of
/// candidates take [`all_candidates`]: with both in one function, the
/// compiler moved the counters between registers on every row, and rows of
/// few candidates ran 0.88-0.93 times as fast as without the blocks of
/// candidates (a call's first block then also tested twice).
///
/// # Safety
/// AVX2 and POPCNT are available; the rows are readable; `out.len() ==
/// rows.n`; `V` as in [`diagnose_rows`].
#[inline(never)]
#[target_feature(enable = "avx2,popcnt")]
unsafe fn diagnose_block<T: Prediction, const V: usize, S: RowsRead>(
    rows: Rows<T>,
    out: &mut [u32],
    both: &mut [__m256i; V],
    read: &mut S,
) -> bool {
    let (k, w) = (rows.k, T::W512 / 2);
    let f64_lanes = std::mem::size_of::<T>() == 8;
    // The last vector's lanes that the one before also holds, as accepting
    // (32-bit lanes: an f64 lane is two).
    let per_lane = 8 / w;
    let repeated: [i32; 8] = std::array::from_fn(|l| -i32::from(l / per_lane < V * w - k));
    let repeated = _mm256_loadu_si256(repeated.as_ptr() as *const __m256i);
    let ones = _mm256_set1_epi32(-1);
    let (mut counters, mut p, mut values) = (*both, rows.p, T::zero256());
    for n_out in out.iter_mut() {
        let mut yes = [_mm256_setzero_si256(); V];
        let mut sum = T::zero256();
        unrolled!(V, |v| {
            let x;
            (x, yes[v]) = rows.test::<V>(p, v);
            sum = if v == 0 { x } else { T::add256(sum, x) };
        });
        yes[V - 1] = _mm256_or_si256(yes[V - 1], repeated);
        values = T::add256(values, sum);
        read.rows_read(p.add(k) as *const u8);
        // Rejecting lanes: zero bytes once the lanes are packed to bytes.
        let mut zeros = 0u32;
        for q in (0..V).step_by(4) {
            let lane = |i: usize| if i < V { yes[i] } else { ones };
            let words = (_mm256_packs_epi32(lane(q), lane(q + 1)), _mm256_packs_epi32(lane(q + 2), lane(q + 3)));
            zeros += (!(_mm256_movemask_epi8(_mm256_packs_epi16(words.0, words.1)) as u32)).count_ones();
        }
        let n = zeros / per_lane as u32;
        // 0xFFFF0000 in every lane if the row has one rejecting sensor, else
        // zero: loaded from a table (a load port) rather than broadcast from
        // a register (two vector operations a row).
        let single = _mm256_load_si256(SINGLE.0[usize::from(n == 1)].as_ptr() as *const __m256i);
        unrolled!(V, |v| {
            let c = if f64_lanes { v / 2 } else { v };
            if !f64_lanes || v % 2 == 1 || v + 1 == V {
                let accepting = if f64_lanes {
                    let odd = if v % 2 == 1 { yes[v] } else { _mm256_setzero_si256() };
                    pair_lanes(yes[v - v % 2], odd)
                } else {
                    yes[v]
                };
                // An accepting lane (all ones) adds one to the lane's low
                // half, a rejecting lane of a single-rejection row one to its
                // high half (0xFFFF0000); the two never meet in a lane.
                counters[c] = _mm256_sub_epi32(counters[c], _mm256_or_si256(accepting, single));
            }
        });
        *n_out = n;
        // The view's bounds are checked when it is made: the next row starts
        // `stride` values on (wrapping past the last row, never read).
        p = p.wrapping_add(rows.stride);
    }
    *both = counters;
    T::nan256(values) != 0
}

/// After a block of candidates (`quiet`), the next block's verdicts come
/// first: if every row of `rows` is a candidate, their counts (zero) go to
/// `out`, `read` is told, and the block needs no diagnostics (true).
///
/// # Safety
/// As [`all_candidates`]; `out.len() == rows.n`.
#[inline(always)]
pub(super) unsafe fn candidates_first<T: Prediction, const V: usize, S: RowsRead>(
    quiet: bool,
    rows: Rows<T>,
    out: &mut [u32],
    read: &mut S,
) -> bool {
    if quiet && all_candidates::<T, V>(rows) {
        read.rows_read(rows.p.wrapping_add(rows.stride * (rows.n - 1)).add(rows.k) as *const u8);
        out.fill(0);
        return true;
    }
    false
}

/// Whether every sensor accepts each of `rows` (the repeated lanes of the
/// last vector repeat a verdict). Not inlined: see [`diagnose_block`].
///
/// # Safety
/// AVX2 is available; the rows are readable; `V` as in [`diagnose_rows`].
#[inline(never)]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn all_candidates<T: Prediction, const V: usize>(rows: Rows<T>) -> bool {
    let ones = _mm256_set1_epi32(-1);
    let (mut all, mut p) = (ones, rows.p);
    for _ in 0..rows.n {
        unrolled!(V, |v| {
            all = _mm256_and_si256(all, rows.test::<V>(p, v).1);
        });
        p = p.wrapping_add(rows.stride);
    }
    _mm256_testc_si256(all, ones) != 0
}

#[cfg(test)]
#[path = "medium_avx2_short_tests.rs"]
mod tests;
