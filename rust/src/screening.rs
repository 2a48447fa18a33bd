//! Emulator screening for adaptive EDMF: keep every point whose emulated
//! prediction could still pass Eq. 8 given the emulator's uncertainty.
//!
//! With an emulator of sensor i giving a predictive mean `mu_i(x)` and standard
//! deviation `sigma_i(x)`, a point x is kept iff, at every sensor,
//!
//! ```text
//! T_low,i - c sigma_i(x) <= mu_i(x) - y_i <= T_high,i + c sigma_i(x)
//! ```
//!
//! i.e. `y_i + T_low,i - c sigma_i <= mu_i <= y_i + T_high,i + c sigma_i`
//! written on the residual (Eq. 14) so that with `sigma = 0` the verdict is
//! bit for bit that of Eq. 8 on `mu` (the NumPy reference computes `g - y`
//! too). Sensors are visited in the order that rejected most points of a
//! first sample, and a row stops at its first rejecting sensor: the order
//! only changes the speed, never the verdict. A NaN mean or deviation keeps
//! no point (every comparison with NaN is false), as a NaN prediction is
//! never a candidate.

use crate::error::{EdmfError, Result};
use crate::matrix::Matrix;
use rayon::prelude::*;
use rayon::ThreadPool;

/// Rows one rayon task handles.
const BLOCK_ROWS: usize = 1024;
/// Values (of each of mu and sigma) per slab between two `stop` checks.
const SLAB_ELEMENTS: usize = 1 << 21;
/// Rows visited at every sensor to learn the screening order.
const LEARN_ROWS: usize = 4096;

/// The points kept by [`screen`] and the order the sensors were visited in.
#[derive(Debug, Clone, PartialEq)]
pub struct Screened {
    /// Indices of the kept rows, ascending.
    pub kept: Vec<u64>,
    /// Sensors from the one that rejected most rows of the first
    /// `LEARN_ROWS` rows to the one that rejected fewest (ties by index).
    pub order: Vec<usize>,
}

fn check_vector(v: &[f64], name: &'static str, n_m: usize) -> Result<()> {
    if v.len() != n_m {
        return Err(EdmfError::invalid(
            name,
            format!("{n_m} values (one per sensor), got {}", v.len()),
        ));
    }
    if let Some((i, x)) = v.iter().enumerate().find(|(_, x)| !x.is_finite()) {
        return Err(EdmfError::invalid(
            name,
            format!("finite values, got {x} at sensor {i}"),
        ));
    }
    Ok(())
}

/// Does row `i` pass sensor `j`? (residual form, see the module docs)
#[inline(always)]
fn passes(
    mu: &Matrix<'_, f64>,
    sigma: &Matrix<'_, f64>,
    i: usize,
    j: usize,
    y: &[f64],
    low: &[f64],
    high: &[f64],
    c: f64,
) -> bool {
    let r = mu.get(i, j) - y[j];
    let margin = c * sigma.get(i, j);
    r >= low[j] - margin && r <= high[j] + margin
}

