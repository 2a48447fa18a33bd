//! Threshold bounds (Goulet & Smith 2013, Eq. 5): per sensor, the shortest
//! interval holding the per-sensor probability of the combined uncertainty U_c.
//!
//! Only the Monte Carlo route lives here (sort + sliding window); the
//! closed-form route (Eq. 6) needs inverse CDFs and stays in Python/SciPy.

use crate::error::{EdmfError, Result};
use crate::matrix::Matrix;
use crate::polling::run_polling;
use rayon::prelude::*;
use rayon::ThreadPool;
use std::sync::atomic::{AtomicBool, Ordering};

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
    let k = window_len(probability, sorted.len());
    narrowest(sorted, &sorted[k - 1..])
}

/// The narrowest of the windows `[lows[i], highs[i]]` (window `i` of the
/// sorted samples: its first and last order statistics); the first on ties.
fn narrowest(lows: &[f64], highs: &[f64]) -> (f64, f64) {
    let mut best = 0;
    let mut best_width = f64::INFINITY;
    for (i, (lo, hi)) in lows.iter().zip(highs).enumerate() {
        let width = hi - lo;
        if width < best_width {
            best_width = width;
            best = i;
        }
    }
    (lows[best], highs[best])
}

/// Shortest intervals of every column of `samples` (n_samples x n_m), in
/// parallel over sensors. `stop` is polled on the calling thread every few
/// milliseconds, and the sort of each column reads the flag it raises between
/// runs: a column of 10^7 samples takes seconds to sort.
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
    let cancel = AtomicBool::new(false);
    let job = || -> Result<Vec<(f64, f64)>> {
        (0..samples.cols())
            .into_par_iter()
            .map(|j| column_interval(samples, j, probability, &cancel))
            .collect()
    };
    let bounds = run_polling(pool, &cancel, stop, || pool.install(job)).ok_or(EdmfError::Interrupted)??;
    // Done, but a Ctrl-C came meanwhile (or just now): the call is interrupted.
    if cancel.load(Ordering::Relaxed) || stop() {
        return Err(EdmfError::Interrupted);
    }
    let (low, high) = bounds.into_iter().unzip();
    Thresholds::new(low, high)
}

/// Column `j`'s shortest interval; `Interrupted` once `cancel` is set.
///
/// The windows of `k = ceil(p n)` sorted samples start at the `t = n - k + 1`
/// lowest and end at the `t` highest, so where those two tails do not
/// overlap (p above about one half: every Šidák probability) only they are
/// sorted, after two linear-time selections; the order statistics, hence the
/// interval, are those of the whole sorted column.
fn column_interval(
    samples: Matrix<'_, f64>,
    j: usize,
    probability: f64,
    cancel: &AtomicBool,
) -> Result<(f64, f64)> {
    let n = samples.rows();
    let mut column = Vec::with_capacity(n);
    for first in (0..n).step_by(SORT_RUN) {
        if cancel.load(Ordering::Relaxed) {
            return Err(EdmfError::Interrupted);
        }
        column.extend((first..(first + SORT_RUN).min(n)).map(|i| samples.get(i, j)));
    }
    if let Some(bad) = column.iter().find(|v| !v.is_finite()) {
        return Err(EdmfError::invalid(
            "combined",
            format!("finite samples, got {bad} in sensor column {j}"),
        ));
    }
    let t = n - window_len(probability, n) + 1;
    if 2 * t >= n {
        let sorted = sort_cancellable(column, cancel).ok_or(EdmfError::Interrupted)?;
        return Ok(shortest_window(&sorted, probability));
    }
    if cancel.load(Ordering::Relaxed) {
        return Err(EdmfError::Interrupted);
    }
    column.select_nth_unstable_by(t - 1, f64::total_cmp);
    let upper = &mut column[t..];
    let top = upper.len() - t;
    upper.select_nth_unstable_by(top, f64::total_cmp);
    let lows = sort_cancellable(column[..t].to_vec(), cancel);
    let highs = sort_cancellable(column[n - t..].to_vec(), cancel);
    match (lows, highs) {
        (Some(lows), Some(highs)) => Ok(narrowest(&lows, &highs)),
        _ => Err(EdmfError::Interrupted),
    }
}

/// Values sorted at a time between reads of the cancel flag (about a
/// millisecond of sorting).
const SORT_RUN: usize = 1 << 15;

