//! Block checksums of model-instance rows, so a resumed run can tell that the
//! input it re-reads is, row for row, the one its checkpoint was made from.
//!
//! **What is summed.** Every value as its *canonical word*: the 64 bits of its
//! float64 value (float32 widened exactly), in row-major instance order,
//! whatever the source's dtype, byte order, memory layout or chunking. Rows
//! are grouped in fixed blocks of [`BLOCK_ROWS`] instances counted from
//! instance 0; block checksums depend on the instance index only.
//!
//! **The checksum** ([`ALGORITHM`], a Fletcher-style sum over eight lanes).
//! In a block of `R` rows and `C` columns, word `w_k` (`k = r C + c`) goes to
//! lane `l = k mod 8` at step `j = k div 8`. Per lane, modulo 2^64:
//!
//! ```text
//! A_l = sum w_k        H_l = sum (w_k >> 32)        (plain sums)
//! B_l = sum j w_k      G_l = sum j (w_k >> 32)      (position-weighted sums)
//! ```
//!
//! and the block's 128-bit checksum mixes `(C, R, A, H, B, G)` (see
//! [`finish`]). [`literal`] is this definition word by word (the oracle of
//! the tests); the vector levels ([`crate::kernel::Isa`]) compute the same
//! sums with additions only.
//!
//! **Why it catches accidental change.** With 32-bit halves `lo`, `hi` of each
//! word, `(A, H)` give the exact integer sums of the `lo` and of the `hi`
//! halves of each lane (no sum of fewer than 2^32 halves overflows), and
//! `(B, G)` their position-weighted sums modulo 2^64. A change with
//! differences `d_k` (each below 2^32 in size) in one lane's halves goes
//! unseen only if `sum d_k = 0` exactly and `sum j_k d_k = 0 mod 2^64`. With at
//! most two changed words in a lane this forces `d = 0` as long as a lane has
//! fewer than 2^32 steps (rows of fewer than 2^19 columns). So **every change
//! of at most two words per lane in a block is detected, with certainty**:
//! any one or two flipped bits, any changed value, any swap of two values,
//! any change within one row of up to 16 columns, any swap of two rows of up
//! to 8 columns. Larger changes (regenerated rows, swapped columns, shifted
//! or truncated data) go unseen only if, in every lane, both halves keep their
//! exact sum *and* their first moment, which values that changed by accident
//! do not do (a swap of two columns, for example, is seen unless the two
//! columns hold, in every lane, halves of equal sum and equal moment). The
//! row count is part of every block's checksum, so a truncated block differs.
//!
//! This guards against accidental change (an edited, regenerated, shifted or
//! damaged input), not deliberate tampering: anyone can make a different input
//! with the same sums. The checkpoint's own files carry sha256 checksums.
//!
//! Summing instead of hashing is what makes it nearly free: the sums are
//! additive, so any rows can be summed apart (by the falsifier's threads,
//! right after the kernel has read them) and the parts added in any order.

use crate::error::{EdmfError, Result};
use crate::kernel::Isa;
use crate::matrix::Matrix;
use rayon::prelude::*;
use rayon::ThreadPool;

/// Name and version of the checksum, recorded in checkpoints.
pub const ALGORITHM: &str = "fletcher64x8/1";
/// Instances per block: the unit a checkpoint records and names when it differs.
pub const BLOCK_ROWS: usize = 65_536;
/// Rows summed in one piece (one parallel task; the falsifier's kernel block).
pub const PIECE_ROWS: usize = 1024;
/// Lanes of the checksum.
pub const LANES: usize = 8;

#[cfg(target_arch = "x86_64")]
use crate::simd::checksum::Words;
#[cfg(not(target_arch = "x86_64"))]
/// Stand-in for the SIMD loads, which exist on x86-64 only.
pub trait Words {}
#[cfg(not(target_arch = "x86_64"))]
impl Words for f32 {}
#[cfg(not(target_arch = "x86_64"))]
impl Words for f64 {}

