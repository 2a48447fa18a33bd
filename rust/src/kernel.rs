//! Row tests of Eq. 8: an instance is a candidate iff for every sensor i,
//! `low_i <= g_i(theta) - y_i <= high_i` (inclusive). Residuals are formed in
//! f64 whatever the prediction type, exactly as the NumPy reference does, so
//! instances lying exactly on a bound get the same verdict in both.
//!
//! Two kernels: `diagnose` visits every sensor and tallies which ones reject
//! (for diagnostics); `screen` only tells candidate or not, trying first the
//! sensors that reject most and stopping as soon as one rejects.

pub use crate::bounds::{Period, ScreenPlan, SensorBounds, BLOCK};
pub use crate::candidates::BitSink;
use crate::matrix::Matrix;

#[cfg(target_arch = "x86_64")]
use crate::simd::Lanes;
#[cfg(not(target_arch = "x86_64"))]
/// Stand-in for the SIMD loads, which exist on x86-64 only.
pub trait Lanes {}
#[cfg(not(target_arch = "x86_64"))]
impl Lanes for f32 {}
#[cfg(not(target_arch = "x86_64"))]
impl Lanes for f64 {}

/// Element types the kernels read natively (no conversion pass).
pub trait Prediction: Copy + Send + Sync + 'static + Lanes {
    fn to_f64(self) -> f64;
    /// `[p_low, p_high]` per sensor in this type (see `acceptance`).
    fn accepted(b: &SensorBounds) -> &[Vec<Self>; 2];
    /// The same repeated over `bounds::CYCLE` values (see `SensorBounds`).
    fn cycled(b: &SensorBounds) -> &[Vec<Self>; 2];
    /// The periodic kernel's pattern for rows of this type, if it takes them.
    fn period(b: &SensorBounds) -> Option<Period>;
    /// The same for rows of whole vectors (see [`Period::whole_rows`]).
    fn whole_period(b: &SensorBounds) -> Option<Period>;
}

impl Prediction for f64 {
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline(always)]
    fn accepted(b: &SensorBounds) -> &[Vec<f64>; 2] {
        &b.accept64
    }
    #[inline(always)]
    fn cycled(b: &SensorBounds) -> &[Vec<f64>; 2] {
        &b.cycle64
    }
    #[inline(always)]
    fn period(b: &SensorBounds) -> Option<Period> {
        b.period64
    }
    #[inline(always)]
    fn whole_period(b: &SensorBounds) -> Option<Period> {
        b.whole64
    }
}

