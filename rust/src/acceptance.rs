//! Eq. 8 moved into prediction space.
//!
//! For one sensor with measurement `y` and thresholds `[low, high]`, the test
//! `low <= fl(p - y) <= high` holds for exactly the predictions `p` in one
//! interval `[p_low, p_high]`: rounding is monotone, so `fl(p - y)` never
//! decreases as `p` grows. Finding both ends once, by bisection over the
//! floating-point numbers themselves, turns the per-instance test into two
//! comparisons with no subtraction and bit-for-bit the same verdict. The same
//! holds for float32 predictions (widened exactly, then subtracted in f64), so
//! they are compared as float32: twice the lanes per vector and no widening.
//!
//! This assumes IEEE default arithmetic (round to nearest, subnormals kept).
//! Rust never changes it, but a library built with `-ffast-math` may set
//! flush-to-zero on a thread; the kernels could then disagree on subnormals.

/// Floats in their total order, as integers (IEEE-754 `totalOrder` keys).
pub trait Ordered: Copy {
    const NEG_INF: Self;
    const POS_INF: Self;
    const NAN: Self;
    fn key(self) -> i64;
    fn from_key(key: i64) -> Self;
}

impl Ordered for f64 {
    const NEG_INF: f64 = f64::NEG_INFINITY;
    const POS_INF: f64 = f64::INFINITY;
    const NAN: f64 = f64::NAN;
    fn key(self) -> i64 {
        let bits = self.to_bits() as i64;
        // Negative floats order in reverse: flip all bits but the sign.
        bits ^ (((bits >> 63) as u64) >> 1) as i64
    }
    fn from_key(key: i64) -> f64 {
        f64::from_bits((key ^ (((key >> 63) as u64) >> 1) as i64) as u64)
    }
}

impl Ordered for f32 {
    const NEG_INF: f32 = f32::NEG_INFINITY;
    const POS_INF: f32 = f32::INFINITY;
    const NAN: f32 = f32::NAN;
    fn key(self) -> i64 {
        let bits = self.to_bits() as i32;
        (bits ^ (((bits >> 31) as u32) >> 1) as i32) as i64
    }
    fn from_key(key: i64) -> f32 {
        let key = key as i32;
        f32::from_bits((key ^ (((key >> 31) as u32) >> 1) as i32) as u32)
    }
}

