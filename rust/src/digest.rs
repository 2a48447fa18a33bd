//! Content digests of model-instance rows, so a resumed run can tell that the
//! input it re-reads is, row for row, the one its checkpoint was made from.
//!
//! The digest is a property of the *values*, not of how they were handed
//! over: every value is hashed as the little-endian bytes of its float64
//! conversion (exact for float32), in row-major order, whatever the source's
//! dtype, memory layout or chunking. Rows are grouped in fixed leaves of
//! [`LEAF_ROWS`] instances counted from instance 0, leaves in fixed blocks of
//! [`BLOCK_ROWS`]; a block's digest is xxh3-128 over its width, its row count
//! and its leaves' xxh3-64 digests. Because leaf and block boundaries depend
//! only on the instance index, any chunking gives the same list of block
//! digests, and the leaves inside one chunk are hashed in parallel.
//!
//! This is a check against accidental change (an edited or regenerated input
//! file), not a cryptographic seal.

use crate::error::{EdmfError, Result};
use crate::matrix::Matrix;
use rayon::prelude::*;
use rayon::ThreadPool;
use xxhash_rust::xxh3::{xxh3_128, xxh3_64};

/// Instances per leaf: the unit hashed in one piece (and in parallel).
pub const LEAF_ROWS: usize = 1024;
/// Instances per block: the unit a checkpoint records and names when it differs.
pub const BLOCK_ROWS: usize = 64 * LEAF_ROWS;

/// Values a digest reads (as float64).
pub trait Value: Copy + Send + Sync {
    fn as_f64(self) -> f64;
    /// True when the type's in-memory bytes are those of a float64 in little-endian order.
    const IS_LE_F64: bool;
}

impl Value for f64 {
    fn as_f64(self) -> f64 {
        self
    }
    const IS_LE_F64: bool = cfg!(target_endian = "little");
}

impl Value for f32 {
    fn as_f64(self) -> f64 {
        f64::from(self)
    }
    const IS_LE_F64: bool = false;
}

/// Streaming digest of rows fed in instance order, chunk after chunk.
#[derive(Debug, Default, Clone)]
pub struct RowDigest {
    cols: Option<usize>,
    n_rows: u64,
    /// Leaf digests of the block being filled.
    leaves: Vec<u64>,
    /// Bytes of the leaf being filled (fewer than LEAF_ROWS rows).
    pending: Vec<u8>,
    pending_rows: usize,
    /// Digests of the completed blocks, in order.
    blocks: Vec<u128>,
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

    /// Digests of the blocks completed so far (block k: instances k*BLOCK_ROWS..).
    pub fn blocks(&self) -> &[u128] {
        &self.blocks
    }

    /// Digest of the rows after the last complete block, None when there are none.
    pub fn partial(&self) -> Option<u128> {
        let rows = (self.n_rows % BLOCK_ROWS as u64) as usize;
        if rows == 0 {
            return None;
        }
        let mut leaves = self.leaves.clone();
        if self.pending_rows > 0 {
            leaves.push(xxh3_64(&self.pending));
        }
        Some(block_digest(self.cols.unwrap_or(0), rows, &leaves))
    }