/// Values a checksum reads (as float64).
pub trait Value: Copy + Send + Sync + Words {
    fn as_f64(self) -> f64;
    /// The canonical word: the bits of the float64 value.
    #[inline(always)]
    fn bits(self) -> u64 {
        self.as_f64().to_bits()
    }
}

impl Value for f64 {
    #[inline(always)]
    fn as_f64(self) -> f64 {
        self
    }
}

impl Value for f32 {
    #[inline(always)]
    fn as_f64(self) -> f64 {
        f64::from(self)
    }
}

/// The lane sums of (part of) one block, modulo 2^64 (see the module docs).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Sums {
    pub a: [u64; LANES],
    pub h: [u64; LANES],
    pub b: [u64; LANES],
    pub g: [u64; LANES],
}

impl Sums {
    /// Adds `other`'s sums (of other words of the same block).
    pub fn add(&mut self, other: &Sums) {
        for l in 0..LANES {
            self.a[l] = self.a[l].wrapping_add(other.a[l]);
            self.h[l] = self.h[l].wrapping_add(other.h[l]);
            self.b[l] = self.b[l].wrapping_add(other.b[l]);
            self.g[l] = self.g[l].wrapping_add(other.g[l]);
        }
    }
}

/// The definition, word by word: adds to `s` the words of `values`, the
/// first being word `k0` of its block.
pub fn literal<T: Value>(values: &[T], k0: u64, s: &mut Sums) {
    for (i, v) in values.iter().enumerate() {
        let k = k0 + i as u64;
        let (l, j, w) = ((k % LANES as u64) as usize, k / LANES as u64, v.bits());
        s.a[l] = s.a[l].wrapping_add(w);
        s.h[l] = s.h[l].wrapping_add(w >> 32);
        s.b[l] = s.b[l].wrapping_add(j.wrapping_mul(w));
        s.g[l] = s.g[l].wrapping_add(j.wrapping_mul(w >> 32));
    }
}

/// [`literal`] at instruction-set level `isa` (the same sums at every level;
/// a level the CPU does not run falls back to the definition).
pub fn sum_with<T: Value>(isa: Isa, values: &[T], k0: u64, s: &mut Sums) {
    let head = (((LANES as u64 - k0 % LANES as u64) % LANES as u64) as usize).min(values.len());
    let m = (values.len() - head) / LANES;
    let groups = &values[head..head + m * LANES];
    if m == 0 {
        return literal(values, k0, s);
    }
    #[cfg(target_arch = "x86_64")]
    let [s1, h1, s2, h2] = match isa {
        // SAFETY: the CPU runs the level (checked by `supported`).
        Isa::Avx512 if isa.supported() => unsafe { T::groups_avx512(groups) },
        Isa::Avx2 if isa.supported() => unsafe { T::groups_avx2(groups) },
        _ => groups_portable(groups),
    };
    #[cfg(not(target_arch = "x86_64"))]
    let [s1, h1, s2, h2] = {
        let _ = isa;
        groups_portable(groups)
    };
    literal(&values[..head], k0, s);
    // Over steps j0 .. j0 + m: s1 = sum x_t, s2 = sum (m - t) x_t, so
    // sum (j0 + t) x_t = (j0 + m) s1 - s2 (all modulo 2^64).
    let end = (k0 + head as u64) / LANES as u64 + m as u64;
    for l in 0..LANES {
        s.a[l] = s.a[l].wrapping_add(s1[l]);
        s.h[l] = s.h[l].wrapping_add(h1[l]);
        s.b[l] = s.b[l].wrapping_add(end.wrapping_mul(s1[l]).wrapping_sub(s2[l]));
        s.g[l] = s.g[l].wrapping_add(end.wrapping_mul(h1[l]).wrapping_sub(h2[l]));
    }
    literal(&values[head + m * LANES..], k0 + (head + m * LANES) as u64, s);
}

