//! A period's verdict string for the periodic kernel ([`super::periodic`]):
//! one bit per value of a period, in a `u64` where it fits, and the
//! per-bit tallies of the diagnostics.

use std::arch::x86_64::*;

/// A period's verdict bits: `u64` when they fit (every f64 period, f32
/// periods of up to four vectors), else `u128`, whose shifts, adds and
/// two `pext` cost several instructions each in the per-period work.
pub trait Bits:
    Copy
    + PartialEq
    + std::ops::BitOr<Output = Self>
    + std::ops::BitAnd<Output = Self>
    + std::ops::Not<Output = Self>
    + std::ops::Shl<usize, Output = Self>
    + std::ops::Shr<usize, Output = Self>
{
    const BITS: usize;
    const ZERO: Self;
    /// A verdict mask (`W` bits).
    fn mask(m: u32) -> Self;
    /// The low `BITS` bits of a [`crate::kernel::Period`] field pattern.
    fn pattern(x: u128) -> Self;
    /// Sum modulo 2^BITS.
    fn add(self, o: Self) -> Self;
    /// Difference modulo 2^BITS.
    fn sub(self, o: Self) -> Self;
    /// The low 64 bits.
    fn low64(self) -> u64;
    /// The bits of `self` at the set bits of `at`, packed low (`pext`).
    ///
    /// # Safety
    /// BMI2 is available.
    unsafe fn gather(self, at: Self) -> u32;

    /// The string of the `w`-bit lane masks `masks`, vector 0 lowest.
    #[inline(always)]
    fn string(masks: &[u32], w: usize) -> Self {
        // Last vector first, one shift at a time: written as a sum of
        // shifted masks, LLVM's SLP vectorizer moved the masks through
        // vector registers and back (18 % slower for f32 rows of 5).
        let mut bits = Self::ZERO;
        for &m in masks.iter().rev() {
            bits = bits << w | Self::mask(m);
        }
        bits
    }
}

/// What `u64` and `u128` strings do alike: their own wrapping arithmetic.
macro_rules! integer_bits {
    ($t:ty) => {
        const BITS: usize = <$t>::BITS as usize;
        const ZERO: Self = 0;
        #[inline(always)]
        fn mask(m: u32) -> Self {
            m.into()
        }
        #[inline(always)]
        fn pattern(x: u128) -> Self {
            x as $t
        }
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            self.wrapping_add(o)
        }
        #[inline(always)]
        fn sub(self, o: Self) -> Self {
            self.wrapping_sub(o)
        }
        #[inline(always)]
        fn low64(self) -> u64 {
            self as u64
        }
    };
}

impl Bits for u64 {
    integer_bits!(u64);
    #[inline(always)]
    unsafe fn gather(self, at: Self) -> u32 {
        _pext_u64(self, at) as u32
    }
}

impl Bits for u128 {
    integer_bits!(u128);
    #[inline(always)]
    unsafe fn gather(self, at: Self) -> u32 {
        let (lo, hi) = (at as u64, (at >> 64) as u64);
        _pext_u64(self as u64, lo) as u32 | (_pext_u64((self >> 64) as u64, hi) as u32).wrapping_shl(lo.count_ones())
    }
}

/// How many periods had each bit of their string set, one byte lane a bit
/// (bit `i` in byte `i`), added to `u64` totals before a byte can overflow.
pub trait BitCounts: Copy {
    /// Periods a byte counts before [`Self::flush`].
    const MAX: u32 = u8::MAX as u32;

    /// # Safety
    /// The level's features are enabled.
    unsafe fn new() -> Self;

    /// Counts the set bits of `x`, of which only the first `n` can be set.
    ///
    /// # Safety
    /// The level's features are enabled.
    unsafe fn add<B: Bits>(self, x: B, n: usize) -> Self;

    /// The bytes, bit `i`'s count in byte `i`.
    ///
    /// # Safety
    /// The level's features are enabled.
    unsafe fn bytes(self) -> [u8; 128];

    /// Adds the byte counts of the first `n` bits to `totals` and starts
    /// again from zero.
    ///
    /// # Safety
    /// The level's features are enabled.
    #[inline(always)]
    unsafe fn flush(self, n: usize, totals: &mut [u64; 128]) -> Self {
        for (t, &c) in totals[..n].iter_mut().zip(&self.bytes()) {
            *t += c as u64;
        }
        Self::new()
    }
}

/// [`BitCounts`] in AVX-512 registers: one masked add per 64 bits
/// (AVX-512BW). (Counting per sensor lane in `u32` lanes took one
/// mask-register move and one add per 16 bits, plus a mask-register spill
/// per vector: the scarce resource on Zen 4.)
#[derive(Clone, Copy)]
pub struct BitTally {
    lo: __m512i,
    hi: __m512i,
}

impl BitCounts for BitTally {
    #[inline(always)]
    unsafe fn new() -> Self {
        BitTally { lo: _mm512_setzero_si512(), hi: _mm512_setzero_si512() }
    }

    #[inline(always)]
    unsafe fn add<B: Bits>(self, x: B, n: usize) -> Self {
        let one = _mm512_set1_epi8(1);
        let lo = _mm512_mask_add_epi8(self.lo, x.low64(), self.lo, one);
        let hi = if n > 64 {
            _mm512_mask_add_epi8(self.hi, (x >> 64).low64(), self.hi, one)
        } else {
            self.hi
        };
        BitTally { lo, hi }
    }

    #[inline(always)]
    unsafe fn bytes(self) -> [u8; 128] {
        let mut b = [0u8; 128];
        _mm512_storeu_si512(b.as_mut_ptr() as *mut __m512i, self.lo);
        _mm512_storeu_si512(b.as_mut_ptr().add(64) as *mut __m512i, self.hi);
        b
    }
}

/// Adds the total of bit `i < n` to `out[i % k]` (bit `i` of a period's
/// string is sensor `i % k`).
pub fn spread(totals: &[u64; 128], n: usize, k: usize, out: &mut [u64]) {
    let mut j = 0;
    for &c in &totals[..n] {
        out[j] += c;
        j = if j + 1 == k { 0 } else { j + 1 };
    }
}
