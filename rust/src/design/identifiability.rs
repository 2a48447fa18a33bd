//! Expected identifiability of a sensor set (Bertola, Papadopoulou, Vernay &
//! Smith 2017, Sensors 17:2904, Sec. 2.4; Goulet & Smith 2013, Eqs. 4 and 8).
//!
//! Simulation s takes a true instance `j_s` and one residual `u_s,i` per
//! sensor (drawn by the caller, so that any implementation can use the same
//! draws), sets the simulated measurements `y = G[j_s, S] - u_s` (Eq. 4) and
//! counts the instances that Eq. 8 keeps: `low_i <= G[k, S_i] - y_i <= high_i`
//! at every sensor of S. The Eq. 8 test is the falsifier's own, moved into
//! prediction space (`acceptance::accepted`): two comparisons per value and
//! bit-for-bit the verdict of the residual test.
//!
//! The predictions of S are copied once into one contiguous column per sensor
//! (N x |S| values, which stay in cache for the simulations); each simulation
//! filters the instances sensor after sensor and stops when none is left.

use rayon::prelude::*;
use rayon::ThreadPool;

use crate::acceptance::{accepted, Ordered};
use crate::error::{EdmfError, Result};
use crate::kernel::Prediction;
use crate::matrix::Matrix;

/// Simulations run between two `stop` checks.
const BATCH: usize = 256;

/// Candidate-set size of every simulation.
///
/// `truth[s]` is the true instance of simulation s, `residuals` its
/// `(n_simulations, |S|)` draws of the combined uncertainty at the sensors, and
/// `low`/`high` the threshold bounds of the sensors (Eq. 5 for |S| sensors).
#[allow(clippy::too_many_arguments)]
pub fn candidate_counts<T: Prediction + Ordered>(
    g: Matrix<'_, T>,
    sensors: &[usize],
    truth: &[u64],
    residuals: Matrix<'_, f64>,
    low: &[f64],
    high: &[f64],
    pool: &ThreadPool,
    stop: &mut dyn FnMut() -> bool,
) -> Result<Vec<u64>> {
    let (n, m) = (g.rows(), sensors.len());
    if let Some(&i) = sensors.iter().find(|&&i| i >= g.cols()) {
        return Err(EdmfError::invalid(
            "sensors",
            format!("location indices below {}, got {i}", g.cols()),
        ));
    }
    if residuals.rows() != truth.len() || residuals.cols() != m {
        return Err(EdmfError::invalid(
            "residuals",
            format!(
                "shape ({}, {m}) (simulations, sensors), got ({}, {})",
                truth.len(),
                residuals.rows(),
                residuals.cols()
            ),
        ));
    }
    if let Some(&j) = truth.iter().find(|&&j| j as usize >= n) {
        return Err(EdmfError::invalid(
            "truth",
            format!("instance indices below {n}, got {j}"),
        ));
    }
    if low.len() != m || high.len() != m {
        return Err(EdmfError::invalid(
            "thresholds",
            format!("{m} low and high bounds"),
        ));
    }
    if low.iter().chain(high).any(|v| !v.is_finite()) || low.iter().zip(high).any(|(a, b)| a > b) {
        return Err(EdmfError::invalid("thresholds", "finite bounds with low <= high"));
    }
    for s in 0..residuals.rows() {
        for i in 0..m {
            if !residuals.get(s, i).is_finite() {
                return Err(EdmfError::invalid(
                    "residuals",
                    format!("finite values, got one at simulation {s}"),
                ));
            }
        }
    }
    // The predictions of S, one contiguous column per sensor.
    let columns: Vec<Vec<T>> = sensors
        .iter()
        .map(|&i| (0..n).map(|k| g.get(k, i)).collect())
        .collect();
    let count_one = |s: usize, survivors: &mut Vec<u32>| -> u64 {
        let j = truth[s] as usize;
        let mut windows = Vec::with_capacity(m);
        for i in 0..m {
            let y = columns[i][j].to_f64() - residuals.get(s, i); // Eq. 4
            if !y.is_finite() {
                return 0; // a NaN truth: every residual is NaN, nothing passes Eq. 8
            }
            windows.push(accepted::<T>(y, low[i], high[i], |p| p.to_f64()));
        }
        if m == 0 {
            return n as u64;
        }
        let (a, b) = windows[0];
        survivors.clear();
        survivors.extend(
            columns[0]
                .iter()
                .enumerate()
                .filter(|(_, &p)| p.to_f64() >= a.to_f64() && p.to_f64() <= b.to_f64())
                .map(|(k, _)| k as u32),
        );
        for i in 1..m {
            if survivors.is_empty() {
                break;
            }
            let (a, b) = (windows[i].0.to_f64(), windows[i].1.to_f64());
            let col = &columns[i];
            survivors.retain(|&k| {
                let p = col[k as usize].to_f64();
                p >= a && p <= b
            });
        }
        survivors.len() as u64
    };
    let mut sizes = Vec::with_capacity(truth.len());
    for start in (0..truth.len()).step_by(BATCH) {
        if stop() {
            return Err(EdmfError::Interrupted);
        }
        let end = (start + BATCH).min(truth.len());
        let batch: Vec<u64> = pool.install(|| {
            (start..end)
                .into_par_iter()
                .map_init(|| Vec::with_capacity(n), |buf, s| count_one(s, buf))
                .collect()
        });
        sizes.extend(batch);
    }
    Ok(sizes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_the_instances_within_the_bounds() {
        // One sensor; predictions 0..10, truth 5, residual 0, bounds [-1.5, 1.5].
        let g: Vec<f64> = (0..10).map(|v| v as f64).collect();
        let m = Matrix::row_major(&g, 10, 1).unwrap();
        let r = [0.0, 1.0];
        let res = Matrix::row_major(&r, 2, 1).unwrap();
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let sizes = candidate_counts(m, &[0], &[5, 0], res, &[-1.5], &[1.5], &pool, &mut || false).unwrap();
        // Simulation 1: y = 0 - 1 = -1, residuals k + 1 in [-1.5, 1.5] for k = 0.
        assert_eq!(sizes, vec![3, 1]);
        assert!(candidate_counts(m, &[1], &[5], res, &[-1.0], &[1.0], &pool, &mut || false).is_err());
    }
}
