//! A period's verdict string for the periodic kernel ([`super::periodic`]):
//! one bit per value of a period, in a `u64` where it fits, and the
//! per-bit tallies of the diagnostics.

use std::arch::x86_64::*;

/// A period's verdict bits: `u64` when they fit (every f64 period, f32
/// periods of up to four vectors), else [`Split60`] where the rows allow
/// (the diagnostics of rows of 5 and 10) or `u128`, whose shifts, adds and
/// two `pext` cost several instructions each in the per-period work.
///
/// The kernels use the arithmetic only within a row's field (see
/// [`row_fields`]), which is what lets a `Split60` do it per word.
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
    /// Sum, wrapping (a `Split60` per word: no carry leaves a field).
    fn add(self, o: Self) -> Self;
    /// Difference, wrapping (a `Split60` per word: no borrow leaves a field).
    fn sub(self, o: Self) -> Self;
    /// The low 64 bits (a `Split60`: its first word).
    fn low64(self) -> u64;
    /// The bits of `self` at the set bits of `at`, packed low (`pext`).
    ///
    /// # Safety
    /// BMI2 is available.
    unsafe fn gather(self, at: Self) -> u32;

    /// The fields of `self` with exactly one bit set, whole; the others 0
    /// (field patterns `(low, top)` of [`crate::kernel::Period`], fields of
    /// `k` bits). See [`row_fields`].
    #[inline(always)]
    fn one_bit_fields(self, (low, top): (Self, Self), k: usize) -> (Self, Self) {
        // `self` without each field's lowest set bit: `| top` keeps a zero
        // field from borrowing from the next.
        let rest = self & (self | top).sub(top >> (k - 1));
        let several = any_field(rest, (low, top));
        (any_field(self, (low, top)), self & !(several.sub(several >> (k - 1)) | several))
    }

    /// String position of bit 0 of the second word (see [`Self::word`]).
    const HI_BASE: usize = 64;

    /// Word `c` (0 or 1) of the string: its bits `64 c ..` (a [`Split60`]
    /// string's second word starts at position 60).
    #[inline(always)]
    fn word(self, c: usize) -> u64 {
        if c == 0 || Self::BITS <= 64 {
            self.low64() & if c == 0 { u64::MAX } else { 0 }
        } else {
            (self >> 64).low64()
        }
    }

    /// The `k` bits of row `r`'s field, low.
    #[inline(always)]
    fn field(self, r: usize, k: usize) -> u64 {
        (self >> (r * k)).low64() & ((1u64 << k) - 1)
    }

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

/// The top bit of every field of `bits` that has a bit set (the carry
/// trick; field patterns `(low, top)` of [`crate::kernel::Period`]).
#[inline(always)]
pub fn any_field<B: Bits>(bits: B, (low, top): (B, B)) -> B {
    ((bits & low).add(low) | bits) & top
}

/// Per-row verdicts of a period's string `bits` (rows of `k` sensors, field
/// patterns `(low, top)` of [`crate::kernel::Period`]): the top bits of the
/// non-zero fields, their rows as bits (bit `r`: row `r` rejected, `pext`),
/// and the fields with exactly one bit, whole (their bit is the sensor that
/// alone rejected the row). All rows at once, no branch:
///
/// - the carry trick: `(f & low) + low` carries into the top bit iff a low
///   bit is set, so `((f & low) + low | f) & top` is the field's top bit iff
///   `f != 0`;
/// - `f & (f - 1)` is non-zero iff `f` has two bits or more; the `- 1` is
///   subtracting bit 0 of the non-zero fields only (a zero field would
///   borrow from the next);
/// - a one-bit field's top bit `t` becomes the whole field as `(t - t >> (k
///   - 1)) | t`.
///
/// Every step stays within a field (no carry or borrow leaves one), which is
/// what lets [`Split60`] run it on two words apart.
///
/// # Safety
/// BMI2 is available.
#[inline(always)]
pub unsafe fn row_fields<B: Bits>(bits: B, (low, top): (B, B), k: usize) -> (B, u32, B) {
    let (nonzero, single) = bits.one_bit_fields((low, top), k);
    (nonzero, nonzero.gather(top), single)
}