    /// Feeds the next rows (any strides, float64 or float32).
    pub fn update<T: Value>(&mut self, m: Matrix<'_, T>, pool: &ThreadPool) -> Result<()> {
        self.check_width(m.cols())?;
        let (head, whole) = self.leaves_in(m.rows());
        // Whole leaves inside this chunk, in parallel.
        let digests: Vec<u64> = pool.install(|| {
            (0..whole)
                .into_par_iter()
                .map_init(Vec::new, |buf, l| {
                    let s = head + l * LEAF_ROWS;
                    leaf_digest(m.slice_rows(s, s + LEAF_ROWS), buf)
                })
                .collect()
        });
        self.absorb(m, &digests);
        Ok(())
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

    /// Where the whole leaves of the next `rows` rows lie: `(head, whole)`,
    /// leaf `l` being rows `head + l * LEAF_ROWS ..` of them (the first
    /// `head` rows complete the leaf the previous chunk left open).
    pub fn leaves_in(&self, rows: usize) -> (usize, usize) {
        let head = if self.pending_rows > 0 {
            (LEAF_ROWS - self.pending_rows).min(rows)
        } else {
            0
        };
        (head, (rows - head) / LEAF_ROWS)
    }

    /// Feeds the next rows whose whole leaves the caller has already hashed
    /// with [`leaf_digest`] (e.g. while the rows were in cache for another
    /// pass): `leaves[l]` is the digest of leaf `l` as placed by
    /// [`leaves_in`](Self::leaves_in). Same result as [`update`](Self::update).
    pub fn update_hashed<T: Value>(&mut self, m: Matrix<'_, T>, leaves: &[u64]) -> Result<()> {
        self.check_width(m.cols())?;
        let whole = self.leaves_in(m.rows()).1;
        if leaves.len() != whole {
            return Err(EdmfError::invalid(
                "leaves",
                format!("{whole} leaf digests for {} rows, got {}", m.rows(), leaves.len()),
            ));
        }
        self.absorb(m, leaves);
        Ok(())
    }

    /// Takes in rows of a checked width, given the digests of their whole leaves.
    fn absorb<T: Value>(&mut self, m: Matrix<'_, T>, leaves: &[u64]) {
        let rows = m.rows();
        if rows == 0 {
            return;
        }
        self.cols = Some(m.cols());
        let (head, whole) = self.leaves_in(rows);
        // Complete the leaf the previous chunk left open.
        if head > 0 {
            append_rows(&mut self.pending, m.slice_rows(0, head));
            self.pending_rows += head;
            if self.pending_rows == LEAF_ROWS {
                let d = xxh3_64(&self.pending);
                self.pending.clear();
                self.pending_rows = 0;
                self.push_leaf(d);
            }
        }
        for &d in &leaves[..whole] {
            self.push_leaf(d);
        }
        // The rest opens a new leaf.
        let i = head + whole * LEAF_ROWS;
        if i < rows {
            append_rows(&mut self.pending, m.slice_rows(i, rows));
            self.pending_rows += rows - i;
        }
        self.n_rows += rows as u64;
    }

    fn push_leaf(&mut self, digest: u64) {
        self.leaves.push(digest);
        if self.leaves.len() * LEAF_ROWS == BLOCK_ROWS {
            let d = block_digest(self.cols.unwrap_or(0), BLOCK_ROWS, &self.leaves);
            self.blocks.push(d);
            self.leaves.clear();
        }
    }
}

fn block_digest(cols: usize, rows: usize, leaves: &[u64]) -> u128 {
    let mut bytes = Vec::with_capacity(16 + 8 * leaves.len());
    bytes.extend_from_slice(&(cols as u64).to_le_bytes());
    bytes.extend_from_slice(&(rows as u64).to_le_bytes());
    for d in leaves {
        bytes.extend_from_slice(&d.to_le_bytes());
    }
    xxh3_128(&bytes)
}

/// xxh3-64 of a whole leaf ([`LEAF_ROWS`] rows); hashed in place when it is
/// contiguous float64 (the common case: no copy), else converted once into
/// `buf` (float32 -> float64 is a single vectorised loop) and hashed there.
pub fn leaf_digest<T: Value>(m: Matrix<'_, T>, buf: &mut Vec<f64>) -> u64 {
    if T::IS_LE_F64 {
        if let Some(values) = m.contiguous() {
            return xxh3_64(as_bytes(values));
        }
    }
    if cfg!(target_endian = "big") {
        let mut bytes = Vec::new();
        append_rows(&mut bytes, m);
        return xxh3_64(&bytes);
    }
    buf.clear();
    match m.contiguous() {
        Some(values) => buf.extend(values.iter().map(|&v| v.as_f64())),
        None => {
            buf.reserve(m.rows() * m.cols());
            for i in 0..m.rows() {
                match m.row_slice(i) {
                    Some(row) => buf.extend(row.iter().map(|&v| v.as_f64())),
                    None => buf.extend((0..m.cols()).map(|j| m.get(i, j).as_f64())),
                }
            }
        }
    }
    xxh3_64(as_bytes(buf))
}

/// The memory of `values`, which holds float64 in little-endian order
/// (callers check `T::IS_LE_F64`).
fn as_bytes<T: Value>(values: &[T]) -> &[u8] {
    // SAFETY: any initialised memory may be read as u8 (no alignment or
    // validity requirement), over exactly the slice's size.
    unsafe { std::slice::from_raw_parts(values.as_ptr() as *const u8, std::mem::size_of_val(values)) }
}

/// Appends the rows' values as little-endian float64 bytes, row-major.
fn append_rows<T: Value>(out: &mut Vec<u8>, m: Matrix<'_, T>) {
    let (rows, cols) = (m.rows(), m.cols());
    let mut row_buf: Vec<f64> = Vec::with_capacity(cols);
    out.reserve(rows * cols * 8);
    for i in 0..rows {
        row_buf.clear();
        match m.row_slice(i) {
            // A plain conversion loop the compiler vectorises (float32 -> float64).
            Some(row) => row_buf.extend(row.iter().map(|&v| v.as_f64())),
            None => row_buf.extend((0..cols).map(|j| m.get(i, j).as_f64())),
        }
        if cfg!(target_endian = "little") {
            out.extend_from_slice(as_bytes(&row_buf));
        } else {
            for v in &row_buf {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pool() -> ThreadPool {
        rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap()
    }

    fn digest_in_chunks(data: &[f64], cols: usize, step: usize) -> (Vec<u128>, Option<u128>) {
        let rows = data.len() / cols;
        let all = Matrix::row_major(data, rows, cols).unwrap();
        let mut d = RowDigest::new();
        let p = pool();
        let mut s = 0;
        while s < rows {
            let e = (s + step).min(rows);
            d.update(all.slice_rows(s, e), &p).unwrap();
            s = e;
        }
        assert_eq!(d.n_rows(), rows as u64);
        (d.blocks().to_vec(), d.partial())
    }

    #[test]
    fn the_digest_does_not_depend_on_chunking() {
        let cols = 3;
        let rows = 2 * BLOCK_ROWS + 777;
        let data: Vec<f64> = (0..rows * cols).map(|k| (k as f64).sin()).collect();
        let want = digest_in_chunks(&data, cols, rows);
        assert_eq!(want.0.len(), 2);
        assert!(want.1.is_some());
        for step in [1, 999, LEAF_ROWS, LEAF_ROWS + 1, BLOCK_ROWS - 3] {
            assert_eq!(digest_in_chunks(&data, cols, step), want, "step {step}");
        }
    }

    #[test]
    fn layout_and_float32_give_the_digest_of_the_values() {
        let (rows, cols) = (LEAF_ROWS + 5, 4);
        let c: Vec<f32> = (0..rows * cols).map(|k| k as f32 * 0.25).collect();
        let mut f = vec![0.0f64; rows * cols]; // same values, Fortran order, float64
        for i in 0..rows {
            for j in 0..cols {
                f[j * rows + i] = f64::from(c[i * cols + j]);
            }
        }
        let p = pool();
        let mut a = RowDigest::new();
        a.update(Matrix::row_major(&c, rows, cols).unwrap(), &p).unwrap();
        let mut b = RowDigest::new();
        b.update(Matrix::col_major(&f, rows, cols).unwrap(), &p).unwrap();
        assert_eq!(a.partial(), b.partial());
    }

    #[test]
    fn one_changed_value_changes_its_block_only() {
        let cols = 2;
        let rows = 3 * BLOCK_ROWS;
        let mut data: Vec<f64> = (0..rows * cols).map(|k| k as f64).collect();
        let (before, _) = digest_in_chunks(&data, cols, 5000);
        data[(BLOCK_ROWS + 12345) * cols + 1] += 0.5; // (1e-12 would be below one ulp of these values)
        let (after, _) = digest_in_chunks(&data, cols, 5000);
        assert_eq!(before[0], after[0]);
        assert_ne!(before[1], after[1]);
        assert_eq!(before[2], after[2]);
    }

    #[test]
    fn a_change_of_width_is_an_error() {
        let data = [0.0f64; 12];
        let p = pool();
        let mut d = RowDigest::new();
        d.update(Matrix::row_major(&data, 4, 3).unwrap(), &p).unwrap();
        assert!(d.update(Matrix::row_major(&data, 3, 4).unwrap(), &p).is_err());
    }
}
