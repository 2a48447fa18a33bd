//! Block checksums of model-instance rows, so a resumed run can tell that the
//! input it re-reads is, row for row, the one its checkpoint was made from.
//!
//! **What is summed.** The values' bits at their stored width, in row-major
//! instance order, as one stream of 32-bit *units* per block (a float64 value
//! is two units, low half first; a float32 value one), whatever the source's
//! byte order, memory layout or chunking. Word `k` of a block is units `2k`
//! (low half) and `2k + 1` (high half): on a little-endian machine, the
//! block's bytes read as u64 words, so float64 words are the values' bits and
//! a float32 word holds two values. Rows are grouped in fixed blocks of
//! [`BLOCK_ROWS`] instances counted from instance 0; block checksums depend on
//! the instance index only. (Version 1 widened float32 to float64 first, one
//! conversion per value on top of the sums; see [`ALGORITHM`].)
//!
//! **The checksum** ([`ALGORITHM`], a Fletcher-style sum over eight lanes).
//! Word `w_k` goes to lane `l = k mod 8` at step `j = k div 8`. Per lane,
//! modulo 2^64:
//!
//! ```text
//! A_l = sum w_k        H_l = sum (w_k >> 32)        (plain sums)
//! B_l = sum j w_k      G_l = sum j (w_k >> 32)      (position-weighted sums)
//! ```
//!
//! and the block's 128-bit checksum mixes `(C, R, U, A, H, B, G)`, with `C`
//! columns, `R` rows and `U` units (see [`finish`]), so the same values stored
//! as float32 and as float64 differ. [`literal`] is this definition unit by
//! unit (the oracle of the tests); the vector levels ([`crate::kernel::Isa`])
//! compute the same sums with additions only.
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
//! any change within one row of up to 16 float64 (32 float32) columns, any
//! swap of two rows of up to 8 float64 (16 float32) columns. Larger changes
//! (regenerated rows, swapped columns, shifted or truncated data) go unseen
//! only if, in every lane, both halves keep their exact sum *and* their first
//! moment, which values that changed by accident do not do (a swap of two
//! columns, for example, is seen unless the two columns hold, in every lane,
//! halves of equal sum and equal moment). The row and unit counts are part of
//! every block's checksum, so a truncated block, or one whose dtype changed,
//! differs.
//!
//! This guards against accidental change (an edited, regenerated, shifted or
//! damaged input), not deliberate tampering: anyone can make a different input
//! with the same sums. The checkpoint's own files carry sha256 checksums.
//!
//! Summing instead of hashing is what makes it nearly free: the sums are
//! additive, so any rows can be summed apart (by the falsifier's threads,
//! by the kernel as it reads them, see [`crate::summing`]) and the parts
//! added in any order.

use crate::error::{EdmfError, Result};
use crate::kernel::Isa;
use crate::matrix::Matrix;
use rayon::prelude::*;
use rayon::ThreadPool;

/// Name and version of the checksum, recorded in checkpoints. Version 2 sums
/// float32 values at their own width (version 1: widened to float64).
pub const ALGORITHM: &str = "fletcher64x8/2";
/// Instances per block: the unit a checkpoint records and names when it differs.
pub const BLOCK_ROWS: usize = 65_536;
/// Rows summed in one piece by `RowDigest::update` (one parallel task), and
/// the falsifier's block of candidate counts.
pub const PIECE_ROWS: usize = 1024;
/// Lanes of the checksum.
pub const LANES: usize = 8;
/// 32-bit units in one step of the lanes (eight words, 64 bytes: a group).
pub const STEP_UNITS: u64 = 2 * LANES as u64;

/// Lane sums of consecutive whole groups, as the vector loops keep them:
/// `[s1, h1, s2, h2]` (see [`add_groups`]).
pub type Groups = [[u64; LANES]; 4];

/// Values a checksum reads.
pub trait Value: Copy + Send + Sync {
    /// 32-bit units per value.
    const UNITS: usize;
    /// The value's bits (float32: in the low 32).
    fn bits(self) -> u64;
    /// Word `k` of `values`, whose first unit starts a word.
    fn word(values: &[Self], k: usize) -> u64;
}

