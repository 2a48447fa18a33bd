//! The streaming evaluator of the greedy placement, used when the labels of
//! every location ([`super::bins::BinMatrix`]) would not fit the memory
//! allowed for them (e.g. 10^6 x 1,000 predictions with many bins): bins are
//! computed from the predictions at each evaluation, reading the predictions
//! in tiles of locations row after row of the instances still confused with
//! another, so each cache line read serves a whole tile. Working space O(N)
//! per worker.

use super::entropy::{column_bins, dense_bin, Binning, Partition};
use crate::kernel::Prediction;
use crate::matrix::Matrix;

/// Per-thread working space: the bins of one block of locations and a
/// zeroed counting array.
pub(crate) struct Scratch {
    pub bins: Vec<u32>,
    pub count: Vec<u32>,
    pub touched: Vec<u32>,
}

/// `sum c log2 c` after adding each location of `block`.
pub(crate) fn score_block<T: Prediction>(
    g: Matrix<'_, T>,
    binning: &Binning,
    part: &Partition,
    block: &[usize],
    clog: &[f64],
    s: &mut Scratch,
) -> Vec<f64> {
    let n = g.rows();
    let dense: Vec<bool> = block.iter().map(|&i| binning.is_dense(i, n)).collect();
    // One pass over the rows that matter (instances still confused with
    // another, in increasing order) fills the bins of the block's dense
    // locations; their binning constants are hoisted out of the row loop.
    let cols: Vec<usize> = block
        .iter()
        .copied()
        .filter(|&i| binning.is_dense(i, n))
        .collect();
    let slots: Vec<usize> = (0..block.len()).filter(|&c| dense[c]).collect();
    let min: Vec<f64> = cols.iter().map(|&i| binning.min[i]).collect();
    let width: Vec<f64> = cols.iter().map(|&i| binning.width[i]).collect();
    let nan: Vec<u32> = cols.iter().map(|&i| binning.nan_label(i)).collect();
    let bins = &mut s.bins[..block.len() * n];
    let rows = part.confused();
    // Sparse rows defeat the hardware prefetcher: ask for the tile's cache
    // lines of the row AHEAD rows on (C order; one hint per 8 values).
    const AHEAD: usize = 8;
    let hint = g.rows_contiguous() && rows.len() < n;
    for (r, &k) in rows.iter().enumerate() {
        if hint {
            if let Some(&next) = rows.get(r + AHEAD) {
                for j in (0..cols.len()).step_by(8) {
                    g.prefetch(next as usize, cols[j]);
                }
                if let Some(&last) = cols.last() {
                    g.prefetch(next as usize, last);
                }
            }
        }
        let k = k as usize;
        for j in 0..cols.len() {
            let v = g.get(k, cols[j]).to_f64();
            bins[slots[j] * n + k] = dense_bin(v, min[j], width[j], nan[j]);
        }
    }
    block
        .iter()
        .enumerate()
        .map(|(c, &i)| {
            let bins = &mut s.bins[c * n..(c + 1) * n];
            if !dense[c] {
                column_bins(g, binning, i, None, bins);
            }
            let labels = if dense[c] { binning.n_bins[i] as usize } else { n };
            part.score(bins, labels, &mut s.count, &mut s.touched, clog)
        })
        .collect()
}

/// Locations read together from each row: enough for whole cache lines, few
/// enough that their bins (4 bytes per instance each) stay within ~8 MiB.
pub(crate) fn tile_width(n: usize) -> usize {
    ((8 << 20) / (4 * n.max(1))).clamp(8, 64)
}
