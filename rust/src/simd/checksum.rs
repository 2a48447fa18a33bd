//! The checksum's inner loop (see [`crate::digest`]) over whole groups of
//! eight little-endian words (64 bytes: eight float64 or sixteen float32
//! values), in AVX-512F and in AVX2. Both compute exactly the sums of the
//! portable definition (`digest::literal`): integer additions modulo 2^64 are
//! associative, so the recurrence below and the definition's products agree
//! bit for bit.
//!
//! Over `m` groups `x_0 .. x_{m-1}` (lane by lane) the loop keeps
//! `s1 = sum x_t` and `s2 = sum (m - t) x_t` (add `s1` into `s2` after each
//! group: two additions, no multiplication), and the same for the high
//! halves `x_t >> 32`; the caller turns `s2` into the position-weighted
//! `sum (j0 + t) x_t = (j0 + m) s1 - s2`. That is five vector operations per
//! 64 bytes (a load, a shift, four additions), on data the falsifier's kernel
//! has just brought into cache. The words are the bytes as they are: float32
//! values are not widened first (version 1 did, with one conversion per
//! eight values on top of the five operations; `cargo bench --bench
//! checksum` now times float64 and float32 on the same bytes,
//! `benches/results-checksum.txt`).
//!
//! [`Fletcher`] is the same recurrence fed by the AVX-512 periodic kernel,
//! one vector at a time as it compares them: there the four additions are
//! all the checksum costs (no load, nothing read twice).

use super::periodic::{Avx512Vectors, Vectors};
use super::periodic_avx2::Avx2Vectors;
use crate::kernel::Prediction;
use std::arch::x86_64::*;

pub use crate::digest::Groups;

/// The recurrence for one group `x` into `(s1, h1, s2, h2)`.
macro_rules! step {
    ($add:ident, $srl:ident, $x:expr, $s1:ident, $h1:ident, $s2:ident, $h2:ident) => {{
        let x = $x;
        $s1 = $add($s1, x);
        $h1 = $add($h1, $srl::<32>(x));
        $s2 = $add($s2, $s1);
        $h2 = $add($h2, $h1);
    }};
}

/// The sums of the `m` groups of 64 bytes at `p`.
///
/// Even and odd groups go to two sets of accumulators (two independent
/// chains of additions: 10 % faster on Zen 4), put together at the end: with
/// `m = 2M`, group `2i` has weight `m - 2i = 2(M - i)` and group `2i + 1`
/// weight `2(M - i) - 1`, so `s2 = 2 s2_even + 2 s2_odd - s1_odd`.
///
/// # Safety
/// AVX-512F is available and `p` points to `64 m` readable bytes.
#[target_feature(enable = "avx512f")]
pub unsafe fn groups_avx512(p: *const u8, m: usize) -> Groups {
    let z = _mm512_setzero_si512();
    let (mut a1, mut ah, mut a2, mut ag) = (z, z, z, z);
    let (mut b1, mut bh, mut b2, mut bg) = (z, z, z, z);
    let load = |t: usize| {
        // SAFETY: group t < m lies within the caller's 64 m bytes.
        unsafe { _mm512_loadu_si512(p.add(64 * t) as *const __m512i) }
    };
    for i in 0..m / 2 {
        step!(_mm512_add_epi64, _mm512_srli_epi64, load(2 * i), a1, ah, a2, ag);
        step!(_mm512_add_epi64, _mm512_srli_epi64, load(2 * i + 1), b1, bh, b2, bg);
    }
    let twice = |v| _mm512_slli_epi64::<1>(v);
    let mut s1 = _mm512_add_epi64(a1, b1);
    let mut h1 = _mm512_add_epi64(ah, bh);
    let mut s2 = _mm512_sub_epi64(twice(_mm512_add_epi64(a2, b2)), b1);
    let mut h2 = _mm512_sub_epi64(twice(_mm512_add_epi64(ag, bg)), bh);
    if m % 2 == 1 {
        // One more group: every earlier weight grows by one (s2 += s1), its own is 1.
        step!(_mm512_add_epi64, _mm512_srli_epi64, load(m - 1), s1, h1, s2, h2);
    }
    let mut out = [[0u64; 8]; 4];
    for (o, v) in out.iter_mut().zip([s1, h1, s2, h2]) {
        // SAFETY: `o` holds exactly 64 bytes.
        unsafe { _mm512_storeu_si512(o.as_mut_ptr() as *mut __m512i, v) };
    }
    out
}

/// What the kernel hands each vector it reads, besides comparing it, in the
/// order of the data: nothing ([`NoSums`]), or the checkpoint checksum's
/// sums ([`Fletcher`]), so that a checkpointed run sums its rows in
/// the pass that screens them instead of reading them again (the vector is
/// in a register already, and the additions fill the kernel's gaps).
pub trait SumVectors<T: Prediction, L: Vectors<T>>: Copy {
    /// # Safety: the level's features are enabled.
    unsafe fn add(&mut self, x: L::V);
}

