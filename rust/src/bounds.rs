//! Per-sensor data the row kernels read: the measurements and thresholds of
//! Eq. 8, the same test as acceptance intervals in prediction space, and the
//! screening order.

use crate::acceptance::{accepted_f32, accepted_f64};
use crate::error::{EdmfError, Result};

/// Sensors screened together: one or two vectors at every instruction-set
/// level, and one branch in the row loop.
pub const BLOCK: usize = 16;

/// Measurements and thresholds laid out per sensor, in column order.
#[derive(Debug, Clone)]
pub struct SensorBounds {
    pub measured: Vec<f64>,
    pub low: Vec<f64>,
    pub high: Vec<f64>,
    /// `[p_low, p_high]` per sensor for f64 and f32 predictions (`acceptance`),
    /// padded with NaN (rejects) to a whole number of blocks, so that vector
    /// loads of them never run past the end.
    pub(crate) accept64: [Vec<f64>; 2],
    pub(crate) accept32: [Vec<f32>; 2],
    /// The acceptance intervals repeated sensor after sensor over
    /// [`CYCLE`] values (value `i` is sensor `i % n`): the lane pattern of
    /// short rows stored back to back, loaded as whole vectors by the
    /// periodic kernel instead of being assembled lane by lane per block.
    pub(crate) cycle64: [Vec<f64>; 2],
    pub(crate) cycle32: [Vec<f32>; 2],
    /// The periodic kernel's pattern for f64 and f32 rows (AVX-512 vectors of
    /// 8 and 16 values), worked out once here rather than for every block.
    pub(crate) period64: Option<Period>,
    pub(crate) period32: Option<Period>,
    /// The same for rows of whole vectors ([`Period::whole_rows`], AVX2).
    pub(crate) whole64: Option<Period>,
    pub(crate) whole32: Option<Period>,
}

/// Rows of `k` sensors stored back to back repeat their sensor pattern every
/// `lcm(k, w)` values: `vectors` vectors of `w` holding `rows` rows, whose
/// verdict bits form one string of `vectors * w` bits (row `r` owns bits
/// `r*k .. r*k + k`). A period may be several repeats of the pattern (see
/// [`Period::new`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Period {
    /// Vectors per period.
    pub vectors: usize,
    /// Rows per period.
    pub rows: usize,
    /// Per row's field: every bit but the top one (screening's carry trick).
    pub low_bits: u128,
    /// Per row's field: the top bit.
    pub top_bits: u128,
    /// Every interval has `low <= high` (no NaN end, not empty): then a
    /// value outside on both sides is NaN, and NaN costs no comparison.
    pub proper: bool,
}

/// Most vectors in a period (the periodic kernel keeps two interval vectors
/// per vector of the period: 16 registers at AVX-512, 32 at AVX2, which has 16
/// and so reloads some of them from the stack).
pub const MAX_PERIOD_VECTORS: usize = 8;

/// Most vectors in a period whose pattern is repeated ([`Period::new`]):
/// periods of eight f64 vectors (rows of 4 sensors) were screened through
/// memory at 0.93-0.95 of the speed of one-vector periods, though twice as
/// fast from cache (`benches/results-short-rows.txt`, "session 33").
const MAX_REPEATED_VECTORS: usize = 6;

/// Values after which rows of `k` sensors in vectors of `w` repeat their
/// sensor pattern: `lcm(k, w)`.
fn pattern_values(k: usize, w: usize) -> usize {
    fn gcd(a: usize, b: usize) -> usize {
        if b == 0 {
            a
        } else {
            gcd(b, a % b)
        }
    }
    k / gcd(k, w) * w
}

