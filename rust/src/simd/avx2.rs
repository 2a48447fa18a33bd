//! AVX2: rows of more than eight sensors are tested by `long_avx2`, in the
//! predictions' own type; rows of up to eight by `short_avx2`, widened to
//! f64. Rows stored back to back whose pattern repeats within eight vectors
//! of 8 f64 or 16 f32 (rows of 5 and 10 among them), and rows of whole
//! vectors, two or more to a period (f64 rows of 8, 16, 24 and 32 sensors,
//! f32 of 16, 32 and 48: `Period::whole_rows`), take the periodic kernel instead
//! (`periodic_avx2`) when the bits are asked for, as `falsify` does.

use super::long_avx2;
use super::periodic::Periodic;
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
    if takes(&m) {
        // SAFETY: AVX2 and POPCNT are enabled; `takes` checked the row width
        // and that rows are contiguous.
        unsafe { ShortRows4::new(b).diagnose(m, out, t) };
    } else {
        // SAFETY: AVX2 and POPCNT are enabled.
        unsafe { long_avx2::diagnose(m, b, out, t) }
    }
}

#[target_feature(enable = "avx2,popcnt")]
pub fn screen<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, plan: &ScreenPlan, out: &mut [u32]) {
    if takes(&m) {
        // SAFETY: as in `diagnose`.
        unsafe { ShortRows4::new(b).screen(m, out) };
    } else {
        screen_impl(m, b, plan, out, |row| row_rejected(row, b))
    }
}

/// The rows of `m` that the periodic kernel takes (whole periods of rows
/// stored back to back), their values and the kernel; the rest of `m` after
/// them. None where `pext` is slow (see [`fast_pext`]).
#[inline]
#[target_feature(enable = "avx2")]
fn periodic<'a, T: Prediction>(
    m: Matrix<'a, T>,
    b: &SensorBounds,
) -> Option<(Periodic<T, Avx2Vectors>, &'a [T], usize)> {
    let data = m.packed_rows()?;
    T::period(b).or(T::whole_period(b)).filter(|_| fast_pext())?;
    // SAFETY: AVX2 is enabled; a period takes the width.
    let kernel = unsafe { Periodic::<T, Avx2Vectors>::new(b) };
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
    let Some((kernel, data, whole)) = periodic(m, b) else {
        return via_counts(m.rows(), counts, sink, |r0, r1, out| diagnose(m.slice_rows(r0, r1), b, out, t));
    };
    let (head, tail) = counts.map(|c| c.split_at_mut(whole)).unzip();
    // SAFETY: AVX2, BMI2 (checked by `periodic`) and POPCNT are enabled;
    // `data` holds the rows back to back.
    let periods = whole / kernel.rows();
    match head {
        Some(h) => unsafe { kernel.diagnose::<true>(data, periods, h, sink, t) },
        None => unsafe { kernel.diagnose::<false>(data, periods, &mut [], sink, t) },
    }
    // Fewer rows than a period.
    let rest = m.slice_rows(whole, m.rows());
    via_counts(rest.rows(), tail, sink, |r0, r1, out| diagnose(rest.slice_rows(r0, r1), b, out, t));
}

/// Candidate bits of the rows of `m` into `sink`.
#[target_feature(enable = "avx2,popcnt")]
pub fn screen_bits<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, plan: &ScreenPlan, sink: &mut BitSink) {
    let mut start = 0;
    if let Some((kernel, data, whole)) = periodic(m, b) {
        // SAFETY: as in `diagnose_bits`.
        unsafe { kernel.screen(data, whole / kernel.rows(), sink) };
        start = whole;
    }
    let rest = m.slice_rows(start, m.rows());
    via_counts(rest.rows(), None, sink, |r0, r1, out| screen(rest.slice_rows(r0, r1), b, plan, out));
}
