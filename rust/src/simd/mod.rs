//! x86-64 vector kernels, chosen at run time by [`crate::kernel::Isa`].
//!
//! The portable loops in `kernel.rs` are the literal residual test of Eq. 8.
//! These compare predictions with the acceptance intervals of `acceptance`,
//! which give exactly the verdict of the portable code's residual test, so
//! every level gives the same answer.

/// Runs `$body` with `$v` = 0, 1, .. while below `$V` (at most 25),
/// unrolled: LLVM left such a loop rolled for eight f64 vectors, with the
/// counters and the intervals on the stack (half the speed; `medium`).
macro_rules! unrolled {
    ($V:expr, |$v:ident| $body:block) => {
        unrolled!(@ $V, $v, $body, 0 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24)
    };
    (@ $V:expr, $v:ident, $body:block, $($i:literal)*) => {
        $( if $i < $V { let $v: usize = $i; $body } )*
    };
}

/// `$call` with `$V` a constant: the AVX2 vectors of a row of `$k` sensors
/// of type `$T` as `medium_avx2::vectors` gives them (2-25; panics
/// otherwise), so each count gets its own compiled loop.
macro_rules! by_vectors {
    ($T:ty, $k:expr, |$V:ident| $call:expr) => {
        by_vectors!(@ $T, $k, $V, $call, 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20 21 22 23 24 25)
    };
    (@ $T:ty, $k:expr, $V:ident, $call:expr, $($n:literal)*) => {
        match $crate::simd::medium_avx2::vectors::<$T>($k) {
            $(Some($n) => {
                const $V: usize = $n;
                $call
            })*
            v => panic!("rows of 9-96 f64 or 9-200 f32 sensors (2-25 vectors), got {} sensors ({v:?})", $k),
        }
    };
}

pub mod avx2;
pub mod avx512;
pub mod bit_counts;
mod bit_string;
pub mod checksum;
pub mod cpu;
mod long;
pub mod long_avx2;
pub mod medium;
pub mod medium_avx2;
mod medium_avx2_screen;
mod medium_avx2_short;
pub mod periodic;
pub mod periodic_avx2;
pub mod prefetch;
pub mod row_batches;
pub mod short;
pub mod short_avx2;
mod split_string;

use std::arch::x86_64::*;

/// Asks for the cache lines `pf` puts ahead of a row, i.e. a few rows ahead
/// when rows are contiguous.
#[inline(always)]
pub fn prefetch_ahead<T>(pf: prefetch::Prefetch, row: &[T]) {
    let start = row.as_ptr() as *const i8;
    for line in (0..std::mem::size_of_val(row)).step_by(64) {
        pf.line(start.wrapping_add(line));
    }
}

/// A prediction type as vector lanes. The AVX2 short-row kernel
/// (`short_avx2`) widens to f64 and uses the f64 acceptance intervals; the
/// other kernels compare in the type itself (AVX-512: f64 eight to a vector
/// and f32 sixteen; AVX2: four and eight).
pub trait Lanes: Copy {
    /// Four values widened to f64. # Safety: `p` points to four readable values; AVX2 is available.
    unsafe fn load4(p: *const Self) -> __m256d;
    /// The lanes of `m64` (f64 lanes, all ones = load) or of `m32` (the
    /// same for 32-bit lanes) widened to f64, others 0; lanes left out are
    /// never touched. # Safety: the selected lanes are readable; AVX2 is available.
    unsafe fn maskload4(m64: __m256i, m32: __m128i, p: *const Self) -> __m256d;

