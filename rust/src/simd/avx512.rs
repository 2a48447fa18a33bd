//! AVX-512F: predictions compared in their own type (f64 eight lanes, f32
//! sixteen) with the acceptance intervals, straight into mask registers; the
//! last lanes of a row are loaded masked, so there is no scalar tail.

use super::medium;
use super::periodic::Periodic;
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

/// Adds one to `counts[j + l]` for every lane `l` set in `out`, reading and
/// writing whole vectors: `counts` is padded past the last sensor. Masked
/// loads and stores here cost f32 rows of 50 sensors two thirds of their
/// speed (AMD EPYC Zen 4: a masked store does not forward to the next row's
/// load of the same counts, so every row waited for it).
///
/// # Safety
/// AVX-512F is available; `counts` holds `j + W512` values.
#[inline(always)]
unsafe fn add_counts<T: Prediction>(counts: &mut [u64], j: usize, out: u32) {
    let ones = _mm512_set1_epi64(1);
    for half in 0..T::W512 / 8 {
        let c = counts.as_mut_ptr().add(j + 8 * half) as *mut __m512i;
        let now = _mm512_loadu_si512(c);
        _mm512_storeu_si512(c, _mm512_mask_add_epi64(now, (out >> (8 * half)) as __mmask8, now, ones));
    }
}

/// Per-sensor counts padded to whole vectors, for [`add_counts`].
struct PaddedCounts(Vec<u64>);

impl PaddedCounts {
    fn new(k: usize) -> Self {
        PaddedCounts(vec![0; k.div_ceil(16) * 16])
    }

    /// Adds the counts into `per_sensor` (one per sensor).
    fn add_to(&self, per_sensor: &mut [u64]) {
        for (t, c) in per_sensor.iter_mut().zip(&self.0) {
            *t += c;
        }
    }
}