/// The vector loops' recurrence (`simd::checksum`) in plain Rust over
/// fixed-width lanes, which the compiler vectorises for any target: the
/// portable level, and CPUs other than x86-64, sum at memory speed too
/// instead of at the definition's one multiplication per word.
fn groups_portable<T: Value>(values: &[T]) -> [[u64; LANES]; 4] {
    let (mut s1, mut h1, mut s2, mut h2) = ([0u64; LANES], [0u64; LANES], [0u64; LANES], [0u64; LANES]);
    for group in values.chunks_exact(LANES) {
        for l in 0..LANES {
            let w = group[l].bits();
            s1[l] = s1[l].wrapping_add(w);
            h1[l] = h1[l].wrapping_add(w >> 32);
            s2[l] = s2[l].wrapping_add(s1[l]);
            h2[l] = h2[l].wrapping_add(h1[l]);
        }
    }
    [s1, h1, s2, h2]
}

/// The sums of some consecutive rows, split at the block boundary they may
/// cross: `first` for the block of their first row, `second` for the next.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Part {
    pub first: Sums,
    pub second: Sums,
}

/// Values converted per batch when rows are not one run of memory.
const BATCH_VALUES: usize = 1 << 14;

/// The sums of the rows of `m`, the first being instance `first_row`, at
/// instruction-set level `isa`; `buf` is scratch for rows that are not one
/// run of memory (Fortran order, strided), converted batch by batch.
pub fn part_with<T: Value>(isa: Isa, m: Matrix<'_, T>, first_row: u64, buf: &mut Vec<f64>) -> Part {
    let in_block = (first_row % BLOCK_ROWS as u64) as usize;
    let split = m.rows().min(BLOCK_ROWS - in_block);
    let mut p = Part::default();
    rows_sums(isa, m.slice_rows(0, split), in_block, buf, &mut p.first);
    rows_sums(isa, m.slice_rows(split, m.rows()), 0, buf, &mut p.second);
    p
}

/// [`part_with`] at the fastest level of this CPU.
pub fn part<T: Value>(m: Matrix<'_, T>, first_row: u64, buf: &mut Vec<f64>) -> Part {
    part_with(Isa::detect(), m, first_row, buf)
}

/// Bytes of input summed right after the kernel has read them: small enough
/// to be still in L2 (1-2 MiB per core on current x86), large enough that
/// the kernel is called on long runs of rows. Measured on an AMD EPYC (Zen 4),
/// one thread, CPU time of falsifier + checksum over falsifier alone, median
/// of 24 cases, load average 2-4: 1.51-1.53 at 16 KiB (in L1, but the kernel then restarts
/// every ~200 short rows), 1.25-1.27 at 128 KiB, 1.30-1.35 per whole block.
const INTERLEAVE_BYTES: usize = 128 << 10;

/// [`part`] of the rows of `m`, computed [`INTERLEAVE_BYTES`] at a time, each
/// right after `kernel(r0, r1)` has been called on rows `r0..r1` of `m`
/// (every row once, in order).
pub fn part_after<T: Value>(
    m: Matrix<'_, T>,
    first_row: u64,
    buf: &mut Vec<f64>,
    mut kernel: impl FnMut(usize, usize),
) -> Part {
    let isa = Isa::detect();
    let row_bytes = (m.cols() * std::mem::size_of::<T>()).max(1);
    let step = (INTERLEAVE_BYTES / row_bytes).clamp(16, PIECE_ROWS);
    let block = |row: u64| row / BLOCK_ROWS as u64;
    let mut p = Part::default();
    let mut r = 0;
    while r < m.rows() {
        let e = (r + step).min(m.rows());
        kernel(r, e);
        let q = part_with(isa, m.slice_rows(r, e), first_row + r as u64, buf);
        if block(first_row + r as u64) == block(first_row) {
            p.first.add(&q.first);
            p.second.add(&q.second);
        } else {
            p.second.add(&q.first); // (q.second is empty: rows span fewer than BLOCK_ROWS)
        }
        r = e;
    }
    p
}

