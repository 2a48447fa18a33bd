//! AVX-512 block kernels for short rows: at most two vectors of sensors (16
//! f64 or 32 f32). A whole block of rows is tested with the acceptance
//! intervals held in registers, and verdicts are bit masks:
//!
//! - rows of at most half a vector, stored back to back, are packed several
//!   to a vector (two rows of 4 f64, four of 2, sixteen f32 rows of 1...):
//!   one load of consecutive rows, one lane permutation into slots of a power
//!   of two lanes, one comparison for all of them;
//! - longer rows take one vector, or one vector plus a masked tail, and
//!   are run sixteen rows at a time by `row_batches` (its own doc says how).
//!
//! For packed rows, a row's bits in the mask give its verdict and its
//! violation count by a popcount, without a branch. Diagnostics come from
//! the same masks: the per-sensor counts are masked vector adds, "falsified
//! only by" adds the bits of the rows with exactly one rejecting sensor (that
//! bit is the sensor), and NaN rows are counted only in the rare vectors
//! holding a NaN.

use super::prefetch::Prefetch;
use super::checksum::RowsRead;
use crate::candidates::BitSink;
use crate::kernel::{Prediction, SensorBounds, Tally};
use crate::matrix::Matrix;
use std::arch::x86_64::*;

/// Rows of `k` sensors laid out in lane slots, and the acceptance intervals
/// in the same layout.
pub struct ShortRows<T: Prediction> {
    pub(super) low: [T::V512; 2],
    pub(super) high: [T::V512; 2],
    /// Slot permutation of packed rows (unused when one row per unit).
    index: __m512i,
    /// Lanes holding a sensor in a unit of whole rows, per vector.
    pub(super) lanes: [u32; 2],
    /// Lanes loaded for a whole packed unit (`rows * k` values).
    load: u32,
    pub(super) k: usize,
    /// Lanes (= mask bits) per row slot: a power of two when packed.
    slot: usize,
    /// Rows per unit (one load and test): `W512 / slot` when packed, else 1.
    pub(super) rows: usize,
    /// Vectors per unit: 2 for rows longer than a vector, else 1.
    pub(super) vectors: usize,
}

/// Mask of the first `n` bits (n <= 64).
#[inline(always)]
fn prefix(n: usize) -> u64 {
    if n >= 64 {
        u64::MAX
    } else {
        (1u64 << n) - 1
    }
}

/// Every `slot`-th bit starting at bit 0, over `rows` slots, each widened
/// to the `k` bits of a row: the valid lanes of `rows` packed rows.
fn slot_lanes(k: usize, slot: usize, rows: usize) -> u64 {
    (0..rows).fold(0, |m, r| m | prefix(k) << (r * slot))
}

impl<T: Prediction> ShortRows<T> {
    /// Whether rows of `k` sensors are short enough (two vectors at most).
    pub fn fits(k: usize) -> bool {
        (1..=2 * T::W512).contains(&k)
    }

