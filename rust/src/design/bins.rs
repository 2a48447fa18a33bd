//! The bins of every candidate location, computed once before the greedy
//! placement and stored location-major in the narrowest integer type.
//!
//! The greedy steps then read one location as one contiguous stream of N
//! small integers (N bytes for up to 256 bins) instead of recomputing
//! `floor((G[k, i] - min_i) / w_i)` from the predictions at every step,
//! which costs a cache line of predictions per instance when the
//! predictions are stored row after row. Labels are the dense bins of
//! [`Binning`] (or, for locations with more bins than a counting array
//! holds, the ranks of the distinct bins): the same partition of the
//! instances, so every entropy is that of the definition.

use rayon::prelude::*;
use rayon::ThreadPool;

use super::entropy::{column_bins, dense_bin, Bin, Binning};
use crate::kernel::Prediction;
use crate::matrix::Matrix;

/// One location's labels, instance after instance.
#[derive(Debug, Clone)]
pub enum Column {
    U8(Vec<u8>),
    U16(Vec<u16>),
    U32(Vec<u32>),
}

/// Runs `$body` with `$c` bound to the column's labels as a typed slice.
macro_rules! with_column {
    ($col:expr, |$c:ident| $body:expr) => {
        match $col {
            $crate::design::bins::Column::U8(v) => {
                let $c: &[u8] = v;
                $body
            }
            $crate::design::bins::Column::U16(v) => {
                let $c: &[u16] = v;
                $body
            }
            $crate::design::bins::Column::U32(v) => {
                let $c: &[u32] = v;
                $body
            }
        }
    };
}
pub(crate) use with_column;

impl Column {
    fn zeros(n: usize, labels: u32) -> Self {
        if labels <= u8::MAX as u32 + 1 {
            Column::U8(vec![0; n])
        } else if labels <= u16::MAX as u32 + 1 {
            Column::U16(vec![0; n])
        } else {
            Column::U32(vec![0; n])
        }
    }

    fn bytes(labels: u32) -> usize {
        if labels <= u8::MAX as u32 + 1 {
            1
        } else if labels <= u16::MAX as u32 + 1 {
            2
        } else {
            4
        }
    }

    /// Writes `src` (labels that fit) at rows `start..`.
    fn write(&mut self, start: usize, src: &[u32]) {
        fn put<B: Bin>(dst: &mut [B], src: &[u32]) {
            for (d, &s) in dst.iter_mut().zip(src) {
                *d = B::from_u32(s);
            }
        }
        let end = start + src.len();
        match self {
            Column::U8(v) => put(&mut v[start..end], src),
            Column::U16(v) => put(&mut v[start..end], src),
            Column::U32(v) => put(&mut v[start..end], src),
        }
    }
}

/// The labels of every location and how many each may take.
#[derive(Debug, Clone)]
pub struct BinMatrix {
    pub columns: Vec<Column>,
    /// Labels of each location are below this (a counting array's length).
    pub labels: Vec<u32>,
}

