//! AVX2 row tests of rows longer than the short-row kernels take, compared
//! in the predictions' own type (f32 eight to a register, f64 four) with the
//! intervals of the AVX-512 kernels. With diagnostics, each vector's verdict
//! bits go into the row's verdict string, whose popcount is the violation
//! count and whose lowest bit is the first rejecting sensor; the per-sensor
//! counts are counted per bit of that string in byte lanes, 32 sensors a
//! register (`periodic_avx2::bit_bytes`), and added to the tally every 255
//! rows. After four candidates in a row the verdict comes first (as
//! `long::attribute` does after two). With diagnostics, rows stored one
//! after another of 9-96 f64 or 9-200 f32 sensors go to `medium_avx2` instead;
//! these keep the longer rows and rows not stored that way.
//!
//! Why: the row loop this replaces widened f32 to f64 (four values a
//! comparison) and added every vector's verdicts to u64 counts in memory (a
//! load, a subtraction and a store per four sensors). With
//! `EDMF_RS_ISA=avx2` on an AMD EPYC (CPU family 26, Zen 5), f32 rows of 50 and 200 with
//! diagnostics read 0.44-0.54 of the read floor and f64 rows of 50 0.76-0.82
//! (`benches/results-short-rows.txt`, sections "session 16 AVX2 first code";
//! with this kernel, sections "session 16 AVX2 final code", 0.79-1.04 and
//! 0.96-1.05).

use super::prefetch::Prefetch;
use super::checksum::RowsRead;
use super::periodic_avx2::bit_bytes;
use crate::kernel::{diagnose_impl, Prediction, SensorBounds, Tally, BLOCK};
use crate::matrix::Matrix;
use std::arch::x86_64::*;

/// Candidates in a row after which a row's verdict comes first.
const VERDICT_FIRST: u32 = 4;

/// Per-sensor rejection counts, one byte lane a sensor, 32 to a register:
/// in a `Vec`, or in an array of two (rows of up to 64 sensors), which the
/// compiler keeps in registers.
struct ByteCounts<S> {
    lanes: S,
    rows: u32,
}

impl<S: AsRef<[__m256i]> + AsMut<[__m256i]>> ByteCounts<S> {
    /// Counts the set bits of `words` (bit `j`: sensor `j`; a word for every
    /// two lanes), and moves the counts to `per_sensor` before a byte can
    /// overflow.
    ///
    /// # Safety
    /// AVX2 is available.
    #[inline(always)]
    unsafe fn add(&mut self, words: &[u64], per_sensor: &mut [u64]) {
        for (c, lane) in self.lanes.as_mut().iter_mut().enumerate() {
            *lane = _mm256_sub_epi8(*lane, bit_bytes((words[c / 2] >> (32 * (c % 2))) as u32));
        }
        self.rows += 1;
        if self.rows == u8::MAX as u32 {
            self.flush(per_sensor);
        }
    }

    /// Adds the counts to `per_sensor` (one per sensor; lanes past it count
    /// nothing) and zeroes them.
    ///
    /// # Safety
    /// AVX2 is available.
    #[inline(never)]
    #[target_feature(enable = "avx2")]
    unsafe fn flush(&mut self, per_sensor: &mut [u64]) {
        for (c, lane) in self.lanes.as_mut().iter_mut().enumerate() {
            let mut bytes = [0u8; 32];
            _mm256_storeu_si256(bytes.as_mut_ptr() as *mut __m256i, *lane);
            *lane = _mm256_setzero_si256();
            for (t, &n) in per_sensor.iter_mut().skip(32 * c).zip(&bytes) {
                *t += u64::from(n);
            }
        }
        self.rows = 0;
    }
}

