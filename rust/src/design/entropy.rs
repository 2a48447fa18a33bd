//! Joint entropy of sensor locations (Papadopoulou, Raphael, Smith & Sekhar
//! 2014, Entropy 16(9):5078, Eqs. 3-6; Bertola et al. 2017, Sensors 17:2904).
//!
//! Bin of instance k at location i: `b[k, i] = floor((G[k, i] - min_k G[k, i]) / w_i)`,
//! in float64. The joint entropy of a set S is `H(S) = -sum_t p_t log2 p_t` over
//! the distinct tuples `t = (b[k, i])_{i in S}`, written here as
//! `H = log2 N - (1/N) sum_t c_t log2 c_t` with `c_t` the instance counts.
//!
//! A [`Partition`] holds the groups of instances that share a tuple. Adding a
//! location splits each group by its bin: one pass over the members with a
//! counting array indexed by the (dense) bin, so O(N) per location and no hash
//! map. Groups of one instance can never split again and contribute
//! `1 log2 1 = 0`, so they are dropped from the partition: later steps read only
//! the instances that are still confused with another.

pub(crate) use super::partition::{clog_table, entropy_of};
pub use super::partition::{Bin, Partition};
use crate::error::{EdmfError, Result};
use crate::kernel::Prediction;
use crate::matrix::Matrix;

/// Largest bin count read through a counting array; locations with more bins
/// (very narrow widths) are relabelled densely by a sort instead.
pub(crate) fn dense_cap(n: usize) -> usize {
    (4 * n).max(1 << 16)
}

/// How each location's predictions are binned.
#[derive(Debug, Clone)]
pub struct Binning {
    /// `min_k G[k, i]` over the non-NaN predictions (0 if there are none).
    pub min: Vec<f64>,
    pub width: Vec<f64>,
    /// Bins of each location, the NaN bin (last) included.
    pub n_bins: Vec<f64>,
    /// Whether NaN predictions form a bin of their own (else they are refused).
    pub nan_bin: bool,
}

impl Binning {
    /// One pass over the predictions: per-location minimum and bin count.
    /// Widths must be finite and > 0; NaN predictions are an error unless
    /// `nan_bin`; infinite predictions are always an error.
    pub fn new<T: Prediction>(g: Matrix<'_, T>, widths: &[f64], nan_bin: bool) -> Result<Self> {
        Self::build(g, widths, nan_bin, None)
    }

    /// As [`Binning::new`], the rows shared among the workers of `pool`
    /// in blocks (minima and maxima are exact, so the result is the same;
    /// the error reported is that of the first bad value, row after row).
    pub fn new_in<T: Prediction>(
        g: Matrix<'_, T>,
        widths: &[f64],
        nan_bin: bool,
        pool: &rayon::ThreadPool,
    ) -> Result<Self> {
        Self::build(g, widths, nan_bin, Some(pool))
    }

    fn build<T: Prediction>(
        g: Matrix<'_, T>,
        widths: &[f64],
        nan_bin: bool,
        pool: Option<&rayon::ThreadPool>,
    ) -> Result<Self> {
        use rayon::prelude::*;
        let l = g.cols();
        if widths.len() != l {
            return Err(EdmfError::invalid(
                "widths",
                format!("one width per location ({l}), got {}", widths.len()),
            ));
        }
        if let Some((i, w)) = widths
            .iter()
            .enumerate()
            .find(|(_, w)| !(w.is_finite() && **w > 0.0))
        {
            return Err(EdmfError::invalid(
                "widths",
                format!("finite widths > 0, got {w} at location {i}"),
            ));
        }
        const BLOCK: usize = 1024;
        let scan = |r0: usize| scan_rows(g, r0..(r0 + BLOCK).min(g.rows()), nan_bin);
        let starts: Vec<usize> = (0..g.rows()).step_by(BLOCK).collect();
        let blocks: Vec<Result<(Vec<f64>, Vec<f64>)>> = match pool {
            Some(pool) => pool.install(|| starts.par_iter().map(|&r0| scan(r0)).collect()),
            None => starts.iter().map(|&r0| scan(r0)).collect(),
        };
        let mut min = vec![f64::INFINITY; l];
        let mut max = vec![f64::NEG_INFINITY; l];
        for block in blocks {
            let (lo, hi) = block?;
            for i in 0..l {
                min[i] = min[i].min(lo[i]);
                max[i] = max[i].max(hi[i]);
            }
        }
        let mut n_bins = vec![1.0; l];
        for i in 0..l {
            if min[i] > max[i] {
                min[i] = 0.0; // all NaN (or no instances): one bin
                continue;
            }
            // floor is monotone in g, so the largest bin is that of the maximum.
            n_bins[i] = ((max[i] - min[i]) / widths[i]).floor() + 2.0; // + the NaN bin
        }
        Ok(Binning {
            min,
            width: widths.to_vec(),
            n_bins,
            nan_bin,
        })
    }

