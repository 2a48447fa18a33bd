//! x86-64 vector kernels, chosen at run time by [`crate::kernel::Isa`].
//!
//! The portable loops in `kernel.rs` reach about half the speed of these:
//! LLVM does not fuse the compare, count and NaN tracking into one vector pass
//! by itself. Residuals are formed in f64 (f32 predictions widened first),
//! exactly as in the portable code, so every level gives the same answer.

pub mod avx2;
pub mod avx512;

use std::arch::x86_64::*;

/// How far ahead of the row being tested its successors are prefetched. The
/// hardware prefetcher alone leaves these short row loops waiting on memory:
/// with this, one core reads at the speed of a plain sum (measured: 1.6x).
const PREFETCH_BYTES: usize = 4096;

/// Asks for the cache lines `PREFETCH_BYTES` past a row of `len` values,
/// i.e. a few rows ahead when rows are contiguous. A prefetch never faults,
/// so addresses past the end of the data are harmless.
#[inline(always)]
pub fn prefetch_ahead<T>(row: &[T]) {
    let ahead = (row.as_ptr() as *const i8).wrapping_add(PREFETCH_BYTES);
    for line in (0..std::mem::size_of_val(row)).step_by(64) {
        // SAFETY: SSE is part of x86-64; prefetching any address is allowed.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(ahead.wrapping_add(line)) };
    }
}

/// Element types that load predictions as f64 lanes.
pub trait Lanes: Copy {
    /// Four values. # Safety: `p` points to four readable values; AVX2 is available.
    unsafe fn load4(p: *const Self) -> __m256d;
    /// Eight values. # Safety: `p` points to eight readable values; AVX-512F is available.
    unsafe fn load8(p: *const Self) -> __m512d;
    /// The first lanes set in `mask` (a prefix), others 0.
    /// # Safety: those lanes are readable; AVX-512F is available.
    unsafe fn load8_masked(mask: __mmask8, p: *const Self) -> __m512d;
}

impl Lanes for f64 {
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn load4(p: *const f64) -> __m256d {
        _mm256_loadu_pd(p)
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn load8(p: *const f64) -> __m512d {
        _mm512_loadu_pd(p)
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn load8_masked(mask: __mmask8, p: *const f64) -> __m512d {
        _mm512_maskz_loadu_pd(mask, p)
    }
}

impl Lanes for f32 {
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn load4(p: *const f32) -> __m256d {
        _mm256_cvtps_pd(_mm_loadu_ps(p))
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn load8(p: *const f32) -> __m512d {
        _mm512_cvtps_pd(_mm256_loadu_ps(p))
    }

    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn load8_masked(mask: __mmask8, p: *const f32) -> __m512d {
        // A masked load never touches the lanes it leaves out.
        _mm512_cvtps_pd(_mm512_castps512_ps256(_mm512_maskz_loadu_ps(
            mask as __mmask16,
            p,
        )))
    }
}
