//! Hierarchical (greedy) sensor placement by joint entropy (Papadopoulou et
//! al. 2014, Sec. 3.2; Bertola et al. 2017, Sec. 2.3).
//!
//! From the empty set (or the sensors the user fixes), each step adds the
//! location with the largest gain `H(S + {i}) - H(S)` (per unit cost when
//! locations have costs), among those the remaining budget and the per-type
//! quotas allow. Gains within [`TIE`] bits of the best count as ties, which
//! go to the lowest index: the same partition reached through different
//! locations can differ in the last bits of its sum, and a tie must not
//! depend on that.
//!
//! Lazy evaluation (Minoux 1978): joint entropy is submodular, so a
//! location's gain can only shrink as sensors are added and its last
//! evaluated gain bounds its gain now. Each step evaluates locations in
//! decreasing order of their bounds until no bound left can reach the ties
//! of the best gain found; every location that plain greedy would count as
//! a tie is then evaluated afresh, so the choice is plain greedy's.
//!
//! The labels of every location are computed once ([`BinMatrix`]) when they
//! fit [`PlacementOptions::bin_memory`]; otherwise the streaming evaluator
//! ([`super::tiles`]) bins from the predictions at each evaluation.

use rayon::prelude::*;
use rayon::ThreadPool;
use std::sync::Mutex;

use super::bins::{with_column, BinMatrix};
use super::entropy::{clog_table, column_bins, dense_cap, entropy_of, Binning, Partition};
use super::options::check;
pub use super::options::{Placement, PlacementOptions, DEFAULT_BIN_MEMORY, TIE};
use super::tiles::{score_block, tile_width, Scratch};
use crate::error::{EdmfError, Result};
use crate::kernel::Prediction;
use crate::matrix::Matrix;

/// How the gains of a batch of locations are computed.
enum Evaluator<'a, T> {
    /// From the labels computed once.
    Bins(BinMatrix),
    /// From the predictions, in tiles (bins beyond the memory allowed).
    Stream { g: Matrix<'a, T>, tile: usize },
}

/// Per-worker working space (each worker locks only its own).
fn scratch(pool: &ThreadPool, bins: usize, count: usize) -> Vec<Mutex<Scratch>> {
    (0..pool.current_num_threads().max(1))
        .map(|_| {
            Mutex::new(Scratch {
                bins: vec![0u32; bins],
                count: vec![0u32; count],
                touched: Vec::new(),
            })
        })
        .collect()
}

fn my_scratch(s: &[Mutex<Scratch>]) -> std::sync::MutexGuard<'_, Scratch> {
    let slot = rayon::current_thread_index().unwrap_or(0) % s.len();
    s[slot].lock().unwrap_or_else(|e| e.into_inner())
}

