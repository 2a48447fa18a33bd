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
//! submodularity would allow lazy evaluation with the same result), in
//! parallel over blocks of neighbouring locations so that one read of a row
//! serves a whole block.

use rayon::prelude::*;
use rayon::ThreadPool;

use super::entropy::{clog_table, column_bins, dense_cap, entropy_of, Binning, Partition};
use crate::error::{EdmfError, Result};
use crate::kernel::Prediction;
use crate::matrix::Matrix;

/// Gains (bits, or bits per unit cost) this close to the best are ties.
pub const TIE: f64 = 1e-9;

/// Locations read together from each row.
const BLOCK: usize = 8;

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
    // One pass over the rows fills the bins of all dense locations of the block.
    for k in 0..n {
        for (c, &i) in block.iter().enumerate() {
            if dense[c] {
                s.bins[c * n + k] = binning.dense_bin(i, g.get(k, i).to_f64());
            }
        }
    }
    block
        .iter()
        .enumerate()
        .map(|(c, &i)| {
            let bins = &mut s.bins[c * n..(c + 1) * n];
            if !dense[c] {
                column_bins(g, binning, i, bins);
            }
            part.score(bins, &mut s.count, clog)
        })
        .collect()
}

/// Greedy placement over the columns of `g` (instances x candidate locations).
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
    let mut add = |i: usize, part: &mut Partition, out: &mut Placement, spent: &mut f64| {
        column_bins(g, &binning, i, &mut bins);
        part.refine(&bins, &mut map, &clog);
        out.order.push(i);
        out.entropy.push(part.entropy());
        if let Some(c) = &opts.costs {
            *spent += c[i];
        }
    };
    for &i in &opts.fixed {
        taken[i] = true;
        add(i, &mut part, &mut out, &mut spent);
    }
    while out.order.len() < opts.k {
        if stop() {
            return Err(EdmfError::Interrupted);
        }
        let cost = |i: usize| opts.costs.as_ref().map_or(1.0, |c| c[i]);
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
                .par_chunks(BLOCK)
                .map_init(
                    || Scratch {
                        bins: vec![0u32; BLOCK * n],
                        count: vec![0u32; count_len],
                    },
                    |s, block| score_block(g, &binning, &part, block, &clog, s),
                )
                .flatten_iter()
                .collect()
        });
        out.evaluations += remaining.len() as u64;
        let value: Vec<f64> = remaining
            .iter()
            .zip(&scores)
            .map(|(&i, &acc)| (entropy_of(n, acc) - h) / cost(i))
            .collect();
        let best = value.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        // `remaining` is in index order: the first within TIE is the lowest index.
        let j = value.iter().position(|&v| v >= best - TIE).unwrap_or(0);
        let i = remaining[j];
        let gain = entropy_of(n, scores[j]) - h;
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