/// Smallest `p` (not NaN) for which the monotone `accepts` (false, then true
/// as `p` grows) is true; `None` if it never is.
fn smallest<T: Ordered>(accepts: impl Fn(T) -> bool) -> Option<T> {
    let (mut lo, mut hi) = (T::NEG_INF.key(), T::POS_INF.key());
    if !accepts(T::from_key(hi)) {
        return None;
    }
    while lo < hi {
        let mid = ((lo as i128 + hi as i128) >> 1) as i64; // hi - lo overflows i64
        if accepts(T::from_key(mid)) {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    Some(T::from_key(lo))
}

/// Largest `p` for which the monotone `accepts` (true, then false) is true.
fn largest<T: Ordered>(accepts: impl Fn(T) -> bool) -> Option<T> {
    match smallest(|p: T| !accepts(p)) {
        None => Some(T::POS_INF),
        Some(p) if p.key() == T::NEG_INF.key() => None,
        Some(p) => Some(T::from_key(p.key() - 1)),
    }
}

/// `[p_low, p_high]`: the predictions a sensor accepts (Eq. 8). When none is,
/// the interval is empty (`p_low > p_high`, or NaN ends, with which every
/// comparison says "outside").
///
/// `measured`, `low` and `high` must be finite (checked by the callers), which
/// is what makes the residual monotone in `p` over the whole line, infinities
/// included.
pub fn accepted<T: Ordered>(measured: f64, low: f64, high: f64, widen: impl Fn(T) -> f64) -> (T, T) {
    let residual = |p: T| widen(p) - measured; // Eq. 8
    match (smallest(|p| residual(p) >= low), largest(|p| residual(p) <= high)) {
        (Some(a), Some(b)) => (a, b),
        _ => (T::NAN, T::NAN),
    }
}

/// Acceptance interval of a sensor for f64 predictions.
pub fn accepted_f64(measured: f64, low: f64, high: f64) -> (f64, f64) {
    accepted(measured, low, high, |p: f64| p)
}

/// Acceptance interval of a sensor for f32 predictions (widened exactly).
pub fn accepted_f32(measured: f64, low: f64, high: f64) -> (f32, f32) {
    accepted(measured, low, high, |p: f32| p as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::uniform;

    fn literal(p: f64, y: f64, lo: f64, hi: f64) -> bool {
        let r = p - y;
        r >= lo && r <= hi
    }

    #[test]
    fn keys_follow_the_total_order() {
        let xs = [
            f64::NEG_INFINITY,
            -1e300,
            -1.0,
            -f64::MIN_POSITIVE,
            -0.0,
            0.0,
            5e-324,
            1.0,
            f64::INFINITY,
        ];
        for w in xs.windows(2) {
            assert!(w[0].key() < w[1].key(), "{} {}", w[0], w[1]);
            assert_eq!(f64::from_key(w[0].key()).to_bits(), w[0].to_bits());
        }
        let ys = [f32::NEG_INFINITY, -1.0f32, -0.0, 0.0, 1e-45, 3.0, f32::INFINITY];
        for w in ys.windows(2) {
            assert!(w[0].key() < w[1].key());
            assert_eq!(f32::from_key(w[1].key()).to_bits(), w[1].to_bits());
        }
    }

    /// The interval gives the literal verdict at its ends, one step outside
    /// them, and at random points, over wildly scaled inputs.
    #[test]
    fn interval_matches_the_residual_test() {
        let mut s = 0x1234_5678_9abc_def1u64;
        for case in 0..3000 {
            let scale = 10f64.powi((uniform(&mut s) * 40.0) as i32 - 20);
            let y = (uniform(&mut s) - 0.5) * scale * if case % 7 == 0 { 1e10 } else { 1.0 };
            let a = (uniform(&mut s) - 0.5) * scale;
            let b = a + uniform(&mut s) * scale * if case % 5 == 0 { 0.0 } else { 1.0 };
            let (lo, hi) = accepted_f64(y, a, b);
            let (lo32, hi32) = accepted_f32(y, a, b);
            let mut probes = vec![lo, hi, y + a, y + b, 0.0, -0.0, f64::INFINITY, f64::NEG_INFINITY];
            for v in [lo, hi] {
                if v.is_finite() {
                    probes.push(f64::from_key(v.key() - 1));
                    probes.push(f64::from_key(v.key() + 1));
                }
            }
            for _ in 0..8 {
                probes.push(y + (uniform(&mut s) * 3.0 - 1.0) * scale);
            }
            for p in probes {
                assert_eq!(
                    lo <= p && p <= hi,
                    literal(p, y, a, b),
                    "p={p:e} y={y:e} [{a:e}, {b:e}]"
                );
                let q = p as f32;
                let inside32 = lo32 <= q && q <= hi32;
                assert_eq!(
                    inside32,
                    literal(q as f64, y, a, b),
                    "q={q:e} y={y:e} [{a:e}, {b:e}]"
                );
            }
            for v in [lo32, hi32] {
                if v.is_finite() {
                    for q in [f32::from_key(v.key() - 1), v, f32::from_key(v.key() + 1)] {
                        assert_eq!(lo32 <= q && q <= hi32, literal(q as f64, y, a, b));
                    }
                }
            }
        }
    }

    #[test]
    fn an_interval_no_float32_reaches_is_empty() {
        // Between two neighbouring float32 values: no f32 prediction accepted.
        let y = 1.0f32 as f64 + 1e-9;
        let (lo, hi) = accepted_f32(y, 0.0, 1e-12);
        assert!(lo > hi, "[{lo}, {hi}]");
        let (lo, hi) = accepted_f64(y, 0.0, 1e-12);
        assert!(lo <= hi);
    }
}
