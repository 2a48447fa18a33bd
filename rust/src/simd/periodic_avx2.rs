//! The periodic kernel (`periodic`) at the AVX2 level: a "vector" of `W`
//! values is two 256-bit registers (f64 four lanes each, f32 eight, compared
//! in their own type with the intervals of the AVX-512 kernels), so rows of 5
//! and 10 sensors are read as a plain stream of whole vectors here too. The
//! per-bit counts of the diagnostics expand 32 verdict bits at a time into
//! byte lanes (`vpshufb`, compare, subtract): AVX2 has no masked byte add.
//!
//! Why: without it, AVX2 rows of 5-8 sensors took one masked load pair and
//! the counts per row, and rows of 9-15 the long-row loop with a scalar
//! tail: f64 rows of 10 with diagnostics ran at 0.17-0.35 of the read floor
//! (`benches/results-short-rows.txt`, "session 15: AVX2 short rows").
//!
//! `pext` (the rows' verdicts) is microcoded on AMD Zen 1 and 2, which have
//! AVX2 but not AVX-512: there the older kernels run ([`fast_pext`]).

use super::bit_string::{BitCounts, Bits};
use super::cpu::Cpu;
use super::prefetch::Prefetch;
use super::periodic::{Periodic, SumVectors, Vectors};
use crate::candidates::BitSink;
use crate::kernel::{Prediction, SensorBounds, Tally};
use std::arch::x86_64::*;

/// AVX2: two registers a vector, the low half first.
pub struct Avx2Vectors;

impl<T: Prediction> Vectors<T> for Avx2Vectors {
    type V = [T::V256; 2];
    type Counts = ByteTally256;
    const INTERVALS_FROM_MEMORY: bool = true;
    const SPLIT_56: bool = true;
    #[inline(always)]
    fn prefetch() -> Prefetch {
        Prefetch::FIXED
    }
    #[inline(always)]
    unsafe fn load(p: *const T) -> Self::V {
        [T::load256(p), T::load256(p.add(T::W512 / 2))]
    }
    #[inline(always)]
    unsafe fn outside(x: Self::V, low: Self::V, high: Self::V) -> u32 {
        let half = T::W512 / 2;
        let inside = T::inside256(x[0], low[0], high[0]) | T::inside256(x[1], low[1], high[1]) << half;
        !inside & (u32::MAX >> (32 - T::W512))
    }
    #[inline(always)]
    unsafe fn inside(x: Self::V, low: Self::V, high: Self::V) -> u32 {
        T::inside256(x[0], low[0], high[0]) | T::inside256(x[1], low[1], high[1]) << (T::W512 / 2)
    }
    #[inline(always)]
    unsafe fn sides(x: Self::V, low: Self::V, high: Self::V) -> (u32, u32) {
        let half = T::W512 / 2;
        let (ge0, le0) = T::sides256(x[0], low[0], high[0]);
        let (ge1, le1) = T::sides256(x[1], low[1], high[1]);
        (ge0 | ge1 << half, le0 | le1 << half)
    }
    #[inline(always)]
    unsafe fn nan(x: Self::V) -> u32 {
        T::nan256(x[0]) | T::nan256(x[1]) << (T::W512 / 2)
    }
    #[inline(always)]
    unsafe fn add(a: Self::V, b: Self::V) -> Self::V {
        [T::add256(a[0], b[0]), T::add256(a[1], b[1])]
    }
}

/// [`BitCounts`] in four AVX2 registers (32 bits each): a 32-bit piece of
/// the string is broadcast, each byte lane picks the byte holding its bit
/// (`vpshufb`), and lanes whose bit is set are all ones after a compare,
/// i.e. -1: subtracting them counts one.
#[derive(Clone, Copy)]
pub struct ByteTally256 {
    bytes: [__m256i; 4],
}

impl BitCounts for ByteTally256 {
    #[inline(always)]
    unsafe fn new() -> Self {
        ByteTally256 {
            bytes: [_mm256_setzero_si256(); 4],
        }
    }

    #[inline(always)]
    unsafe fn add<B: Bits>(self, x: B, n: usize) -> Self {
        let mut bytes = self.bytes;
        for (c, b) in bytes.iter_mut().enumerate() {
            // Piece `c` is word `c / 2`'s bits from 32 (c % 2), at string
            // position `HI_BASE` onwards for word 1. `n` is a constant where
            // this is inlined: unused pieces cost nothing.
            let first = if c < 2 { 32 * c } else { B::HI_BASE + 32 * (c - 2) };
            if first < n {
                *b = _mm256_sub_epi8(*b, bit_bytes((x.word(c / 2) >> (32 * (c % 2))) as u32));
            }
        }
        ByteTally256 { bytes }
    }

