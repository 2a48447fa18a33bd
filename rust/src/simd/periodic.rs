//! AVX-512 kernel for short rows stored back to back, read as a plain stream
//! of whole vectors: rows of `k` sensors repeat their sensor pattern every
//! `lcm(k, W)` values, i.e. every `P = lcm(k, W) / W` vectors holding
//! `R = lcm(k, W) / k` rows. The acceptance intervals are laid out once in
//! that pattern (`P` vectors), so a period costs `P` full loads and `2P`
//! comparisons, with no masked load, no permutation and no row straddling
//! a vector to care about; the `P` verdict masks are one `P * W`-bit string
//! (at most 128 bits) in which row `r` owns bits `r*k .. r*k + k`.
//!
//! Why: with one load per row (the `ShortRows` layouts for rows of 5-10
//! f32), the cost per row, not the bytes read, sets the pace, and f32 rows
//! ran at half the speed of f64 rows per byte. Here the loads per row are
//! `k / W` of a vector, whatever `k`.
//!
//! - Screening: a row is rejected iff its field has a bit set, for all `R`
//!   rows at once by a carry trick (add the field's low bits to themselves:
//!   the carry reaches the field's top bit iff one of them is set).
//! - Diagnostics: the field's popcount is the row's violation count;
//!   "falsified only by" comes from the fields with exactly one bit (field
//!   arithmetic on the string, as screening's carry trick); the per-sensor
//!   counts of both are counted per bit of the string in byte lanes, one
//!   masked add per 64 bits (bit `i` is sensor `i % k`); NaN lanes are
//!   worked out only in the rare periods whose values sum to NaN. Periods
//!   whose rows are all candidates cost their comparisons only.
//! - The string is `u64` where a period fits (every f64 period; f32 periods
//!   of up to four vectors) and rows of 5 and 10 sensors shift their fields
//!   by constants: `u128` words and run-time shifts took several
//!   instructions each, per period. With diagnostics, f32 rows of 5, 10 and
//!   20 (80-bit periods) keep their string as two words split at a row
//!   boundary ([`super::split_string::Split60`]): the field arithmetic then
//!   has no carry between words (`benches/results-short-rows.txt`, "session
//!   21"), and runs on both words at once in a 128-bit vector register;
//!   at AVX2 so do f32 rows of 7 and 14 (112 bits, split at bit 56:
//!   [`Vectors::SPLIT_56`]).
//! - The lanes are compared as "inside" and the string negated once in a
//!   general register (`u128` strings excepted), and on AVX-512 the two
//!   strings' short second words (outside, and "only by") are counted as
//!   one word.
//!
//! Why (session 27; `cargo bench --bench core_kernels`, one core from L2,
//! AMD Zen 4; section "session 27: the kernels alone" of
//! `benches/results-short-rows.txt`): the loop with diagnostics was bound
//! by its general-register operations, not by the counts or the NaN test
//! (taking them out changed nothing there). The field arithmetic of both
//! words in one vector register, with the second words counted as one
//! (neither gained alone), made typical f32 rows of 5, 10 and 20 (now
//! `Split60` too) faster at AVX-512 (figures in `docs/performance.md`,
//! "session 27");
//! comparing "inside" took a mask-register `knot` per vector out of every
//! loop. Tried and not kept: the NaN test once per 64 periods (a running
//! sum), and at AVX2 the packed second words (its 32-bit pieces make no
//! fewer steps); with both, AVX2's worst-case rows ran at 0.8-0.9 of the
//! speed.
//!
//! Why the diagnostics are built this way (kernel alone, `cargo bench --
//! short_rows`, sections "session 9: cargo bench" and "session 15: cargo
//! bench" of `benches/results-short-rows.txt`): moving each mask to a
//! general register and back and testing every lane for NaN was replaced
//! in session 9; in session 15, counting in `u32` lanes per vector (one
//! mask-register move and one add per 16 bits, and mask registers spilled),
//! a `u128` string where a `u64` holds it, field shifts by a run-time
//! count, and the candidate sink's state stored back after every period.
//! Tried in session 22 and not kept: the field arithmetic of eight periods'
//! strings at once in vector lanes (0.72-0.98 of this speed on typical
//! float32 rows at AVX-512: recording the periods afterwards went through
//! the stack; "session 22" in `docs/performance.md`).
//!
//! Rows after the last whole period (fewer than `R`) go to the caller.
//!
//! The same code runs at two levels ([`Vectors`]): a "vector" of `W` values
//! is one AVX-512 register, or two AVX2 registers (`periodic_avx2`), so the
//! period, the intervals' pattern and the verdict string are the same.

