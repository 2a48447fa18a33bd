//! A period's verdict string for the periodic kernel ([`super::periodic`]):
//! one bit per value of a period, in a `u64` where it fits, and the
//! per-bit tallies of the diagnostics.

use std::arch::x86_64::*;

/// A period's verdict bits: `u64` when they fit (every f64 period, f32
/// periods of up to four vectors), else [`Split60`] where the rows allow
/// (the diagnostics of rows of 5 and 10) or `u128`, whose shifts, adds and
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
    let any = |f: B| ((f & low).add(low) | f) & top;
    let nonzero = any(bits);
    let several = any(bits & bits.sub(nonzero >> (k - 1)));
    let one = nonzero & !several;
    (nonzero, nonzero.gather(top), bits & (one.sub(one >> (k - 1)) | one))
}

/// A string of up to 124 bits held as two words split at bit 60, a row
/// boundary of rows of 5, 6, 10, 12, 15, 20 and 30 sensors: every row's
/// field lies in one word, so the field arithmetic (the carry trick, the
/// lowest bit's subtraction, shifts by less than a field) runs on the two
/// words apart, with no carry, borrow or double shift between them as a
/// `u128` has. Shifts act on each word alone: they are only used within
/// a field.
#[derive(Clone, Copy, PartialEq)]
pub struct Split60 {
    lo: u64,
    hi: u64,
}

const SPLIT: u32 = 60;

impl Split60 {
    #[inline(always)]
    fn of(x: u128) -> Self {
        Split60 { lo: x as u64 & ((1 << SPLIT) - 1), hi: (x >> SPLIT) as u64 }
    }
}

macro_rules! split_op {
    ($tr:ident, $f:ident, $op:tt) => {
        impl std::ops::$tr for Split60 {
            type Output = Self;
            #[inline(always)]
            fn $f(self, o: Self) -> Self {
                Split60 { lo: self.lo $op o.lo, hi: self.hi $op o.hi }
            }
        }
    };
}
split_op!(BitOr, bitor, |);
split_op!(BitAnd, bitand, &);

impl std::ops::Not for Split60 {
    type Output = Self;
    #[inline(always)]
    fn not(self) -> Self {
        Split60 { lo: !self.lo, hi: !self.hi }
    }
}

impl std::ops::Shl<usize> for Split60 {
    type Output = Self;
    #[inline(always)]
    fn shl(self, n: usize) -> Self {
        Split60 { lo: self.lo << n, hi: self.hi << n }
    }
}

impl std::ops::Shr<usize> for Split60 {
    type Output = Self;
    #[inline(always)]
    fn shr(self, n: usize) -> Self {
        Split60 { lo: self.lo >> n, hi: self.hi >> n }
    }
}

impl Bits for Split60 {
    const BITS: usize = 124;
    const ZERO: Self = Split60 { lo: 0, hi: 0 };
    const HI_BASE: usize = SPLIT as usize;
    #[inline(always)]
    fn mask(m: u32) -> Self {
        Split60 { lo: m.into(), hi: 0 }
    }
    #[inline(always)]
    fn pattern(x: u128) -> Self {
        Self::of(x)
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Split60 { lo: self.lo.wrapping_add(o.lo), hi: self.hi.wrapping_add(o.hi) }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Split60 { lo: self.lo.wrapping_sub(o.lo), hi: self.hi.wrapping_sub(o.hi) }
    }
    #[inline(always)]
    fn low64(self) -> u64 {
        self.lo
    }
    #[inline(always)]
    unsafe fn gather(self, at: Self) -> u32 {
        _pext_u64(self.lo, at.lo) as u32 | (_pext_u64(self.hi, at.hi) as u32).wrapping_shl(at.lo.count_ones())
    }
    #[inline(always)]
    fn word(self, c: usize) -> u64 {
        if c == 0 {
            self.lo
        } else {
            self.hi
        }
    }
    #[inline(always)]
    fn field(self, r: usize, k: usize) -> u64 {
        let at = r * k;
        let w = if at < SPLIT as usize { self.lo >> at } else { self.hi >> (at - SPLIT as usize) };
        w & ((1u64 << k) - 1)
    }
    #[inline(always)]
    fn string(masks: &[u32], w: usize) -> Self {
        Self::of(<u128 as Bits>::string(masks, w))
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
    #[inline(always)]
    unsafe fn new() -> Self {
        BitTally { lo: _mm512_setzero_si512(), hi: _mm512_setzero_si512() }
    }

    #[inline(always)]
    unsafe fn add<B: Bits>(self, x: B, n: usize) -> Self {
        let one = _mm512_set1_epi8(1);
        let lo = _mm512_mask_add_epi8(self.lo, x.word(0), self.lo, one);
        let hi = if n > 64 {
            _mm512_mask_add_epi8(self.hi, x.word(1), self.hi, one)
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bounds::Period;

    /// The row verdicts and one-bit fields of random strings, as `u128` and
    /// as [`Split60`], against each row's field read one at a time: rows of
    /// 5, 10 and 20 float32 sensors (80-bit periods), fields drawn to be
    /// empty, single or several bits often.
    #[test]
    fn split_strings_match_rows_read_one_by_one() {
        if !std::arch::is_x86_feature_detected!("bmi2") {
            return; // the periodic kernels that use these need BMI2 too
        }
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for k in [5usize, 10, 20] {
            let p = Period::new(k, 16, true).expect("a period of float32 rows");
            let (rows, n) = (p.rows, p.vectors * 16);
            assert_eq!(n, 80);
            for _ in 0..20_000 {
                let mut x = 0u128;
                for r in 0..rows {
                    let f = match next() % 4 {
                        0 => 0,
                        1 => 1u64 << (next() % k as u64),
                        _ => next() & next() & ((1u64 << k) - 1),
                    };
                    x |= (f as u128) << (r * k);
                }
                // SAFETY: BMI2 is available (checked).
                let (wide, split) = unsafe {
                    (
                        row_fields(x, (p.low_bits, p.top_bits), k),
                        row_fields(Split60::of(x), (Split60::of(p.low_bits), Split60::of(p.top_bits)), k),
                    )
                };
                assert_eq!(wide.1, split.1, "rejected rows of {x:#x}, rows of {k}");
                for r in 0..rows {
                    let f = x.field(r, k);
                    assert_eq!(wide.1 >> r & 1, (f != 0) as u32, "row {r} of {x:#x}");
                    let single = if f.count_ones() == 1 { f } else { 0 };
                    assert_eq!((wide.2.field(r, k), split.2.field(r, k)), (single, single), "row {r} of {x:#x}");
                }
                let words = |s: Split60| [s.word(0), s.word(1)];
                assert_eq!(words(split.2), words(Split60::of(wide.2)));
            }
        }
    }
}