    #[inline(always)]
    unsafe fn bytes(self) -> [u8; 128] {
        let mut out = [0u8; 128];
        for (c, b) in self.bytes.iter().enumerate() {
            _mm256_storeu_si256(out.as_mut_ptr().add(32 * c) as *mut __m256i, *b);
        }
        out
    }
}

/// All ones (-1: subtracting it counts one) in byte lane `i` where bit `i`
/// of `piece` is set, else 0.
///
/// # Safety
/// AVX2 is available.
#[inline(always)]
pub(super) unsafe fn bit_bytes(piece: u32) -> __m256i {
    // Byte lane i takes byte i / 8 of the piece (`vpshufb` picks within
    // each 128-bit half, and every half holds the whole piece).
    let pick = _mm256_setr_epi8(
        0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1, //
        2, 2, 2, 2, 2, 2, 2, 2, 3, 3, 3, 3, 3, 3, 3, 3,
    );
    let bit = _mm256_set1_epi64x(0x8040_2010_0804_0201u64 as i64);
    let lanes = _mm256_shuffle_epi8(_mm256_set1_epi32(piece as i32), pick);
    _mm256_cmpeq_epi8(_mm256_and_si256(lanes, bit), bit)
}

impl<T: Prediction> Periodic<T, Avx2Vectors> {
    /// See `Periodic::build`: `T::period(b)`, or else `T::whole_period(b)`.
    ///
    /// # Safety
    /// AVX2 is available; one of the two is `Some`.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn new(b: &SensorBounds) -> Self {
        Self::build(
            b,
            T::period(b)
                .or(T::whole_period(b))
                .expect("a period this kernel takes"),
        )
    }

    /// [`Self::new`] without the repeats of `Period::new` (see
    /// `Period::unrepeated`): the screening loop's period.
    ///
    /// # Safety
    /// As [`Self::new`].
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn unrepeated(b: &SensorBounds) -> Self {
        let period = T::period(b).or(T::whole_period(b)).expect("a period this kernel takes");
        Self::build(b, period.unrepeated(b.len(), T::W512))
    }

    /// See `Periodic::screen_any`.
    ///
    /// # Safety
    /// AVX2, BMI2 and POPCNT are available; `data` holds the rows back to back.
    #[inline]
    #[target_feature(enable = "avx2,bmi2,popcnt")]
    pub unsafe fn screen<S: SumVectors<T, Avx2Vectors>>(&self, data: &[T], periods: usize, out: &mut BitSink, sums: &mut S) {
        self.screen_any(data, periods, out, sums)
    }

    /// See `Periodic::diagnose_any`.
    ///
    /// # Safety
    /// As [`Self::screen`]; `t` has `k` sensors.
    #[inline]
    #[target_feature(enable = "avx2,bmi2,popcnt")]
    pub unsafe fn diagnose<const COUNTS: bool, S: SumVectors<T, Avx2Vectors>>(
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

/// Whether `pext` is fast here: it is one instruction on Intel since
/// Haswell and on AMD since Zen 3 (family 0x19), microcoded (tens to
/// hundreds of cycles) on AMD families before that (Zen 1 and 2, 0x17;
/// Hygon, 0x18).
pub fn fast_pext() -> bool {
    static FAST: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *FAST.get_or_init(|| std::arch::is_x86_feature_detected!("bmi2") && pext_is_fast(Cpu::this()))
}

/// [`fast_pext`] for `cpu` (which has BMI2).
fn pext_is_fast(cpu: Cpu) -> bool {
    !(cpu.amd && cpu.family < 0x19)
}

#[cfg(test)]
mod tests {
    use super::{pext_is_fast, Cpu};

    #[test]
    fn pext_is_slow_on_zen_1_and_2_only() {
        // Zen 1-2 (0x17), Hygon (0x18), Zen 3-4 (0x19), Zen 5 (0x1A), Intel.
        for (amd, family, fast) in [(true, 0x17, false), (true, 0x18, false), (true, 0x19, true), (true, 0x1A, true), (false, 6, true)] {
            assert_eq!(pext_is_fast(Cpu { amd, family }), fast, "{family:#x}");
        }
    }
}