/// Adds the sums of rows `m` (row `row` of their block onwards) to `s`.
fn rows_sums<T: Value>(isa: Isa, m: Matrix<'_, T>, row: usize, buf: &mut Vec<f64>, s: &mut Sums) {
    let (rows, cols) = (m.rows(), m.cols());
    if let Some(values) = m.contiguous() {
        return sum_with(isa, values, (row * cols) as u64, s);
    }
    let batch = (BATCH_VALUES / cols.max(1)).max(1);
    let mut first = 0;
    while first < rows {
        let last = (first + batch).min(rows);
        buf.clear();
        for i in first..last {
            match m.row_slice(i) {
                Some(r) => buf.extend(r.iter().map(|&v| v.as_f64())),
                None => buf.extend((0..cols).map(|j| m.get(i, j).as_f64())),
            }
        }
        sum_with(isa, buf, ((row + first) * cols) as u64, s);
        first = last;
    }
}

/// MurmurHash3's 64-bit finaliser: a bijection of u64 that spreads every bit.
fn fmix64(mut x: u64) -> u64 {
    x ^= x >> 33;
    x = x.wrapping_mul(0xff51_afd7_ed55_8ccd);
    x ^= x >> 33;
    x = x.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    x ^ (x >> 33)
}

/// The 128-bit checksum of a block of `rows` rows of `cols` columns whose
/// sums are `s`: two chains `h = fmix64(h ^ word)` over the words
/// `(tag, cols, rows, A, H, B, G)`, forward and backward, each a bijection
/// of `h` at every step, so any one changed word changes both halves.
pub fn finish(cols: usize, rows: usize, s: &Sums) -> u128 {
    const TAG: u64 = u64::from_le_bytes(*b"fl64x8/1");
    let mut words = vec![TAG, cols as u64, rows as u64];
    for lanes in [&s.a, &s.h, &s.b, &s.g] {
        words.extend_from_slice(lanes);
    }
    let forward = words.iter().fold(0x6564_6d66_5f72_7331u64, |h, &w| fmix64(h ^ w));
    let backward = words
        .iter()
        .rev()
        .fold(0x9e37_79b9_7f4a_7c15u64, |h, &w| fmix64(h ^ w));
    (u128::from(forward) << 64) | u128::from(backward)
}

/// Streaming checksums of rows fed in instance order, chunk after chunk.
#[derive(Debug, Default, Clone)]
pub struct RowDigest {
    cols: Option<usize>,
    n_rows: u64,
    /// Sums of the block being filled.
    open: Sums,
    /// Checksums of the completed blocks, in order.
    blocks: Vec<u128>,
}

/// The sums of a chunk being fed, per block from the digest's open block on;
/// taken by [`RowDigest::commit`] once the whole chunk is summed.
#[derive(Debug, Clone)]
pub struct Pending {
    first_row: u64,
    rows: usize,
    sums: Vec<Sums>,
}

impl Pending {
    /// Instance index of the chunk's first row.
    pub fn first_row(&self) -> u64 {
        self.first_row
    }

    /// Adds `part`, the sums of the rows starting at row `chunk_row` of the chunk.
    pub fn add(&mut self, chunk_row: usize, part: &Part) {
        let block = |row: u64| (row / BLOCK_ROWS as u64) as usize;
        let k = block(self.first_row + chunk_row as u64) - block(self.first_row);
        self.sums[k].add(&part.first);
        self.sums[k + 1].add(&part.second); // `begin` leaves room for it
    }
}

impl RowDigest {
    pub fn new() -> Self {
        Self::default()
    }

    /// Rows fed so far.
    pub fn n_rows(&self) -> u64 {
        self.n_rows
    }

