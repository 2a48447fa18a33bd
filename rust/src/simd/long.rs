//! AVX-512 kernels of the rows the periodic, short-row and medium kernels do
//! not take: with diagnostics, f32 rows of more than 128 sensors and f64
//! rows of more than 64; screened, rows
//! of more than two vectors (rows whose values are not contiguous get the
//! literal test of each value). Rows are tested two at a time, vector by vector: each vector of intervals is
//! loaded once for both rows. With diagnostics the per-sensor counts are one
//! load, two masked adds of the *accepting* sensors and one store a vector
//! (rejections = rows attributed - acceptances, so no complement per
//! vector), and a row's accepting sensors are gathered 64 to a word, whose
//! complement's popcount and lowest bit give the violation count and the
//! first rejecting sensor: per word, not per vector.
//!
//! Why: the row-at-a-time loop this replaces (`avx512::diagnose_row`) read
//! the intervals and updated the counts in memory for every vector of every
//! row. Gathering the words alone gained nothing; with them gathered, taking
//! the count update out made typical float32 rows of 200 sensors with
//! diagnostics run 1.48 times as fast (kernel alone, one core, AMD EPYC
//! Zen 4). Why two rows, not four: four ran as fast or faster alone, but through
//! memory typical float64 rows of 200 with diagnostics then ran at 0.87-0.89
//! of the old kernel's speed, two at 0.99-1.01.
//! Measurements: `benches/results-long-rows.txt`, sections "session 28".

use super::checksum::RowsRead;
use super::prefetch::Prefetch;
use crate::kernel::{diagnose_impl, screen_impl, Prediction, ScreenPlan, SensorBounds, Tally, BLOCK};
use crate::matrix::Matrix;
use std::arch::x86_64::*;

/// Rows tested together.
const GROUP: usize = 2;

/// Candidates in a row after which the verdicts of the next rows come first
/// (a NaN is outside every interval, so a candidate row holds none): only a
/// group with a rejected row is then attributed, in a second visit of its
/// vectors, now in L1. Runs of candidates (every instance kept) thus cost
/// about what screening does; the outcome does not depend on the branch.
const VERDICT_FIRST: u32 = 2;

/// Rows between two flushes of [`PaddedCounts`] (its u32 lanes cannot wrap).
pub(super) const FLUSH_ROWS: usize = 1 << 16;

/// Per-sensor counts of accepting sensors padded to whole vectors (u32
/// lanes for f32 rows, in the same buffer, u64 for f64), and the rows
/// attributed since the last flush.
pub(super) struct PaddedCounts {
    accepting: Vec<u64>,
    rows: u64,
}

impl PaddedCounts {
    pub(super) fn new(k: usize) -> Self {
        PaddedCounts { accepting: vec![0; k.div_ceil(16) * 16], rows: 0 }
    }

    /// Adds the rejections into `per_sensor` (one per sensor) and starts again.
    pub(super) fn flush<T: Prediction>(&mut self, per_sensor: &mut [u64]) {
        if T::W512 == 16 {
            // SAFETY: the buffer holds twice as many u32 as u64, all initialised.
            let narrow =
                unsafe { std::slice::from_raw_parts(self.accepting.as_ptr() as *const u32, 2 * self.accepting.len()) };
            for (t, &c) in per_sensor.iter_mut().zip(narrow) {
                *t += self.rows - u64::from(c);
            }
        } else {
            for (t, &c) in per_sensor.iter_mut().zip(&self.accepting) {
                *t += self.rows - c;
            }
        }
        self.accepting.fill(0);
        self.rows = 0;
    }
}

/// Mask of the first `n` lanes (n <= 16).
#[inline(always)]
fn prefix(n: usize) -> u32 {
    (1u32 << n) - 1
}

/// `c` plus one in every lane set in `inside` (u32 lanes for f32, u64 for f64).
#[inline(always)]
unsafe fn add_accepting<T: Prediction>(c: __m512i, inside: u32) -> __m512i {
    if T::W512 == 16 {
        _mm512_mask_sub_epi32(c, inside as __mmask16, c, _mm512_set1_epi32(-1))
    } else {
        _mm512_mask_sub_epi64(c, inside as __mmask8, c, _mm512_set1_epi64(-1))
    }
}