impl Prediction for f32 {
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline(always)]
    fn accepted(b: &SensorBounds) -> &[Vec<f32>; 2] {
        &b.accept32
    }
    #[inline(always)]
    fn cycled(b: &SensorBounds) -> &[Vec<f32>; 2] {
        &b.cycle32
    }
    #[inline(always)]
    fn period(b: &SensorBounds) -> Option<Period> {
        b.period32
    }
    #[inline(always)]
    fn whole_period(b: &SensorBounds) -> Option<Period> {
        b.whole32
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
        Tally {
            per_sensor: vec![0; n_sensors],
            only_by: vec![0; n_sensors],
            invalid: 0,
        }
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
pub(crate) fn outside(prediction: f64, measured: f64, low: f64, high: f64) -> bool {
    let residual = prediction - measured; // Eq. 8 / Eq. 14
    !((residual >= low) & (residual <= high)) // NaN is outside
}

/// Sensors tested together: fixed-width lanes that LLVM turns into SIMD.
const LANES: usize = 8;

/// Rejecting-sensor count and NaN flag of one contiguous row; adds each
/// sensor's rejection to `counts`. Branch-free over fixed-width lanes (exact
/// chunks, so no bounds checks) so that it vectorises.
#[inline(always)]
fn diagnose_row<T: Prediction>(row: &[T], b: &SensorBounds, counts: &mut [u64]) -> (u32, bool, usize) {
    let k = row.len();
    let (y, lo, hi, counts) = (&b.measured[..k], &b.low[..k], &b.high[..k], &mut counts[..k]);
    let mut n = [0u64; LANES];
    let mut nan = [0u64; LANES];
    let lanes = row
        .chunks_exact(LANES)
        .zip(y.chunks_exact(LANES))
        .zip(lo.chunks_exact(LANES).zip(hi.chunks_exact(LANES)))
        .zip(counts.chunks_exact_mut(LANES));
    for (((p, y), (lo, hi)), c) in lanes {
        for l in 0..LANES {
            let p = p[l].to_f64();
            let v = outside(p, y[l], lo[l], hi[l]) as u64;
            c[l] += v;
            n[l] += v;
            nan[l] |= p.is_nan() as u64;
        }
    }
    let whole = k - k % LANES;
    for j in whole..k {
        let p = row[j].to_f64();
        let v = outside(p, y[j], lo[j], hi[j]) as u64;
        counts[j] += v;
        n[0] += v;
        nan[0] |= p.is_nan() as u64;
    }
    (n.iter().sum::<u64>() as u32, nan.iter().any(|&x| x != 0), UNKNOWN)
}

/// "First rejecting sensor not tracked": the caller looks for it if it needs it.
pub(crate) const UNKNOWN: usize = usize::MAX;

/// True if any sensor rejects the row whose prediction at sensor j is
/// `prediction(j)`, visiting the plan's blocks in order and stopping at the
/// first block holding a rejection.
#[inline(always)]
fn row_rejected(b: &SensorBounds, plan: &ScreenPlan, k: usize, prediction: impl Fn(usize) -> f64) -> bool {
    plan.blocks.iter().any(|&s| {
        (s..(s + BLOCK).min(k)).fold(false, |any, j| {
            any | outside(prediction(j), b.measured[j], b.low[j], b.high[j])
        })
    })
}

#[inline(always)]
pub(crate) fn diagnose_impl<T: Prediction>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    out: &mut [u32],
    tally: &mut Tally,
    mut row_kernel: impl FnMut(&[T], &SensorBounds, &mut [u64]) -> (u32, bool, usize),
) {
    for (i, n_out) in out.iter_mut().enumerate() {
        let (n, nan, first) = match m.row_slice(i) {
            Some(row) => row_kernel(row, b, &mut tally.per_sensor),
            None => {
                let (mut n, mut nan) = (0u32, false);
                for j in 0..b.len() {
                    let p = m.get(i, j).to_f64();
                    let v = outside(p, b.measured[j], b.low[j], b.high[j]);
                    tally.per_sensor[j] += v as u64;
                    n += v as u32;
                    nan |= p.is_nan();
                }
                (n, nan, UNKNOWN)
            }
        };
        // Branch-free for the vector kernels, which know the first rejecting
        // sensor (outcomes are random row to row: a branch would mispredict).
        let j = if first != UNKNOWN {
            first
        } else if n == 1 {
            (0..b.len())
                .find(|&j| outside(m.get(i, j).to_f64(), b.measured[j], b.low[j], b.high[j]))
                .unwrap_or(0)
        } else {
            0
        };
        tally.only_by[j] += (n == 1) as u64;
        tally.invalid += nan as u64;
        *n_out = n;
    }
}

#[inline(always)]
pub(crate) fn screen_impl<T: Prediction>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    plan: &ScreenPlan,
    out: &mut [u32],
    mut row_kernel: impl FnMut(&[T]) -> bool,
) {
    for (i, flag) in out.iter_mut().enumerate() {
        let rejected = match m.row_slice(i) {
            Some(row) => row_kernel(row),
            None => row_rejected(b, plan, m.cols(), |j| m.get(i, j).to_f64()),
        };
        *flag = rejected as u32;
    }
}

/// Environment variable that caps the kernels at one level (`portable`,
/// `avx2`, `avx512`); ignored if unknown or not run by this CPU.
pub const ISA_ENV: &str = "EDMF_RS_ISA";

