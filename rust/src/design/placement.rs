//! Hierarchical (greedy) sensor placement by joint entropy (Papadopoulou et
//! al. 2014, Sec. 3.2; Bertola et al. 2017, Sec. 2.3).
//!
//! From the empty set (or the sensors the user fixes), each step adds the
//! location with the largest gain `H(S + {i}) - H(S)` (per unit cost when
//! locations have costs), among those the remaining budget affords. Gains
//! within [`TIE`] bits of the best count as ties, which go to the lowest index:
//! the same partition reached through different locations can differ in the
//! last bits of its sum, and a tie must not depend on that.
//!
//! Each step evaluates every remaining location (the exact greedy choice;
//! submodularity would allow lazy evaluation with the same result, but a
//! location read alone costs a cache line per instance, so whole tiles of
//! neighbouring locations are read and evaluated together, in parallel).

use rayon::prelude::*;
use rayon::ThreadPool;
use std::sync::Mutex;

use super::entropy::{clog_table, column_bins, dense_bin, dense_cap, entropy_of, Binning, Partition};
use crate::error::{EdmfError, Result};
use crate::kernel::Prediction;
use crate::matrix::Matrix;

/// Gains (bits, or bits per unit cost) this close to the best are ties.
pub const TIE: f64 = 1e-9;

/// What the greedy placement may choose and when it stops.
#[derive(Debug, Clone, Default)]
pub struct PlacementOptions {
    /// Most sensors in the design, fixed ones included.
    pub k: usize,
    /// Locations every design starts with, in this order.
    pub fixed: Vec<usize>,
    /// Cost of each location (> 0); gains are divided by it.
    pub costs: Option<Vec<f64>>,
    /// Total cost the design may not exceed (needs `costs`).
    pub budget: Option<f64>,
    /// Stop when the best gain (bits) falls below this.
    pub tolerance: Option<f64>,
    /// NaN predictions form a bin of their own (else they are refused).
    pub nan_bin: bool,
}

/// The chosen locations in order and the joint entropy after each one.
#[derive(Debug, Clone, PartialEq)]
pub struct Placement {
    pub order: Vec<usize>,
    pub entropy: Vec<f64>,
    /// (step, location) pairs whose entropy was evaluated.
    pub evaluations: u64,
}

fn check(opts: &PlacementOptions, l: usize) -> Result<()> {
    if opts.k > l {
        return Err(EdmfError::invalid(
            "k",
            format!("at most {l} sensors (the candidate locations), got {}", opts.k),
        ));
    }
    let mut seen = vec![false; l];
    for &i in &opts.fixed {
        if i >= l {
            return Err(EdmfError::invalid(
                "fixed",
                format!("location indices below {l}, got {i}"),
            ));
        }
        if std::mem::replace(&mut seen[i], true) {
            return Err(EdmfError::invalid(
                "fixed",
                format!("distinct locations, got {i} twice"),
            ));
        }
    }
    if opts.fixed.len() > opts.k {
        return Err(EdmfError::invalid(
            "k",
            format!("at least the {} fixed sensors, got {}", opts.fixed.len(), opts.k),
        ));
    }
    if let Some(costs) = &opts.costs {
        if costs.len() != l {
            return Err(EdmfError::invalid(
                "costs",
                format!("one cost per location ({l}), got {}", costs.len()),
            ));
        }
        if let Some((i, c)) = costs
            .iter()
            .enumerate()
            .find(|(_, c)| !(c.is_finite() && **c > 0.0))
        {
            return Err(EdmfError::invalid(
                "costs",
                format!("finite costs > 0, got {c} at location {i}"),
            ));
        }
    }
    if let Some(b) = opts.budget {
        let Some(costs) = &opts.costs else {
            return Err(EdmfError::invalid("budget", "costs to go with it"));
        };
        let cheapest = costs.iter().copied().fold(f64::INFINITY, f64::min);
        if !(b.is_finite() && b >= cheapest) {
            return Err(EdmfError::invalid(
                "budget",
                format!("a finite budget of at least the cheapest sensor ({cheapest}), got {b}"),
            ));
        }
        let fixed: f64 = opts.fixed.iter().map(|&i| costs[i]).sum();
        if fixed > b {
            return Err(EdmfError::invalid(
                "budget",
                format!("at least the cost of the fixed sensors ({fixed}), got {b}"),
            ));
        }
    }
    if let Some(t) = opts.tolerance {
        if !(t.is_finite() && t >= 0.0) {
            return Err(EdmfError::invalid(
                "tolerance",
                format!("a finite gain >= 0 (bits), got {t}"),
            ));
        }
    }
    Ok(())
}

/// Per-thread working space: the bins of one block of locations and a
/// zeroed counting array.
struct Scratch {
    bins: Vec<u32>,
    count: Vec<u32>,
}

/// `sum c log2 c` after adding each location of `block`.
fn score_block<T: Prediction>(
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
            part.score(bins, &mut s.count, clog)
        })
        .collect()
}

/// Locations read together from each row: enough for whole cache lines, few
/// enough that their bins (4 bytes per instance each) stay within ~8 MiB.
fn tile_width(n: usize) -> usize {
    ((8 << 20) / (4 * n.max(1))).clamp(8, 64)
}