/// One vector of sensors from `j` (the lanes in `lanes`) of each row: its
/// acceptances added to the counts, its accepting lanes or'ed into bits
/// `at..` of the row's word, its values added to the row's `sums` (NaN is
/// looked for in the sum once a row: see [`attribute`]).
///
/// # Safety
/// AVX-512F is available; the lanes lie within every row; the acceptance
/// vectors and `counts` hold a whole vector from `j`.
#[inline(always)]
unsafe fn visit<T: Prediction, const N: usize>(
    rows: &[&[T]; N],
    accept: &[Vec<T>; 2],
    counts: &mut PaddedCounts,
    (j, lanes, at, first_visit): (usize, u32, usize, bool),
    (words, sums): (&mut [u64; N], &mut [T::V512; N]),
) {
    let all = prefix(T::W512);
    let low = T::load512(all, accept[0].as_ptr().add(j));
    let high = T::load512(all, accept[1].as_ptr().add(j));
    let c = if T::W512 == 16 {
        counts.accepting.as_mut_ptr().cast::<u32>().add(j) as *mut __m512i
    } else {
        counts.accepting.as_mut_ptr().add(j) as *mut __m512i
    };
    let mut sum = _mm512_loadu_si512(c);
    for r in 0..N {
        // The first visit of the rows asks for the lines ahead.
        if first_visit {
            Prefetch::FIXED.line(rows[r].as_ptr().wrapping_add(j)); // see `Prefetch::now` for which kernels choose
        }
        let p = T::load512(lanes, rows[r].as_ptr().add(j));
        let inside = T::inside512(lanes, p, low, high);
        sums[r] = T::add512(sums[r], p);
        sum = add_accepting::<T>(sum, inside);
        words[r] |= u64::from(inside) << at;
    }
    _mm512_storeu_si512(c, sum);
}

/// Adds the rejections among the `valid` bits of each row's word of
/// accepting sensors `j0..j0 + 64` to its count and its first rejecting sensor.
#[inline(always)]
fn tally<const N: usize>(j0: usize, words: &[u64; N], valid: u64, (n, first): (&mut [u32; N], &mut [usize; N])) {
    for r in 0..N {
        let out = !words[r] & valid;
        n[r] += out.count_ones();
        let none = ((out == 0) as usize).wrapping_neg(); // all ones if none rejects
        first[r] = first[r].min((j0 + out.trailing_zeros() as usize) | none);
    }
}

/// Rejecting lanes of every vector of each of `rows`, or'ed: nonzero iff
/// some sensor rejects the row (a NaN is outside every interval). Every
/// vector in column order, each vector of intervals loaded once for the
/// rows, each row's vector asking first for the line the prefetch distance
/// past it (`super::prefetch`).
///
/// Why not stop at the first rejecting block, most rejecting first, and
/// prefetch the whole row at its start, as this did: from memory, rows read
/// whole and in order with the prefetches spread ran faster. The recorded
/// runs do not take the parts apart; the likely causes are that the plan's
/// order reads a row's lines out of sequence, that each exit mispredicts, and
/// that a burst of one prefetch per line (25 for f64 rows of 200) stalls the
/// loads behind it. Side by side through `falsify` (AMD EPYC Zen 4, 2 threads,
/// `benches/results-short-rows.txt`, section "session 14: side by side"),
/// with the slabs sized for the pool as well (`falsifier.rs`), rows of 100
/// and 200 sensors went from 0.58-0.90 of the read floor to 0.78-1.15. The
/// price is paid from cache, where stopping early saved work: the kernel alone screening f64 rows of 200 with 91 % rejected went from
/// 58-60 to 41 M rows/s, with every row a candidate from 28-31 to 41-44
/// (`cargo bench -- long_rows`, `benches/results-long-rows.txt`, "session 14").
///
/// # Safety
/// AVX-512F is available; the rows have the width of `accept`, whose vectors
/// are padded to whole blocks.
#[inline(always)]
unsafe fn rejecting<T: Prediction, const N: usize>(rows: &[&[T]; N], accept: &[Vec<T>; 2]) -> [u32; N] {
    let (k, w) = (rows[0].len(), T::W512);
    let mut any = [0; N];
    let whole = k - k % w;
    for j in (0..whole).step_by(w) {
        rejecting_lanes(rows, accept, (j, prefix(w)), &mut any);
    }
    if whole < k {
        rejecting_lanes(rows, accept, (whole, prefix(k - whole)), &mut any);
    }
    any
}

