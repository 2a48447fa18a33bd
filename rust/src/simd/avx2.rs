//! AVX2: rows of more than eight sensors are tested by `long_avx2`, in the
//! predictions' own type, except that rows of 9-96 f64 or 9-200 f32 sensors
//! stored one after another are diagnosed by `medium_avx2` (the same work for every
//! row; rows of up to 32 f32 or 12 f64 sensors by `medium_avx2_short`), and
//! rows of 9-16 f32 or 9-12 f64 are screened by `medium_avx2_screen`; rows
//! of up to eight by `short_avx2`, widened to f64. Rows stored back to back whose pattern repeats within
//! eight vectors of 8 f64 or 16 f32 (rows of 5 and 10 among them), and rows of whole
//! vectors, two or more to a period (f64 rows of 8, 16, 24 and 32 sensors,
//! f32 of 16, 32 and 48: `Period::whole_rows`), take the periodic kernel instead
//! (`periodic_avx2`) when the bits are asked for, as `falsify` does.

use super::checksum::{Fletcher2, FletcherRows, RowsRead};
use super::long_avx2;
use super::medium_avx2;
use super::medium_avx2_screen;
use super::periodic::{NoSums, Periodic, SumVectors};
use super::periodic_avx2::{fast_pext, Avx2Vectors};
use super::short_avx2::{takes, ShortRows4};
use crate::candidates::BitSink;
use crate::kernel::{screen_impl, via_counts, Prediction, ScreenPlan, SensorBounds, Tally, BLOCK};
use crate::matrix::Matrix;

/// True if any sensor rejects the row: every vector, in column order,
/// without a branch, one prefetch per line spread over the row, as the
/// AVX-512 kernel does (see `avx512::any_rejecting` for why). Side by side
/// through `falsify` with `EDMF_RS_ISA=avx2` (AMD EPYC Zen 4,
/// `benches/results-short-rows.txt`, section "session 14: side by side,
/// AVX2"), screening f64 rows of 200 sensors went from 0.76-0.79 to
/// 1.01-1.05 of the read floor and f32 rows of 50, most falsified, from
/// 0.68-0.73 to 0.85-0.89. Since session 16 the loop is
/// `long_avx2::any_rejecting`: the same order, a prefetch per 64 bytes, f32
/// in f32 (it had been widened to f64).
#[inline]
#[target_feature(enable = "avx2")]
fn row_rejected<T: Prediction>(row: &[T], b: &SensorBounds) -> bool {
    let accept = T::accepted(b);
    assert!(accept[0].len() >= row.len().div_ceil(BLOCK) * BLOCK);
    // SAFETY: AVX2 is enabled; the intervals are padded (asserted).
    unsafe { long_avx2::any_rejecting(row, accept) }
}

#[target_feature(enable = "avx2,popcnt")]
pub fn diagnose<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, out: &mut [u32], t: &mut Tally) {
    diagnose_rows(m, b, out, (t, &mut NoSums))
}

/// [`diagnose`], telling `sums` each row the long-row kernel has read.
#[inline]
#[target_feature(enable = "avx2,popcnt")]
fn diagnose_rows<T: Prediction, S: RowsRead>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    out: &mut [u32],
    (t, sums): (&mut Tally, &mut S),
) {
    if takes(&m) {
        // SAFETY: AVX2 and POPCNT are enabled; `takes` checked the row width
        // and that rows are contiguous.
        unsafe { ShortRows4::new(b).diagnose(m, out, t) };
    } else if medium_avx2::vectors::<T>(m.cols()).is_some() && (m.rows() == 0 || m.row_slice(0).is_some()) {
        // SAFETY: AVX2 and POPCNT are enabled; the kernel takes the width; rows are contiguous.
        unsafe { medium_avx2::diagnose(m, b, out, (t, sums)) }
    } else {
        // SAFETY: AVX2 and POPCNT are enabled.
        unsafe { long_avx2::diagnose(m, b, out, (t, sums)) }
    }
}

#[target_feature(enable = "avx2,popcnt")]
pub fn screen<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, plan: &ScreenPlan, out: &mut [u32]) {
    screen_rows(m, b, plan, out, &mut NoSums)
}