use super::prefetch::Prefetch;
use super::bit_string::{any_field, BitCounts, BitTally, Bits};
pub use super::checksum::{NoSums, SumVectors};
use crate::candidates::BitSink;
use crate::kernel::{Period, Prediction, SensorBounds, Tally};

const MAX_VECTORS: usize = crate::bounds::MAX_PERIOD_VECTORS;

/// What the kernel needs of a vector level: loads and comparisons of
/// `T::W512` values at a time, and per-bit counts of the verdict strings.
/// Every method is inlined into the level's entry points, which enable its
/// CPU features.
pub trait Vectors<T: Prediction> {
    type V: Copy;
    type Counts: BitCounts;
    /// # Safety: `T::W512` values from `p` are readable; the level's features are enabled.
    unsafe fn load(p: *const T) -> Self::V;
    /// Bits of the lanes outside `[low, high]` (NaN is outside). # Safety: as `load`.
    unsafe fn outside(x: Self::V, low: Self::V, high: Self::V) -> u32;
    /// Bits of the lanes inside `[low, high]` (NaN is not). # Safety: as `load`.
    unsafe fn inside(x: Self::V, low: Self::V, high: Self::V) -> u32;
    /// Bits of the lanes where `x >= low`, and where `x <= high`. # Safety: as `load`.
    unsafe fn sides(x: Self::V, low: Self::V, high: Self::V) -> (u32, u32);
    /// Bits of the NaN lanes. # Safety: as `load`.
    unsafe fn nan(x: Self::V) -> u32;
    /// `a + b` lane by lane. # Safety: as `load`.
    unsafe fn add(a: Self::V, b: Self::V) -> Self::V;
    /// Whether the diagnostics loop of float32 periods of up to four vectors
    /// reads the intervals from memory (as compare operands) each period
    /// rather than holding them in registers: AVX2's sixteen registers held
    /// the intervals (4 a vector of the period) and spilled the byte counts,
    /// whose store and reload each period were a chain through memory
    /// (`perf annotate`, float32 rows of 6). Typical float32 rows of 4, 6, 8
    /// and 12 ran 1.03-1.17 times as fast through `falsify` with it. With it
    /// for float64 too, float64 periods of five and six vectors, whose loops
    /// did not change, ran 0.86-0.97 times as fast alone (the function's
    /// other arms did), so it is float32's only (`benches/results-short-rows.txt`,
    /// "session 33").
    const INTERVALS_FROM_MEMORY: bool = false;
    /// Whether the diagnostics split the 112-bit strings of float32 rows of
    /// 7 and 14 sensors at bit 56 ([`super::split_string::Split56`]) rather
    /// than keeping a `u128`: alone on one core, typical rows ran 1.09-1.25
    /// times as fast at AVX2 and 0.95-0.99 at AVX-512 (`cargo bench --bench
    /// core_kernels`; `benches/results-short-rows.txt`, "session 33").
    const SPLIT_56: bool = false;
    /// The level's prefetch, taken once a call and held in a register by
    /// the period loops: AVX-512's as chosen for this CPU (`Prefetch::now`),
    /// AVX2's a constant (`Prefetch::FIXED`; a chosen one slowed the AVX2
    /// instance to 0.836-0.923 of its speed: `benches/results-short-rows.txt`,
    /// "session 19: where the time went"). Read again at every line, the
    /// AVX-512 loop loaded the hint from memory for each vector (section
    /// "session 20: the prefetch taken once a call"); `Prefetch::line`
    /// still matches on it at every line.
    #[inline(always)]
    fn prefetch() -> Prefetch {
        Prefetch::now()
    }
}

/// AVX-512: one register a vector.
pub struct Avx512Vectors;

impl<T: Prediction> Vectors<T> for Avx512Vectors {
    type V = T::V512;
    type Counts = BitTally;
    #[inline(always)]
    unsafe fn load(p: *const T) -> T::V512 {
        T::load512(u32::MAX >> (32 - T::W512), p)
    }
    #[inline(always)]
    unsafe fn outside(x: T::V512, low: T::V512, high: T::V512) -> u32 {
        let full = u32::MAX >> (32 - T::W512);
        !T::inside512(full, x, low, high) & full
    }
    #[inline(always)]
    unsafe fn inside(x: T::V512, low: T::V512, high: T::V512) -> u32 {
        T::inside512(u32::MAX >> (32 - T::W512), x, low, high)
    }
    #[inline(always)]
    unsafe fn sides(x: T::V512, low: T::V512, high: T::V512) -> (u32, u32) {
        T::sides512(x, low, high)
    }
    #[inline(always)]
    unsafe fn nan(x: T::V512) -> u32 {
        T::nan512(u32::MAX >> (32 - T::W512), x)
    }
    #[inline(always)]
    unsafe fn add(a: T::V512, b: T::V512) -> T::V512 {
        T::add512(a, b)
    }
}

