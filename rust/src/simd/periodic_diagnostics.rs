//! The periodic kernel's diagnostics ([`super::Periodic`]): per period,
//! the row verdicts, "falsified only by" and the per-sensor counts, from
//! one verdict string (see the parent module's notes).

use super::super::bit_string::{row_fields, spread, BitCounts, Bits};
use super::super::prefetch::Prefetch;
use super::super::split_string::{Split56, Split60};
use super::{NoSums, Periodic, SumVectors, Vectors};
use crate::candidates::BitSink;
use crate::kernel::{Period, Prediction, Tally};

impl<T: Prediction, L: Vectors<T>> Periodic<T, L> {
    /// Candidate bits of the first `periods * rows` rows of `data` into
    /// `out`, their diagnostics into `t` and, when `COUNTS`, their
    /// rejecting-sensor counts into `counts` (one per row).
    ///
    /// Without `COUNTS` there is no per-row work: "rejected by exactly one
    /// sensor" is field arithmetic on the period's bit string ([`row_fields`]).
    ///
    /// # Safety
    /// As [`Self::screen_any`]; `t` has `k` sensors.
    #[inline(always)]
    pub(in crate::simd) unsafe fn diagnose_any<const COUNTS: bool, S: SumVectors<T, L>>(
        &self,
        data: &[T],
        periods: usize,
        counts: &mut [u32],
        out: &mut BitSink,
        (t, sums): (&mut Tally, &mut S),
    ) {
        // A local sink and local sums, as in `screen_any`.
        let mut local = std::mem::replace(out, BitSink::new(&mut [], 0));
        let (sink, mut s) = (&mut local, *sums);
        let t = (t, &mut s);
        match self.period.vectors {
            1 => self.diagnose_p::<1, 0, COUNTS, S>(data, periods, counts, sink, t),
            2 => self.diagnose_p::<2, 0, COUNTS, S>(data, periods, counts, sink, t),
            3 => self.diagnose_p::<3, 0, COUNTS, S>(data, periods, counts, sink, t),
            4 => self.diagnose_p::<4, 0, COUNTS, S>(data, periods, counts, sink, t),
            // Rows of 5, 10 and 20 sensors, common in load tests: field
            // shifts by a constant (a u128 shift by a run-time count is five
            // instructions with a branchless fix-up).
            5 => match self.k {
                5 => self.diagnose_p::<5, 5, COUNTS, S>(data, periods, counts, sink, t),
                10 => self.diagnose_p::<5, 10, COUNTS, S>(data, periods, counts, sink, t),
                20 => self.diagnose_p::<5, 20, COUNTS, S>(data, periods, counts, sink, t),
                _ => self.diagnose_p::<5, 0, COUNTS, S>(data, periods, counts, sink, t),
            },
            6 => self.diagnose_p::<6, 0, COUNTS, S>(data, periods, counts, sink, t),
            // Rows of 7 and 14: float32 periods of 112 bits, split at bit 56
            // where the level does (`Vectors::SPLIT_56`); field shifts by a
            // constant (float64 periods of 56 bits) at every level.
            7 => match self.k {
                7 => self.diagnose_p::<7, 7, COUNTS, S>(data, periods, counts, sink, t),
                14 => self.diagnose_p::<7, 14, COUNTS, S>(data, periods, counts, sink, t),
                _ => self.diagnose_p::<7, 0, COUNTS, S>(data, periods, counts, sink, t),
            },
            _ => self.diagnose_p::<8, 0, COUNTS, S>(data, periods, counts, sink, t),
        }
        (*out, *sums) = (local, s);
    }

    /// [`Self::diagnose_any`] with `P` vectors a period (see `screen_p`) of rows
    /// of `K` sensors (0: `self.k`, known at run time).
    #[inline(always)]
    unsafe fn diagnose_p<const P: usize, const K: usize, const COUNTS: bool, S: SumVectors<T, L>>(
        &self,
        data: &[T],
        periods: usize,
        counts: &mut [u32],
        sink: &mut BitSink,
        t: (&mut Tally, &mut S),
    ) {
        if P * T::W512 <= 64 {
            self.diagnose_pb::<u64, P, K, COUNTS, S>(data, periods, counts, sink, t)
        } else if K != 0 && 60 % K == 0 && P * T::W512 - 60 <= 64 {
            self.diagnose_pb::<Split60, P, K, COUNTS, S>(data, periods, counts, sink, t)
        } else if L::SPLIT_56 && K != 0 && 56 % K == 0 && P * T::W512 - 56 <= 64 {
            self.diagnose_pb::<Split56, P, K, COUNTS, S>(data, periods, counts, sink, t)
        } else {
            self.diagnose_pb::<u128, P, K, COUNTS, S>(data, periods, counts, sink, t)
        }
    }