/// [`screen`], telling `sums` each row the long-row kernel has read.
#[inline]
#[target_feature(enable = "avx2,popcnt")]
fn screen_rows<T: Prediction, S: RowsRead>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    plan: &ScreenPlan,
    out: &mut [u32],
    sums: &mut S,
) {
    if takes(&m) {
        // SAFETY: as in `diagnose`.
        unsafe { ShortRows4::new(b).screen(m, out) };
    } else if medium_avx2_screen::takes::<T>(m.cols()) && (m.rows() == 0 || m.row_slice(0).is_some()) {
        // SAFETY: AVX2 is enabled; the kernel takes the width; rows are contiguous.
        unsafe { medium_avx2_screen::screen(m, b, out, sums) }
    } else {
        let mut read = *sums;
        screen_impl(m, b, plan, out, |row| {
            let rejected = row_rejected(row, b);
            // SAFETY: AVX2 is enabled.
            unsafe { read.rows_read(row.as_ptr_range().end as *const u8) };
            rejected
        });
        *sums = read;
    }
}

/// The rows of `m` that the periodic kernel takes (whole periods of rows
/// stored back to back), their values and the kernel; the rest of `m` after
/// them. None where `pext` is slow (see [`fast_pext`]). For `screening`,
/// the period without repeats (`Period::unrepeated`).
#[inline]
#[target_feature(enable = "avx2")]
fn periodic<'a, T: Prediction>(
    m: Matrix<'a, T>,
    b: &SensorBounds,
    screening: bool,
) -> Option<(Periodic<T, Avx2Vectors>, &'a [T], usize)> {
    let data = m.packed_rows().filter(|_| periodic_takes(m, b))?;
    // SAFETY: AVX2 is enabled; a period takes the width.
    let kernel = unsafe {
        if screening {
            Periodic::<T, Avx2Vectors>::unrepeated(b)
        } else {
            Periodic::<T, Avx2Vectors>::new(b)
        }
    };
    let whole = m.rows() - m.rows() % kernel.rows();
    Some((kernel, data, whole))
}

/// Candidate bits of the rows of `m` into `sink`, their rejecting-sensor
/// counts into `counts` if given, their diagnostics into `t`.
#[target_feature(enable = "avx2,popcnt")]
pub fn diagnose_bits<T: Prediction>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    counts: Option<&mut [u32]>,
    sink: &mut BitSink,
    t: &mut Tally,
) {
    diagnose_bits_adding(m, b, counts, sink, (t, &mut NoSums, &mut NoSums));
}

/// [`diagnose_bits`] that also adds rows to `sums` (empty) as it reads them
/// (see `summing::part_after`): the periodic kernel's whole vectors, or the
/// groups that the rows of the long-row kernel fill ([`FletcherRows`]);
/// rows `0..n` for the `n` returned (0 where neither kernel reads the rows,
/// or they are not stored back to back).
#[target_feature(enable = "avx2,popcnt")]
pub fn diagnose_bits_summed<T: Prediction>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    counts: Option<&mut [u32]>,
    sink: &mut BitSink,
    (t, sums): (&mut Tally, &mut Fletcher2),
) -> usize {
    match rows_summed(m, b) {
        Some((mut read, n)) => {
            diagnose_bits_adding(m, b, counts, sink, (t, &mut NoSums, &mut read));
            *sums = read.sums();
            n
        }
        None => diagnose_bits_adding(m, b, counts, sink, (t, sums, &mut NoSums)),
    }
}