impl Period {
    /// The period of rows of `k` sensors in vectors of `w` values, if the
    /// periodic kernel takes them: more than one row per period (else a row
    /// is read as whole vectors already), at most [`MAX_PERIOD_VECTORS`]
    /// vectors and 128 verdict bits.
    ///
    /// A pattern of at most 32 bits (f32 rows of 1, 2, 4 and 8 sensors; f64
    /// rows of 1-4, 6 and 12) is repeated as often as a `u64` string,
    /// [`MAX_REPEATED_VECTORS`] vectors and 32 rows (the candidate bits a
    /// period pushes) allow: the kernel's work per period (the field
    /// arithmetic, the byte counts, the candidate bits) is then shared by
    /// more rows. Typical rows with diagnostics, alone on one core (`cargo
    /// bench --bench core_kernels`, Zen 4): f64 rows of 2 and 4 and f32 rows
    /// of 2, 4 and 8 ran 2.64-3.14 times as fast at AVX-512 as with one
    /// vector a period (`benches/results-short-rows.txt`, "session 33").
    pub fn new(k: usize, w: usize, proper: bool) -> Option<Period> {
        if k == 0 || k.is_multiple_of(w) {
            return None;
        }
        let lcm = pattern_values(k, w);
        // lcm <= 128 bits of verdicts; then k < 64 (k is not a multiple of w).
        if lcm / w > MAX_PERIOD_VECTORS || lcm > 128 || k >= 64 {
            return None;
        }
        let repeats = if lcm <= 32 {
            (64 / lcm).min(MAX_REPEATED_VECTORS / (lcm / w)).min(32 / (lcm / k))
        } else {
            1
        };
        Some(Period::of(k, repeats * lcm / w, repeats * lcm / k, proper))
    }

    /// This period as one pattern, without the repeats of [`Period::new`]
    /// (periods of rows of whole vectors are kept): with them, AVX2 screened
    /// rows of 4 sensors through memory at 0.94-0.98 of the speed without
    /// (`benches/results-short-rows.txt`, "session 33").
    pub fn unrepeated(self, k: usize, w: usize) -> Period {
        if k == 0 || k.is_multiple_of(w) {
            return self;
        }
        let lcm = pattern_values(k, w);
        Period::of(k, lcm / w, lcm / k, self.proper)
    }

    /// For rows of whole vectors (`k` a multiple of `w`, below 64), a period
    /// of several rows: as many as [`MAX_PERIOD_VECTORS`] vectors and 128
    /// verdict bits hold, if two or more (f64 rows of 8, 16, 24 and 32
    /// sensors, f32 rows of 16, 32 and 48). The AVX2 periodic kernel takes
    /// these too; AVX-512 tests such rows a whole vector at a time already.
    pub fn whole_rows(k: usize, w: usize, proper: bool) -> Option<Period> {
        if k == 0 || !k.is_multiple_of(w) || k >= 64 {
            return None;
        }
        let rows = (MAX_PERIOD_VECTORS / (k / w)).min(128 / k);
        (rows >= 2).then(|| Period::of(k, rows * k / w, rows, proper))
    }

    /// `rows` rows of `k` sensors in `vectors` vectors.
    fn of(k: usize, vectors: usize, rows: usize, proper: bool) -> Period {
        let (low_bits, top_bits) = Self::fields(k, rows);
        Period { vectors, rows, low_bits, top_bits, proper }
    }

    /// The field patterns of `rows` rows of `k` sensors: each field's bits
    /// below its top bit, and its top bit. Inlined, so that a kernel whose
    /// `k` and `rows` are constants has them as constants (not spilled).
    #[inline(always)]
    pub fn fields(k: usize, rows: usize) -> (u128, u128) {
        let (mut low_bits, mut top_bits) = (0u128, 0u128);
        for r in 0..rows {
            low_bits |= ((1u128 << (k - 1)) - 1) << (r * k);
            top_bits |= 1u128 << (r * k + k - 1);
        }
        (low_bits, top_bits)
    }
}

/// Values of the repeated acceptance intervals: the longest period of the
/// periodic kernel (eight vectors of sixteen f32).
pub const CYCLE: usize = 128;