/// `values` in `f64::total_cmp` order, as `sort_unstable_by` gives it (equal
/// values under `total_cmp` have equal bits, so the result is the same
/// array), or `None` once `cancel` is set: runs of [`SORT_RUN`] sorted, then
/// merged pairwise, reading `cancel` between runs.
fn sort_cancellable(values: Vec<f64>, cancel: &AtomicBool) -> Option<Vec<f64>> {
    let mut sorted = values;
    for run in sorted.chunks_mut(SORT_RUN) {
        if cancel.load(Ordering::Relaxed) {
            return None;
        }
        run.sort_unstable_by(f64::total_cmp);
    }
    let n = sorted.len();
    let mut merged = vec![0.0; if n > SORT_RUN { n } else { 0 }];
    let mut width = SORT_RUN;
    while width < n {
        for start in (0..n).step_by(2 * width) {
            let (mid, end) = ((start + width).min(n), (start + 2 * width).min(n));
            merge(
                &sorted[start..mid],
                &sorted[mid..end],
                &mut merged[start..end],
                cancel,
            )?;
        }
        std::mem::swap(&mut sorted, &mut merged);
        width *= 2;
    }
    Some(sorted)
}

/// `left` and `right` (each sorted) merged into `out`, reading `cancel`
/// every [`SORT_RUN`] values.
fn merge(left: &[f64], right: &[f64], out: &mut [f64], cancel: &AtomicBool) -> Option<()> {
    let (mut i, mut j) = (0, 0);
    for piece in out.chunks_mut(SORT_RUN) {
        if cancel.load(Ordering::Relaxed) {
            return None;
        }
        for slot in piece {
            // Left first on ties: equal values are equal bits, either is right.
            if j == right.len() || (i < left.len() && left[i].total_cmp(&right[j]).is_le()) {
                *slot = left[i];
                i += 1;
            } else {
                *slot = right[j];
                j += 1;
            }
        }
    }
    Some(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::polling::run_polling;

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
    fn the_cancellable_sort_is_the_standard_sort() {
        // Several runs and a ragged last one; duplicates, signed zeros, extremes.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for n in [
            0,
            1,
            SORT_RUN - 1,
            SORT_RUN,
            SORT_RUN + 1,
            3 * SORT_RUN + 17,
            8 * SORT_RUN,
        ] {
            let values: Vec<f64> = (0..n)
                .map(|i| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    match i % 7 {
                        0 => -0.0,
                        1 => 0.0,
                        2 => f64::MAX,
                        3 => (state % 5) as f64,
                        _ => f64::from_bits(state >> 2) - 1e300,
                    }
                })
                .collect();
            let mut expected = values.clone();
            expected.sort_unstable_by(f64::total_cmp);
            let got = sort_cancellable(values, &AtomicBool::new(false)).unwrap();
            assert_eq!(
                got.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                expected.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                "n = {n}"
            );
        }
    }

    #[test]
    fn sorting_the_tails_only_gives_the_whole_sort_s_interval() {
        // p above and below one half (tails only, whole sort), with ties and
        // a long flat stretch; against shortest_interval on the sorted column.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for (n, p) in [
            (1000, 0.9),
            (1000, 0.5),
            (1001, 0.51),
            (70_001, 0.99),
            (70_001, 0.3),
            (3, 0.6),
        ] {
            let data: Vec<f64> = (0..n)
                .map(|i| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    if i % 3 == 0 {
                        1.5
                    } else {
                        (state % 1000) as f64 / 7.0
                    }
                })
                .collect();
            let mut sorted = data.clone();
            sorted.sort_unstable_by(f64::total_cmp);
            let m = Matrix::row_major(&data, n, 1).unwrap();
            let got = shortest_intervals(m, p, &pool(1), &mut || false).unwrap();
            let want = shortest_interval(&sorted, p).unwrap();
            assert_eq!((got.low()[0], got.high()[0]), want, "n = {n}, p = {p}");
        }
    }

    #[test]
    fn a_raised_flag_stops_the_sort_and_a_stop_request_the_call() {
        let values: Vec<f64> = (0..4 * SORT_RUN).map(|i| ((i * 7919) % 1000) as f64).collect();
        assert_eq!(sort_cancellable(values, &AtomicBool::new(true)), None);
        let data = vec![1.0; 1000];
        let m = Matrix::row_major(&data, 1000, 1).unwrap();
        let got = shortest_intervals(m, 0.9, &pool(2), &mut || true);
        assert_eq!(got, Err(EdmfError::Interrupted));
    }

    #[test]
    fn the_polling_thread_raises_the_flag_a_running_job_reads() {
        // The job ends only once the flag is up: without polling it would
        // spin until the 60 s guard and report false.
        let cancel = AtomicBool::new(false);
        let seen = run_polling(&pool(2), &cancel, &mut || true, || {
            let start = std::time::Instant::now();
            while !cancel.load(Ordering::Relaxed) && start.elapsed().as_secs() < 60 {
                std::thread::yield_now();
            }
            cancel.load(Ordering::Relaxed)
        });
        assert_eq!(seen, Some(true));
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