/// Rejecting-sensor count, NaN flag and first rejecting sensor of a row (the
/// last sensor when none rejects); adds every rejection to `counts`. Whole
/// vectors first, then one masked tail.
#[inline]
#[target_feature(enable = "avx512f,popcnt,bmi1")]
fn diagnose_row<T: Prediction>(row: &[T], b: &SensorBounds, counts: &mut [u64]) -> (u32, bool, usize) {
    let (k, accept, w) = (row.len(), T::accepted(b), T::W512);
    assert!(accept[0].len() >= k.div_ceil(BLOCK) * BLOCK && counts.len() >= k.div_ceil(w) * w);
    super::prefetch_ahead(row);
    // `first` is the lowest rejecting position, or past the row: branch-free,
    // since which sensor rejects varies at random from row to row.
    let (mut n, mut nan, mut first) = (0u32, 0u32, usize::MAX);
    let whole = k - k % w;
    let mut tally = |j: usize, lanes: u32| {
        // SAFETY: AVX-512F is enabled; the lanes of `lanes` lie below `k`,
        // within `row` and `counts`, and the acceptance vectors are padded.
        let (out, nans) = unsafe { group(row, accept, j, lanes) };
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
    if whole < k {
        tally(whole, prefix(k - whole));
    }
    (n, nan != 0, first.min(k.saturating_sub(1)))
}

/// True if any sensor rejects the row, visiting the plan's blocks in order
/// with one branch per block (short rows: all blocks, no branch).
#[inline]
#[target_feature(enable = "avx512f")]
fn row_rejected<T: Prediction>(row: &[T], b: &SensorBounds, plan: &ScreenPlan) -> bool {
    let (k, accept, w) = (row.len(), T::accepted(b), T::W512);
    assert!(accept[0].len() >= k.div_ceil(BLOCK) * BLOCK);
    super::prefetch_ahead(row);
    let tail = k - k % BLOCK;
    // Rejecting lanes of the block starting at sensor `s`.
    let block = |s: usize| {
        let mut rejects = 0;
        // A fixed number of vectors per block; in the last, partial block the
        // lanes past the row's end are masked off (possibly all of a vector).
        for g in 0..BLOCK / w {
            let j = s + g * w;
            let lanes = if s < tail {
                prefix(w)
            } else {
                prefix(k.saturating_sub(j).min(w))
            };
            // SAFETY: AVX-512F is enabled; the lanes read lie below `k` and the
            // acceptance vectors are padded to whole blocks.
            rejects |= unsafe { group(row, accept, j, lanes) }.0;
        }
        rejects
    };
    if plan.exits_early() {
        plan.blocks().iter().any(|&s| block(s) != 0)
    } else {
        plan.blocks().iter().fold(0, |any, &s| any | block(s)) != 0
    }
}

/// The rows of `m` that the periodic kernel takes (whole periods of rows
/// stored back to back), their values and the kernel; the rest of `m` after them.
#[inline]
#[target_feature(enable = "avx512f")]
fn periodic<'a, T: Prediction>(m: Matrix<'a, T>, b: &SensorBounds) -> Option<(Periodic<T>, &'a [T], usize)> {
    let data = m.packed_rows()?;
    Periodic::<T>::period(m.cols()).filter(|_| ShortRows::<T>::fits(m.cols()))?; // the tail's kernel
    if !std::arch::is_x86_feature_detected!("bmi2") {
        return None;
    }
    // SAFETY: AVX-512F is enabled; `period` accepted the width.
    let kernel = unsafe { Periodic::<T>::new(b) };
    let whole = m.rows() - m.rows() % kernel.rows();
    Some((kernel, data, whole))
}

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
    if let Some((kernel, data, whole)) = periodic(m, b) {
        let periods = whole / kernel.rows();
        let rest = m.slice_rows(whole, m.rows());
        // SAFETY: AVX-512F, POPCNT and BMI2 (checked by `periodic`) are
        // enabled; `data` holds the rows back to back.
        let tail = match counts {
            Some(c) => {
                let (head, tail) = c.split_at_mut(whole);
                unsafe { kernel.diagnose::<true>(data, periods, head, sink, t) };
                Some(tail)
            }
            None => {
                unsafe { kernel.diagnose::<false>(data, periods, &mut [], sink, t) };
                None
            }
        };
        if rest.rows() > 0 {
            // SAFETY: as below (the rest is packed rows too).
            unsafe { ShortRows::<T>::new(b, true).diagnose(rest, tail, sink, t) };
        }
    } else if takes(&m) {
        // SAFETY: AVX-512F and POPCNT are enabled; `takes` checked the row
        // width and that rows are contiguous; packed only if back to back.
        unsafe { ShortRows::<T>::new(b, m.packed_rows().is_some()).diagnose(m, counts, sink, t) };
    } else {
        let contiguous = m.rows() == 0 || m.row_slice(0).is_some();
        match medium::vectors::<T>(m.cols()).filter(|_| contiguous) {
            // SAFETY (each arm): AVX-512F and POPCNT are enabled, `vectors`
            // gave the arm's count, rows are contiguous, intervals padded.
            Some(v) => via_counts(m.rows(), counts, sink, |r0, r1, out| {
                let rows = m.slice_rows(r0, r1);
                match v {
                    3 => unsafe { medium::diagnose::<T, 3>(rows, b, out, t) },
                    4 => unsafe { medium::diagnose::<T, 4>(rows, b, out, t) },
                    5 => unsafe { medium::diagnose::<T, 5>(rows, b, out, t) },
                    6 => unsafe { medium::diagnose::<T, 6>(rows, b, out, t) },
                    7 => unsafe { medium::diagnose::<T, 7>(rows, b, out, t) },
                    _ => unsafe { medium::diagnose::<T, 8>(rows, b, out, t) },
                }
            }),
            None => {
                let mut per_sensor = PaddedCounts::new(m.cols());
                via_counts(m.rows(), counts, sink, |r0, r1, out| {
                    diagnose_impl(m.slice_rows(r0, r1), b, out, t, |row, b, _| {
                        diagnose_row(row, b, &mut per_sensor.0)
                    })
                });
                per_sensor.add_to(&mut t.per_sensor);
            }
        }
    }
}

/// Candidate bits of the rows of `m` into `sink`.
#[target_feature(enable = "avx512f,popcnt")]
pub fn screen_bits<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, plan: &ScreenPlan, sink: &mut BitSink) {
    if let Some((kernel, data, whole)) = periodic(m, b) {
        // SAFETY: AVX-512F, POPCNT and BMI2 (checked by `periodic`) are
        // enabled; `data` holds the rows back to back.
        unsafe { kernel.screen(data, whole / kernel.rows(), sink) };
        let rest = m.slice_rows(whole, m.rows());
        if rest.rows() > 0 {
            // SAFETY: as below (the rest is packed rows too).
            unsafe { ShortRows::<T>::new(b, true).screen(rest, sink) };
        }
    } else if takes(&m) {
        // SAFETY: as in `diagnose_bits`.
        unsafe { ShortRows::<T>::new(b, m.packed_rows().is_some()).screen(m, sink) };
    } else {
        via_counts(m.rows(), None, sink, |r0, r1, out| {
            screen_impl(m.slice_rows(r0, r1), b, plan, out, |row| row_rejected(row, b, plan))
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