    /// Width of the rows (None before the first non-empty chunk).
    pub fn cols(&self) -> Option<usize> {
        self.cols
    }

    /// Checksums of the blocks completed so far (block k: instances k*BLOCK_ROWS..).
    pub fn blocks(&self) -> &[u128] {
        &self.blocks
    }

    /// Checksum of the rows after the last complete block, None when there are none.
    pub fn partial(&self) -> Option<u128> {
        let rows = (self.n_rows % BLOCK_ROWS as u64) as usize;
        (rows > 0).then(|| finish(self.cols.unwrap_or(0), rows, &self.open))
    }

    /// An error unless chunks of `cols` columns may follow those fed so far.
    pub fn check_width(&self, cols: usize) -> Result<()> {
        match self.cols {
            Some(c) if c != cols => Err(EdmfError::invalid(
                "rows",
                format!("a chunk of {cols} columns after chunks of {c}"),
            )),
            _ => Ok(()),
        }
    }

    /// Room for the sums of a chunk of `rows` rows fed next.
    pub fn begin(&self, rows: usize) -> Result<Pending> {
        // Blocks the chunk touches, plus one a piece's `second` may name (zero then).
        let n = (self.n_rows % BLOCK_ROWS as u64) as usize + rows;
        let mut sums = Vec::new();
        sums.try_reserve(n / BLOCK_ROWS + 2)
            .map_err(|_| EdmfError::OutOfMemory {
                what: "block checksums",
                elements: n / BLOCK_ROWS + 2,
            })?;
        sums.resize(n / BLOCK_ROWS + 2, Sums::default());
        Ok(Pending {
            first_row: self.n_rows,
            rows,
            sums,
        })
    }

    /// Feeds the next rows (any strides, float64 or float32), summed in
    /// [`PIECE_ROWS`]-row pieces in parallel.
    pub fn update<T: Value>(&mut self, m: Matrix<'_, T>, pool: &ThreadPool) -> Result<()> {
        self.check_width(m.cols())?;
        let mut pending = self.begin(m.rows())?;
        let first = self.n_rows;
        let parts: Vec<Part> = pool.install(|| {
            (0..m.rows().div_ceil(PIECE_ROWS))
                .into_par_iter()
                .map_init(Vec::new, |buf, p| {
                    let s = p * PIECE_ROWS;
                    part(
                        m.slice_rows(s, (s + PIECE_ROWS).min(m.rows())),
                        first + s as u64,
                        buf,
                    )
                })
                .collect()
        });
        for (p, sums) in parts.iter().enumerate() {
            pending.add(p * PIECE_ROWS, sums);
        }
        self.commit(m.cols(), pending)
    }

    /// Takes in a chunk of `cols` columns whose rows were summed, every one
    /// once, into `pending` (from [`begin`](Self::begin), e.g. by the
    /// falsifier while it had the rows in cache). Same result as
    /// [`update`](Self::update).
    pub fn commit(&mut self, cols: usize, pending: Pending) -> Result<()> {
        self.check_width(cols)?;
        if pending.first_row != self.n_rows {
            return Err(EdmfError::invalid(
                "pending",
                format!(
                    "sums from row {} fed after row {}",
                    pending.first_row, self.n_rows
                ),
            ));
        }
        if pending.rows == 0 {
            return Ok(());
        }
        self.cols = Some(cols);
        let mut row = self.n_rows;
        let end = self.n_rows + pending.rows as u64;
        for sums in &pending.sums {
            self.open.add(sums);
            let block_end = (row / BLOCK_ROWS as u64 + 1) * BLOCK_ROWS as u64;
            if block_end > end {
                break;
            }
            self.blocks.push(finish(cols, BLOCK_ROWS, &self.open));
            self.open = Sums::default();
            row = block_end;
        }
        self.n_rows = end;
        Ok(())
    }
}

#[cfg(test)]
#[path = "digest_tests.rs"]
mod tests;