    /// Whether location `i` is binned through a counting array.
    pub(crate) fn is_dense(&self, i: usize, n: usize) -> bool {
        self.n_bins[i] <= dense_cap(n) as f64
    }

    /// Dense bin of a prediction at a location read through a counting
    /// array; NaN gets the last bin.
    #[inline(always)]
    pub(crate) fn dense_bin(&self, i: usize, v: f64) -> u32 {
        dense_bin(v, self.min[i], self.width[i], self.nan_label(i))
    }

    /// The dense label of the NaN bin of location `i` (the last one).
    #[inline(always)]
    pub(crate) fn nan_label(&self, i: usize) -> u32 {
        (self.n_bins[i] - 1.0) as u32
    }

    /// Bin as a sort key (exact integer as a float); NaN sorts last, alone.
    #[inline(always)]
    pub(crate) fn key(&self, i: usize, v: f64) -> f64 {
        if v.is_nan() {
            f64::INFINITY
        } else {
            ((v - self.min[i]) / self.width[i]).floor()
        }
    }
}

/// Minimum and maximum of each location over `rows` (NaN skipped when
/// `nan_bin`); the first bad value, row after row, is the error.
fn scan_rows<T: Prediction>(
    g: Matrix<'_, T>,
    rows: std::ops::Range<usize>,
    nan_bin: bool,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let l = g.cols();
    let mut min = vec![f64::INFINITY; l];
    let mut max = vec![f64::NEG_INFINITY; l];
    for k in rows {
        for i in 0..l {
            let v = g.get(k, i).to_f64();
            if v.is_nan() {
                if !nan_bin {
                    return Err(EdmfError::invalid(
                        "predictions",
                        format!(
                            "no NaN (got one at instance {k}, location {i}); pass nan_policy='bin' \
                             to give NaN predictions a bin of their own"
                        ),
                    ));
                }
                continue;
            }
            if v.is_infinite() {
                return Err(EdmfError::invalid(
                    "predictions",
                    format!("finite values, got {v} at instance {k}, location {i}"),
                ));
            }
            min[i] = min[i].min(v);
            max[i] = max[i].max(v);
        }
    }
    Ok((min, max))
}

/// `floor((v - min) / w)` for a dense location, `nan` for NaN. `v - min >= 0`
/// exactly (min is the least value), so the truncating cast is the floor.
#[inline(always)]
pub(crate) fn dense_bin(v: f64, min: f64, w: f64, nan: u32) -> u32 {
    if v.is_nan() {
        nan
    } else {
        ((v - min) / w) as u32
    }
}

/// Dense bins (0..n_distinct) of location `i`, written to `out` for the
/// instances `rows` (all when `None`; other entries are left as they are).
/// Narrow bins beyond the counting-array cap are relabelled by a sort over all
/// instances, which keeps the same partition (labels only change names).
pub(crate) fn column_bins<T: Prediction>(
    g: Matrix<'_, T>,
    binning: &Binning,
    i: usize,
    rows: Option<&[u32]>,
    out: &mut [u32],
) {
    let n = g.rows();
    if binning.is_dense(i, n) {
        match rows {
            Some(rows) => {
                for &k in rows {
                    out[k as usize] = binning.dense_bin(i, g.get(k as usize, i).to_f64());
                }
            }
            None => {
                for (k, b) in out.iter_mut().enumerate().take(n) {
                    *b = binning.dense_bin(i, g.get(k, i).to_f64());
                }
            }
        }
    } else {
        let keys: Vec<f64> = (0..n).map(|k| binning.key(i, g.get(k, i).to_f64())).collect();
        relabel(&keys, out);
    }
}

