//! AVX-512F: predictions compared in their own type (f64 eight lanes, f32
//! sixteen) with the acceptance intervals, straight into mask registers; the
//! last lanes of a row are loaded masked, so there is no scalar tail.

use super::prefetch::Prefetch;
use super::medium;
use super::checksum::{Fletcher, FletcherRows, RowsRead};
use super::periodic::{Avx512Vectors, NoSums, Periodic, SumVectors};
use super::short::{takes, ShortRows};
use crate::candidates::BitSink;
use crate::kernel::{diagnose_impl, screen_impl, via_counts, Prediction, ScreenPlan, SensorBounds, Tally, BLOCK};
use crate::matrix::Matrix;
use std::arch::x86_64::*;

/// Mask of the first `n` lanes (n <= 16).
#[inline(always)]
fn prefix(n: usize) -> u32 {
    (1u32 << n) - 1
}

/// Rejecting lanes and NaN lanes among `lanes` of the vector of sensors
/// `j..j + W512` of `row`.
///
/// # Safety
/// AVX-512F is available, the lanes set in `lanes` are within `row` from `j`,
/// and the acceptance vectors hold `W512` values from `j` (they are padded to
/// whole blocks, and `j` is a multiple of `W512`).
#[inline(always)]
unsafe fn group<T: Prediction>(row: &[T], accept: &[Vec<T>; 2], j: usize, lanes: u32) -> (u32, u32) {
    let all = u32::MAX >> (32 - T::W512);
    let p = T::load512(lanes, row.as_ptr().wrapping_add(j));
    let low = T::load512(all, accept[0].as_ptr().add(j));
    let high = T::load512(all, accept[1].as_ptr().add(j));
    (!T::inside512(lanes, p, low, high) & lanes, T::nan512(lanes, p))
}

/// Adds one to sensor `j + l`'s count for every lane `l` set in `out`,
/// reading and writing one whole vector: the counts are padded past the last
/// sensor, u32 lanes for f32 and u64 for f64, one vector of counts per vector
/// of predictions. Masked loads and stores here cost f32 rows of 50 sensors
/// two thirds of their speed (AMD EPYC Zen 4: a masked store does not forward
/// to the next row's load of the same counts, so every row waited for it).
///
/// # Safety
/// AVX-512F is available; `counts` holds `j + W512` counts ([`PaddedCounts`]).
#[inline(always)]
unsafe fn add_counts<T: Prediction>(counts: &mut PaddedCounts, j: usize, out: u32) {
    if T::W512 == 16 {
        let c = (counts.0.as_mut_ptr() as *mut u32).add(j) as *mut __m512i;
        let now = _mm512_loadu_si512(c);
        _mm512_storeu_si512(c, _mm512_mask_add_epi32(now, out as __mmask16, now, _mm512_set1_epi32(1)));
    } else {
        let c = counts.0.as_mut_ptr().add(j) as *mut __m512i;
        let now = _mm512_loadu_si512(c);
        _mm512_storeu_si512(c, _mm512_mask_add_epi64(now, out as __mmask8, now, _mm512_set1_epi64(1)));
    }
}

/// Per-sensor counts padded to whole vectors, for [`add_counts`]: u32 lanes
/// for f32 rows (in the same buffer), u64 for f64. Flushed into the tally at
/// least every [`FLUSH_ROWS`] rows, so the u32 lanes cannot overflow.
struct PaddedCounts(Vec<u64>);

/// Rows between two flushes of [`PaddedCounts`].
const FLUSH_ROWS: usize = 1 << 16;

impl PaddedCounts {
    fn new(k: usize) -> Self {
        PaddedCounts(vec![0; k.div_ceil(16) * 16])
    }