/// The acceptance intervals of rows of `k` sensors in their period's pattern.
pub struct Periodic<T: Prediction, L: Vectors<T>> {
    low: [L::V; MAX_VECTORS],
    high: [L::V; MAX_VECTORS],
    k: usize,
    /// Vectors, rows, field bits and proper intervals (see [`Period`]).
    period: Period,
}

impl<T: Prediction> Periodic<T, Avx512Vectors> {
    /// See [`Periodic::build`].
    ///
    /// # Safety
    /// AVX-512F is available; `T::period(b)` is `Some`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    pub unsafe fn new(b: &SensorBounds) -> Self {
        Self::build(b, T::period(b).expect("a period this kernel takes"))
    }

    /// See [`Periodic::screen_any`].
    ///
    /// # Safety
    /// AVX-512F, BMI2 and POPCNT are available; `data` holds the rows back to back.
    #[inline]
    #[target_feature(enable = "avx512f,bmi2,popcnt")]
    pub unsafe fn screen<S: SumVectors<T, Avx512Vectors>>(
        &self,
        data: &[T],
        periods: usize,
        out: &mut BitSink,
        sums: &mut S,
    ) {
        self.screen_any(data, periods, out, sums)
    }

    /// See [`Periodic::diagnose_any`].
    ///
    /// # Safety
    /// As [`Self::screen`], and AVX-512BW is available; `t` has `k` sensors.
    #[inline]
    #[target_feature(enable = "avx512f,avx512bw,bmi2,popcnt")]
    pub unsafe fn diagnose<const COUNTS: bool, S: SumVectors<T, Avx512Vectors>>(
        &self,
        data: &[T],
        periods: usize,
        counts: &mut [u32],
        out: &mut BitSink,
        (t, sums): (&mut Tally, &mut S),
    ) {
        // One entry per `COUNTS`: both in one function ran f32 rows of 5 and
        // 10 6-11 % slower at AVX2 (`benches/results-short-rows.txt`,
        // "session 16: one entry per COUNTS").
        self.diagnose_any::<COUNTS, S>(data, periods, counts, out, (t, sums))
    }
}

impl<T: Prediction, L: Vectors<T>> Periodic<T, L> {
    /// The pattern for `b` (rows of `b.len()` sensors): whole-vector loads of
    /// the repeated intervals (lane `l` of vector `v` is sensor
    /// `(v * w + l) % k`) and `period`, worked out in `SensorBounds`. Built
    /// once per block of rows, so nothing here scales with the sensors.
    ///
    /// # Safety
    /// The level's features are enabled; `period` is one of `b`'s for `T`.
    #[inline(always)]
    pub(super) unsafe fn build(b: &SensorBounds, period: Period) -> Self {
        let (k, w, cycle) = (b.len(), T::W512, T::cycled(b));
        assert!(period.vectors <= MAX_VECTORS && period.rows * k == period.vectors * w);
        assert!(cycle[0].len() >= MAX_VECTORS * w && cycle[1].len() >= MAX_VECTORS * w);
        let (mut low, mut high) =
            ([L::load(cycle[0].as_ptr()); MAX_VECTORS], [L::load(cycle[1].as_ptr()); MAX_VECTORS]);
        for v in 1..period.vectors {
            low[v] = L::load(cycle[0].as_ptr().add(v * w));
            high[v] = L::load(cycle[1].as_ptr().add(v * w));
        }
        Periodic { low, high, k, period }
    }

    /// Rows per period: the caller hands the rows after the last whole period elsewhere.
    pub fn rows(&self) -> usize {
        self.period.rows
    }