/// Dense labels of float keys (exact integers), in order of value.
pub(crate) fn relabel(keys: &[f64], out: &mut [u32]) {
    let mut idx: Vec<u32> = (0..keys.len() as u32).collect();
    idx.sort_unstable_by(|&a, &b| keys[a as usize].total_cmp(&keys[b as usize]));
    let mut label = 0u32;
    for j in 0..idx.len() {
        if j > 0 && keys[idx[j] as usize] != keys[idx[j - 1] as usize] {
            label += 1;
        }
        out[idx[j] as usize] = label;
    }
}

/// `H(S)` of the given locations (repeats allowed: they change nothing).
pub fn joint_entropy<T: Prediction>(
    g: Matrix<'_, T>,
    widths: &[f64],
    sensors: &[usize],
    nan_bin: bool,
) -> Result<f64> {
    if let Some(&i) = sensors.iter().find(|&&i| i >= g.cols()) {
        return Err(EdmfError::invalid(
            "sensors",
            format!("location indices below {}, got {i}", g.cols()),
        ));
    }
    let binning = Binning::new(g, widths, nan_bin)?;
    let n = g.rows();
    let clog = clog_table(n);
    let mut part = Partition::new(n, &clog);
    let mut bins = vec![0u32; n];
    let mut map: Vec<u32> = Vec::new();
    for &i in sensors {
        column_bins(g, &binning, i, Some(part.confused()), &mut bins);
        let need = bins.iter().map(|&b| b as usize + 1).max().unwrap_or(0);
        if map.len() < need {
            map.resize(need, 0);
        }
        part.refine(&bins, &mut map, &clog);
    }
    Ok(part.entropy())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_equal_halves_carry_one_bit() {
        let g = [0.0, 0.0, 1.0, 1.0];
        let m = Matrix::row_major(&g, 4, 1).unwrap();
        assert_eq!(joint_entropy(m, &[0.5], &[0], false).unwrap(), 1.0);
        assert_eq!(joint_entropy(m, &[0.5], &[], false).unwrap(), 0.0);
        // One bin wide enough for all: nothing learnt.
        assert_eq!(joint_entropy(m, &[2.0], &[0], false).unwrap(), 0.0);
    }

    #[test]
    fn all_distinct_reaches_log2_n() {
        let g: Vec<f64> = (0..8).map(|v| v as f64).collect();
        let m = Matrix::row_major(&g, 8, 1).unwrap();
        assert!((joint_entropy(m, &[1.0], &[0], false).unwrap() - 3.0).abs() < 1e-12);
    }

    #[test]
    fn bad_widths_and_nan_are_refused() {
        let g = [0.0, f64::NAN];
        let m = Matrix::row_major(&g, 2, 1).unwrap();
        assert!(joint_entropy(m, &[0.0], &[0], true).is_err());
        assert!(joint_entropy(m, &[f64::NAN], &[0], true).is_err());
        assert!(joint_entropy(m, &[1.0], &[0], false).is_err());
        assert_eq!(joint_entropy(m, &[1.0], &[0], true).unwrap(), 1.0);
        assert!(joint_entropy(m, &[1.0], &[1], true).is_err());
    }

    #[test]
    fn narrow_bins_are_relabelled_to_the_same_partition() {
        let g = [0.0, 1e-300, 1.0, 1.0];
        let m = Matrix::row_major(&g, 4, 1).unwrap();
        assert!((joint_entropy(m, &[1e-305], &[0], false).unwrap() - 1.5).abs() < 1e-12);
    }
}
