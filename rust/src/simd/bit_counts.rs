//! Bit-sliced counters: how often each bit position of a stream of vectors
//! was set, for "falsified only by" (one bit per row rejected by a single
//! sensor, the bit being the sensor).
//!
//! Why: in the typical case (most rows falsified, each sensor rejecting a
//! few of them) a sixth of the rows of 10 sensors has exactly one rejecting
//! sensor, and adding those bits to per-lane counters one mask at a time
//! (shift, move to a mask register, masked add, per row or per 16 bits)
//! halved the speed of the short-row kernels with diagnostics. Here a
//! vector of such bits is added to `PLANES` bit planes by a ripple of
//! `and`/`xor` (plane `p` holds bit `p` of every position's count): two
//! plain vector operations per plane, whatever the number of bits set.
//! The planes go to integer counts every `FLUSH_EVERY` additions, before
//! they can overflow.

use std::arch::x86_64::*;

/// Bits of count per position held in the vector planes.
const PLANES: usize = 8;
/// Additions between flushes: the planes count up to `2^PLANES - 1`.
const FLUSH_EVERY: u32 = (1 << PLANES) - 1;

/// Counts per bit position of 512-bit vectors read as 16 lanes of 32 bits,
/// summed over the lanes. The planes are plain values (no counts array
/// beside them), so that a kernel keeps them in registers.
#[derive(Clone, Copy)]
pub struct BitPlanes {
    planes: [__m512i; PLANES],
    added: u32,
}

impl BitPlanes {
    /// # Safety
    /// AVX-512F is available.
    #[inline(always)]
    pub unsafe fn new() -> Self {
        BitPlanes { planes: [_mm512_setzero_si512(); PLANES], added: 0 }
    }

    /// Counts the bits set in `x`; true when the planes are full and must
    /// go to `flush` before the next addition.
    ///
    /// # Safety
    /// AVX-512F is available.
    #[inline(always)]
    pub unsafe fn add(&mut self, x: __m512i) -> bool {
        let mut carry = x;
        for p in &mut self.planes {
            let next = _mm512_and_si512(*p, carry);
            *p = _mm512_xor_si512(*p, carry);
            carry = next;
        }
        self.added += 1;
        self.added == FLUSH_EVERY
    }

    /// Adds the planes' counts to `counts` (`counts[b]`: times bit `b` was
    /// set in any lane) and empties them. Out of line: it runs once every
    /// `FLUSH_EVERY` additions.
    ///
    /// # Safety
    /// AVX-512F and POPCNT are available.
    #[inline(never)]
    #[target_feature(enable = "avx512f,popcnt")]
    pub unsafe fn flush(&mut self, counts: &mut [u64; 32]) {
        for (p, plane) in self.planes.iter_mut().enumerate() {
            if _mm512_test_epi32_mask(*plane, *plane) != 0 {
                for (b, c) in counts.iter_mut().enumerate() {
                    let set = _mm512_test_epi32_mask(*plane, _mm512_set1_epi32(1 << b));
                    *c += (set.count_ones() as u64) << p;
                }
            }
            *plane = _mm512_setzero_si512();
        }
        self.added = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Counts the bits of many pseudo-random words both ways, across
    /// several flushes.
    #[test]
    fn counts_match_a_plain_count() {
        if !(std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("popcnt")) {
            return; // the kernels that use these counts need AVX-512F too
        }
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        // SAFETY: AVX-512F and POPCNT are available (checked).
        unsafe {
            let (mut planes, mut counts, mut expect) = (BitPlanes::new(), [0u64; 32], [0u64; 32]);
            for _ in 0..1000 {
                let words: [u32; 16] = std::array::from_fn(|_| (next() & next()) as u32);
                for w in words {
                    for (b, e) in expect.iter_mut().enumerate() {
                        *e += (w >> b & 1) as u64;
                    }
                }
                if planes.add(_mm512_loadu_si512(words.as_ptr() as *const __m512i)) {
                    planes.flush(&mut counts);
                }
            }
            planes.flush(&mut counts);
            assert_eq!(counts, expect);
        }
    }
}