    /// Adds the counts into `per_sensor` (one per sensor) and zeroes them.
    fn flush<T: Prediction>(&mut self, per_sensor: &mut [u64]) {
        if T::W512 == 16 {
            // SAFETY: the buffer holds twice as many u32 as u64, all initialised.
            let narrow = unsafe { std::slice::from_raw_parts(self.0.as_ptr() as *const u32, 2 * self.0.len()) };
            for (t, &c) in per_sensor.iter_mut().zip(narrow) {
                *t += u64::from(c);
            }
        } else {
            for (t, &c) in per_sensor.iter_mut().zip(&self.0) {
                *t += c;
            }
        }
        self.0.fill(0);
    }
}

/// Rejecting-sensor count, NaN flag and first rejecting sensor of a row (the
/// last sensor when none rejects); adds every rejection to `counts`.
///
/// After candidate rows (`after_candidate`; the caller asks for it after
/// two in a row), the verdict comes first, one comparison pair a vector and
/// nothing else (a NaN is outside every interval, so a candidate row holds
/// none), and only a rejected row is attributed, in a second visit of its
/// vectors, now in L1. Otherwise the row is attributed in one visit, as
/// before. Runs of candidates (every instance kept) thus cost about what
/// screening does: f32 rows of 200 sensors, one thread, from cache, 13.9-14.0
/// -> 23.6-29.7 M rows/s, most falsified unchanged (`cargo bench -- long_rows`,
/// AMD EPYC Zen 4, `benches/results-long-rows.txt`). The branch follows the
/// data's runs; the outcome does not depend on it. The attribution has no
/// branch on each vector's outcome, which is random from row to row.
#[inline]
#[target_feature(enable = "avx512f,popcnt,bmi1")]
fn diagnose_row<T: Prediction>(
    row: &[T],
    b: &SensorBounds,
    counts: &mut PaddedCounts,
    after_candidate: bool,
) -> (u32, bool, usize) {
    let (k, accept, w) = (row.len(), T::accepted(b), T::W512);
    assert!(accept[0].len() >= k.div_ceil(BLOCK) * BLOCK && counts.0.len() >= k.div_ceil(w) * w);
    // Whole vectors, then one masked tail.
    let (whole, tail) = (k - k % w, prefix(k % w));
    // SAFETY: AVX-512F is enabled; the intervals are padded (asserted).
    if after_candidate && unsafe { any_rejecting(row, accept) } == 0 {
        return (0, false, k.saturating_sub(1));
    }
    let (mut n, mut nan, mut first) = (0u32, 0u32, usize::MAX);
    let pf = Prefetch::FIXED; // see `Prefetch::now` for which kernels choose
    let mut tally = |j: usize, lanes: u32| {
        // The first visit of the row asks for the lines ahead, spread as in `any_rejecting`.
        if !after_candidate {
            pf.line(row.as_ptr().wrapping_add(j));
        }
        // SAFETY: AVX-512F is enabled; the lanes lie below `k`, within `row`,
        // and the acceptance vectors are padded.
        let (out, nans) = unsafe { group(row, accept, j, lanes) };
        // SAFETY: AVX-512F is enabled; `counts` is padded to whole vectors.
        unsafe { add_counts::<T>(counts, j, out) };
        n += out.count_ones();
        // Past the row when this vector has none (not j + 32: a later
        // vector's rejection would then be attributed to the wrong sensor).
        let none = ((out == 0) as usize).wrapping_neg(); // all ones if none rejects
        first = first.min((j + out.trailing_zeros() as usize) | none);
        nan |= nans;
    };
    for j in (0..whole).step_by(w) {
        tally(j, prefix(w));
    }
    if tail != 0 {
        tally(whole, tail);
    }
    (n, nan != 0, first.min(k.saturating_sub(1)))
}