/// A block of rows of one column, written by one worker.
enum ChunkMut<'a> {
    U8(&'a mut [u8]),
    U16(&'a mut [u16]),
    U32(&'a mut [u32]),
    /// A location binned by ranks (already written).
    Done,
}

/// Rows binned per block: the block's predictions (about 256 KiB) stay in
/// cache while every location is binned from them, column after column.
fn block_rows<T>(l: usize) -> usize {
    let row = l * std::mem::size_of::<T>();
    ((256 << 10) / row.max(1)).clamp(64, 4096) / 64 * 64
}

impl BinMatrix {
    /// Bytes the labels would take (a location with more bins than a
    /// counting array holds is counted at 4 bytes a label).
    pub fn bytes<T: Prediction>(g: Matrix<'_, T>, binning: &Binning) -> usize {
        let n = g.rows();
        (0..g.cols())
            .map(|i| {
                let labels = if binning.is_dense(i, n) {
                    binning.n_bins[i] as u32
                } else {
                    u32::MAX
                };
                n * Column::bytes(labels)
            })
            .sum()
    }

    /// Bins every location. The rows are shared among the workers in
    /// blocks; each block is read from the predictions once and binned
    /// location after location into that block of every column.
    pub fn build<T: Prediction>(g: Matrix<'_, T>, binning: &Binning, pool: &ThreadPool) -> Self {
        let (n, l) = (g.rows(), g.cols());
        // Locations with more bins than a counting array: ranks by a sort (rare).
        let ranked: Vec<Option<(Column, u32)>> = pool.install(|| {
            (0..l)
                .into_par_iter()
                .map(|i| {
                    if binning.is_dense(i, n) {
                        return None;
                    }
                    let mut ranks = vec![0u32; n];
                    column_bins(g, binning, i, None, &mut ranks);
                    let labels = ranks.iter().copied().max().map_or(1, |m| m + 1);
                    let mut c = Column::zeros(n, labels);
                    c.write(0, &ranks);
                    Some((c, labels))
                })
                .collect()
        });
        let (mut columns, labels): (Vec<Column>, Vec<u32>) = ranked
            .into_iter()
            .enumerate()
            .map(|(i, r)| {
                r.unwrap_or_else(|| {
                    let labels = binning.n_bins[i] as u32;
                    (Column::zeros(n, labels), labels)
                })
            })
            .unzip();
        let rows = block_rows::<T>(l);
        let n_blocks = n.div_ceil(rows);
        let mut blocks: Vec<Vec<ChunkMut<'_>>> = (0..n_blocks).map(|_| Vec::with_capacity(l)).collect();
        for (i, col) in columns.iter_mut().enumerate() {
            if !binning.is_dense(i, n) {
                blocks.iter_mut().for_each(|b| b.push(ChunkMut::Done));
                continue;
            }
            match col {
                Column::U8(v) => v
                    .chunks_mut(rows)
                    .zip(&mut blocks)
                    .for_each(|(c, b)| b.push(ChunkMut::U8(c))),
                Column::U16(v) => v
                    .chunks_mut(rows)
                    .zip(&mut blocks)
                    .for_each(|(c, b)| b.push(ChunkMut::U16(c))),
                Column::U32(v) => v
                    .chunks_mut(rows)
                    .zip(&mut blocks)
                    .for_each(|(c, b)| b.push(ChunkMut::U32(c))),
            }
        }
        pool.install(|| {
            blocks
                .into_par_iter()
                .enumerate()
                .for_each(|(b, chunks)| bin_block(g, binning, b * rows, chunks))
        });
        BinMatrix { columns, labels }
    }

    /// Keeps the rows `rows` of every column, in that order (see
    /// [`super::partition::Partition::renumber`]).
    pub fn compact(&mut self, rows: &[u32], pool: &ThreadPool) {
        // Gathered through a worker's buffer and written back in place: no
        // new column is allocated (fresh pages would fault in every time).
        fn gather<B: Bin>(v: &mut Vec<B>, rows: &[u32], tmp: &mut Vec<u32>) {
            tmp.clear();
            tmp.extend(rows.iter().map(|&r| v[r as usize].index() as u32));
            v.truncate(rows.len());
            for (d, &s) in v.iter_mut().zip(tmp.iter()) {
                *d = B::from_u32(s);
            }
        }
        pool.install(|| {
            self.columns
                .par_iter_mut()
                .for_each_init(Vec::new, |tmp, c| match c {
                    Column::U8(v) => gather(v, rows, tmp),
                    Column::U16(v) => gather(v, rows, tmp),
                    Column::U32(v) => gather(v, rows, tmp),
                })
        });
    }

    /// Labels of the largest location (a counting array's length).
    pub fn max_labels(&self) -> usize {
        self.labels.iter().copied().max().unwrap_or(1).max(1) as usize
    }
}

/// Bins rows `r0..` (as many as each chunk holds) of every dense location.
fn bin_block<T: Prediction>(g: Matrix<'_, T>, binning: &Binning, r0: usize, chunks: Vec<ChunkMut<'_>>) {
    fn fill<T: Prediction, B: Bin>(g: Matrix<'_, T>, binning: &Binning, i: usize, r0: usize, out: &mut [B]) {
        let (min, w, nan) = (binning.min[i], binning.width[i], binning.nan_label(i));
        for (r, o) in out.iter_mut().enumerate() {
            *o = B::from_u32(dense_bin(g.get(r0 + r, i).to_f64(), min, w, nan));
        }
    }
    for (i, chunk) in chunks.into_iter().enumerate() {
        match chunk {
            ChunkMut::U8(c) => fill(g, binning, i, r0, c),
            ChunkMut::U16(c) => fill(g, binning, i, r0, c),
            ChunkMut::U32(c) => fill(g, binning, i, r0, c),
            ChunkMut::Done => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_take_the_narrowest_type_and_equal_the_dense_bins() {
        // Location 0: 3 bins (u8); location 1: 300 bins (u16); location 2:
        // bins far beyond the counting array (ranks, u8 here: 4 distinct).
        let n = 600;
        let mut g = Vec::new();
        for k in 0..n {
            g.extend([(k % 3) as f64, (k % 300) as f64, [0.0, 1e-300, 1.0, 2.0][k % 4]]);
        }
        let m = Matrix::row_major(&g, n, 3).unwrap();
        let b = Binning::new(m, &[1.0, 1.0, 1e-305], false).unwrap();
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let bm = BinMatrix::build(m, &b, &pool);
        assert!(matches!(bm.columns[0], Column::U8(_)));
        assert!(matches!(bm.columns[1], Column::U16(_)));
        assert!(matches!(bm.columns[2], Column::U8(_)));
        assert_eq!(bm.labels[2], 4);
        for k in 0..n {
            let got: Vec<usize> = bm
                .columns
                .iter()
                .map(|c| with_column!(c, |c| c[k].index()))
                .collect();
            assert_eq!(got, vec![k % 3, k % 300, k % 4]);
        }
    }
}
