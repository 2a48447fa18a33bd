//! Threshold bounds (Goulet & Smith 2013, Eq. 5): per sensor, the shortest
//! interval holding the per-sensor probability of the combined uncertainty U_c.
//!
//! Only the Monte Carlo route lives here (sort + sliding window); the
//! closed-form route (Eq. 6) needs inverse CDFs and stays in Python/SciPy.

use crate::error::{EdmfError, Result};
use crate::matrix::Matrix;
use rayon::prelude::*;
use rayon::ThreadPool;

/// Per-sensor bounds `[low_i, high_i]` on the residual g_i(theta) - y_i (Eq. 8).
#[derive(Debug, Clone, PartialEq)]
pub struct Thresholds {
    low: Vec<f64>,
    high: Vec<f64>,
}

impl Thresholds {
    /// Validates what Eq. 8 needs: one bound pair per sensor, finite, low <= high.
    pub fn new(low: Vec<f64>, high: Vec<f64>) -> Result<Self> {
        if low.len() != high.len() {
            return Err(EdmfError::invalid(
                "thresholds",
                format!(
                    "low and high of equal length, got {} and {}",
                    low.len(),
                    high.len()
                ),
            ));
        }
        if low.is_empty() {
            return Err(EdmfError::invalid(
                "thresholds",
                "at least one sensor (n_m >= 1), got 0",
            ));
        }
        for (i, (&l, &h)) in low.iter().zip(&high).enumerate() {
            if !l.is_finite() || !h.is_finite() {
                return Err(EdmfError::invalid(
                    "thresholds",
                    format!("finite bounds, got [{l}, {h}] at sensor {i}"),
                ));
            }
            if l > h {
                return Err(EdmfError::invalid(
                    "thresholds",
                    format!("low <= high, got low={l} > high={h} at sensor {i}"),
                ));
            }
        }
        Ok(Thresholds { low, high })
    }

    pub fn low(&self) -> &[f64] {
        &self.low
    }

    pub fn high(&self) -> &[f64] {
        &self.high
    }

    pub fn n_sensors(&self) -> usize {
        self.low.len()
    }
}

/// Checks a per-sensor probability lies strictly inside (0, 1).
pub fn check_probability(probability: f64) -> Result<()> {
    if probability.is_finite() && probability > 0.0 && probability < 1.0 {
        Ok(())
    } else {
        Err(EdmfError::invalid(
            "probability",
            format!("a value in (0, 1), got {probability}"),
        ))
    }
}

/// The fewest samples whose shortest interval can exclude at least one sample:
/// below `1/(1-p)` every interval holding `p` of the samples is the full range.
pub fn min_samples(probability: f64) -> Result<usize> {
    check_probability(probability)?;
    Ok((1.0 / (1.0 - probability)).ceil() as usize)
}

/// Number of samples the interval must hold: `ceil(p * n)`, at least one.
pub fn window_len(probability: f64, n: usize) -> usize {
    ((probability * n as f64).ceil() as usize).clamp(1, n.max(1))
}

/// Shortest interval holding `window_len(p, n)` of `sorted` samples.
/// Ties go to the lowest interval so the answer never depends on scheduling.
pub fn shortest_interval(sorted: &[f64], probability: f64) -> Result<(f64, f64)> {
    check_probability(probability)?;
    if sorted.is_empty() {
        return Err(EdmfError::invalid("combined", "at least one sample, got none"));
    }
    Ok(shortest_window(sorted, probability))
}

/// `shortest_interval` for checked arguments (non-empty, 0 < p < 1).
fn shortest_window(sorted: &[f64], probability: f64) -> (f64, f64) {
    let n = sorted.len();
    let k = window_len(probability, n);
    let mut best = 0;
    let mut best_width = f64::INFINITY;
    for (i, (lo, hi)) in sorted.iter().zip(&sorted[k - 1..]).enumerate() {
        let width = hi - lo;
        if width < best_width {
            best_width = width;
            best = i;
        }
    }
    (sorted[best], sorted[best + k - 1])
}