/// Greedy placement over the columns of `g` (instances x candidate locations).
///
/// Every step evaluates every remaining location (the exact greedy choice),
/// reading the predictions in tiles of neighbouring locations, row after row
/// of the instances still confused with another: each cache line read serves
/// a whole tile, and the rows read shrink as the instances are told apart.
pub fn place<T: Prediction>(
    g: Matrix<'_, T>,
    widths: &[f64],
    opts: &PlacementOptions,
    pool: &ThreadPool,
    stop: &mut dyn FnMut() -> bool,
) -> Result<Placement> {
    let (n, l) = (g.rows(), g.cols());
    check(opts, l)?;
    let binning = Binning::new(g, widths, opts.nan_bin)?;
    let clog = clog_table(n);
    let cap = dense_cap(n);
    let count_len = (0..l)
        .map(|i| {
            if binning.is_dense(i, n) {
                binning.n_bins[i] as usize
            } else {
                n
            }
        })
        .max()
        .unwrap_or(0)
        .min(cap)
        .max(1);
    let tile = tile_width(n);
    // Working space per worker, kept across steps: O(N) each.
    let scratch: Vec<Mutex<Scratch>> = (0..pool.current_num_threads().max(1))
        .map(|_| {
            Mutex::new(Scratch {
                bins: vec![0u32; tile * n],
                count: vec![0u32; count_len],
            })
        })
        .collect();
    let mut part = Partition::new(n, &clog);
    let mut taken = vec![false; l];
    let mut out = Placement {
        order: Vec::new(),
        entropy: Vec::new(),
        evaluations: 0,
    };
    let mut spent = 0.0;
    let mut bins = vec![0u32; n];
    let mut map = vec![0u32; count_len];
    let cost = |i: usize| opts.costs.as_ref().map_or(1.0, |c| c[i]);
    let mut add = |i: usize, part: &mut Partition, out: &mut Placement, spent: &mut f64| {
        column_bins(g, &binning, i, Some(part.confused()), &mut bins);
        part.refine(&bins, &mut map, &clog);
        out.order.push(i);
        out.entropy.push(part.entropy());
        *spent += cost(i);
    };
    for &i in &opts.fixed {
        taken[i] = true;
        add(i, &mut part, &mut out, &mut spent);
    }
    while out.order.len() < opts.k {
        if stop() {
            return Err(EdmfError::Interrupted);
        }
        let remaining: Vec<usize> = (0..l)
            .filter(|&i| !taken[i])
            .filter(|&i| opts.budget.is_none_or(|b| spent + cost(i) <= b))
            .collect();
        if remaining.is_empty() {
            break;
        }
        let h = part.entropy();
        let scores: Vec<f64> = pool.install(|| {
            remaining
                .par_chunks(tile)
                .map(|block| {
                    // The worker's own scratch (locked by this worker only).
                    let slot = rayon::current_thread_index().unwrap_or(0) % scratch.len();
                    let mut s = scratch[slot].lock().unwrap_or_else(|e| e.into_inner());
                    score_block(g, &binning, &part, block, &clog, &mut s)
                })
                .flatten_iter()
                .collect()
        });
        out.evaluations += remaining.len() as u64;
        let evaluated: Vec<(usize, f64, f64)> = remaining
            .iter()
            .zip(&scores)
            .map(|(&i, &acc)| {
                let gain = entropy_of(n, acc) - h;
                (i, gain / cost(i), gain)
            })
            .collect();
        let best = evaluated.iter().map(|e| e.1).fold(f64::NEG_INFINITY, f64::max);
        // The lowest index among the values within TIE of the best.
        let Some(&(i, _, gain)) = evaluated.iter().filter(|e| e.1 >= best - TIE).min_by_key(|e| e.0) else {
            break; // not reached: the first candidate is always evaluated
        };
        if opts.tolerance.is_some_and(|t| gain < t) {
            break;
        }
        taken[i] = true;
        add(i, &mut part, &mut out, &mut spent);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pool() -> ThreadPool {
        rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap()
    }

    #[test]
    fn picks_the_most_informative_then_the_complement() {
        // Locations 0 and 1 split 3:1, location 2 splits 2:2 (one bit).
        let g = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 1.0];
        let m = Matrix::row_major(&g, 4, 3).unwrap();
        let opts = PlacementOptions {
            k: 3,
            ..Default::default()
        };
        let p = place(m, &[0.5; 3], &opts, &pool(), &mut || false).unwrap();
        assert_eq!(p.order, vec![2, 0, 1]); // 0 and 1 tie at step 2: lowest index
        assert_eq!(p.entropy[0], 1.0);
        assert!((p.entropy[1] - 1.5).abs() < 1e-12);
        assert!((p.entropy[2] - 1.5).abs() < 1e-12);
    }

    #[test]
    fn bad_options_are_errors() {
        let g = [0.0; 6];
        let m = Matrix::row_major(&g, 2, 3).unwrap();
        let w = [1.0; 3];
        let run = |o: PlacementOptions| place(m, &w, &o, &pool(), &mut || false);
        assert!(run(PlacementOptions {
            k: 4,
            ..Default::default()
        })
        .is_err());
        assert!(run(PlacementOptions {
            k: 2,
            fixed: vec![1, 1],
            ..Default::default()
        })
        .is_err());
        assert!(run(PlacementOptions {
            k: 2,
            fixed: vec![3],
            ..Default::default()
        })
        .is_err());
        let costs = Some(vec![1.0, 2.0, 0.0]);
        assert!(run(PlacementOptions {
            k: 2,
            costs,
            ..Default::default()
        })
        .is_err());
        let costs = Some(vec![1.0, 2.0, 3.0]);
        assert!(run(PlacementOptions {
            k: 2,
            costs,
            budget: Some(0.5),
            ..Default::default()
        })
        .is_err());
    }
}