/// [`diagnose_bits`], the periodic kernel's vectors to `vectors` and the
/// long-row kernel's rows to `rows`; the rows in whole periods.
#[inline]
#[target_feature(enable = "avx2,popcnt")]
fn diagnose_bits_adding<T: Prediction, V: SumVectors<T, Avx2Vectors>, R: RowsRead>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    counts: Option<&mut [u32]>,
    sink: &mut BitSink,
    (t, vectors, rows): (&mut Tally, &mut V, &mut R),
) -> usize {
    let Some((kernel, data, whole)) = periodic(m, b, false) else {
        via_counts(m.rows(), counts, sink, |r0, r1, out| {
            diagnose_rows(m.slice_rows(r0, r1), b, out, (&mut *t, &mut *rows))
        });
        return 0;
    };
    let (head, tail) = counts.map(|c| c.split_at_mut(whole)).unzip();
    // SAFETY: AVX2, BMI2 (checked by `periodic`) and POPCNT are enabled;
    // `data` holds the rows back to back.
    let periods = whole / kernel.rows();
    match head {
        Some(h) => unsafe { kernel.diagnose::<true, V>(data, periods, h, sink, (t, vectors)) },
        None => unsafe { kernel.diagnose::<false, V>(data, periods, &mut [], sink, (t, vectors)) },
    }
    // Fewer rows than a period.
    let rest = m.slice_rows(whole, m.rows());
    via_counts(rest.rows(), tail, sink, |r0, r1, out| diagnose(rest.slice_rows(r0, r1), b, out, t));
    whole
}

/// Whether the periodic kernel takes rows `m`: stored back to back, a
/// period (or whole vectors) for their width, and a fast `pext`.
fn periodic_takes<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds) -> bool {
    m.packed_rows().is_some() && T::period(b).or(T::whole_period(b)).is_some() && fast_pext()
}

/// Whether the summed kernels sum rows `m` as they read them: rows stored
/// back to back that the periodic kernel or the long-row kernel reads.
pub fn kernel_sums<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds) -> bool {
    periodic_takes(m, b) || (m.packed_rows().is_some() && !takes(&m))
}

/// The long-row kernel's sums of rows `m` and the rows it will sum, where
/// it reads them (packed rows the periodic kernel does not take).
#[inline]
#[target_feature(enable = "avx2")]
fn rows_summed<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds) -> Option<(FletcherRows<Fletcher2>, usize)> {
    let data = m.packed_rows().filter(|_| !periodic_takes(m, b) && !takes(&m))?;
    // SAFETY: AVX2 is enabled.
    let sums = unsafe { Fletcher2::new() };
    Some(FletcherRows::new(sums, data.as_ptr() as *const u8, m.rows(), std::mem::size_of_val(m.row_slice(0)?)))
}

/// Candidate bits of the rows of `m` into `sink`.
#[target_feature(enable = "avx2,popcnt")]
pub fn screen_bits<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, plan: &ScreenPlan, sink: &mut BitSink) {
    screen_bits_adding(m, (b, plan), sink, (&mut NoSums, &mut NoSums));
}

/// [`screen_bits`] that also adds rows to `sums`, as [`diagnose_bits_summed`].
#[target_feature(enable = "avx2,popcnt")]
pub fn screen_bits_summed<T: Prediction>(
    m: Matrix<'_, T>,
    (b, plan): (&SensorBounds, &ScreenPlan),
    sink: &mut BitSink,
    sums: &mut Fletcher2,
) -> usize {
    match rows_summed(m, b) {
        Some((mut read, n)) => {
            screen_bits_adding(m, (b, plan), sink, (&mut NoSums, &mut read));
            *sums = read.sums();
            n
        }
        None => screen_bits_adding(m, (b, plan), sink, (sums, &mut NoSums)),
    }
}

/// [`screen_bits`], adding as [`diagnose_bits_adding`].
#[inline]
#[target_feature(enable = "avx2,popcnt")]
fn screen_bits_adding<T: Prediction, V: SumVectors<T, Avx2Vectors>, R: RowsRead>(
    m: Matrix<'_, T>,
    (b, plan): (&SensorBounds, &ScreenPlan),
    sink: &mut BitSink,
    (vectors, rows): (&mut V, &mut R),
) -> usize {
    let mut start = 0;
    if let Some((kernel, data, whole)) = periodic(m, b, true) {
        // SAFETY: as in `diagnose_bits_adding`.
        unsafe { kernel.screen(data, whole / kernel.rows(), sink, vectors) };
        start = whole;
    }
    let rest = m.slice_rows(start, m.rows());
    via_counts(rest.rows(), None, sink, |r0, r1, out| {
        screen_rows(rest.slice_rows(r0, r1), b, plan, out, &mut *rows)
    });
    start
}