/// Shortest intervals of every column of `samples` (n_samples x n_m), in parallel
/// over sensors. `stop` is polled between batches of sensors on the calling thread.
pub fn shortest_intervals(
    samples: Matrix<'_, f64>,
    probability: f64,
    pool: &ThreadPool,
    stop: &mut dyn FnMut() -> bool,
) -> Result<Thresholds> {
    let needed = min_samples(probability)?;
    let n = samples.rows();
    if samples.cols() == 0 {
        return Err(EdmfError::invalid(
            "combined",
            "at least one sensor column, got 0",
        ));
    }
    if n < needed {
        return Err(EdmfError::TooFewSamples {
            needed,
            got: n,
            probability,
        });
    }
    let mut low = Vec::with_capacity(samples.cols());
    let mut high = Vec::with_capacity(samples.cols());
    let batch = pool.current_num_threads().max(1);
    for first in (0..samples.cols()).step_by(batch) {
        let last = (first + batch).min(samples.cols());
        let bounds: Vec<Result<(f64, f64)>> = pool.install(|| {
            (first..last)
                .into_par_iter()
                .map(|j| {
                    let mut column: Vec<f64> = (0..n).map(|i| samples.get(i, j)).collect();
                    if let Some(bad) = column.iter().find(|v| !v.is_finite()) {
                        return Err(EdmfError::invalid(
                            "combined",
                            format!("finite samples, got {bad} in sensor column {j}"),
                        ));
                    }
                    column.sort_unstable_by(f64::total_cmp);
                    Ok(shortest_window(&column, probability))
                })
                .collect()
        });
        for b in bounds {
            let (l, h) = b?;
            low.push(l);
            high.push(h);
        }
        if stop() {
            return Err(EdmfError::Interrupted);
        }
    }
    Thresholds::new(low, high)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pool(n: usize) -> ThreadPool {
        rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap()
    }

    #[test]
    fn thresholds_reject_bad_bounds() {
        assert!(Thresholds::new(vec![0.0], vec![1.0]).is_ok());
        assert!(Thresholds::new(vec![1.0], vec![0.0]).is_err());
        assert!(Thresholds::new(vec![f64::NAN], vec![0.0]).is_err());
        assert!(Thresholds::new(vec![], vec![]).is_err());
        assert!(Thresholds::new(vec![0.0, 1.0], vec![1.0]).is_err());
    }

    #[test]
    fn min_samples_is_one_over_one_minus_p() {
        assert_eq!(min_samples(0.5).unwrap(), 2);
        assert_eq!(min_samples(0.99).unwrap(), 100);
        assert!(min_samples(1.0).is_err());
        assert!(min_samples(0.0).is_err());
    }

    #[test]
    fn shortest_interval_finds_the_dense_cluster() {
        // 8 of 10 samples packed in [10, 10.7]; the other two far away on the left.
        let s = [0.0, 1.0, 10.0, 10.1, 10.2, 10.3, 10.4, 10.5, 10.6, 10.7];
        assert_eq!(shortest_interval(&s, 0.8), Ok((10.0, 10.7)));
        assert!(shortest_interval(&[], 0.8).is_err());
        assert!(shortest_interval(&s, 1.0).is_err());
    }

    #[test]
    fn shortest_interval_ties_go_to_the_lowest_window() {
        let s = [0.0, 1.0, 2.0, 3.0];
        assert_eq!(shortest_interval(&s, 0.5), Ok((0.0, 1.0)));
    }

    #[test]
    fn columns_are_independent_and_thread_count_does_not_matter() {
        let n = 1000;
        let mut data = Vec::with_capacity(n * 2);
        for i in 0..n {
            let u = (i as f64 + 0.5) / n as f64;
            data.push(u); // uniform on (0,1)
            data.push(u * u * u); // skewed: mass piles up near 0
        }
        let m = Matrix::row_major(&data, n, 2).unwrap();
        let a = shortest_intervals(m, 0.9, &pool(1), &mut || false).unwrap();
        let b = shortest_intervals(m, 0.9, &pool(2), &mut || false).unwrap();
        assert_eq!(a, b);
        assert!(
            a.low()[1] <= 1e-6,
            "skewed column's interval must start at its mode"
        );
        assert!((a.high()[0] - a.low()[0] - 0.9).abs() < 2e-3);
    }

    #[test]
    fn too_few_samples_says_how_many_are_needed() {
        let data = vec![0.0; 50];
        let m = Matrix::row_major(&data, 50, 1).unwrap();
        match shortest_intervals(m, 0.99, &pool(1), &mut || false) {
            Err(EdmfError::TooFewSamples {
                needed: 100, got: 50, ..
            }) => {}
            other => panic!("expected TooFewSamples, got {other:?}"),
        }
    }

    #[test]
    fn non_finite_samples_are_rejected() {
        let data = vec![0.0, f64::NAN, 1.0, 2.0];
        let m = Matrix::row_major(&data, 4, 1).unwrap();
        assert!(shortest_intervals(m, 0.5, &pool(1), &mut || false).is_err());
    }
}