/// How many periods had each position of their string set, one byte lane a
/// position (word 0's bit `i` in byte `i`, word 1's in byte `64 + i`, see
/// [`Bits::word`]), added to `u64` totals before a byte can overflow.
pub trait BitCounts: Copy {
    /// Periods a byte counts before [`Self::flush`].
    const MAX: u32 = u8::MAX as u32;
    /// Whether a kernel counts two strings' short second words as one word
    /// (see `periodic`): where a count costs a word's mask-register move
    /// (AVX-512), not where it costs a step per 32 bits (AVX2).
    const PACK: bool = false;

    /// # Safety
    /// The level's features are enabled.
    unsafe fn new() -> Self;

    /// Counts the set bits of `x`, a string of `n` positions (only the
    /// positions below `n` can be set).
    ///
    /// # Safety
    /// The level's features are enabled.
    unsafe fn add<B: Bits>(self, x: B, n: usize) -> Self;

    /// The bytes, in the order of [`BitCounts`].
    ///
    /// # Safety
    /// The level's features are enabled.
    unsafe fn bytes(self) -> [u8; 128];

    /// Adds the byte counts to `totals` and starts again from zero. (Every
    /// byte: a string's second word can start before bit 64, see
    /// [`Bits::word`]; a flush is rare.)
    ///
    /// # Safety
    /// The level's features are enabled.
    #[inline(always)]
    unsafe fn flush(self, totals: &mut [u64; 128]) -> Self {
        for (t, &c) in totals.iter_mut().zip(&self.bytes()) {
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
    const PACK: bool = true;

    #[inline(always)]
    unsafe fn new() -> Self {
        BitTally { lo: _mm512_setzero_si512(), hi: _mm512_setzero_si512() }
    }

    #[inline(always)]
    unsafe fn add<B: Bits>(self, x: B, n: usize) -> Self {
        let lo = count_byte_lanes(self.lo, x.word(0));
        let hi = if n > B::HI_BASE { count_byte_lanes(self.hi, x.word(1)) } else { self.hi };
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

/// Adds the totals of a string of `n` positions to `out`, position `i` being
/// sensor `i % k`: totals `0..64` are word 0's bits (positions `0..`), the
/// rest word 1's (positions `hi_base..`, see [`Bits::word`]).
pub fn spread(totals: &[u64; 128], (n, hi_base): (usize, usize), k: usize, out: &mut [u64]) {
    let (first, second) = (n.min(hi_base), n.saturating_sub(hi_base));
    let words = [(&totals[..first], 0), (&totals[64..64 + second], hi_base)];
    for (counts, base) in words {
        for (i, &c) in counts.iter().enumerate() {
            out[(base + i) % k] += c;
        }
    }
}

/// `a` with 1 added to the byte lanes whose bit of `k` is set: one masked
/// subtract of -1. Written as `_mm512_mask_add_epi8`, LLVM emits a mask
/// expansion (`vpmovm2b`) and a plain subtract, two 512-bit operations
/// instead of one: typical f32 rows of 5 and 10 ran 1.03-1.04 times as fast
/// with this one (`cargo bench --bench core_kernels`, Zen 4; section
/// "session 27: the byte count as one masked subtract" of
/// `benches/results-short-rows.txt`).
///
/// # Safety
/// AVX-512F and AVX-512BW are available.
#[inline]
#[target_feature(enable = "avx512f,avx512bw")]
unsafe fn count_byte_lanes(mut a: __m512i, k: u64) -> __m512i {
    let m1 = _mm512_set1_epi8(-1);
    std::arch::asm!("vpsubb {a}{{{k}}}, {a}, {m}", a = inout(zmm_reg) a, k = in(kreg) k, m = in(zmm_reg) m1, options(pure, nomem, nostack));
    a
}