    /// A 256-bit vector of this type, compared in the type itself (the AVX2
    /// periodic kernel, whose intervals are those of the AVX-512 kernels).
    type V256: Copy;
    /// # Safety: `p` points to a 256-bit vector's worth of readable values; AVX2 is available.
    unsafe fn load256(p: *const Self) -> Self::V256;
    /// Bits of the lanes where `low <= p <= high` (NaN is outside).
    /// # Safety: AVX2 is available.
    unsafe fn inside256(p: Self::V256, low: Self::V256, high: Self::V256) -> u32;
    /// Bits of the lanes where `p < low`, `p > high` or `p` is NaN: the
    /// complement of `inside256` in two comparisons and an `or`.
    /// # Safety: AVX2 is available.
    unsafe fn outside256(p: Self::V256, low: Self::V256, high: Self::V256) -> u32;
    /// The lanes where `low <= p <= high` all ones, the others (NaN among
    /// them) zero, as integer lanes of the type's width (`medium_avx2`
    /// counts them). # Safety: AVX2 is available.
    unsafe fn inside_lanes256(p: Self::V256, low: Self::V256, high: Self::V256) -> __m256i;
    /// Bits of the lanes where `p >= low` and where `p <= high` (see `sides512`).
    /// # Safety: AVX2 is available.
    unsafe fn sides256(p: Self::V256, low: Self::V256, high: Self::V256) -> (u32, u32);
    /// The first `n` lanes from `p` (fewer than a vector's), others 0; lanes
    /// left out are never touched. # Safety: those lanes are readable; AVX2 is available.
    unsafe fn head256(n: usize, p: *const Self) -> Self::V256;
    /// Bits of the lanes where `p` is NaN. # Safety: AVX2 is available.
    unsafe fn nan256(p: Self::V256) -> u32;
    /// `a + b`, lane by lane. # Safety: AVX2 is available.
    unsafe fn add256(a: Self::V256, b: Self::V256) -> Self::V256;
    /// All lanes 0. # Safety: AVX2 is available.
    unsafe fn zero256() -> Self::V256;
    /// The vector's bits as four 64-bit words (no conversion). # Safety: AVX2 is available.
    unsafe fn bits256(p: Self::V256) -> __m256i;

    /// Lanes of an AVX-512 vector.
    const W512: usize;
    type V512: Copy;
    /// The lanes set in `lanes` (a prefix), others 0; unmasked when all are set.
    /// # Safety: those lanes are readable; AVX-512F is available.
    unsafe fn load512(lanes: u32, p: *const Self) -> Self::V512;
    /// Bits of the lanes in `lanes` where `low <= p <= high` (NaN is outside).
    /// # Safety: AVX-512F is available.
    unsafe fn inside512(lanes: u32, p: Self::V512, low: Self::V512, high: Self::V512) -> u32;
    /// Bits of the lanes in `lanes` where `p` is NaN. # Safety: AVX-512F is available.
    unsafe fn nan512(lanes: u32, p: Self::V512) -> u32;
    /// `a + b`, lane by lane (NaN if either is NaN). # Safety: AVX-512F is available.
    unsafe fn add512(a: Self::V512, b: Self::V512) -> Self::V512;
    /// All lanes 0. # Safety: AVX-512F is available.
    unsafe fn zero512() -> Self::V512;
    /// Bits of all lanes where `p >= low` and where `p <= high`, unmasked:
    /// with `low <= high`, a lane is in neither iff `p` is NaN (one
    /// comparison fewer than `inside512` and `nan512`). # Safety: AVX-512F is available.
    unsafe fn sides512(p: Self::V512, low: Self::V512, high: Self::V512) -> (u32, u32);
    /// A lane permutation for `permute512`: lane `l` takes lane `idx[l]` (the
    /// first `W512` entries are used). # Safety: AVX-512F is available.
    unsafe fn index512(idx: &[i32; 16]) -> __m512i;
    /// Lanes of `p` rearranged by an index from `index512`. # Safety: AVX-512F is available.
    unsafe fn permute512(idx: __m512i, p: Self::V512) -> Self::V512;
    /// The vector's bits as eight 64-bit words (no conversion). # Safety: AVX-512F is available.
    unsafe fn bits512(p: Self::V512) -> __m512i;
}