/// (Closures take the features of the function they are written in: this
/// and its callers enable AVX2 themselves, or a closure not inlined would
/// call every intrinsic out of line.)
///
/// Calls `f(j, outside, x, last)` for each vector of `row`: its first
/// sensor, the bits of its lanes outside their intervals (NaN is outside),
/// its values and whether it is the row's last vector, which loads only the
/// lanes within the row (the others 0, and not outside). Two vectors (64
/// bytes) a step, each step asking first for the line the prefetch distance past
/// it when `PREFETCH`, and the row's last value's at the end (see
/// `avx512::any_rejecting` for why the prefetches are spread over the row).
///
/// # Safety
/// AVX2 is available; the acceptance vectors are padded to whole blocks.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn each_vector<T: Prediction, const PREFETCH: bool>(
    row: &[T],
    accept: &[Vec<T>; 2],
    mut f: impl FnMut(usize, u32, T::V256, bool),
) {
    let (k, h, p) = (row.len(), T::W512 / 2, row.as_ptr());
    let (low, high) = (accept[0].as_ptr(), accept[1].as_ptr());
    let pf = Prefetch::FIXED;
    let mut test = |j: usize| {
        let x = T::load256(p.add(j));
        f(
            j,
            T::outside256(x, T::load256(low.add(j)), T::load256(high.add(j))),
            x,
            j + h == k,
        );
    };
    let lines = k - k % (2 * h);
    for j in (0..lines).step_by(2 * h) {
        if PREFETCH {
            pf.line(p.add(j));
        }
        test(j);
        test(j + h);
    }
    let mut j = lines;
    if j + h <= k {
        if PREFETCH {
            pf.line(p.add(j));
        }
        test(j);
        j += h;
    }
    if j < k {
        let x = T::head256(k - j, p.add(j));
        f(
            j,
            T::outside256(x, T::load256(low.add(j)), T::load256(high.add(j))) & ((1 << (k - j)) - 1),
            x,
            true,
        );
    }
    if PREFETCH && k > 0 {
        pf.line(p.add(k - 1));
    }
}

/// True if `row` holds a NaN (rare: looked for only when a row's sum is NaN).
#[inline(never)]
fn has_nan<T: Prediction>(row: &[T]) -> bool {
    row.iter().any(|v| v.to_f64().is_nan())
}

/// True if any sensor rejects `row`: every vector, in column order, without
/// a branch.
///
/// # Safety
/// AVX2 is available; the acceptance vectors are padded to whole blocks.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn any_rejecting<T: Prediction>(row: &[T], accept: &[Vec<T>; 2]) -> bool {
    let (k, h) = (row.len(), T::W512 / 2);
    let mut any = 0;
    if k < h || k % h == 0 {
        each_vector::<T, true>(row, accept, |_, out, _, _| any |= out);
        return any != 0;
    }
    // The last vector ends where the row does, a whole load (its lanes
    // also in the vector before give the same verdict twice), not
    // `each_vector`'s masked one: side by side through `falsify`,
    // screening float32 rows of 150 then ran 1.284-1.636 times as fast,
    // from 0.43-0.77 of the read floor to 0.84-0.98, and rows of 129, 170
    // and 200 and float64 rows 0.977-1.034 (AMD EPYC Zen 4;
    // `benches/results-long-rows.txt`, "session 37", parts "AVX2 screening
    // without a masked load"). Why the masked load costs rows of 150 most
    // (rows of 129 and 170 end in one too) is not known.
    each_vector::<T, true>(&row[..k - k % h], accept, |_, out, _, _| any |= out);
    let j = k - h;
    let x = T::load256(row.as_ptr().add(j));
    any |= T::outside256(x, T::load256(accept[0].as_ptr().add(j)), T::load256(accept[1].as_ptr().add(j)));
    Prefetch::FIXED.line(row.as_ptr().add(k - 1));
    any != 0
}