impl<T: Prediction> Evaluator<'_, T> {
    /// `sum c log2 c` after adding each location of `batch` (in its order).
    fn scores(
        &self,
        binning: &Binning,
        part: &Partition,
        batch: &[usize],
        clog: &[f64],
        pool: &ThreadPool,
        s: &[Mutex<Scratch>],
    ) -> Vec<f64> {
        pool.install(|| match self {
            Evaluator::Bins(bm) => batch
                .par_iter()
                .with_max_len(1)
                .map(|&i| {
                    let mut s = my_scratch(s);
                    let Scratch { count, touched, .. } = &mut *s;
                    let labels = bm.labels[i] as usize;
                    with_column!(&bm.columns[i], |c| part.score(c, labels, count, touched, clog))
                })
                .collect(),
            Evaluator::Stream { g, tile } => batch
                .par_chunks(*tile)
                .map(|block| score_block(*g, binning, part, block, clog, &mut my_scratch(s)))
                .flatten_iter()
                .collect(),
        })
    }
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
    let binning = Binning::new_in(g, widths, opts.nan_bin, pool)?;
    let clog = clog_table(n);
    let memory = opts.bin_memory.unwrap_or(DEFAULT_BIN_MEMORY);
    let (eval, count_len, tile) = if BinMatrix::bytes(g, &binning) <= memory {
        let bm = BinMatrix::build(g, &binning, pool);
        let len = bm.max_labels();
        (Evaluator::Bins(bm), len, 0)
    } else {
        let len = (0..l)
            .map(|i| {
                if binning.is_dense(i, n) {
                    binning.n_bins[i] as usize
                } else {
                    n
                }
            })
            .max()
            .unwrap_or(0)
            .min(dense_cap(n))
            .max(1);
        let tile = tile_width(n);
        (Evaluator::Stream { g, tile }, len, tile)
    };
    if stop() {
        return Err(EdmfError::Interrupted);
    }
    // Four counting arrays' worth (large groups are counted interleaved)
    // unless the bins are so many that one is large already.
    let s = scratch(
        pool,
        tile * n,
        if count_len <= 1 << 16 {
            4 * count_len
        } else {
            count_len
        },
    );
    let mut part = Partition::new(n, &clog);
    let mut taken = vec![false; l];
    let mut used = vec![0usize; opts.max_per_type.len()];
    let mut out = Placement {
        order: Vec::new(),
        entropy: Vec::new(),
        evaluations: 0,
    };
    let mut spent = 0.0;
    let mut bins = vec![0u32; if tile > 0 { n } else { 0 }];
    let mut map = vec![0u32; count_len];
    let cost = |i: usize| opts.costs.as_ref().map_or(1.0, |c| c[i]);
    let mut eval = eval;
    // Rows the labels were last compacted to (N at first).
    let mut rows_kept = n;
    let mut add = |i: usize, part: &mut Partition, out: &mut Placement, eval: &mut Evaluator<'_, T>| {
        match eval {
            Evaluator::Bins(bm) => {
                with_column!(&bm.columns[i], |c| part.refine(c, &mut map, &clog));
                // Drop the rows told apart and put the groups in contiguous
                // ranges: after the first sensor, then whenever a quarter of
                // the rows kept has been told apart.
                let m = part.n_confused();
                if out.order.is_empty() || 4 * m <= 3 * rows_kept {
                    let rows = part.renumber();
                    bm.compact(&rows, pool);
                    rows_kept = m;
                }
            }
            Evaluator::Stream { .. } => {
                column_bins(g, &binning, i, Some(part.confused()), &mut bins);
                part.refine(&bins, &mut map, &clog);
            }
        }
        out.order.push(i);
        out.entropy.push(part.entropy());
    };
    for &i in &opts.fixed {
        taken[i] = true;
        spent += cost(i);
        if !used.is_empty() {
            used[opts.type_of[i]] += 1;
        }
        add(i, &mut part, &mut out, &mut eval);
    }
    // Bound of each location's gain (per unit cost): its last evaluated one.
    let mut bound = vec![f64::INFINITY; l];
    let batch_len = 2 * pool.current_num_threads().max(1);
    while out.order.len() < opts.k {
        if stop() {
            return Err(EdmfError::Interrupted);
        }
        let mut eligible: Vec<usize> = (0..l)
            .filter(|&i| !taken[i])
            .filter(|&i| opts.budget.is_none_or(|b| spent + cost(i) <= b))
            .filter(|&i| used.is_empty() || used[opts.type_of[i]] < opts.max_per_type[opts.type_of[i]])
            .collect();
        if eligible.is_empty() {
            break;
        }
        let h = part.entropy();
        // Largest bound first, ties by index (a stable sort keeps index order).
        eligible.sort_by(|&a, &b| bound[b].total_cmp(&bound[a]));
        let mut evaluated: Vec<(usize, f64, f64)> = Vec::new();
        let mut best = f64::NEG_INFINITY;
        let mut pos = 0;
        while pos < eligible.len() {
            // Next batch: locations whose bound may still reach a tie of the
            // best (all of them when exhaustive, all unbounded ones at once).
            let mut end = pos;
            while end < eligible.len() {
                let b = bound[eligible[end]];
                let may = opts.exhaustive || b + TIE * (1.0 + b.abs()) >= best - TIE;
                let full = end - pos >= batch_len && !opts.exhaustive && b.is_finite();
                if !may || full {
                    break;
                }
                end += 1;
            }
            if end == pos {
                break; // no bound left can reach the ties of the best
            }
            let batch = &eligible[pos..end];
            let scores = eval.scores(&binning, &part, batch, &clog, pool, &s);
            out.evaluations += batch.len() as u64;
            for (&i, &acc) in batch.iter().zip(&scores) {
                let gain = entropy_of(n, acc) - h;
                let value = gain / cost(i);
                bound[i] = value;
                best = best.max(value);
                evaluated.push((i, value, gain));
            }
            pos = end;
        }
        // The lowest index among the values within TIE of the best.
        let Some(&(i, _, gain)) = evaluated.iter().filter(|e| e.1 >= best - TIE).min_by_key(|e| e.0) else {
            break; // not reached: the first batch is never empty
        };
        // A gain within TIE of the tolerance reaches it: an added location that
        // leaves the partition as it was gains 0 bits, which the sums can give
        // as -4e-16 (tolerance 0 then stopped the design early).
        if opts.tolerance.is_some_and(|t| gain < t - TIE) {
            break;
        }
        taken[i] = true;
        spent += cost(i);
        if !used.is_empty() {
            used[opts.type_of[i]] += 1;
        }
        add(i, &mut part, &mut out, &mut eval);
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

    /// Levels 0..levels with repeated columns (many ties), deterministic.
    fn tied(n: usize, l: usize, levels: u64, seed: u64) -> Vec<f64> {
        let mut state = seed | 1;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let base: Vec<f64> = (0..n * l).map(|_| (next() % levels) as f64).collect();
        // Every third column repeats its left neighbour.
        (0..n * l)
            .map(|x| {
                let (k, i) = (x / l, x % l);
                let j = if i % 3 == 2 { i - 1 } else { i };
                base[k * l + j]
            })
            .collect()
    }

    #[test]
    fn lazy_exhaustive_and_streaming_give_the_same_placement() {
        for (seed, levels, width) in [(1, 2, 0.5), (2, 3, 0.7), (3, 40, 1.0), (4, 400, 1.0), (5, 4, 3.0)] {
            let (n, l) = (300, 24);
            let g = tied(n, l, levels, seed);
            let m = Matrix::row_major(&g, n, l).unwrap();
            let w = vec![width; l];
            let costs: Vec<f64> = (0..l).map(|i| [1.0, 2.0, 3.5][i % 3]).collect();
            for with_costs in [false, true] {
                let base = PlacementOptions {
                    k: 12,
                    fixed: vec![5],
                    costs: with_costs.then(|| costs.clone()),
                    ..Default::default()
                };
                let run = |o: PlacementOptions| place(m, &w, &o, &pool(), &mut || false).unwrap();
                let plain = run(PlacementOptions {
                    exhaustive: true,
                    ..base.clone()
                });
                let lazy = run(base.clone());
                let stream = run(PlacementOptions {
                    bin_memory: Some(0),
                    ..base.clone()
                });
                let stream_plain = run(PlacementOptions {
                    bin_memory: Some(0),
                    exhaustive: true,
                    ..base.clone()
                });
                assert_eq!(lazy.order, plain.order, "seed {seed}");
                assert_eq!(stream.order, plain.order, "seed {seed}");
                assert_eq!(stream_plain.order, plain.order, "seed {seed}");
                assert_eq!(lazy.entropy, plain.entropy);
                assert_eq!(stream.entropy, plain.entropy);
                // Plain greedy evaluates every remaining location at every step.
                let steps = plain.order.len() - 1;
                let all: u64 = (0..steps).map(|s| (l - 1 - s) as u64).sum();
                assert_eq!(plain.evaluations, all);
                assert!(lazy.evaluations <= plain.evaluations);
            }
        }
    }

    #[test]
    fn lazy_evaluation_skips_locations_on_a_smooth_response() {
        // Neighbouring locations carry nearly the same information: once one
        // is chosen the others' bounds fall below the best and are skipped.
        let (n, l) = (4000, 60);
        let u = tied(n, 2, 1 << 20, 7);
        let mut g = Vec::new();
        for k in 0..n {
            let (a, b) = (u[2 * k] / (1 << 20) as f64, u[2 * k + 1] / (1 << 20) as f64);
            for i in 0..l {
                let x = i as f64 / (l - 1) as f64;
                g.push(a * (std::f64::consts::PI * x).sin() + b * x * x);
            }
        }
        let m = Matrix::row_major(&g, n, l).unwrap();
        let w = vec![0.05; l];
        let o = PlacementOptions {
            k: 8,
            ..Default::default()
        };
        let lazy = place(m, &w, &o, &pool(), &mut || false).unwrap();
        let plain = place(
            m,
            &w,
            &PlacementOptions {
                exhaustive: true,
                ..o.clone()
            },
            &pool(),
            &mut || false,
        )
        .unwrap();
        assert_eq!(lazy.order, plain.order);
        // Here 289 of 452 (step, location) pairs.
        assert!(
            lazy.evaluations * 4 < plain.evaluations * 3,
            "{} vs {}",
            lazy.evaluations,
            plain.evaluations
        );
    }

    #[test]
    fn quotas_limit_the_sensors_of_each_type() {
        let (n, l) = (200, 12);
        let g = tied(n, l, 5, 9);
        let m = Matrix::row_major(&g, n, l).unwrap();
        let w = vec![1.0; l];
        let type_of: Vec<usize> = (0..l).map(|i| i % 2).collect();
        let o = PlacementOptions {
            k: 6,
            type_of: type_of.clone(),
            max_per_type: vec![1, 10],
            ..Default::default()
        };
        let p = place(m, &w, &o, &pool(), &mut || false).unwrap();
        assert_eq!(p.order.len(), 6);
        assert_eq!(p.order.iter().filter(|&&i| type_of[i] == 0).count(), 1);
        // A quota of zero for both types leaves nothing to choose.
        let none = PlacementOptions {
            max_per_type: vec![0, 0],
            ..o.clone()
        };
        assert!(place(m, &w, &none, &pool(), &mut || false)
            .unwrap()
            .order
            .is_empty());
        // Fixed sensors beyond a quota are an error naming it.
        let over = PlacementOptions {
            fixed: vec![0, 2],
            ..o
        };
        let e = place(m, &w, &over, &pool(), &mut || false).unwrap_err();
        assert!(e.to_string().contains("max_per_type"), "{e}");
    }
}