/// Vectors read are only compared.
#[derive(Clone, Copy)]
pub struct NoSums;

impl<T: Prediction, L: Vectors<T>> SumVectors<T, L> for NoSums {
    #[inline(always)]
    unsafe fn add(&mut self, _: L::V) {}
}

/// The sums of [`groups_avx512`] over groups handed one by one, in order, by
/// the periodic kernel as it reads them (each of its vectors is one group of
/// 64 bytes; see `digest::part_after`): one chain of additions, the kernel's
/// own work filling the gaps between them. `Copy`, so the kernel keeps it in
/// registers.
#[derive(Clone, Copy)]
pub struct Fletcher {
    s1: __m512i,
    h1: __m512i,
    s2: __m512i,
    h2: __m512i,
}

impl Fletcher {
    /// No groups yet.
    ///
    /// # Safety
    /// AVX-512F is available.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn new() -> Self {
        let z = _mm512_setzero_si512();
        Fletcher { s1: z, h1: z, s2: z, h2: z }
    }

    /// The lane sums `[s1, h1, s2, h2]` of the groups so far (as [`groups_avx512`]'s).
    ///
    /// # Safety
    /// AVX-512F is available.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn sums(&self) -> Groups {
        let mut out = [[0u64; 8]; 4];
        for (o, v) in out.iter_mut().zip([self.s1, self.h1, self.s2, self.h2]) {
            // SAFETY: `o` holds exactly 64 bytes.
            unsafe { _mm512_storeu_si512(o.as_mut_ptr() as *mut __m512i, v) };
        }
        out
    }

    /// Adds the next group `x` (the recurrence of `step!`, on fields).
    ///
    /// # Safety
    /// AVX-512F is available.
    #[inline(always)]
    unsafe fn add_group(&mut self, x: __m512i) {
        self.s1 = _mm512_add_epi64(self.s1, x);
        self.h1 = _mm512_add_epi64(self.h1, _mm512_srli_epi64::<32>(x));
        self.s2 = _mm512_add_epi64(self.s2, self.s1);
        self.h2 = _mm512_add_epi64(self.h2, self.h1);
    }
}

impl<T: Prediction> SumVectors<T, Avx512Vectors> for Fletcher {
    #[inline(always)]
    unsafe fn add(&mut self, x: T::V512) {
        self.add_group(T::bits512(x));
    }
}

/// What a row-at-a-time kernel does after each row it has read: nothing
/// ([`NoSums`]), or add to the checksum the groups that the rows read so far
/// fill ([`FletcherRows`]). Rows of three or more vectors do not line up with
/// the checksum's 64-byte groups (a row of 50 float64 is 6.25 groups), so the
/// kernel cannot hand over the vectors it compares; it reloads each group
/// once its last byte has been read, from L1, in the same pass. Summed after
/// the kernel instead (128 KiB at a time, from L2), rows of 50 sensors cost
/// a fifth to a quarter more CPU time than the kernel alone; measured side by side in
/// `docs/performance.md`, "The checkpoint checksum in the kernels' pass".
pub trait RowsRead: Copy {
    /// The rows read so far end at address `end`.
    ///
    /// # Safety
    /// The sums' level is available (for [`FletcherRows`]).
    unsafe fn rows_read(&mut self, end: *const u8);
}

impl RowsRead for NoSums {
    #[inline(always)]
    unsafe fn rows_read(&mut self, _: *const u8) {}
}

/// Running sums of whole groups at one vector level: [`Fletcher`]
/// (AVX-512) or [`Fletcher2`] (AVX2).
pub trait GroupSums: Copy {
    /// Adds the group of 64 bytes at `p`.
    ///
    /// # Safety
    /// The level is available; the 64 bytes are readable.
    unsafe fn add_at(&mut self, p: *const u8);
    /// The lane sums `[s1, h1, s2, h2]` of the groups so far (as [`groups_avx512`]'s).
    ///
    /// # Safety
    /// The level is available.
    unsafe fn lane_sums(&self) -> Groups;
}

impl GroupSums for Fletcher {
    #[inline(always)]
    unsafe fn add_at(&mut self, p: *const u8) {
        self.add_group(_mm512_loadu_si512(p as *const __m512i));
    }
    #[inline(always)]
    unsafe fn lane_sums(&self) -> Groups {
        self.sums()
    }
}

/// The sums `F` of the groups of packed rows, added as a kernel reads the
/// rows ([`RowsRead`]): from the first row, which starts a group, up to the
/// last row whose end is also a group's end (the rows after it are left to
/// the caller, see `summing::part_after`).
#[derive(Clone, Copy)]
pub struct FletcherRows<F: GroupSums> {
    sums: F,
    /// Address of the next group to add.
    next: usize,
    /// End of the rows summed.
    limit: usize,
}

