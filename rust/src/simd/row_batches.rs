//! AVX-512 pass for rows of one or two vectors read one row per unit,
//! sixteen rows at a time: the rows of half a vector or more that the
//! periodic kernel does not take (f64 rows of 8, 9, 11, 13, 15 and 16
//! sensors, f32 rows of 9, 11, 13, 15-19, 21-23, 25-27 and 29-32, the rows
//! after the last whole period, any such width when the rows are not back
//! to back or BMI2 is missing).
//!
//! Why: testing a row costs one or two comparisons, but turning its mask
//! into a verdict, a count and diagnostics one row at a time cost about
//! twenty more scalar instructions (popcount, shifts, two masked adds). Here
//! each row only leaves its inside-mask in a small buffer and adds that mask
//! to per-lane counts of values inside; the verdicts of sixteen rows then
//! come from one vector comparison of the sixteen masks, the rows rejected
//! by exactly one sensor from one more, and those rows' bits go to bit
//! planes (`bit_counts`). NaN rows are looked for only in batches whose
//! values sum to NaN. Kernel alone, one thread, Zen 4 (`cargo bench --
//! short_rows_16`, section "session 10: cargo bench" of
//! `benches/results-short-rows.txt`): f64 rows of 16 with diagnostics,
//! every row a candidate, 209-211 -> 376-385 M rows/s. Rows are prefetched
//! 8 KiB ahead, and screening takes each verdict from its row's mask: through
//! `falsify`, screening f64 rows of 16 went from 0.66-0.69 to 1.02-1.05 of
//! the read floor (section "session 13: side by side").

use super::prefetch::{Hint, Prefetch, RUN_TIME};
use super::bit_counts::BitPlanes;
use super::checksum::RowsRead;
use super::short::ShortRows;
use crate::candidates::BitSink;
use crate::kernel::{Prediction, Tally};
use crate::matrix::Matrix;
use std::arch::x86_64::*;

/// Rows per batch: one 32-bit mask each, one vector of masks.
const BATCH: usize = 16;

impl<T: Prediction> ShortRows<T> {
    /// One pass over the rows of `m`, one row per unit, `G` vectors a row
    /// (as `run`, which it replaces for one row per unit); each batch read
    /// told to `sums`.
    ///
    /// # Safety
    /// AVX-512F and POPCNT are available; each row of `m` is contiguous;
    /// `self.rows == 1`, `self.vectors == G`.
    #[inline(always)]
    pub(super) unsafe fn run_rows<const G: usize, const DIAG: bool, const COUNTS: bool, S: RowsRead>(
        &self,
        m: Matrix<'_, T>,
        counts: &mut [u32],
        sink: &mut BitSink,
        ts: (&mut Tally, &mut S),
    ) {
        // The prefetch's hint a constant in the loop for the two that CPUs
        // are given (`Prefetch::for_cpu`); others, named by `PREFETCH_ENV`
        // to compare them, chosen on every line. Chosen on every row, the
        // hint was a jump through a table per row: alone on a core, the
        // constant made these rows with diagnostics 1.03-1.36 times as fast
        // and screened 1.12-1.37 (AMD EPYC Zen 4; `benches/results-short-rows.txt`,
        // "session 29: the row batches' prefetch hint").
        let pf = Prefetch::now();
        match pf.hint {
            Hint::T1 => self.rows_as::<G, DIAG, COUNTS, S, { Hint::T1 as u8 }>(m, counts, sink, ts, pf),
            Hint::Nta => self.rows_as::<G, DIAG, COUNTS, S, { Hint::Nta as u8 }>(m, counts, sink, ts, pf),
            _ => self.rows_as::<G, DIAG, COUNTS, S, RUN_TIME>(m, counts, sink, ts, pf),
        }
    }