    /// The layout for rows of `b.len()` sensors; packed several to a vector
    /// when `packed` (rows back to back in memory) and half a vector or less.
    ///
    /// # Safety
    /// AVX-512F is available; `Self::fits(b.len())`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub unsafe fn new(b: &SensorBounds, packed: bool) -> Self {
        let (k, w, accept) = (b.len(), T::W512, T::accepted(b));
        let (slot, rows, vectors) = if packed && 2 * k <= w {
            let slot = k.next_power_of_two();
            (slot, w / slot, 1)
        } else {
            (w, 1, 1 + (k > w) as usize)
        };
        let mut idx = [0i32; 16];
        let mut bound = [0i32; 16];
        for l in 0..w {
            let (r, j) = (l / slot, (l % slot).min(k - 1));
            idx[l] = (r * k + j) as i32; // element of the loaded rows
            bound[l] = j as i32; // sensor of the lane
        }
        let full = prefix(w) as u32;
        let lanes = if rows > 1 {
            [slot_lanes(k, slot, rows) as u32, 0]
        } else {
            [prefix(k.min(w)) as u32, prefix(k.saturating_sub(w)) as u32]
        };
        // The acceptance vectors are padded to whole blocks of 16 >= 2 * W512 / 2.
        let load = |v: &[T], g: usize| T::load512(full, v.as_ptr().add(w * g));
        let (mut low, mut high) = ([load(&accept[0], 0); 2], [load(&accept[1], 0); 2]);
        if rows > 1 {
            let spread = T::index512(&bound);
            low[0] = T::permute512(spread, low[0]);
            high[0] = T::permute512(spread, high[0]);
        } else if vectors == 2 {
            (low[1], high[1]) = (load(&accept[0], 1), load(&accept[1], 1));
        }
        ShortRows {
            low,
            high,
            index: T::index512(&idx),
            lanes,
            load: prefix(rows * k) as u32,
            k,
            slot,
            rows,
            vectors,
        }
    }

    /// (rejecting lanes, NaN lanes) of the first `n` packed rows (n <=
    /// `self.rows`) starting at `p`, one bit per lane.
    ///
    /// # Safety
    /// AVX-512F is available; `p` points to `n` rows of `k` values back to back.
    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn unit(&self, p: *const T, n: usize) -> (u64, u64) {
        let v = T::permute512(self.index, T::load512(prefix(n * self.k) as u32, p));
        let lanes = self.lanes[0] & prefix(n * self.slot) as u32;
        let out = !T::inside512(lanes, v, self.low[0], self.high[0]) & lanes;
        (out as u64, T::nan512(lanes, v) as u64)
    }

    /// `unit` for a whole unit of packed rows, with the masks computed once in `new`.
    ///
    /// # Safety
    /// As `unit`, with `n = self.rows`.
    #[inline(always)]
    unsafe fn whole_unit(&self, p: *const T) -> (u64, u64) {
        let v = T::permute512(self.index, T::load512(self.load, p));
        let lanes = self.lanes[0];
        let out = !T::inside512(lanes, v, self.low[0], self.high[0]) & lanes;
        (out as u64, T::nan512(lanes, v) as u64)
    }

    /// Writes each row's candidate bit to `sink`.
    ///
    /// # Safety
    /// AVX-512F, POPCNT are available; rows of `m` are contiguous (and back
    /// to back when packed).
    #[inline]
    #[target_feature(enable = "avx512f,popcnt")]
    pub unsafe fn screen<S: RowsRead>(&self, m: Matrix<'_, T>, sink: &mut BitSink, sums: &mut S) {
        self.dispatch::<false, false, S>(m, &mut [], sink, (&mut Tally::zeros(0), sums))
    }

    /// Writes each row's candidate bit to `sink`, its rejecting-sensor count
    /// to `counts` if given (one per row), and adds its diagnostics to `t`
    /// (as `kernel::diagnose`); tells `sums` the rows read (as `screen`).
    ///
    /// # Safety
    /// As [`Self::screen`]; `t` has `k` sensors.
    #[inline]
    #[target_feature(enable = "avx512f,popcnt")]
    pub unsafe fn diagnose<S: RowsRead>(
        &self,
        m: Matrix<'_, T>,
        counts: Option<&mut [u32]>,
        sink: &mut BitSink,
        (t, sums): (&mut Tally, &mut S),
    ) {
        assert!(t.per_sensor.len() == self.k);
        match counts {
            Some(c) => self.dispatch::<true, true, S>(m, c, sink, (t, sums)),
            None => self.dispatch::<true, false, S>(m, &mut [], sink, (t, sums)),
        }
    }

    /// The pass compiled for this layout: rows per unit and vectors per row
    /// as constants, so that the per-row work unrolls and its shifts are
    /// immediates (about a third of the instructions of a generic loop).
    #[inline]
    #[target_feature(enable = "avx512f,popcnt")]
    unsafe fn dispatch<const DIAG: bool, const COUNTS: bool, S: RowsRead>(
        &self,
        m: Matrix<'_, T>,
        counts: &mut [u32],
        sink: &mut BitSink,
        (t, sums): (&mut Tally, &mut S),
    ) {
        assert!((!COUNTS || counts.len() == m.rows()) && m.cols() == self.k);
        let mut read = *sums;
        match (self.rows, self.vectors) {
            (1, 1) => self.run_rows::<1, DIAG, COUNTS, S>(m, counts, sink, (t, &mut read)),
            (1, _) => self.run_rows::<2, DIAG, COUNTS, S>(m, counts, sink, (t, &mut read)),
            (2, _) => self.run::<2, DIAG, COUNTS, S>(m, counts, sink, (t, &mut read)),
            (4, _) => self.run::<4, DIAG, COUNTS, S>(m, counts, sink, (t, &mut read)),
            (8, _) => self.run::<8, DIAG, COUNTS, S>(m, counts, sink, (t, &mut read)),
            _ => self.run::<16, DIAG, COUNTS, S>(m, counts, sink, (t, &mut read)),
        }
        *sums = read;
    }

    /// One pass over the rows of `m`, `R` packed rows per unit (one row per
    /// unit goes to `run_rows`); diagnostics into `t`
    /// when `DIAG`, per-row counts into `counts` when `COUNTS`; each unit
    /// read told to `sums`. Candidate bits go to `sink` 64 rows at a time (R
    /// divides 64).
    #[inline(always)]
    unsafe fn run<const R: usize, const DIAG: bool, const COUNTS: bool, S: RowsRead>(
        &self,
        m: Matrix<'_, T>,
        counts: &mut [u32],
        sink: &mut BitSink,
        (t, sums): (&mut Tally, &mut S),
    ) {
        assert!(R == self.rows && R > 1);
        let (field, slot, k) = (prefix(self.slot), self.slot, self.k);
        let ones = _mm512_set1_epi32(1);
        // Per-lane counts in u32 lanes: a pass has at most 2^31 rows (`avx512::MAX_PASS_ROWS`).
        let (mut per_lane, mut only_lane) = (_mm512_setzero_si512(), _mm512_setzero_si512());
        let mut invalid = 0u64;
        let packed = m.packed_rows().expect("rows back to back");
        let total = m.rows();
        // Candidate bits of the rows since the last push to `sink`.
        let (mut word, mut filled) = (0u64, 0usize);
        let pf = Prefetch::FIXED; // see `Prefetch::now` for which kernels choose
        for u in 0..total.div_ceil(R) {
            let n = R.min(total - u * R);
            // One unit is at most one vector: one line prefetched ahead.
            pf.line(packed.as_ptr().add(u * R * k));
            let (bits, nan) = if n == R {
                self.whole_unit(packed.as_ptr().add(u * R * k))
            } else {
                // The last, partial unit of packed rows.
                self.unit(packed.as_ptr().add(u * R * k), n)
            };
            sums.rows_read(packed.as_ptr().add((u * R + n) * k) as *const u8);
            let mut single = 0u64;
            // `R` constant: unrolled, the shifts are immediates (hence the index).
            #[allow(clippy::needless_range_loop)]
            for r in 0..R {
                if r < n {
                    let f = bits & (field << (r * slot));
                    let count = f.count_ones();
                    if COUNTS {
                        counts[u * R + r] = count;
                    }
                    word |= ((count == 0) as u64) << (filled + r);
                    // The one rejecting sensor's bit, for rows rejected by one only.
                    single |= f & ((count == 1) as u64).wrapping_neg();
                }
            }
            filled += n;
            if filled == 64 {
                sink.push(word, 64);
                (word, filled) = (0, 0);
            }
            if DIAG {
                if nan != 0 {
                    // Rare: a NaN row is never a candidate, counted once.
                    invalid += (0..n).filter(|r| (nan >> (r * slot)) & field != 0).count() as u64;
                }
                per_lane = _mm512_mask_add_epi32(per_lane, bits as __mmask16, per_lane, ones);
                only_lane = _mm512_mask_add_epi32(only_lane, single as __mmask16, only_lane, ones);
            }
        }
        if filled > 0 {
            sink.push(word, filled as u32);
        }
        if DIAG {
            let mut lanes = [[0u32; 16]; 2];
            for (dst, v) in lanes.iter_mut().zip([per_lane, only_lane]) {
                _mm512_storeu_si512(dst.as_mut_ptr() as *mut __m512i, v);
            }
            // Lane of sensor j in slot r: r * slot + j (< w).
            for j in 0..k {
                for r in 0..R {
                    t.per_sensor[j] += lanes[0][r * slot + j] as u64;
                    t.only_by[j] += lanes[1][r * slot + j] as u64;
                }
            }
            t.invalid += invalid;
        }
    }
}

/// Whether the short-row kernels take `m`: rows of at most two vectors,
/// each contiguous.
pub fn takes<T: Prediction>(m: &Matrix<'_, T>) -> bool {
    ShortRows::<T>::fits(m.cols()) && (m.rows() == 0 || m.row_slice(0).is_some())
}