impl SensorBounds {
    /// Bounds of every sensor; all values must be finite, which makes the
    /// acceptance intervals exact.
    pub fn new(measured: &[f64], low: &[f64], high: &[f64]) -> Result<Self> {
        let n = measured.len();
        if low.len() != n || high.len() != n {
            return Err(EdmfError::invalid(
                "thresholds",
                format!("{n} low and high bounds, got {} and {}", low.len(), high.len()),
            ));
        }
        let all = measured.iter().chain(low).chain(high);
        if let Some(v) = all.into_iter().find(|v| !v.is_finite()) {
            return Err(EdmfError::invalid("bounds", format!("finite values, got {v}")));
        }
        let padded = n.div_ceil(BLOCK) * BLOCK;
        let mut accept64 = [vec![f64::NAN; padded], vec![f64::NAN; padded]];
        let mut accept32 = [vec![f32::NAN; padded], vec![f32::NAN; padded]];
        for j in 0..n {
            (accept64[0][j], accept64[1][j]) = accepted_f64(measured[j], low[j], high[j]);
            (accept32[0][j], accept32[1][j]) = accepted_f32(measured[j], low[j], high[j]);
        }
        let cycle = |v: &[f64]| (0..CYCLE).map(|i| v[i % n.max(1)]).collect::<Vec<_>>();
        let cycle32 = |v: &[f32]| (0..CYCLE).map(|i| v[i % n.max(1)]).collect::<Vec<_>>();
        let (cycle64, cycle32) = (
            [cycle(&accept64[0]), cycle(&accept64[1])],
            [cycle32(&accept32[0]), cycle32(&accept32[1])],
        );
        let proper64 = (0..n).all(|j| accept64[0][j] <= accept64[1][j]);
        let proper32 = (0..n).all(|j| accept32[0][j] <= accept32[1][j]);
        Ok(SensorBounds {
            period64: Period::new(n, 8, proper64),
            period32: Period::new(n, 16, proper32),
            whole64: Period::whole_rows(n, 8, proper64),
            whole32: Period::whole_rows(n, 16, proper32),
            cycle64,
            cycle32,
            measured: measured.to_vec(),
            low: low.to_vec(),
            high: high.to_vec(),
            accept64,
            accept32,
        })
    }

    pub fn len(&self) -> usize {
        self.measured.len()
    }

    pub fn is_empty(&self) -> bool {
        self.measured.is_empty()
    }
}

/// Visiting order for screening: blocks of [`BLOCK`] sensors, the block whose
/// sensors rejected most instances of a sample first, so that a row stops
/// after as few tests as possible. The portable kernel follows it, as do all
/// levels for rows that are not contiguous (column-major input); the vector
/// kernels test contiguous rows whole, in column order (from memory the exits
/// cost more than they save: see `simd::avx512::any_rejecting`). The order
/// changes speed only: a row is a candidate iff no sensor rejects it, in
/// whatever order.
#[derive(Debug, Clone)]
pub struct ScreenPlan {
    /// First sensor of each block, in visiting order.
    pub(crate) blocks: Vec<usize>,
}

impl ScreenPlan {
    /// `rejections[j]`: instances sensor j rejected in a sample of instances.
    pub fn new(bounds: &SensorBounds, rejections: &[u64]) -> Self {
        let mut blocks: Vec<usize> = (0..bounds.len()).step_by(BLOCK).collect();
        let rejected = |&s: &usize| -> u64 { rejections[s..(s + BLOCK).min(rejections.len())].iter().sum() };
        // Stable: ties keep column order.
        blocks.sort_by_key(|s| std::cmp::Reverse(rejected(s)));
        ScreenPlan { blocks }
    }

    /// First sensor of each block, most rejecting block first.
    pub fn blocks(&self) -> &[usize] {
        &self.blocks
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_that_reject_most_come_first() {
        let b = SensorBounds::new(&[0.0; 40], &[-1.0; 40], &[1.0; 40]).unwrap();
        let mut rejections = vec![0u64; 40];
        rejections[35] = 5; // block 32..40
        rejections[20] = 3; // block 16..32
        assert_eq!(ScreenPlan::new(&b, &rejections).blocks(), &[32, 16, 0]);
        assert_eq!(ScreenPlan::new(&b, &[0; 40]).blocks(), &[0, 16, 32]);
    }

    #[test]
    fn bounds_must_be_finite_and_of_one_length() {
        assert!(SensorBounds::new(&[0.0], &[-1.0], &[f64::INFINITY]).is_err());
        assert!(SensorBounds::new(&[f64::NAN], &[-1.0], &[1.0]).is_err());
        assert!(SensorBounds::new(&[0.0, 0.0], &[-1.0], &[1.0]).is_err());
        let b = SensorBounds::new(&[0.0; 3], &[-1.0; 3], &[1.0; 3]).unwrap();
        assert_eq!(b.accept64[0].len(), BLOCK);
        assert!(b.accept32[1][3].is_nan());
    }
}