impl<F: GroupSums> FletcherRows<F> {
    /// `sums` (empty) of `rows` rows of `row_bytes` bytes each, stored back
    /// to back from `base` (the start of a checksum group); the rows summed,
    /// a multiple of `64 / gcd(row_bytes, 64)` (at most 15 fewer than `rows`).
    pub fn new(sums: F, base: *const u8, rows: usize, row_bytes: usize) -> (Self, usize) {
        // Rows whose bytes fill whole groups: 64 / gcd(row_bytes, 64).
        let period = 64 >> row_bytes.trailing_zeros().min(6);
        let summed = rows - rows % period;
        let next = base as usize;
        (FletcherRows { sums, next, limit: next + summed * row_bytes }, summed)
    }

    /// The sums of the groups added.
    pub fn sums(&self) -> F {
        self.sums
    }
}

impl<F: GroupSums> RowsRead for FletcherRows<F> {
    #[inline(always)]
    unsafe fn rows_read(&mut self, end: *const u8) {
        let end = (end as usize).min(self.limit);
        while self.next + 64 <= end {
            // SAFETY: the group lies within the rows read (below `end`), and
            // the level is available (the caller's contract).
            unsafe { self.sums.add_at(self.next as *const u8) };
            self.next += 64;
        }
    }
}

/// As [`groups_avx512`], lanes 0-3 and 4-7 of each group in two AVX2 registers.
///
/// # Safety
/// AVX2 is available and `p` points to `64 m` readable bytes.
#[target_feature(enable = "avx2")]
pub unsafe fn groups_avx2(p: *const u8, m: usize) -> Groups {
    let z = _mm256_setzero_si256();
    let (mut s1, mut h1, mut s2, mut h2) = ([z; 2], [z; 2], [z; 2], [z; 2]);
    for t in 0..m {
        for half in 0..2 {
            // SAFETY: group t < m lies within the caller's 64 m bytes.
            let x = unsafe { _mm256_loadu_si256(p.add(64 * t + 32 * half) as *const __m256i) };
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

/// [`Fletcher`] at AVX2: lanes 0-3 and 4-7 of each sum in two registers (as
/// [`groups_avx2`]), fed by the AVX2 kernels as they read (see [`SumVectors`]
/// and [`RowsRead`]).
#[derive(Clone, Copy)]
pub struct Fletcher2 {
    s1: [__m256i; 2],
    h1: [__m256i; 2],
    s2: [__m256i; 2],
    h2: [__m256i; 2],
}

impl Fletcher2 {
    /// No groups yet.
    ///
    /// # Safety
    /// AVX2 is available.
    #[target_feature(enable = "avx2")]
    pub unsafe fn new() -> Self {
        let z = [_mm256_setzero_si256(); 2];
        Fletcher2 { s1: z, h1: z, s2: z, h2: z }
    }

    /// Adds the next group, its words 0-3 in `lo` and 4-7 in `hi`.
    ///
    /// # Safety
    /// AVX2 is available.
    #[inline(always)]
    unsafe fn add_group(&mut self, x: [__m256i; 2]) {
        for half in 0..2 {
            self.s1[half] = _mm256_add_epi64(self.s1[half], x[half]);
            self.h1[half] = _mm256_add_epi64(self.h1[half], _mm256_srli_epi64::<32>(x[half]));
            self.s2[half] = _mm256_add_epi64(self.s2[half], self.s1[half]);
            self.h2[half] = _mm256_add_epi64(self.h2[half], self.h1[half]);
        }
    }
}

impl GroupSums for Fletcher2 {
    #[inline(always)]
    unsafe fn add_at(&mut self, p: *const u8) {
        let half = |h: usize| unsafe { _mm256_loadu_si256(p.add(32 * h) as *const __m256i) };
        self.add_group([half(0), half(1)]);
    }
    #[inline(always)]
    unsafe fn lane_sums(&self) -> Groups {
        let mut out = [[0u64; 8]; 4];
        for (o, v) in out.iter_mut().zip([self.s1, self.h1, self.s2, self.h2]) {
            for half in 0..2 {
                // SAFETY: each half of `o` holds exactly 32 bytes.
                unsafe { _mm256_storeu_si256(o.as_mut_ptr().add(4 * half) as *mut __m256i, v[half]) };
            }
        }
        out
    }
}

impl<T: Prediction> SumVectors<T, Avx2Vectors> for Fletcher2 {
    #[inline(always)]
    unsafe fn add(&mut self, x: [T::V256; 2]) {
        self.add_group([T::bits256(x[0]), T::bits256(x[1])]);
    }
}