    /// [`Self::diagnose_p`] with the period's bits in `B`.
    #[inline(always)]
    unsafe fn diagnose_pb<B: Bits, const P: usize, const K: usize, const COUNTS: bool, S: SumVectors<T, L>>(
        &self,
        data: &[T],
        periods: usize,
        counts: &mut [u32],
        sink: &mut BitSink,
        (t, sums): (&mut Tally, &mut S),
    ) {
        let w = T::W512;
        let (k, rows) = if K == 0 { (self.k, self.period.rows) } else { (K, P * w / K) };
        assert!(P == self.period.vectors && P * w <= B::BITS && k == self.k && rows == self.period.rows);
        assert!(data.len() >= periods * rows * k && t.per_sensor.len() == k);
        assert!(!COUNTS || counts.len() >= periods * rows);
        let all = u32::MAX >> (32 - rows);
        // Per bit of the string, the periods that had it set: rejections,
        // and rejections of rows rejected by that sensor only.
        let (mut outside, mut only) = (L::Counts::new(), L::Counts::new());
        let (mut outside_totals, mut only_totals) = ([0u64; 128], [0u64; 128]);
        let mut pending = 0u32;
        // Strings of two words whose second is at most 32 bits long (f32
        // rows of 5, 10, 20 and 40 sensors): see `seconds` below.
        let pack = L::Counts::PACK && B::BITS > 64 && P * w <= B::HI_BASE + 32;
        let (mut seconds, mut seconds_totals) = (L::Counts::new(), [0u64; 128]);
        let mut invalid = 0u64;
        let pf = L::prefetch();
        let (low, top) = if K != 0 { Period::fields(k, rows) } else { (self.period.low_bits, self.period.top_bits) };
        let patterns = (B::pattern(low), B::pattern(top));
        let every = patterns.0 | patterns.1;
        // See `Vectors::INTERVALS_FROM_MEMORY`.
        let from_memory = L::INTERVALS_FROM_MEMORY && P <= 4 && T::W512 == 16;
        for q in 0..periods {
            let p = data.as_ptr().add(q * rows * k);
            // Masks of the lanes inside, the string negated once in general
            // registers (a mask-register `knot` per vector cost more), except
            // in `u128` strings, whose negation and masking cost more still:
            // there each vector's mask is negated (section "session 27: u128
            // strings" of `benches/results-short-rows.txt`).
            let mut masks = [0u32; P];
            // `black_box`: the intervals are loaded anew each period, not
            // hoisted into registers.
            let iv: &Self = if from_memory { std::hint::black_box(self) } else { self };
            for (v, r) in masks.iter_mut().enumerate() {
                pf.line(p.add(v * w));
                let x = L::load(p.add(v * w));
                sums.add(x);
                *r = if B::BITS < 128 {
                    L::inside(x, iv.low[v], iv.high[v])
                } else {
                    L::outside(x, iv.low[v], iv.high[v])
                };
            }
            let bits = if B::BITS < 128 { !B::string(&masks, w) & every } else { B::string(&masks, w) };
            if bits == B::ZERO {
                // Every row a candidate (no NaN either: NaN rejects): no diagnostic work.
                sink.push(all as u64, rows as u32);
                if COUNTS {
                    counts[q * rows..(q + 1) * rows].fill(0);
                }
                continue;
            }
            // The period's sum is NaN if a value is (or, rarely, if infinities
            // cancel): only then are the NaN lanes worked out.
            let mut sum = L::load(p);
            for v in 1..P {
                sum = L::add(sum, L::load(p.add(v * w)));
            }
            let suspect = L::nan(sum) != 0;
            let (_, rejected, single) = row_fields(bits, patterns, k);
            sink.push((!rejected & all) as u64, rows as u32);
            if COUNTS {
                for (r, c) in counts[q * rows..(q + 1) * rows].iter_mut().enumerate() {
                    *c = bits.field(r, k).count_ones();
                }
            }
            if suspect {
                // Rare: a NaN row is never a candidate, counted once.
                let (_, nan) = self.period_bits::<B, P, true, NoSums>(p, (&mut NoSums, Prefetch::OFF));
                invalid += (0..rows).filter(|&r| nan.field(r, k) != 0).count() as u64;
            }
            if pack {
                // Both strings' second words (at most 32 bits each) in one
                // count: a count costs mask-register moves, the scarce resource.
                outside = outside.add(bits.word(0), 64);
                only = only.add(single.word(0), 64);
                seconds = seconds.add(bits.word(1) | single.word(1) << 32, 64);
            } else {
                outside = outside.add(bits, P * w);
                only = only.add(single, P * w);
            }
            pending += 1;
            if pending == L::Counts::MAX {
                outside = outside.flush(&mut outside_totals);
                only = only.flush(&mut only_totals);
                if pack {
                    seconds = seconds.flush(&mut seconds_totals);
                }
                pending = 0;
            }
        }
        outside.flush(&mut outside_totals);
        only.flush(&mut only_totals);
        if pack {
            seconds.flush(&mut seconds_totals);
            outside_totals[64..96].copy_from_slice(&seconds_totals[..32]);
            only_totals[64..96].copy_from_slice(&seconds_totals[32..64]);
        }
        spread(&outside_totals, (P * w, B::HI_BASE), k, &mut t.per_sensor);
        spread(&only_totals, (P * w, B::HI_BASE), k, &mut t.only_by);
        t.invalid += invalid;
    }
}