/// Rejecting lanes of every vector of `row`, or'ed: nonzero iff some sensor
/// rejects the row (a NaN is outside every interval). Every vector, in
/// column order, without a branch, each asking first for the line
/// the prefetch distance past it (`super::prefetch`).
///
/// Why not stop at the first rejecting block, most rejecting first, and
/// prefetch the whole row at its start, as this did: from memory, rows read
/// whole and in order with the prefetches spread ran faster. The recorded
/// runs do not take the parts apart; the likely causes are that the plan's
/// order reads a row's lines out of sequence, that each exit mispredicts, and
/// that a burst of one prefetch per line (25 for f64 rows of 200) stalls the
/// loads behind it. Side by side through `falsify` (AMD EPYC Zen 4, 2 threads,
/// `benches/results-short-rows.txt`, section "session 14: side by side"),
/// with the slabs sized for the pool as well (`falsifier.rs`), rows of 100
/// and 200 sensors went from 0.58-0.90 of the read floor to 0.78-1.15. The price is paid from cache, where stopping early saved work:
/// the kernel alone screening f64 rows of 200 with 91 % rejected went from
/// 58-60 to 41 M rows/s, with every row a candidate from 28-31 to 41-44
/// (`cargo bench -- long_rows`, `benches/results-long-rows.txt`, "session 14").
///
/// # Safety
/// AVX-512F is available; the acceptance vectors are padded to whole blocks.
#[inline(always)]
unsafe fn any_rejecting<T: Prediction>(row: &[T], accept: &[Vec<T>; 2]) -> u32 {
    let (k, w) = (row.len(), T::W512);
    let whole = k - k % w;
    let (mut any, pf) = (0, Prefetch::FIXED);
    for j in (0..whole).step_by(w) {
        pf.line(row.as_ptr().wrapping_add(j));
        any |= group(row, accept, j, prefix(w)).0;
    }
    if whole < k {
        pf.line(row.as_ptr().wrapping_add(whole));
        any |= group(row, accept, whole, prefix(k - whole)).0;
    }
    any
}

/// True if any sensor rejects the row (see [`any_rejecting`]).
#[inline]
#[target_feature(enable = "avx512f")]
fn row_rejected<T: Prediction>(row: &[T], b: &SensorBounds) -> bool {
    let accept = T::accepted(b);
    assert!(accept[0].len() >= row.len().div_ceil(BLOCK) * BLOCK);
    // SAFETY: AVX-512F is enabled; the intervals are padded (asserted).
    unsafe { any_rejecting(row, accept) != 0 }
}

/// Whether the periodic kernel takes rows `m`: rows stored back to back
/// whose width has a period (and the tail's kernel takes), on a CPU with
/// BMI2 (the rows' verdicts) and AVX-512BW (the diagnostics' byte counts).
pub fn periodic_takes<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds) -> bool {
    m.packed_rows().is_some()
        && T::period(b).is_some()
        && ShortRows::<T>::fits(m.cols())
        && std::arch::is_x86_feature_detected!("bmi2")
        && std::arch::is_x86_feature_detected!("avx512bw")
}

/// The rows of `m` that the periodic kernel takes (whole periods of rows
/// stored back to back), their values and the kernel; the rest of `m` after them.
#[inline]
#[target_feature(enable = "avx512f")]
fn periodic<'a, T: Prediction>(
    m: Matrix<'a, T>,
    b: &SensorBounds,
) -> Option<(Periodic<T, Avx512Vectors>, &'a [T], usize)> {
    let data = m.packed_rows().filter(|_| periodic_takes(m, b))?;
    // SAFETY: AVX-512F is enabled; `period` accepted the width.
    let kernel = unsafe { Periodic::<T, Avx512Vectors>::new(b) };
    let whole = m.rows() - m.rows() % kernel.rows();
    Some((kernel, data, whole))
}

/// Rows of one pass of a kernel: the kernels count per lane in u32 lanes,
/// so a call over more rows (possible through the Rust API, never through
/// `Falsifier`, whose blocks have 1024) is taken in pieces of this many.
const MAX_PASS_ROWS: usize = 1 << 31;

/// Candidate bits of the rows of `m` into `sink`, their rejecting-sensor
/// counts into `counts` if given, their diagnostics into `t`.
#[target_feature(enable = "avx512f,popcnt,bmi1")]
pub fn diagnose_bits<T: Prediction>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    counts: Option<&mut [u32]>,
    sink: &mut BitSink,
    t: &mut Tally,
) {
    diagnose_bits_in_passes(m, b, counts, sink, t, MAX_PASS_ROWS)
}