    /// [`Self::run_rows`] with prefetch hint `H` ([`Prefetch::line_as`]).
    ///
    /// # Safety
    /// As [`Self::run_rows`].
    #[inline(always)]
    unsafe fn rows_as<const G: usize, const DIAG: bool, const COUNTS: bool, S: RowsRead, const H: u8>(
        &self,
        m: Matrix<'_, T>,
        counts: &mut [u32],
        sink: &mut BitSink,
        (t, sums): (&mut Tally, &mut S),
        pf: Prefetch,
    ) {
        assert!(self.rows == 1 && self.vectors == G && m.cols() == self.k);
        let w = T::W512;
        let lanes = self.lanes;
        // A row's sensors as bits of one 32-bit mask (vector g at bit w * g).
        let row_lanes = lanes[0] | if G > 1 { lanes[1] << w } else { 0 };
        let all = _mm512_set1_epi32(row_lanes as i32);
        let (ones, zero) = (_mm512_set1_epi32(1), _mm512_setzero_si512());
        // Per-lane counts of values inside, in u32 lanes (a pass has at most
        // 2^31 rows, `avx512::MAX_PASS_ROWS`), and of rows rejected by one
        // sensor only.
        let (mut inside_lane, mut only) = ([zero; 2], BitPlanes::new());
        let mut only_by = [0u64; 32];
        let mut invalid = 0u64;
        // The masks of two batches: with diagnostics or counts, a batch's
        // sixteen masks are read back as one vector a batch later, when their
        // stores have reached the cache. Read at once, the load waited for the
        // sixteen stores (x86 forwards a load from one store, not from
        // sixteen): alone on a core, the row-batch widths with diagnostics ran
        // 1.00-1.26 times as fast deferred (AMD EPYC Zen 4;
        // `benches/results-short-rows.txt`, "session 30: the row batches'
        // masks read a batch later").
        let mut masks = [[0u32; BATCH]; 2];
        let (stride, total) = (m.row_stride(), m.rows());
        let mut verdicts = Verdicts { word: 0, filled: 0 };
        let batches = total.div_ceil(BATCH);
        // Screening takes each verdict from its row's mask and defers nothing.
        let deferred = DIAG || COUNTS;
        for b in 0..batches + usize::from(deferred) {
            if b < batches {
                let b0 = b * BATCH;
                let n = BATCH.min(total - b0);
                let masks = &mut masks[b % 2];
                // Bounds of the batch checked once: its last row is in `m`.
                let _ = m.row_slice(b0 + n - 1).expect("contiguous rows");
                let base = m.row_slice(b0).expect("contiguous rows").as_ptr();
                let mut sum = [T::zero512(); 2];
                let mut screened = 0u16;
                // `BATCH` constant: unrolled, the row offsets are immediates.
                #[allow(clippy::needless_range_loop)]
                for i in 0..BATCH {
                    if i < n {
                        let p = base.add(i * stride);
                        let mut mask = 0u32;
                        for g in 0..G {
                            // The line ahead of each vector, as in the other kernels
                            // (without it, screening f64 rows of 16 from memory spent
                            // half its time on these loads: perf).
                            pf.line_as::<H, T>(p.wrapping_add(w * g));
                            // `wrapping_add`: the second vector of a one-vector row is never read.
                            let v = T::load512(lanes[g], p.wrapping_add(w * g));
                            let inside = T::inside512(lanes[g], v, self.low[g], self.high[g]);
                            mask |= inside << (w * g);
                            if DIAG {
                                let lane = inside_lane[g];
                                inside_lane[g] = _mm512_mask_add_epi32(lane, inside as __mmask16, lane, ones);
                                sum[g] = T::add512(sum[g], v);
                            }
                        }
                        masks[i] = mask;
                        if !deferred {
                            // Screening: the verdict straight from the mask, not from the
                            // sixteen masks read back as one vector.
                            screened |= ((mask == row_lanes) as u16) << i;
                        }
                    } else {
                        // Past the last row: no rejecting sensor, masked off below.
                        masks[i] = row_lanes;
                    }
                }
                sums.rows_read(base.add((n - 1) * stride + self.k) as *const u8);
                if !deferred {
                    verdicts.add(screened, n, sink);
                }
                if DIAG {
                    let nan = (0..G).fold(0, |a, g| a | T::nan512(lanes[g], sum[g]));
                    if nan != 0 {
                        // Rare: a NaN row is never a candidate, counted once.
                        invalid += (0..n)
                            .filter(|&i| {
                                let p = base.add(i * stride);
                                (0..G).any(|g| T::nan512(lanes[g], T::load512(lanes[g], p.wrapping_add(w * g))) != 0)
                            })
                            .count() as u64;
                    }
                }
            }
            if deferred && b > 0 {
                // The batch before.
                let b0 = (b - 1) * BATCH;
                let n = BATCH.min(total - b0);
                let masks = &mut masks[(b - 1) % 2];
                let valid = if n == BATCH { u16::MAX } else { ((1u32 << n) - 1) as u16 };
                // Rejecting sensors of each row: its lanes outside (not needed to screen).
                let out = _mm512_xor_si512(_mm512_loadu_si512(masks.as_ptr() as *const __m512i), all);
                let candidates = _mm512_mask_cmpeq_epi32_mask(valid, out, zero);
                verdicts.add(candidates, n, sink);
                if COUNTS {
                    _mm512_storeu_si512(masks.as_mut_ptr() as *mut __m512i, out);
                    for (c, o) in counts[b0..b0 + n].iter_mut().zip(masks.iter()) {
                        *c = o.count_ones();
                    }
                }
                if DIAG {
                    // Exactly one rejecting sensor: out != 0 and out & (out - 1) == 0.
                    let several = _mm512_test_epi32_mask(out, _mm512_sub_epi32(out, ones));
                    let single = valid & !candidates & !several;
                    if single != 0 && only.add(_mm512_maskz_mov_epi32(single, out)) {
                        // The one rejecting sensor's bit, of those rows.
                        only.flush(&mut only_by);
                    }
                }
            }
        }
        if verdicts.filled > 0 {
            sink.push(verdicts.word, verdicts.filled);
        }
        if DIAG {
            only.flush(&mut only_by);
            let mut per_lane = [[0u32; 16]; 2];
            for (dst, v) in per_lane.iter_mut().zip(&inside_lane) {
                _mm512_storeu_si512(dst.as_mut_ptr() as *mut __m512i, *v);
            }
            for j in 0..self.k {
                // Every row visited rejects at sensor j unless its value is inside.
                t.per_sensor[j] += total as u64 - per_lane[j / w][j % w] as u64;
                // Bit j of a row's mask is sensor j (vector g at bit w * g).
                t.only_by[j] += only_by[j];
            }
            t.invalid += invalid;
        }
    }
}

/// Candidate bits of batches, pushed to the sink 64 at a time.
struct Verdicts {
    word: u64,
    filled: u32,
}

impl Verdicts {
    /// Adds the bits of a batch of `n` rows (bit `i`: row `i` a candidate).
    #[inline(always)]
    fn add(&mut self, bits: u16, n: usize, sink: &mut BitSink) {
        self.word |= (bits as u64) << self.filled;
        self.filled += n as u32;
        if self.filled == 64 {
            sink.push(self.word, 64);
            (self.word, self.filled) = (0, 0);
        }
    }
}
