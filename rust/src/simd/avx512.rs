//! AVX-512F: predictions compared in their own type (f64 eight lanes, f32
//! sixteen) with the acceptance intervals, straight into mask registers; the
//! last lanes of a row are loaded masked, so there is no scalar tail.

use super::long;
use super::medium;
use super::checksum::{Fletcher, FletcherRows, RowsRead};
use super::periodic::{Avx512Vectors, NoSums, Periodic, SumVectors};
use super::short::{takes, ShortRows};
use crate::candidates::BitSink;
use crate::kernel::{via_counts, Prediction, ScreenPlan, SensorBounds, Tally};
use crate::matrix::Matrix;

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
                let mut per_sensor = long::PaddedCounts::new(m.cols());
                via_counts(m.rows(), counts, sink, |r0, r1, out| {
                    for s0 in (r0..r1).step_by(long::FLUSH_ROWS) {
                        let s1 = (s0 + long::FLUSH_ROWS).min(r1);
                        let rows = m.slice_rows(s0, s1);
                        // SAFETY: AVX-512F, POPCNT and BMI1 are enabled; the
                        // intervals are padded; at most FLUSH_ROWS rows.
                        unsafe { long::diagnose(rows, b, &mut out[s0 - r0..s1 - r0], (t, sums), &mut per_sensor) };
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
        // SAFETY: AVX-512F is enabled; the intervals are padded.
        via_counts(m.rows(), None, sink, |r0, r1, out| unsafe { long::screen(m.slice_rows(r0, r1), (b, plan), out, sums) })
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