/// [`diagnose_bits`] in passes of at most `pass_rows` rows (a parameter so
/// that a test can split small calls).
#[target_feature(enable = "avx512f,popcnt,bmi1")]
pub(crate) fn diagnose_bits_in_passes<T: Prediction>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    mut counts: Option<&mut [u32]>,
    sink: &mut BitSink,
    t: &mut Tally,
    pass_rows: usize,
) {
    assert!((1..=MAX_PASS_ROWS).contains(&pass_rows));
    for r0 in (0..m.rows().max(1)).step_by(pass_rows) {
        let r1 = (r0 + pass_rows).min(m.rows());
        let part = counts.as_deref_mut().map(|c| &mut c[r0..r1]);
        diagnose_bits_pass(m.slice_rows(r0, r1), b, part, sink, (t, &mut NoSums));
    }
}

/// [`diagnose_bits`] over at most `MAX_PASS_ROWS` rows, telling `sums` each
/// row the row-at-a-time kernels have read.
#[target_feature(enable = "avx512f,popcnt,bmi1")]
fn diagnose_bits_pass<T: Prediction, S: RowsRead>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    counts: Option<&mut [u32]>,
    sink: &mut BitSink,
    (t, sums): (&mut Tally, &mut S),
) {
    if let Some(p) = periodic(m, b) {
        diagnose_periodic(p, (m, b), counts, sink, (t, &mut NoSums));
    } else if takes(&m) {
        // SAFETY: AVX-512F and POPCNT are enabled; `takes` checked the row
        // width and that rows are contiguous; packed only if back to back.
        unsafe { ShortRows::<T>::new(b, m.packed_rows().is_some()).diagnose(m, counts, sink, (t, sums)) };
    } else {
        let contiguous = m.rows() == 0 || m.row_slice(0).is_some();
        match medium::vectors::<T>(m.cols()).filter(|_| contiguous) {
            // SAFETY (each arm): AVX-512F and POPCNT are enabled, `vectors`
            // gave the arm's count, rows are contiguous, intervals padded.
            Some(v) => via_counts(m.rows(), counts, sink, |r0, r1, out| {
                let rows = m.slice_rows(r0, r1);
                match v {
                    3 => unsafe { medium::diagnose::<T, 3, S>(rows, b, out, (t, sums)) },
                    4 => unsafe { medium::diagnose::<T, 4, S>(rows, b, out, (t, sums)) },
                    5 => unsafe { medium::diagnose::<T, 5, S>(rows, b, out, (t, sums)) },
                    6 => unsafe { medium::diagnose::<T, 6, S>(rows, b, out, (t, sums)) },
                    7 => unsafe { medium::diagnose::<T, 7, S>(rows, b, out, (t, sums)) },
                    _ => unsafe { medium::diagnose::<T, 8, S>(rows, b, out, (t, sums)) },
                }
            }),
            None => {
                let mut per_sensor = PaddedCounts::new(m.cols());
                via_counts(m.rows(), counts, sink, |r0, r1, out| {
                    for s0 in (r0..r1).step_by(FLUSH_ROWS) {
                        let s1 = (s0 + FLUSH_ROWS).min(r1);
                        let part = &mut out[s0 - r0..s1 - r0];
                        // Candidates in a row so far: the verdict comes first after two
                        // (after one, most falsified rows with candidates scattered
                        // among them paid for a test they did not need).
                        let (mut run, mut read) = (0u32, *sums);
                        diagnose_impl(m.slice_rows(s0, s1), b, part, t, |row, b, _| {
                            let verdict = diagnose_row(row, b, &mut per_sensor, run >= 2);
                            run = if verdict.0 == 0 { run.saturating_add(1) } else { 0 };
                            // SAFETY: AVX-512F is enabled.
                            unsafe { read.rows_read(row.as_ptr_range().end as *const u8) };
                            verdict
                        });
                        *sums = read;
                        per_sensor.flush::<T>(&mut t.per_sensor);
                    }
                });
            }
        }
    }
}

