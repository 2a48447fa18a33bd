//! The checksum's inner loop (see [`crate::digest`]) over whole groups of
//! eight canonical words, in AVX-512F and in AVX2. Both compute exactly the
//! sums of the portable definition (`digest::literal`): integer additions
//! modulo 2^64 are associative, so the recurrence below and the definition's
//! products agree bit for bit.
//!
//! Over `m` groups `x_0 .. x_{m-1}` (lane by lane) the loop keeps
//! `s1 = sum x_t` and `s2 = sum (m - t) x_t` (add `s1` into `s2` after each
//! group: two additions, no multiplication), and the same for the high
//! halves `x_t >> 32`; the caller turns `s2` into the position-weighted
//! `sum (j0 + t) x_t = (j0 + m) s1 - s2`. That is five vector operations per
//! 64 bytes of float64 (a load, a shift, four additions), all on data the
//! falsifier's kernel has just brought into cache.

use std::arch::x86_64::*;

/// Lane sums of whole groups: `[s1, h1, s2, h2]`, eight lanes each.
pub type Groups = [[u64; 8]; 4];

/// A prediction type read as canonical words (the bits of its float64 value).
pub trait Words: Copy {
    /// The lane sums of the `values.len() / 8` whole groups of `values`.
    /// # Safety: AVX-512F is available.
    unsafe fn groups_avx512(values: &[Self]) -> Groups;
    /// As `groups_avx512`, lanes 0-3 and 4-7 in two AVX2 registers.
    /// # Safety: AVX2 is available.
    unsafe fn groups_avx2(values: &[Self]) -> Groups;
}

/// The AVX-512 loop, with `$load(p)` giving eight words from `p` (written
/// out per type so that the load is inlined into the loop).
macro_rules! groups_avx512 {
    ($name:ident, $t:ty, $load:expr) => {
        #[target_feature(enable = "avx512f")]
        unsafe fn $name(values: &[$t]) -> Groups {
            let m = values.len() / 8;
            let p = values.as_ptr();
            let (mut s1, mut h1) = (_mm512_setzero_si512(), _mm512_setzero_si512());
            let (mut s2, mut h2) = (_mm512_setzero_si512(), _mm512_setzero_si512());
            for t in 0..m {
                // SAFETY: group t lies within `values` (t < len / 8).
                let x = unsafe { $load(p.add(8 * t)) };
                s1 = _mm512_add_epi64(s1, x);
                h1 = _mm512_add_epi64(h1, _mm512_srli_epi64::<32>(x));
                s2 = _mm512_add_epi64(s2, s1);
                h2 = _mm512_add_epi64(h2, h1);
            }
            let mut out = [[0u64; 8]; 4];
            for (o, v) in out.iter_mut().zip([s1, h1, s2, h2]) {
                // SAFETY: `o` holds exactly 64 bytes.
                unsafe { _mm512_storeu_si512(o.as_mut_ptr() as *mut __m512i, v) };
            }
            out
        }
    };
}

/// The AVX2 loop, with `$load(p)` giving four words from `p`.
macro_rules! groups_avx2 {
    ($name:ident, $t:ty, $load:expr) => {
        #[target_feature(enable = "avx2")]
        unsafe fn $name(values: &[$t]) -> Groups {
            let m = values.len() / 8;
            let p = values.as_ptr();
            let z = _mm256_setzero_si256();
            let (mut s1, mut h1, mut s2, mut h2) = ([z; 2], [z; 2], [z; 2], [z; 2]);
            for t in 0..m {
                for half in 0..2 {
                    // SAFETY: group t lies within `values` (t < len / 8).
                    let x = unsafe { $load(p.add(8 * t + 4 * half)) };
                    s1[half] = _mm256_add_epi64(s1[half], x);
                    h1[half] = _mm256_add_epi64(h1[half], _mm256_srli_epi64::<32>(x));
                    s2[half] = _mm256_add_epi64(s2[half], s1[half]);
                    h2[half] = _mm256_add_epi64(h2[half], h1[half]);
                }
            }
            let mut out = [[0u64; 8]; 4];
            for (o, v) in out.iter_mut().zip([s1, h1, s2, h2]) {
                for half in 0..2 {
                    // SAFETY: each half of `o` holds exactly 32 bytes.
                    unsafe { _mm256_storeu_si256(o.as_mut_ptr().add(4 * half) as *mut __m256i, v[half]) };
                }
            }
            out
        }
    };
}

groups_avx512!(f64_avx512, f64, |p: *const f64| _mm512_loadu_si512(
    p as *const __m512i
));
// Exact widening, as `f64::from` (the same conversion instruction).
groups_avx512!(f32_avx512, f32, |p: *const f32| _mm512_castpd_si512(
    _mm512_cvtps_pd(_mm256_loadu_ps(p))
));
groups_avx2!(f64_avx2, f64, |p: *const f64| _mm256_loadu_si256(
    p as *const __m256i
));
groups_avx2!(f32_avx2, f32, |p: *const f32| _mm256_castpd_si256(
    _mm256_cvtps_pd(_mm_loadu_ps(p))
));

impl Words for f64 {
    unsafe fn groups_avx512(values: &[f64]) -> Groups {
        // SAFETY: the caller guarantees AVX-512F.
        unsafe { f64_avx512(values) }
    }

    unsafe fn groups_avx2(values: &[f64]) -> Groups {
        // SAFETY: the caller guarantees AVX2.
        unsafe { f64_avx2(values) }
    }
}

impl Words for f32 {
    unsafe fn groups_avx512(values: &[f32]) -> Groups {
        // SAFETY: the caller guarantees AVX-512F.
        unsafe { f32_avx512(values) }
    }

    unsafe fn groups_avx2(values: &[f32]) -> Groups {
        // SAFETY: the caller guarantees AVX2.
        unsafe { f32_avx2(values) }
    }
}