/// Or's into `any` the rejecting lanes among `lanes` of the vector from `j`
/// of each row, asking first for the line the prefetch distance past it.
/// A function, not a closure: a closure does not take its caller's target
/// features, so the intrinsics' wrappers in it may stay calls (they did in
/// the extension's build, which then ran five times slower).
///
/// # Safety
/// As [`rejecting`]; the lanes lie within every row.
#[inline(always)]
unsafe fn rejecting_lanes<T: Prediction, const N: usize>(
    rows: &[&[T]; N],
    accept: &[Vec<T>; 2],
    (j, lanes): (usize, u32),
    any: &mut [u32; N],
) {
    let all = prefix(T::W512);
    let low = T::load512(all, accept[0].as_ptr().add(j));
    let high = T::load512(all, accept[1].as_ptr().add(j));
    for (row, any) in rows.iter().zip(any) {
        Prefetch::FIXED.line(row.as_ptr().wrapping_add(j)); // see `Prefetch::now`
        let p = T::load512(lanes, row.as_ptr().add(j));
        *any |= !T::inside512(lanes, p, low, high) & lanes;
    }
}

/// Rejecting-sensor count, NaN flag and first rejecting sensor (the last
/// sensor when none rejects) of each of `N` rows of one width, adding their
/// acceptances to `counts`; with `verdict_first`, rows that all are
/// candidates are first told apart and not attributed.
///
/// NaN is looked for in each row's sum of values (one add a vector, where a
/// NaN comparison and its mask's move to a general register were two more
/// operations), and value by value only when the sum is NaN. Alone on one
/// core, rows of 65-200 sensors with diagnostics ran 0.93-1.17 times as fast
/// (AMD EPYC Zen 4, `benches/results-long-rows.txt`, "session 34"; through
/// `falsify` these rows wait on memory).
///
/// # Safety
/// AVX-512F, POPCNT and BMI1 are available; the rows have the width of `b`,
/// whose acceptance vectors are padded to whole blocks; `counts` is padded
/// to whole vectors of that width.
#[inline]
#[target_feature(enable = "avx512f,popcnt,bmi1")]
unsafe fn attribute<T: Prediction, const N: usize>(
    rows: [&[T]; N],
    b: &SensorBounds,
    counts: &mut PaddedCounts,
    verdict_first: bool,
) -> [(u32, bool, usize); N] {
    let (k, w, accept) = (b.len(), T::W512, T::accepted(b));
    let last = k.saturating_sub(1);
    if verdict_first && rejecting(&rows, accept) == [0; N] {
        return [(0, false, last); N];
    }
    counts.rows += N as u64;
    let (mut n, mut sums, mut first) = ([0u32; N], [T::zero512(); N], [usize::MAX; N]);
    for j0 in (0..k - k % 64).step_by(64) {
        let mut words = [0u64; N];
        unrolled!(64 / T::W512, |v| {
            let at = (j0 + v * w, prefix(w), v * w, !verdict_first);
            visit(&rows, accept, counts, at, (&mut words, &mut sums));
        });
        tally(j0, &words, u64::MAX, (&mut n, &mut first));
    }
    let j0 = k - k % 64;
    if j0 < k {
        let (mut words, mut valid) = ([0u64; N], 0u64);
        for (v, j) in (j0..k).step_by(w).enumerate() {
            let lanes = prefix((k - j).min(w));
            visit(&rows, accept, counts, (j, lanes, v * w, !verdict_first), (&mut words, &mut sums));
            valid |= u64::from(lanes) << (v * w);
        }
        tally(j0, &words, valid, (&mut n, &mut first));
    }
    let mut verdicts = [(0, false, 0); N];
    for r in 0..N {
        // The row's values sum to NaN iff one is NaN, or (rarely) infinities
        // cancel: then the row is looked at value by value.
        let nan = T::nan512(prefix(w), sums[r]) != 0 && rows[r].iter().any(|x| x.to_f64().is_nan());
        verdicts[r] = (n[r], nan, first[r].min(last));
    }
    verdicts
}

