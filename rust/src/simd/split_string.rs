//! A period's verdict string split at a row boundary, for the periodic
//! kernel's diagnostics of float32 rows of 5, 10 and 20 sensors (80-bit
//! periods, [`Split60`]) and of 7 and 14 (112-bit periods, [`Split56`]).

use super::bit_string::Bits;
use std::arch::x86_64::*;

/// A string of up to 124 bits held as two words split at bit 60, a row
/// boundary for rows of any `k` dividing 60: every row's field lies in one
/// word, so the field arithmetic ([`super::bit_string::row_fields`]: the carry trick, the
/// lowest bit's subtraction, shifts by less than a field) runs on the two
/// words apart, with no carry, borrow or double shift between them as a
/// `u128` has. Shifts act on each word alone, which is right within a
/// field only: the string itself is built as a `u128` and split
/// ([`Bits::string`] below).
#[derive(Clone, Copy, PartialEq)]
pub struct Split<const SPLIT: u32> {
    lo: u64,
    hi: u64,
}

/// Split at bit 60: rows of 5, 10 and 20 sensors (80-bit float32 periods).
pub type Split60 = Split<60>;
/// Split at bit 56: rows of 7 and 14 sensors (112-bit float32 periods).
pub type Split56 = Split<56>;

impl<const SPLIT: u32> Split<SPLIT> {
    #[inline(always)]
    fn of(x: u128) -> Self {
        Split { lo: x as u64 & ((1 << SPLIT) - 1), hi: (x >> SPLIT) as u64 }
    }
}

macro_rules! split_op {
    ($tr:ident, $f:ident, $op:tt) => {
        impl<const S: u32> std::ops::$tr for Split<S> {
            type Output = Self;
            #[inline(always)]
            fn $f(self, o: Self) -> Self {
                Split { lo: self.lo $op o.lo, hi: self.hi $op o.hi }
            }
        }
    };
}
split_op!(BitOr, bitor, |);
split_op!(BitAnd, bitand, &);

impl<const S: u32> std::ops::Not for Split<S> {
    type Output = Self;
    #[inline(always)]
    fn not(self) -> Self {
        Split { lo: !self.lo, hi: !self.hi }
    }
}

impl<const S: u32> std::ops::Shl<usize> for Split<S> {
    type Output = Self;
    #[inline(always)]
    fn shl(self, n: usize) -> Self {
        Split { lo: self.lo << n, hi: self.hi << n }
    }
}

impl<const S: u32> std::ops::Shr<usize> for Split<S> {
    type Output = Self;
    #[inline(always)]
    fn shr(self, n: usize) -> Self {
        Split { lo: self.lo >> n, hi: self.hi >> n }
    }
}

impl<const SPLIT: u32> Bits for Split<SPLIT> {
    const BITS: usize = SPLIT as usize + 64;
    const ZERO: Self = Split { lo: 0, hi: 0 };
    const HI_BASE: usize = SPLIT as usize;
    #[inline(always)]
    fn mask(m: u32) -> Self {
        Split { lo: m.into(), hi: 0 }
    }
    #[inline(always)]
    fn pattern(x: u128) -> Self {
        Self::of(x)
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Split { lo: self.lo.wrapping_add(o.lo), hi: self.hi.wrapping_add(o.hi) }
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        Split { lo: self.lo.wrapping_sub(o.lo), hi: self.hi.wrapping_sub(o.hi) }
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
    /// Both words at once in one 128-bit vector register (SSE2, in every
    /// x86-64): the general registers are this loop's busiest resource, so
    /// the eleven operations a word here cost more there than the moves.
    #[inline(always)]
    fn one_bit_fields(self, (low, top): (Self, Self), k: usize) -> (Self, Self) {
        // SAFETY: SSE2 is part of x86-64.
        unsafe {
            let v = |s: Self| _mm_set_epi64x(s.hi as i64, s.lo as i64);
            let (bits, low, top) = (v(self), v(low), v(top));
            let shift = _mm_cvtsi32_si128(k as i32 - 1);
            let rest = _mm_and_si128(bits, _mm_sub_epi64(_mm_or_si128(bits, top), _mm_srl_epi64(top, shift)));
            let carried = _mm_add_epi64(_mm_and_si128(rest, low), low);
            let several = _mm_and_si128(_mm_or_si128(carried, rest), top);
            let spread = _mm_or_si128(_mm_sub_epi64(several, _mm_srl_epi64(several, shift)), several);
            let single = _mm_andnot_si128(spread, bits);
            let nonzero = _mm_and_si128(_mm_or_si128(_mm_add_epi64(_mm_and_si128(bits, low), low), bits), top);
            let s = |x: __m128i| Split { lo: _mm_cvtsi128_si64(x) as u64, hi: _mm_cvtsi128_si64(_mm_unpackhi_epi64(x, x)) as u64 };
            (s(nonzero), s(single))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::bit_string::row_fields;
    use crate::bounds::Period;

    /// The row verdicts and one-bit fields of random strings, as `u128` and
    /// as [`Split`], against each row's field read one at a time: rows of
    /// 5, 10 and 20 float32 sensors (80-bit periods, [`Split60`]) and of 7
    /// and 14 (112-bit periods, [`Split56`]), fields drawn to be empty,
    /// single or several bits often.
    #[test]
    fn split_strings_match_rows_read_one_by_one() {
        if !std::arch::is_x86_feature_detected!("bmi2") {
            return; // the periodic kernels that use these need BMI2 too
        }
        for k in [5usize, 10, 20] {
            check::<60>(k, 80);
        }
        for k in [7usize, 14] {
            check::<56>(k, 112);
        }
    }

    fn check<const S: u32>(k: usize, bits: usize) {
        let mut state = 0x2545_F491_4F6C_DD1Du64 ^ k as u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let p = Period::new(k, 16, true).expect("a period of float32 rows");
        let (rows, n) = (p.rows, p.vectors * 16);
        assert_eq!(n, bits);
        let of = Split::<S>::of;
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
            // SAFETY: BMI2 is available (checked by the caller).
            let (wide, split) = unsafe {
                (row_fields(x, (p.low_bits, p.top_bits), k), row_fields(of(x), (of(p.low_bits), of(p.top_bits)), k))
            };
            assert_eq!(wide.1, split.1, "rejected rows of {x:#x}, rows of {k}");
            for r in 0..rows {
                let f = x.field(r, k);
                assert_eq!(wide.1 >> r & 1, (f != 0) as u32, "row {r} of {x:#x}");
                let single = if f.count_ones() == 1 { f } else { 0 };
                assert_eq!((wide.2.field(r, k), split.2.field(r, k)), (single, single), "row {r} of {x:#x}");
            }
            let words = |s: Split<S>| [s.word(0), s.word(1)];
            assert_eq!(words(split.2), words(of(wide.2)));
        }
    }
}