impl Value for f64 {
    const UNITS: usize = 2;
    #[inline(always)]
    fn bits(self) -> u64 {
        self.to_bits()
    }
    #[inline(always)]
    fn word(values: &[f64], k: usize) -> u64 {
        values[k].to_bits()
    }
}

impl Value for f32 {
    const UNITS: usize = 1;
    #[inline(always)]
    fn bits(self) -> u64 {
        u64::from(self.to_bits())
    }
    #[inline(always)]
    fn word(values: &[f32], k: usize) -> u64 {
        values[2 * k].bits() | (values[2 * k + 1].bits() << 32)
    }
}

/// The lane sums of (part of) one block, modulo 2^64 (see the module docs),
/// and the number of units summed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Sums {
    pub units: u64,
    pub a: [u64; LANES],
    pub h: [u64; LANES],
    pub b: [u64; LANES],
    pub g: [u64; LANES],
}

impl Sums {
    /// Adds `other`'s sums (of other units of the same block).
    pub fn add(&mut self, other: &Sums) {
        self.units = self.units.wrapping_add(other.units);
        for l in 0..LANES {
            self.a[l] = self.a[l].wrapping_add(other.a[l]);
            self.h[l] = self.h[l].wrapping_add(other.h[l]);
            self.b[l] = self.b[l].wrapping_add(other.b[l]);
            self.g[l] = self.g[l].wrapping_add(other.g[l]);
        }
    }
}

/// The definition, unit by unit: adds to `s` the values of `values`, the
/// first starting at unit `u0` of its block.
pub fn literal<T: Value>(values: &[T], u0: u64, s: &mut Sums) {
    let mut i = u0;
    for v in values {
        let bits = v.bits();
        for half_of_value in 0..T::UNITS {
            let unit = (bits >> (32 * half_of_value)) & 0xFFFF_FFFF;
            let (k, high) = (i / 2, i % 2 == 1);
            let (l, j) = ((k % LANES as u64) as usize, k / LANES as u64);
            let w = if high { unit << 32 } else { unit };
            s.a[l] = s.a[l].wrapping_add(w);
            s.b[l] = s.b[l].wrapping_add(j.wrapping_mul(w));
            if high {
                s.h[l] = s.h[l].wrapping_add(unit);
                s.g[l] = s.g[l].wrapping_add(j.wrapping_mul(unit));
            }
            i += 1;
        }
    }
    s.units = s.units.wrapping_add(values.len() as u64 * T::UNITS as u64);
}

/// [`literal`] at instruction-set level `isa` (the same sums at every level;
/// a level the CPU does not run falls back to the definition).
pub fn sum_with<T: Value>(isa: Isa, values: &[T], u0: u64, s: &mut Sums) {
    let per_unit = T::UNITS as u64;
    // Values before the first unit that starts a step; none fit when a float64
    // starts mid-word (a block mixing dtypes), and the definition does it all.
    let to_step = (STEP_UNITS - u0 % STEP_UNITS) % STEP_UNITS;
    if to_step % per_unit != 0 {
        return literal(values, u0, s);
    }
    let head = ((to_step / per_unit) as usize).min(values.len());
    let per_group = LANES * 2 / T::UNITS;
    let m = (values.len() - head) / per_group;
    if m == 0 {
        return literal(values, u0, s);
    }
    let groups = &values[head..head + m * per_group];
    #[cfg(target_arch = "x86_64")]
    let [s1, h1, s2, h2] = {
        use crate::simd::checksum;
        let bytes = groups.as_ptr() as *const u8;
        match isa {
            // SAFETY: the CPU runs the level (checked by `supported`); `groups`
            // holds exactly `m` groups of 64 bytes, read as little-endian words
            // (the definition's words on x86-64).
            Isa::Avx512 if isa.supported() => unsafe { checksum::groups_avx512(bytes, m) },
            Isa::Avx2 if isa.supported() => unsafe { checksum::groups_avx2(bytes, m) },
            _ => groups_portable(groups, m),
        }
    };
    #[cfg(not(target_arch = "x86_64"))]
    let [s1, h1, s2, h2] = {
        let _ = isa;
        groups_portable(groups, m)
    };
    literal(&values[..head], u0, s);
    add_groups(s, &[s1, h1, s2, h2], m, (u0 + head as u64 * per_unit) / STEP_UNITS);
    let rest = head + m * per_group;
    literal(&values[rest..], u0 + rest as u64 * per_unit, s);
}