/// Instruction-set level of the row kernels. All levels give identical
/// results; the fastest one the CPU runs is chosen at run time, so one build
/// is fast on new CPUs and still runs on old ones.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Isa {
    Portable,
    Avx2,
    Avx512,
}

impl Isa {
    /// Whether this CPU runs `self`.
    pub fn supported(self) -> bool {
        match self {
            Isa::Portable => true,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => {
                std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("popcnt")
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                // Every AVX-512 kernel is reached through here: its prefetch
                // is chosen before it runs (see `simd::prefetch::Prefetch::now`).
                crate::simd::prefetch::Prefetch::current();
                std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("popcnt")
                    && std::arch::is_x86_feature_detected!("bmi1")
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// Every level this CPU runs, slowest first.
    pub fn available() -> Vec<Isa> {
        [Isa::Portable, Isa::Avx2, Isa::Avx512]
            .into_iter()
            .filter(|i| i.supported())
            .collect()
    }

    /// The level named `name` ("portable", "avx2" or "avx512", any case).
    pub fn from_name(name: &str) -> Option<Isa> {
        match name.trim().to_ascii_lowercase().as_str() {
            "portable" => Some(Isa::Portable),
            "avx2" => Some(Isa::Avx2),
            "avx512" => Some(Isa::Avx512),
            _ => None,
        }
    }

    /// The fastest level this CPU runs, or the level named by the environment
    /// variable [`ISA_ENV`] if the CPU runs it (to test every level through the
    /// Python package, and to compare them). Read once; asked for every block.
    pub fn detect() -> Isa {
        static DETECTED: std::sync::OnceLock<Isa> = std::sync::OnceLock::new();
        *DETECTED.get_or_init(|| {
            let forced = std::env::var(ISA_ENV).ok().and_then(|v| Isa::from_name(&v));
            match forced {
                Some(isa) if isa.supported() => isa,
                _ => *Isa::available().last().unwrap_or(&Isa::Portable),
            }
        })
    }
}

/// Writes the number of rejecting sensors of each row of `m` into `out` and
/// adds the per-sensor counts to `tally`. `b` must be in column order. An
/// `isa` the CPU does not run falls back to the portable kernel.
///
/// # Panics
/// If `m` has not one column per sensor of `b`, or `out` not one value per
/// row (a caller's bug: `Falsifier::update` checks widths and returns errors).
pub fn diagnose_with<T: Prediction>(
    isa: Isa,
    m: Matrix<'_, T>,
    b: &SensorBounds,
    out: &mut [u32],
    tally: &mut Tally,
) {
    assert!(
        m.cols() == b.len() && out.len() == m.rows(),
        "one column per sensor, one output per row"
    );
    match isa {
        // SAFETY: the CPU runs the level (checked by `supported`).
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512 if isa.supported() => unsafe { crate::simd::avx512::diagnose(m, b, out, tally) },
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 if isa.supported() => unsafe { crate::simd::avx2::diagnose(m, b, out, tally) },
        _ => diagnose_impl(m, b, out, tally, diagnose_row),
    }
}

/// Writes 0 for candidates and 1 for falsified instances, stopping early in
/// each row once a sensor rejects it; `plan` orders the sensors of `b`.
///
/// # Panics
/// As [`diagnose_with`].
pub fn screen_with<T: Prediction>(
    isa: Isa,
    m: Matrix<'_, T>,
    b: &SensorBounds,
    plan: &ScreenPlan,
    out: &mut [u32],
) {
    assert!(
        m.cols() == b.len() && out.len() == m.rows(),
        "one column per sensor, one output per row"
    );
    match isa {
        // SAFETY: the CPU runs the level (checked by `supported`).
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512 if isa.supported() => unsafe { crate::simd::avx512::screen(m, b, plan, out) },
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 if isa.supported() => unsafe { crate::simd::avx2::screen(m, b, plan, out) },
        _ => screen_impl(m, b, plan, out, |row| {
            row_rejected(b, plan, row.len(), |j| row[j].to_f64())
        }),
    }
}

/// Runs `kernel(r0, r1, out)` (per-row values of rows `r0..r1` into `out`,
/// 0 = candidate) over `rows` rows and appends their candidate bits to
/// `sink`: into `counts` when given, else a few hundred rows at a time
/// through a buffer on the stack (for the kernels that test one row at a time).
pub(crate) fn via_counts(
    rows: usize,
    counts: Option<&mut [u32]>,
    sink: &mut BitSink,
    mut kernel: impl FnMut(usize, usize, &mut [u32]),
) {
    match counts {
        Some(c) => {
            kernel(0, rows, c);
            sink.push_verdicts(c);
        }
        None => {
            let mut buf = [0u32; 256];
            for r0 in (0..rows).step_by(buf.len()) {
                let r1 = (r0 + buf.len()).min(rows);
                kernel(r0, r1, &mut buf[..r1 - r0]);
                sink.push_verdicts(&buf[..r1 - r0]);
            }
        }
    }
}

/// Appends one candidate bit per row of `m` to `sink` (as [`diagnose_with`]
/// gives them), writes the rows' rejecting-sensor counts to `counts` only
/// if given, and adds the per-sensor counts to `tally`. The short-row
/// kernels (periodic at both vector levels, the others at AVX-512) write the
/// bits straight from their masks.
///
/// # Panics
/// As [`diagnose_with`] (`counts`, if given, has one value per row).
pub fn diagnose_bits_with<T: Prediction>(
    isa: Isa,
    m: Matrix<'_, T>,
    b: &SensorBounds,
    counts: Option<&mut [u32]>,
    sink: &mut BitSink,
    tally: &mut Tally,
) {
    assert!(
        m.cols() == b.len() && counts.as_ref().is_none_or(|c| c.len() == m.rows()),
        "one column per sensor, one count per row"
    );
    match isa {
        // SAFETY: the CPU runs the level (checked by `supported`).
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512 if isa.supported() => unsafe { crate::simd::avx512::diagnose_bits(m, b, counts, sink, tally) },
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 if isa.supported() => unsafe {
            crate::simd::avx2::diagnose_bits(m, b, counts, sink, tally)
        },
        _ => via_counts(m.rows(), counts, sink, |r0, r1, out| {
            diagnose_with(isa, m.slice_rows(r0, r1), b, out, tally)
        }),
    }
}

/// Appends one candidate bit per row of `m` to `sink` (as [`screen_with`]).
///
/// # Panics
/// As [`screen_with`].
pub fn screen_bits_with<T: Prediction>(
    isa: Isa,
    m: Matrix<'_, T>,
    b: &SensorBounds,
    plan: &ScreenPlan,
    sink: &mut BitSink,
) {
    assert!(m.cols() == b.len(), "one column per sensor");
    match isa {
        // SAFETY: the CPU runs the level (checked by `supported`).
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512 if isa.supported() => unsafe { crate::simd::avx512::screen_bits(m, b, plan, sink) },
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 if isa.supported() => unsafe { crate::simd::avx2::screen_bits(m, b, plan, sink) },
        _ => via_counts(m.rows(), None, sink, |r0, r1, out| {
            screen_with(isa, m.slice_rows(r0, r1), b, plan, out)
        }),
    }
}

/// [`diagnose_with`] at the fastest level of this CPU.
pub fn diagnose<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, out: &mut [u32], tally: &mut Tally) {
    diagnose_with(Isa::detect(), m, b, out, tally)
}

/// [`screen_with`] at the fastest level of this CPU.
pub fn screen<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, plan: &ScreenPlan, out: &mut [u32]) {
    screen_with(Isa::detect(), m, b, plan, out)
}

#[cfg(test)]
#[path = "kernel_tests.rs"]
mod tests;