/// Writes the number of rejecting sensors of each row of `m` into `out` and
/// adds the per-sensor counts to `t` (rows that are not contiguous take the
/// portable loop); tells `sums` each row read.
///
/// # Safety
/// AVX2 and POPCNT are available.
#[inline]
#[target_feature(enable = "avx2,popcnt")]
pub unsafe fn diagnose<T: Prediction, S: RowsRead>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    out: &mut [u32],
    (t, sums): (&mut Tally, &mut S),
) {
    // Rows of up to 64 sensors keep their string in a register.
    if m.cols() <= 64 {
        diagnose_words::<T, true, S>(m, b, out, (t, sums))
    } else {
        diagnose_words::<T, false, S>(m, b, out, (t, sums))
    }
}

/// [`diagnose`] with the row's string in one `u64` (`ONE`, rows of up to 64
/// sensors) or in a vector of them.
///
/// # Safety
/// As [`diagnose`].
#[inline]
#[target_feature(enable = "avx2,popcnt")]
unsafe fn diagnose_words<T: Prediction, const ONE: bool, S: RowsRead>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    out: &mut [u32],
    (t, sums): (&mut Tally, &mut S),
) {
    let (k, accept) = (m.cols(), T::accepted(b));
    assert!(accept[0].len() >= k.div_ceil(BLOCK) * BLOCK && accept[1].len() == accept[0].len());
    assert!(!ONE || k <= 64);
    let mut words = vec![0u64; k.div_ceil(64)];
    let mut counts = ByteCounts {
        lanes: vec![_mm256_setzero_si256(); k.div_ceil(32)],
        rows: 0,
    };
    let mut pair = ByteCounts {
        lanes: [_mm256_setzero_si256(); 2],
        rows: 0,
    };
    // Candidates in a row so far: the verdict comes first after a few.
    let mut run = 0u32;
    let mut verdict = |row: &[T], per_sensor: &mut [u64]| {
        if run >= VERDICT_FIRST && !any_rejecting(row, accept) {
            run = run.saturating_add(1);
            return (0, false, k.saturating_sub(1));
        }
        // Each word of the string is built in a register and stored once
        // (or'ed into memory vector by vector, each store waited for the last).
        // The row's values summed: NaN iff one is (or, rarely, if infinities
        // cancel), so NaN lanes are looked for only then.
        let (mut word, mut sum) = (0u64, T::zero256());
        let bits = |j: usize, outside: u32, x: T::V256, last: bool| {
            word |= u64::from(outside) << (j % 64);
            sum = T::add256(sum, x);
            // A vector holds 4 or 8 values: words end where vectors do.
            if !ONE && (last || (j + T::W512 / 2).is_multiple_of(64)) {
                words[j / 64] = word;
                word = 0;
            }
        };
        // A rejected row after candidates was read by `any_rejecting` just now.
        if run < VERDICT_FIRST {
            each_vector::<T, true>(row, accept, bits);
        } else {
            each_vector::<T, false>(row, accept, bits);
        }
        let nan = T::nan256(sum) != 0 && has_nan(row);
        let (n, first) = if ONE {
            pair.add(&[word], per_sensor);
            (
                word.count_ones(),
                if word == 0 {
                    k.saturating_sub(1)
                } else {
                    word.trailing_zeros() as usize
                },
            )
        } else {
            counts.add(&words, per_sensor);
            let first = words.iter().position(|&w| w != 0);
            let n = words.iter().map(|w| w.count_ones()).sum();
            (
                n,
                first.map_or(k.saturating_sub(1), |i| {
                    i * 64 + words[i].trailing_zeros() as usize
                }),
            )
        };
        run = if n == 0 { run.saturating_add(1) } else { 0 };
        (n, nan, first)
    };
    let mut read = *sums;
    diagnose_impl(m, b, out, t, |row, _, per_sensor| {
        let v = verdict(row, per_sensor);
        // SAFETY: AVX2 is enabled.
        unsafe { read.rows_read(row.as_ptr_range().end as *const u8) };
        v
    });
    *sums = read;
    counts.flush(&mut t.per_sensor);
    pair.flush(&mut t.per_sensor);
}