/// Adds to `s` the lane sums `[s1, h1, s2, h2]` of the `m` groups at steps
/// `j0 .. j0 + m` of a block: `s1 = sum x_t` and `s2 = sum (m - t) x_t` (the
/// loops' recurrence), so `sum (j0 + t) x_t = (j0 + m) s1 - s2`, all modulo
/// 2^64; likewise the high halves `h1`, `h2`.
pub fn add_groups(s: &mut Sums, [s1, h1, s2, h2]: &Groups, m: usize, j0: u64) {
    let end = j0 + m as u64;
    for l in 0..LANES {
        s.a[l] = s.a[l].wrapping_add(s1[l]);
        s.h[l] = s.h[l].wrapping_add(h1[l]);
        s.b[l] = s.b[l].wrapping_add(end.wrapping_mul(s1[l]).wrapping_sub(s2[l]));
        s.g[l] = s.g[l].wrapping_add(end.wrapping_mul(h1[l]).wrapping_sub(h2[l]));
    }
    s.units = s.units.wrapping_add(m as u64 * STEP_UNITS);
}

/// The vector loops' recurrence (`simd::checksum`) in plain Rust over
/// fixed-width lanes: the portable level, and CPUs other than x86-64.
fn groups_portable<T: Value>(values: &[T], m: usize) -> Groups {
    let (mut s1, mut h1, mut s2, mut h2) = ([0u64; LANES], [0u64; LANES], [0u64; LANES], [0u64; LANES]);
    for t in 0..m {
        for l in 0..LANES {
            let w = T::word(values, LANES * t + l);
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
pub fn part_with<T: Value>(isa: Isa, m: Matrix<'_, T>, first_row: u64, buf: &mut Vec<T>) -> Part {
    let in_block = (first_row % BLOCK_ROWS as u64) as usize;
    let split = m.rows().min(BLOCK_ROWS - in_block);
    let mut p = Part::default();
    rows_sums(isa, m.slice_rows(0, split), in_block, buf, &mut p.first);
    rows_sums(isa, m.slice_rows(split, m.rows()), 0, buf, &mut p.second);
    p
}

/// [`part_with`] at the fastest level of this CPU.
pub fn part<T: Value>(m: Matrix<'_, T>, first_row: u64, buf: &mut Vec<T>) -> Part {
    part_with(Isa::detect(), m, first_row, buf)
}

/// Adds the sums of rows `m` (row `row` of their block onwards) to `s`.
fn rows_sums<T: Value>(isa: Isa, m: Matrix<'_, T>, row: usize, buf: &mut Vec<T>, s: &mut Sums) {
    let (rows, cols) = (m.rows(), m.cols());
    if let Some(values) = m.contiguous() {
        return sum_with(isa, values, first_unit::<T>(row, cols), s);
    }
    let batch = (BATCH_VALUES / cols.max(1)).max(1);
    let mut first = 0;
    while first < rows {
        let last = (first + batch).min(rows);
        buf.clear();
        for i in first..last {
            match m.row_slice(i) {
                Some(r) => buf.extend_from_slice(r),
                None => buf.extend((0..cols).map(|j| m.get(i, j))),
            }
        }
        sum_with(isa, buf, first_unit::<T>(row + first, cols), s);
        first = last;
    }
}

/// The unit at which row `row` of its block starts: rows of one dtype are one
/// stream of units. (A block whose chunks change dtype gets, row by row, the
/// positions of its own dtype: still a function of each row's index, dtype
/// and values only, so whatever the chunking.)
pub fn first_unit<T: Value>(row: usize, cols: usize) -> u64 {
    (row as u64) * (cols as u64) * T::UNITS as u64
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
/// `(tag, cols, rows, units, A, H, B, G)`, forward and backward, each a bijection
/// of `h` at every step, so any one changed word changes both halves.
pub fn finish(cols: usize, rows: usize, s: &Sums) -> u128 {
    const TAG: u64 = u64::from_le_bytes(*b"fl64x8/2");
    let mut words = vec![TAG, cols as u64, rows as u64, s.units];
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