/// Writes the rejecting-sensor count of every row of `m` to `out` and adds
/// the rows' diagnostics to `t` (the per-sensor counts through `counts`,
/// flushed at the end); tells `sums` each row it has read.
///
/// # Safety
/// AVX-512F, POPCNT and BMI1 are available; `m` has the width of `b`, whose
/// acceptance vectors are padded to whole blocks; `counts` is
/// `PaddedCounts::new(b.len())`; `m` has at most [`FLUSH_ROWS`] rows.
#[target_feature(enable = "avx512f,popcnt,bmi1")]
pub(super) unsafe fn diagnose<T: Prediction, S: RowsRead>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    out: &mut [u32],
    (t, sums): (&mut Tally, &mut S),
    counts: &mut PaddedCounts,
) {
    let (k, w) = (b.len(), T::W512);
    assert!(m.cols() == k && out.len() == m.rows() && m.rows() <= FLUSH_ROWS);
    assert!(T::accepted(b)[0].len() >= k.div_ceil(BLOCK) * BLOCK && counts.accepting.len() >= k.div_ceil(w) * w);
    if !m.rows_contiguous() {
        // Rows not contiguous: the literal test of each value (`diagnose_impl`).
        return diagnose_impl(m, b, out, t, |_, _, _| unreachable!("rows are not contiguous"));
    }
    let (groups, mut run) = (m.rows() / GROUP, 0u32);
    for g in 0..groups {
        let mut rows: [&[T]; GROUP] = [&[]; GROUP];
        for (r, row) in rows.iter_mut().enumerate() {
            *row = m.row_slice(g * GROUP + r).expect("contiguous rows (checked above)");
        }
        let verdicts = attribute(rows, b, counts, run >= VERDICT_FIRST);
        for (r, &(n, nan, first)) in verdicts.iter().enumerate() {
            run = if n == 0 { run.saturating_add(1) } else { 0 };
            t.only_by[first] += u64::from(n == 1);
            t.invalid += u64::from(nan);
            out[g * GROUP + r] = n;
            sums.rows_read(rows[r].as_ptr_range().end as *const u8);
        }
    }
    // The last row alone, as the pairs above (and in `screen`): one generic
    // body over both widths screened at 0.89-0.99 of this speed alone on a
    // core (`benches/results-long-rows.txt`, "session 28 review"), so the
    // loops stay written out.
    for i in groups * GROUP..m.rows() {
        let row = m.row_slice(i).expect("contiguous rows (checked above)");
        let [(n, nan, first)] = attribute([row], b, counts, run >= VERDICT_FIRST);
        run = if n == 0 { run.saturating_add(1) } else { 0 };
        t.only_by[first] += u64::from(n == 1);
        t.invalid += u64::from(nan);
        out[i] = n;
        sums.rows_read(row.as_ptr_range().end as *const u8);
    }
    counts.flush::<T>(&mut t.per_sensor);
}

/// Writes every row's verdict of `m` to `out` (1 falsified, 0 candidate);
/// tells `sums` each row it has read. Rows are tested two at a time, each
/// vector of intervals loaded once for both.
///
/// # Safety
/// AVX-512F is available; `m` has the width of `b`, whose acceptance
/// vectors are padded to whole blocks.
#[target_feature(enable = "avx512f")]
pub(super) unsafe fn screen<T: Prediction, S: RowsRead>(
    m: Matrix<'_, T>,
    (b, plan): (&SensorBounds, &ScreenPlan),
    out: &mut [u32],
    sums: &mut S,
) {
    let (k, accept) = (b.len(), T::accepted(b));
    assert!(m.cols() == k && out.len() == m.rows() && accept[0].len() >= k.div_ceil(BLOCK) * BLOCK);
    if !m.rows_contiguous() {
        // Rows not contiguous: the literal test of each value (`screen_impl`).
        return screen_impl(m, b, plan, out, |_| unreachable!("rows are not contiguous"));
    }
    let groups = m.rows() / GROUP;
    for g in 0..groups {
        let mut rows: [&[T]; GROUP] = [&[]; GROUP];
        for (r, row) in rows.iter_mut().enumerate() {
            *row = m.row_slice(g * GROUP + r).expect("contiguous rows (checked above)");
        }
        for (r, any) in rejecting(&rows, accept).into_iter().enumerate() {
            out[g * GROUP + r] = u32::from(any != 0);
            sums.rows_read(rows[r].as_ptr_range().end as *const u8);
        }
    }
    for i in groups * GROUP..m.rows() {
        let row = m.row_slice(i).expect("contiguous rows (checked above)");
        out[i] = u32::from(rejecting(&[row], accept)[0] != 0);
        sums.rows_read(row.as_ptr_range().end as *const u8);
    }
}