/// Screens every row of `mu` and `sigma` (N x n_m each) against the
/// measurements `y` and threshold bounds `[low, high]` widened by `c` sigma.
///
/// Errors: shapes that differ, vectors of the wrong length or not finite,
/// `low > high`, `c` negative or not finite, a negative `sigma` (a NaN one
/// keeps no point), or `stop()` returning true between slabs.
#[allow(clippy::too_many_arguments)]
pub fn screen(
    mu: Matrix<'_, f64>,
    sigma: Matrix<'_, f64>,
    y: &[f64],
    low: &[f64],
    high: &[f64],
    c: f64,
    pool: &ThreadPool,
    stop: &mut dyn FnMut() -> bool,
) -> Result<Screened> {
    let (rows, n_m) = (mu.rows(), mu.cols());
    if n_m == 0 {
        return Err(EdmfError::invalid("mu", "at least one sensor (column)"));
    }
    if sigma.rows() != rows || sigma.cols() != n_m {
        return Err(EdmfError::invalid(
            "sigma",
            format!(
                "the shape of mu ({rows}, {n_m}), got ({}, {})",
                sigma.rows(),
                sigma.cols()
            ),
        ));
    }
    check_vector(y, "measurements", n_m)?;
    check_vector(low, "low", n_m)?;
    check_vector(high, "high", n_m)?;
    if let Some(j) = (0..n_m).find(|&j| low[j] > high[j]) {
        return Err(EdmfError::invalid(
            "low",
            format!("low <= high, got low={} > high={} at sensor {j}", low[j], high[j]),
        ));
    }
    if !(c.is_finite() && c >= 0.0) {
        return Err(EdmfError::invalid("c", format!("a finite number >= 0, got {c}")));
    }
    let slab_rows = (SLAB_ELEMENTS / n_m).div_ceil(BLOCK_ROWS).max(1) * BLOCK_ROWS;

    // The order: rejections per sensor over the first rows, every sensor visited.
    let learn = rows.min(LEARN_ROWS);
    let rejected: Vec<u64> = (0..n_m)
        .map(|j| {
            (0..learn)
                .filter(|&i| !passes(&mu, &sigma, i, j, y, low, high, c))
                .count() as u64
        })
        .collect();
    let mut order: Vec<usize> = (0..n_m).collect();
    order.sort_by(|&a, &b| rejected[b].cmp(&rejected[a]).then(a.cmp(&b)));

    let mut kept = Vec::new();
    let mut first = 0;
    while first < rows {
        let last = (first + slab_rows).min(rows);
        let order = &order;
        let blocks: Vec<std::result::Result<Vec<u64>, (usize, usize)>> = pool.install(|| {
            (first..last)
                .step_by(BLOCK_ROWS)
                .collect::<Vec<_>>()
                .into_par_iter()
                .map(|start| {
                    let end = (start + BLOCK_ROWS).min(last);
                    let mut out = Vec::new();
                    for i in start..end {
                        // A negative sigma is an error wherever it is: check the whole row.
                        if let Some(j) = (0..n_m).find(|&j| sigma.get(i, j) < 0.0) {
                            return Err((i, j));
                        }
                        if order.iter().all(|&j| passes(&mu, &sigma, i, j, y, low, high, c)) {
                            out.push(i as u64);
                        }
                    }
                    Ok(out)
                })
                .collect()
        });
        for block in blocks {
            match block {
                Ok(found) => kept.extend_from_slice(&found),
                Err((i, j)) => {
                    return Err(EdmfError::invalid(
                        "sigma",
                        format!(
                            "standard deviations >= 0, got {} at row {i}, sensor {j}",
                            sigma.get(i, j)
                        ),
                    ))
                }
            }
        }
        first = last;
        if stop() {
            return Err(EdmfError::Interrupted);
        }
    }
    Ok(Screened { kept, order })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::uniform;

    fn pool(n: usize) -> ThreadPool {
        rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap()
    }

    #[test]
    fn keeps_the_rows_the_rule_keeps_whatever_the_thread_count() {
        let mut state = 0x9e3779b97f4a7c15u64;
        for &(rows, n_m) in &[(1usize, 1usize), (5000, 3), (20_000, 7)] {
            let mu: Vec<f64> = (0..rows * n_m).map(|_| 4.0 * uniform(&mut state) - 2.0).collect();
            let sigma: Vec<f64> = (0..rows * n_m).map(|_| 0.3 * uniform(&mut state)).collect();
            let y = vec![0.1; n_m];
            let low: Vec<f64> = (0..n_m).map(|j| -0.5 - 0.1 * j as f64).collect();
            let high = vec![0.4; n_m];
            let m = Matrix::row_major(&mu, rows, n_m).unwrap();
            let s = Matrix::row_major(&sigma, rows, n_m).unwrap();
            let one = screen(m, s, &y, &low, &high, 3.0, &pool(1), &mut || false).unwrap();
            let two = screen(m, s, &y, &low, &high, 3.0, &pool(2), &mut || false).unwrap();
            assert_eq!(one, two);
            // Every sensor visited, in index order: the verdict must not depend on the order.
            let want: Vec<u64> = (0..rows)
                .filter(|&i| {
                    (0..n_m).all(|j| {
                        let r = mu[i * n_m + j] - y[j];
                        let margin = 3.0 * sigma[i * n_m + j];
                        r >= low[j] - margin && r <= high[j] + margin
                    })
                })
                .map(|i| i as u64)
                .collect();
            assert_eq!(one.kept, want);
            assert!(!want.is_empty() && want.len() < rows || rows == 1);
        }
    }

    #[test]
    fn zero_sigma_is_eq_8() {
        let mu = [0.0, 1.0, 2.0, 3.0];
        let sigma = [0.0; 4];
        let m = Matrix::row_major(&mu, 4, 1).unwrap();
        let s = Matrix::row_major(&sigma, 4, 1).unwrap();
        let out = screen(m, s, &[1.0], &[-1.0], &[1.0], 3.0, &pool(1), &mut || false).unwrap();
        assert_eq!(out.kept, vec![0, 1, 2]);
        // A margin of 0.5 sigma per unit c lets row 3 in at c = 2.
        let sigma = [0.5; 4];
        let s = Matrix::row_major(&sigma, 4, 1).unwrap();
        let out = screen(m, s, &[1.0], &[-1.0], &[1.0], 2.0, &pool(1), &mut || false).unwrap();
        assert_eq!(out.kept, vec![0, 1, 2, 3]);
    }

    #[test]
    fn the_sensor_rejecting_most_comes_first() {
        // Sensor 1 rejects every row, sensor 0 none.
        let mu = [0.0, 5.0, 0.0, 5.0, 0.0, 5.0];
        let sigma = [0.0; 6];
        let m = Matrix::row_major(&mu, 3, 2).unwrap();
        let s = Matrix::row_major(&sigma, 3, 2).unwrap();
        let out = screen(
            m,
            s,
            &[0.0, 0.0],
            &[-1.0, -1.0],
            &[1.0, 1.0],
            3.0,
            &pool(1),
            &mut || false,
        )
        .unwrap();
        assert_eq!(out.order, vec![1, 0]);
        assert!(out.kept.is_empty());
    }

    #[test]
    fn nan_keeps_nothing_and_bad_arguments_are_errors() {
        let mu = [f64::NAN, 0.0];
        let sigma = [0.0, f64::NAN];
        let m = Matrix::row_major(&mu, 2, 1).unwrap();
        let s = Matrix::row_major(&sigma, 2, 1).unwrap();
        let out = screen(m, s, &[0.0], &[-1.0], &[1.0], 3.0, &pool(1), &mut || false).unwrap();
        assert!(out.kept.is_empty());
        let neg = [0.0, -1.0];
        let s = Matrix::row_major(&neg, 2, 1).unwrap();
        let err = screen(m, s, &[0.0], &[-1.0], &[1.0], 3.0, &pool(1), &mut || false).unwrap_err();
        assert!(err.to_string().starts_with("sigma:"), "{err}");
        let s = Matrix::row_major(&sigma, 2, 1).unwrap();
        assert!(screen(m, s, &[0.0], &[-1.0], &[1.0], -1.0, &pool(1), &mut || false).is_err());
        assert!(screen(m, s, &[0.0], &[1.0], &[-1.0], 3.0, &pool(1), &mut || false).is_err());
        assert!(screen(m, s, &[0.0, 1.0], &[-1.0], &[1.0], 3.0, &pool(1), &mut || false).is_err());
        let wide = [0.0; 4];
        let s2 = Matrix::row_major(&wide, 2, 2).unwrap();
        assert!(screen(m, s2, &[0.0], &[-1.0], &[1.0], 3.0, &pool(1), &mut || false).is_err());
        assert_eq!(
            screen(m, s, &[0.0], &[-1.0], &[1.0], 3.0, &pool(1), &mut || true).unwrap_err(),
            EdmfError::Interrupted
        );
    }
}
