//! Row tests of Eq. 8: an instance is a candidate iff for every sensor i,
//! `low_i <= g_i(theta) - y_i <= high_i` (inclusive). Residuals are formed in
//! f64 whatever the prediction type, exactly as the NumPy reference does, so
//! instances lying exactly on a bound get the same verdict in both.
//!
//! Two kernels: `diagnose` visits every sensor and tallies which ones reject
//! (for diagnostics); `screen` stops at the first rejecting sensor, visiting
//! sensors in the order that rejects most, and only tells candidate or not.

use crate::matrix::Matrix;

/// Element types the kernels read natively (no conversion pass).
pub trait Prediction: Copy + Send + Sync + 'static {
    fn to_f64(self) -> f64;
}

impl Prediction for f64 {
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
}

impl Prediction for f32 {
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
}

/// Measurements and thresholds laid out per sensor, in one visiting order.
#[derive(Debug, Clone)]
pub struct SensorBounds {
    /// Column index in the prediction matrix of each visited sensor.
    pub column: Vec<usize>,
    pub measured: Vec<f64>,
    pub low: Vec<f64>,
    pub high: Vec<f64>,
}

impl SensorBounds {
    pub fn new(measured: &[f64], low: &[f64], high: &[f64]) -> Self {
        SensorBounds {
            column: (0..measured.len()).collect(),
            measured: measured.to_vec(),
            low: low.to_vec(),
            high: high.to_vec(),
        }
    }

    /// The same bounds visited in `order` (a permutation of the columns).
    pub fn reordered(&self, order: &[usize]) -> Self {
        SensorBounds {
            column: order.iter().map(|&j| self.column[j]).collect(),
            measured: order.iter().map(|&j| self.measured[j]).collect(),
            low: order.iter().map(|&j| self.low[j]).collect(),
            high: order.iter().map(|&j| self.high[j]).collect(),
        }
    }

    pub fn len(&self) -> usize {
        self.column.len()
    }

    pub fn is_empty(&self) -> bool {
        self.column.is_empty()
    }
}

/// Counts over a set of instances. Integer sums only, so merging partial
/// tallies in any order gives the same totals (deterministic across threads).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Tally {
    /// Instances each sensor rejects.
    pub per_sensor: Vec<u64>,
    /// Instances rejected by that sensor and no other.
    pub only_by: Vec<u64>,
    /// Instances with at least one NaN prediction (never candidates).
    pub invalid: u64,
}

impl Tally {
    pub fn zeros(n_sensors: usize) -> Self {
        Tally { per_sensor: vec![0; n_sensors], only_by: vec![0; n_sensors], invalid: 0 }
    }

    pub fn merge(mut self, other: Tally) -> Tally {
        self.add(&other);
        self
    }

    pub fn add(&mut self, other: &Tally) {
        for (a, b) in self.per_sensor.iter_mut().zip(&other.per_sensor) {
            *a += b;
        }
        for (a, b) in self.only_by.iter_mut().zip(&other.only_by) {
            *a += b;
        }
        self.invalid += other.invalid;
    }
}

#[inline(always)]
fn outside(prediction: f64, measured: f64, low: f64, high: f64) -> bool {
    let residual = prediction - measured; // Eq. 8 / Eq. 14
    !((residual >= low) & (residual <= high)) // NaN is outside
}