/// [`diagnose_bits`] over fewer than `MAX_PASS_ROWS` rows that also adds
/// rows to `sums` (empty) as it reads them (see `summing::part_after`): the
/// periodic kernel's whole vectors, or the groups that the rows of a
/// row-at-a-time kernel fill ([`FletcherRows`]); rows `0..n` for the `n`
/// returned (0 for rows not stored back to back).
#[target_feature(enable = "avx512f,popcnt,bmi1")]
pub fn diagnose_bits_summed<T: Prediction>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    counts: Option<&mut [u32]>,
    sink: &mut BitSink,
    (t, sums): (&mut Tally, &mut Fletcher),
) -> usize {
    assert!(m.rows() < MAX_PASS_ROWS);
    if let Some(p) = periodic(m, b) {
        return diagnose_periodic(p, (m, b), counts, sink, (t, sums));
    }
    match rows_summed(m, b) {
        Some((mut read, n)) => {
            diagnose_bits_pass(m, b, counts, sink, (t, &mut read));
            *sums = read.sums();
            n
        }
        None => {
            diagnose_bits_pass(m, b, counts, sink, (t, &mut NoSums));
            0
        }
    }
}

/// Whether the summed kernels sum rows `m` as they read them: rows stored
/// back to back (the periodic kernel's, and those the other kernels read).
pub fn kernel_sums<T: Prediction>(m: Matrix<'_, T>) -> bool {
    m.packed_rows().is_some()
}

/// The row-at-a-time kernels' sums of rows `m` and the rows they will sum,
/// where they sum them (packed rows the periodic kernel does not take).
#[inline]
#[target_feature(enable = "avx512f")]
fn rows_summed<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds) -> Option<(FletcherRows<Fletcher>, usize)> {
    let data = m.packed_rows().filter(|_| !periodic_takes(m, b))?;
    // SAFETY: AVX-512F is enabled.
    let sums = unsafe { Fletcher::new() };
    Some(FletcherRows::new(sums, data.as_ptr() as *const u8, m.rows(), std::mem::size_of_val(m.row_slice(0)?)))
}