impl Lanes for f64 {
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn load4(p: *const f64) -> __m256d {
        _mm256_loadu_pd(p)
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn maskload4(m64: __m256i, _: __m128i, p: *const f64) -> __m256d {
        _mm256_maskload_pd(p, m64)
    }

    type V256 = __m256d;

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn load256(p: *const f64) -> __m256d {
        _mm256_loadu_pd(p)
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn inside256(p: __m256d, low: __m256d, high: __m256d) -> u32 {
        let inside = _mm256_and_pd(_mm256_cmp_pd::<_CMP_GE_OQ>(p, low), _mm256_cmp_pd::<_CMP_LE_OQ>(p, high));
        _mm256_movemask_pd(inside) as u32
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn outside256(p: __m256d, low: __m256d, high: __m256d) -> u32 {
        let (below, above) = (_mm256_cmp_pd::<_CMP_NGE_UQ>(p, low), _mm256_cmp_pd::<_CMP_NLE_UQ>(p, high));
        let outside = _mm256_or_pd(below, above);
        _mm256_movemask_pd(outside) as u32
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn inside_lanes256(p: __m256d, low: __m256d, high: __m256d) -> __m256i {
        _mm256_castpd_si256(_mm256_and_pd(_mm256_cmp_pd::<_CMP_GE_OQ>(p, low), _mm256_cmp_pd::<_CMP_LE_OQ>(p, high)))
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn sides256(p: __m256d, low: __m256d, high: __m256d) -> (u32, u32) {
        (
            _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_GE_OQ>(p, low)) as u32,
            _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LE_OQ>(p, high)) as u32,
        )
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn head256(n: usize, p: *const f64) -> __m256d {
        let lanes = _mm256_cmpgt_epi64(_mm256_set1_epi64x(n as _), _mm256_setr_epi64x(0, 1, 2, 3));
        _mm256_maskload_pd(p, lanes)
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn nan256(p: __m256d) -> u32 {
        _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_UNORD_Q>(p, p)) as u32
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn add256(a: __m256d, b: __m256d) -> __m256d {
        _mm256_add_pd(a, b)
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn zero256() -> __m256d {
        _mm256_setzero_pd()
    }

    const W512: usize = 8;
    type V512 = __m512d;

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn load512(lanes: u32, p: *const f64) -> __m512d {
        if lanes == 0xFF {
            _mm512_loadu_pd(p)
        } else {
            _mm512_maskz_loadu_pd(lanes as __mmask8, p)
        }
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn inside512(lanes: u32, p: __m512d, low: __m512d, high: __m512d) -> u32 {
        let ge = _mm512_mask_cmp_pd_mask::<_CMP_GE_OQ>(lanes as __mmask8, p, low);
        _mm512_mask_cmp_pd_mask::<_CMP_LE_OQ>(ge, p, high) as u32
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn nan512(lanes: u32, p: __m512d) -> u32 {
        _mm512_mask_cmp_pd_mask::<_CMP_UNORD_Q>(lanes as __mmask8, p, p) as u32
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn add512(a: __m512d, b: __m512d) -> __m512d {
        _mm512_add_pd(a, b)
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn bits512(p: __m512d) -> __m512i {
        _mm512_castpd_si512(p)
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn bits256(p: __m256d) -> __m256i {
        _mm256_castpd_si256(p)
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn zero512() -> __m512d {
        _mm512_setzero_pd()
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn sides512(p: __m512d, low: __m512d, high: __m512d) -> (u32, u32) {
        (
            _mm512_cmp_pd_mask::<_CMP_GE_OQ>(p, low) as u32,
            _mm512_cmp_pd_mask::<_CMP_LE_OQ>(p, high) as u32,
        )
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn index512(idx: &[i32; 16]) -> __m512i {
        _mm512_cvtepi32_epi64(_mm256_loadu_si256(idx.as_ptr() as *const __m256i))
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn permute512(idx: __m512i, p: __m512d) -> __m512d {
        _mm512_permutexvar_pd(idx, p)
    }
}

impl Lanes for f32 {
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn load4(p: *const f32) -> __m256d {
        _mm256_cvtps_pd(_mm_loadu_ps(p))
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn maskload4(_: __m256i, m32: __m128i, p: *const f32) -> __m256d {
        _mm256_cvtps_pd(_mm_maskload_ps(p, m32))
    }

    type V256 = __m256;

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn load256(p: *const f32) -> __m256 {
        _mm256_loadu_ps(p)
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn inside256(p: __m256, low: __m256, high: __m256) -> u32 {
        let inside = _mm256_and_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(p, low), _mm256_cmp_ps::<_CMP_LE_OQ>(p, high));
        _mm256_movemask_ps(inside) as u32
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn outside256(p: __m256, low: __m256, high: __m256) -> u32 {
        let (below, above) = (_mm256_cmp_ps::<_CMP_NGE_UQ>(p, low), _mm256_cmp_ps::<_CMP_NLE_UQ>(p, high));
        let outside = _mm256_or_ps(below, above);
        _mm256_movemask_ps(outside) as u32
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn inside_lanes256(p: __m256, low: __m256, high: __m256) -> __m256i {
        _mm256_castps_si256(_mm256_and_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(p, low), _mm256_cmp_ps::<_CMP_LE_OQ>(p, high)))
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn sides256(p: __m256, low: __m256, high: __m256) -> (u32, u32) {
        (
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(p, low)) as u32,
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(p, high)) as u32,
        )
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn head256(n: usize, p: *const f32) -> __m256 {
        let lanes = _mm256_cmpgt_epi32(_mm256_set1_epi32(n as _), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
        _mm256_maskload_ps(p, lanes)
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn nan256(p: __m256) -> u32 {
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_UNORD_Q>(p, p)) as u32
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn add256(a: __m256, b: __m256) -> __m256 {
        _mm256_add_ps(a, b)
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn zero256() -> __m256 {
        _mm256_setzero_ps()
    }

    const W512: usize = 16;
    type V512 = __m512;

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn load512(lanes: u32, p: *const f32) -> __m512 {
        if lanes == 0xFFFF {
            _mm512_loadu_ps(p)
        } else {
            // A masked load never touches the lanes it leaves out.
            _mm512_maskz_loadu_ps(lanes as __mmask16, p)
        }
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn inside512(lanes: u32, p: __m512, low: __m512, high: __m512) -> u32 {
        let ge = _mm512_mask_cmp_ps_mask::<_CMP_GE_OQ>(lanes as __mmask16, p, low);
        _mm512_mask_cmp_ps_mask::<_CMP_LE_OQ>(ge, p, high) as u32
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn nan512(lanes: u32, p: __m512) -> u32 {
        _mm512_mask_cmp_ps_mask::<_CMP_UNORD_Q>(lanes as __mmask16, p, p) as u32
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn add512(a: __m512, b: __m512) -> __m512 {
        _mm512_add_ps(a, b)
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn bits512(p: __m512) -> __m512i {
        _mm512_castps_si512(p)
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn bits256(p: __m256) -> __m256i {
        _mm256_castps_si256(p)
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn zero512() -> __m512 {
        _mm512_setzero_ps()
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn sides512(p: __m512, low: __m512, high: __m512) -> (u32, u32) {
        (
            _mm512_cmp_ps_mask::<_CMP_GE_OQ>(p, low) as u32,
            _mm512_cmp_ps_mask::<_CMP_LE_OQ>(p, high) as u32,
        )
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn index512(idx: &[i32; 16]) -> __m512i {
        _mm512_loadu_si512(idx.as_ptr() as *const __m512i)
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn permute512(idx: __m512i, p: __m512) -> __m512 {
        _mm512_permutexvar_ps(idx, p)
    }
}