    /// Rejecting lanes and NaN lanes of the period starting at `p`, one bit
    /// per value (bit `v*W + l` for lane `l` of vector `v`); each vector to `sums`.
    ///
    /// # Safety
    /// The level's features are enabled; `p` points to `rows * k` readable values.
    #[inline(always)]
    unsafe fn period_bits<B: Bits, const P: usize, const NAN: bool, S: SumVectors<T, L>>(
        &self,
        p: *const T,
        (sums, pf): (&mut S, Prefetch),
    ) -> (B, B) {
        let w = T::W512;
        for v in 0..P {
            // One cache line a vector, as far ahead as the row kernels.
            pf.line(p.add(v * w));
        }
        if !NAN {
            // The inside lanes, negated as one string (see `diagnose_pb`).
            let mut inside = [0u32; P];
            for (v, r) in inside.iter_mut().enumerate() {
                let x = L::load(p.add(v * w));
                sums.add(x);
                *r = L::inside(x, self.low[v], self.high[v]);
            }
            let every = B::pattern(self.period.low_bits | self.period.top_bits);
            return (!B::string(&inside, w) & every, B::ZERO);
        }
        let full = u32::MAX >> (32 - w);
        let (mut out, mut nan) = ([0u32; P], [0u32; P]);
        for v in 0..P {
            let x = L::load(p.add(v * w));
            sums.add(x);
            if NAN && self.period.proper {
                let (ge, le) = L::sides(x, self.low[v], self.high[v]);
                (out[v], nan[v]) = (!(ge & le) & full, !(ge | le) & full);
            } else {
                out[v] = L::outside(x, self.low[v], self.high[v]);
                if NAN {
                    nan[v] = L::nan(x);
                }
            }
        }
        (B::string(&out, w), B::string(&nan, w))
    }

    /// One bit per row (bit r: row r) that is set iff the row's field in
    /// `bits` has a bit set, for all `R` rows at once: the carry trick puts
    /// the answer in each field's top bit, `pext` gathers the top bits.
    ///
    /// # Safety
    /// BMI2 is available.
    #[inline(always)]
    unsafe fn any_per_row<B: Bits>(&self, bits: B) -> (B, u32) {
        let (low, top) = (B::pattern(self.period.low_bits), B::pattern(self.period.top_bits));
        let tops = any_field(bits, (low, top));
        (tops, tops.gather(top))
    }

    /// Candidate bits of the first `periods * rows` rows of `data`, into
    /// `out`; their vectors, in order, to `sums`.
    ///
    /// # Safety
    /// The level's features, BMI2 and POPCNT are enabled; `data` holds those
    /// rows back to back.
    #[inline(always)]
    pub(super) unsafe fn screen_any<S: SumVectors<T, L>>(
        &self,
        data: &[T],
        periods: usize,
        out: &mut BitSink,
        sums: &mut S,
    ) {
        // A local sink and local sums: their state stays in registers (behind
        // `&mut`, LLVM stored the sink after each push, as the words written
        // might alias it).
        let mut local = std::mem::replace(out, BitSink::new(&mut [], 0));
        let (sink, mut s) = (&mut local, *sums);
        match self.period.vectors {
            1 => self.screen_p::<1, S>(data, periods, sink, &mut s),
            2 => self.screen_p::<2, S>(data, periods, sink, &mut s),
            3 => self.screen_p::<3, S>(data, periods, sink, &mut s),
            4 => self.screen_p::<4, S>(data, periods, sink, &mut s),
            5 => self.screen_p::<5, S>(data, periods, sink, &mut s),
            6 => self.screen_p::<6, S>(data, periods, sink, &mut s),
            7 => self.screen_p::<7, S>(data, periods, sink, &mut s),
            _ => self.screen_p::<8, S>(data, periods, sink, &mut s),
        }
        (*out, *sums) = (local, s);
    }

    /// [`Self::screen_any`] with `P` vectors a period: unrolled, the lane
    /// patterns and the masks in registers (a loop over a run-time count
    /// spilled them to the stack).
    #[inline(always)]
    unsafe fn screen_p<const P: usize, S: SumVectors<T, L>>(
        &self,
        data: &[T],
        periods: usize,
        sink: &mut BitSink,
        sums: &mut S,
    ) {
        if P * T::W512 <= 64 {
            self.screen_pb::<u64, P, S>(data, periods, sink, sums)
        } else {
            self.screen_pb::<u128, P, S>(data, periods, sink, sums)
        }
    }

    /// [`Self::screen_p`] with the period's bits in `B`.
    #[inline(always)]
    unsafe fn screen_pb<B: Bits, const P: usize, S: SumVectors<T, L>>(
        &self,
        data: &[T],
        periods: usize,
        sink: &mut BitSink,
        sums: &mut S,
    ) {
        let (k, rows) = (self.k, self.period.rows);
        assert!(P == self.period.vectors && P * T::W512 <= B::BITS);
        assert!(data.len() >= periods * rows * k);
        let all = u32::MAX >> (32 - rows);
        let pf = L::prefetch();
        for q in 0..periods {
            let (bits, _) = self.period_bits::<B, P, false, S>(data.as_ptr().add(q * rows * k), (sums, pf));
            let (_, rejected) = self.any_per_row(bits);
            sink.push((!rejected & all) as u64, rows as u32);
        }
    }
}

#[path = "periodic_diagnostics.rs"]
mod diagnostics;

#[cfg(test)]
#[path = "periodic_tests.rs"]
mod tests;