/// The periodic kernel's whole periods of `m`, the rest by the short-row
/// kernel, each vector read to `sums`; the rows in whole periods.
#[inline]
#[target_feature(enable = "avx512f,popcnt,bmi1")]
fn diagnose_periodic<T: Prediction, S: SumVectors<T, Avx512Vectors>>(
    (kernel, data, whole): (Periodic<T, Avx512Vectors>, &[T], usize),
    (m, b): (Matrix<'_, T>, &SensorBounds),
    counts: Option<&mut [u32]>,
    sink: &mut BitSink,
    (t, sums): (&mut Tally, &mut S),
) -> usize {
    let rest = m.slice_rows(whole, m.rows());
    let (head, tail) = counts.map(|c| c.split_at_mut(whole)).unzip();
    let periods = whole / kernel.rows();
    // SAFETY: AVX-512F, AVX-512BW, POPCNT and BMI2 (checked by `periodic`) are
    // enabled; `data` holds the rows back to back.
    match head {
        Some(h) => unsafe { kernel.diagnose::<true, S>(data, periods, h, sink, (t, sums)) },
        None => unsafe { kernel.diagnose::<false, S>(data, periods, &mut [], sink, (t, sums)) },
    }
    if rest.rows() > 0 {
        // SAFETY: AVX-512F and POPCNT are enabled; the rest is packed rows too.
        unsafe { ShortRows::<T>::new(b, true).diagnose(rest, tail, sink, (t, &mut NoSums)) };
    }
    whole
}

/// [`screen_bits`] that also adds rows to `sums`, as [`diagnose_bits_summed`].
#[target_feature(enable = "avx512f,popcnt")]
pub fn screen_bits_summed<T: Prediction>(
    m: Matrix<'_, T>,
    (b, plan): (&SensorBounds, &ScreenPlan),
    sink: &mut BitSink,
    sums: &mut Fletcher,
) -> usize {
    if let Some(p) = periodic(m, b) {
        return screen_periodic(p, (m, b), sink, sums);
    }
    match rows_summed(m, b) {
        Some((mut read, n)) => {
            screen_rows(m, (b, plan), sink, &mut read);
            *sums = read.sums();
            n
        }
        None => {
            screen_rows(m, (b, plan), sink, &mut NoSums);
            0
        }
    }
}

/// As [`diagnose_periodic`], screening.
#[inline]
#[target_feature(enable = "avx512f,popcnt")]
fn screen_periodic<T: Prediction, S: SumVectors<T, Avx512Vectors>>(
    (kernel, data, whole): (Periodic<T, Avx512Vectors>, &[T], usize),
    (m, b): (Matrix<'_, T>, &SensorBounds),
    sink: &mut BitSink,
    sums: &mut S,
) -> usize {
    // SAFETY: AVX-512F, AVX-512BW, POPCNT and BMI2 (checked by `periodic`) are
    // enabled; `data` holds the rows back to back.
    unsafe { kernel.screen(data, whole / kernel.rows(), sink, sums) };
    let rest = m.slice_rows(whole, m.rows());
    if rest.rows() > 0 {
        // SAFETY: AVX-512F and POPCNT are enabled; the rest is packed rows too.
        unsafe { ShortRows::<T>::new(b, true).screen(rest, sink, &mut NoSums) };
    }
    whole
}

/// Candidate bits of the rows of `m` into `sink`.
#[target_feature(enable = "avx512f,popcnt")]
pub fn screen_bits<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, plan: &ScreenPlan, sink: &mut BitSink) {
    if let Some(p) = periodic(m, b) {
        screen_periodic(p, (m, b), sink, &mut NoSums);
    } else {
        screen_rows(m, (b, plan), sink, &mut NoSums);
    }
}

/// [`screen_bits`] of rows the periodic kernel does not take, telling `sums`
/// each row the row-at-a-time kernel has read.
#[inline]
#[target_feature(enable = "avx512f,popcnt")]
fn screen_rows<T: Prediction, S: RowsRead>(
    m: Matrix<'_, T>,
    (b, plan): (&SensorBounds, &ScreenPlan),
    sink: &mut BitSink,
    sums: &mut S,
) {
    if takes(&m) {
        // SAFETY: as in `diagnose_bits`.
        unsafe { ShortRows::<T>::new(b, m.packed_rows().is_some()).screen(m, sink, sums) };
    } else {
        via_counts(m.rows(), None, sink, |r0, r1, out| {
            let mut read = *sums;
            screen_impl(m.slice_rows(r0, r1), b, plan, out, |row| {
                let rejected = row_rejected(row, b);
                // SAFETY: AVX-512F is enabled.
                unsafe { read.rows_read(row.as_ptr_range().end as *const u8) };
                rejected
            });
            *sums = read;
        })
    }
}

/// [`diagnose_bits`] with every row's count in `out` (the bits thrown away).
#[target_feature(enable = "avx512f,popcnt,bmi1")]
pub fn diagnose<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, out: &mut [u32], t: &mut Tally) {
    let mut words = vec![0u64; out.len().div_ceil(64)];
    let mut sink = BitSink::new(&mut words, 0);
    diagnose_bits(m, b, Some(out), &mut sink, t);
    sink.finish();
}

/// [`screen_bits`] as one verdict per row in `out` (1 falsified, 0 candidate).
#[target_feature(enable = "avx512f,popcnt")]
pub fn screen<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, plan: &ScreenPlan, out: &mut [u32]) {
    let mut words = vec![0u64; out.len().div_ceil(64)];
    let mut sink = BitSink::new(&mut words, 0);
    screen_bits(m, b, plan, &mut sink);
    sink.finish();
    for (i, v) in out.iter_mut().enumerate() {
        *v = ((words[i / 64] >> (i % 64)) & 1 == 0) as u32;
    }
}