/// Writes the number of rejecting sensors of each row of `m` into `out` and
/// adds the per-sensor counts to `tally`. `b` must be in column order.
pub fn diagnose<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, out: &mut [u32], tally: &mut Tally) {
    debug_assert_eq!(out.len(), m.rows());
    for (i, n_out) in out.iter_mut().enumerate() {
        let mut n = 0u32;
        let mut nan = false;
        if let Some(row) = m.row_slice(i) {
            // Equal-length reslices let the compiler drop bounds checks and vectorise.
            let k = row.len();
            let (y, lo, hi) = (&b.measured[..k], &b.low[..k], &b.high[..k]);
            let counts = &mut tally.per_sensor[..k];
            for j in 0..k {
                let p = row[j].to_f64();
                let v = outside(p, y[j], lo[j], hi[j]);
                counts[j] += v as u64;
                n += v as u32;
                nan |= p.is_nan();
            }
        } else {
            for j in 0..b.len() {
                let p = m.get(i, j).to_f64();
                let v = outside(p, b.measured[j], b.low[j], b.high[j]);
                tally.per_sensor[j] += v as u64;
                n += v as u32;
                nan |= p.is_nan();
            }
        }
        if n == 1 {
            // Rare enough to afford a second look at the row to find which one.
            let j = (0..b.len())
                .find(|&j| outside(m.get(i, j).to_f64(), b.measured[j], b.low[j], b.high[j]))
                .unwrap_or(0);
            tally.only_by[j] += 1;
        }
        tally.invalid += nan as u64;
        *n_out = n;
    }
}

/// Writes 0 for candidates and 1 for falsified instances, stopping at the
/// first rejecting sensor of each row. `b` may be in any visiting order.
pub fn screen<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, out: &mut [u32]) {
    debug_assert_eq!(out.len(), m.rows());
    let sensors = || b.column.iter().zip(&b.measured).zip(b.low.iter().zip(&b.high));
    for (i, flag) in out.iter_mut().enumerate() {
        let candidate = match m.row_slice(i) {
            Some(row) => sensors().all(|((&j, &y), (&lo, &hi))| !outside(row[j].to_f64(), y, lo, hi)),
            None => sensors().all(|((&j, &y), (&lo, &hi))| !outside(m.get(i, j).to_f64(), y, lo, hi)),
        };
        *flag = (!candidate) as u32;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_are_inclusive_and_nan_is_outside() {
        let b = SensorBounds::new(&[1.0, 1.0], &[-0.5, -0.5], &[0.5, 0.5]);
        // rows: on both bounds, one sensor out, NaN, both out
        let p = [0.5, 1.5, 0.49, 1.0, f64::NAN, 1.0, 3.0, -3.0];
        let m = Matrix::row_major(&p, 4, 2).unwrap();
        let mut out = [9u32; 4];
        let mut t = Tally::zeros(2);
        diagnose(m, &b, &mut out, &mut t);
        assert_eq!(out, [0, 1, 1, 2]);
        assert_eq!(t.per_sensor, vec![3, 1]);
        assert_eq!(t.only_by, vec![2, 0]);
        assert_eq!(t.invalid, 1);
        let mut flags = [9u32; 4];
        screen(m, &b.reordered(&[1, 0]), &mut flags);
        assert_eq!(flags, [0, 1, 1, 1]);
    }

    #[test]
    fn f32_residuals_are_formed_in_f64() {
        // 0.1f32 is not 0.1; the residual must use its exact f64 value.
        let x = 0.1f32;
        let b = SensorBounds::new(&[0.0], &[x as f64], &[x as f64]);
        let m = Matrix::row_major(std::slice::from_ref(&x), 1, 1).unwrap();
        let mut out = [9u32];
        diagnose(m, &b, &mut out, &mut Tally::zeros(1));
        assert_eq!(out, [0]);
    }

    #[test]
    fn strided_view_matches_contiguous() {
        let b = SensorBounds::new(&[0.0, 0.0, 0.0], &[-1.0; 3], &[1.0; 3]);
        let c = [0.0, 2.0, 0.5, -0.5, 0.0, 0.9, 5.0, 5.0, 5.0];
        let f = [0.0, -0.5, 5.0, 2.0, 0.0, 5.0, 0.5, 0.9, 5.0];
        let (mut oc, mut of) = ([0u32; 3], [0u32; 3]);
        let (mut tc, mut tf) = (Tally::zeros(3), Tally::zeros(3));
        diagnose(Matrix::row_major(&c, 3, 3).unwrap(), &b, &mut oc, &mut tc);
        diagnose(Matrix::col_major(&f, 3, 3).unwrap(), &b, &mut of, &mut tf);
        assert_eq!(oc, of);
        assert_eq!(tc, tf);
        assert_eq!(oc, [1, 0, 3]);
    }
}
