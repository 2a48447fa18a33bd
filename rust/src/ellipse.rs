//! Ellipsoidal bounds (Sec. 3.2, Eq. 9): squared Mahalanobis distances of many
//! points at once. Used to show what the rectangular thresholds buy: the
//! ellipse needs the correlations, and holds less than phi when they are wrong.

use crate::error::{EdmfError, Result};
use crate::matrix::Matrix;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use rayon::ThreadPool;

/// `D_M(x)^2 = (x - mu)^T Sigma^-1 (x - mu)` for every row x of `points` (Eq. 9),
/// by one Cholesky factorisation `Sigma = L L^T` and a triangular solve per point.
pub fn mahalanobis_squared(
    points: Matrix<'_, f64>,
    mean: &[f64],
    covariance: &[f64],
    pool: &ThreadPool,
) -> Result<Vec<f64>> {
    let n = mean.len();
    if n == 0 || points.cols() != n {
        return Err(EdmfError::invalid(
            "points",
            format!(
                "one column per dimension of the mean ({n}), got {}",
                points.cols()
            ),
        ));
    }
    if covariance.len() != n * n {
        return Err(EdmfError::invalid(
            "covariance",
            format!("a {n}x{n} matrix, got {} elements", covariance.len()),
        ));
    }
    let sigma = DMatrix::from_row_slice(n, n, covariance);
    if (&sigma - sigma.transpose()).abs().max() > 1e-12 * sigma.abs().max() {
        return Err(EdmfError::invalid("covariance", "a symmetric matrix"));
    }
    let chol = sigma
        .cholesky()
        .ok_or_else(|| EdmfError::invalid("covariance", "a positive-definite matrix"))?;
    let l = chol.l();
    Ok(pool.install(|| {
        (0..points.rows())
            .into_par_iter()
            .map(|i| {
                let centred = DVector::from_iterator(n, (0..n).map(|j| points.get(i, j) - mean[j]));
                match l.solve_lower_triangular(&centred) {
                    Some(z) => z.norm_squared(),
                    None => f64::NAN,
                }
            })
            .collect()
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_closed_form_in_two_dimensions() {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let rho: f64 = 0.9;
        let cov = [1.0, rho, rho, 1.0];
        let pts = [1.0, -1.0, 0.5, 0.5, 0.0, 0.0];
        let d =
            mahalanobis_squared(Matrix::row_major(&pts, 3, 2).unwrap(), &[0.0, 0.0], &cov, &pool).unwrap();
        for (i, got) in d.iter().enumerate() {
            let (x, y) = (pts[2 * i], pts[2 * i + 1]);
            let want = (x * x - 2.0 * rho * x * y + y * y) / (1.0 - rho * rho);
            assert!((got - want).abs() < 1e-12, "{got} vs {want}");
        }
    }

    #[test]
    fn rejects_a_covariance_that_is_not_positive_definite() {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let pts = [0.0, 0.0];
        let m = Matrix::row_major(&pts, 1, 2).unwrap();
        assert!(mahalanobis_squared(m, &[0.0, 0.0], &[1.0, 2.0, 2.0, 1.0], &pool).is_err());
        assert!(mahalanobis_squared(m, &[0.0, 0.0], &[1.0, 0.5, 0.0, 1.0], &pool).is_err());
        assert!(mahalanobis_squared(m, &[0.0], &[1.0], &pool).is_err());
    }
}
