//! AVX2 diagnostics for rows stored one after another in memory of 9-200
//! f32 sensors (two to twenty-five vectors of eight) or 9-96 f64 (three to
//! twenty-four of four),
//! the AVX2 counterpart of `medium`: every row gets the same work, with no
//! branch on its verdict, except that after a block of candidates the next
//! block's verdicts come first (`medium_avx2_short::candidates_first`), so a
//! run of candidates costs its verdicts only: alone on a core, rows of 13-64
//! sensors with diagnostics, every row a candidate, ran 1.54-2.32 times as
//! fast (AMD EPYC Zen 4; `benches/results-long-rows.txt`, "session 34").
//! Each vector's comparison gives its accepting
//! lanes as all-ones integers, which are subtracted from one 32-bit counter
//! lane per sensor (rejections = rows - acceptances: no complement, no bit
//! expansion; f64 vectors two to a counter, see `pair_lanes`); the same
//! lanes' sign bits make the row's accepting sensors one 64-bit word (two
//! for rows of 65-128, four for f32 rows of more than 128), whose
//! complement's popcount is the violation count and whose lowest bit is the
//! first rejecting sensor ("falsified only by" for rows of four and five
//! f64 vectors: `counts_alone`). Rows of up to four f32 and three f64
//! vectors take `medium_avx2_short` instead (`medium_avx2_short::takes`).
//!
//! Why: `long_avx2`, which took these rows before, counts per bit of the
//! row's verdict string in byte lanes and reads a row's verdict first after
//! four candidates in a row, so with rejected rows scattered among
//! candidates (the typical case) it paid a mispredicted branch and a bit
//! expansion per row: f32 rows of 50 with 45 % of rows rejected ran at 73 M
//! rows/s on one core of an AMD EPYC (Zen 4, `cargo bench -- long_rows`),
//! 14.5 GB/s, below what each of two cores reads from memory there
//! (`benches/results-long-rows.txt`, "session 20"). It took f32 rows of
//! 65-128 too until session 36: typical rows of 65 with diagnostics read
//! 16 GB/s alone on a core against 29 for rows of 64 (section "session 36:
//! f32 rows of 65-128"); and f64 rows of 65-96 and f32 rows of 129-200
//! until session 37, when typical float32 rows of 150 with diagnostics read 0.61-0.64 of the floor through `falsify`
//! (two runs; see [`vectors`]).

use super::checksum::RowsRead;
use super::medium_avx2_short::{self, all_candidates, candidates_first, Rows, BLOCK_ROWS};
use super::prefetch::Prefetch;
use crate::kernel::{Prediction, SensorBounds, Tally};
use crate::matrix::Matrix;
use std::arch::x86_64::*;

/// Rows per pass between two flushes of the counters (32-bit lanes: far
/// below 2^32, so they never wrap).
const FLUSH_ROWS: usize = 1 << 20;

/// Vectors of `T::W512 / 2` lanes per row of `k` sensors if this kernel
/// takes them: more than eight sensors (fewer go to `short_avx2`), f32
/// rows of up to 200 (twenty-five vectors, the widest rows) and
/// f64 rows of up to 96 (twenty-four vectors).
///
/// Why: past sixteen vectors the counters and intervals live on the stack,
/// yet alone on a core (AMD EPYC Zen 4, `cargo bench --bench core_kernels`,
/// against `long_avx2`, which took them before) typical and
/// single-rejection float64 rows of 65-96 with diagnostics ran 0.99-1.30 times as fast
/// (worst case 1.21-1.69) and float32 rows of 129-200 1.03-1.11 (worst case 1.52-1.60);
/// with f64 rows of up to 128 on this kernel, rows of 112 and 128 ran 0.99-1.01 times as fast
/// (typical and single rejections; worst case 1.53-1.55). f64 stops at
/// 96, a judgement: past it the typical rows gain nothing, and each vector
/// count is one more compiled loop
/// (`benches/results-long-rows.txt`, "session 37: the AVX2 medium kernel
/// takes f64 rows of 65-96 and f32 rows of 129-200").
pub fn vectors<T: Prediction>(k: usize) -> Option<usize> {
    let v = k.div_ceil(T::W512 / 2);
    (8 < k && v <= if std::mem::size_of::<T>() == 8 { 24 } else { 25 }).then_some(v)
}

/// Writes the rejecting-sensor count of every row of `m` to `out` and adds
/// the rows' diagnostics to `t`; tells `sums` each row it has read (the
/// checkpoint checksum, if any).
///
/// # Safety
/// AVX2 and POPCNT are available; `vectors::<T>(m.cols())` is `Some`; rows
/// are contiguous (`m.row_slice` is `Some`).
#[inline]
#[target_feature(enable = "avx2,popcnt")]
pub unsafe fn diagnose<T: Prediction, S: RowsRead>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    out: &mut [u32],
    (t, sums): (&mut Tally, &mut S),
) {
    diagnose_in_passes(m, b, out, (t, sums), FLUSH_ROWS)
}

/// [`diagnose`] with the counters flushed every `pass_rows` rows (tests
/// flush far more often than [`FLUSH_ROWS`]), the row's vectors a constant.
///
/// # Safety
/// As [`diagnose`]; `pass_rows < 2^32`.
#[inline]
#[target_feature(enable = "avx2,popcnt")]
pub(crate) unsafe fn diagnose_in_passes<T: Prediction, S: RowsRead>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    out: &mut [u32],
    (t, sums): (&mut Tally, &mut S),
    pass_rows: usize,
) {
    // SAFETY: as this function's, `vectors` gave `V`.
    by_vectors!(T, m.cols(), |V| unsafe { diagnose_rows::<T, V, S>(m, b, out, (t, sums), pass_rows) })
}

/// [`diagnose_in_passes`] for rows of `V` vectors.
///
/// # Safety
/// As [`diagnose_in_passes`]; `vectors::<T>(m.cols()) == Some(V)`.
#[inline]
#[target_feature(enable = "avx2,popcnt")]
unsafe fn diagnose_rows<T: Prediction, const V: usize, S: RowsRead>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    out: &mut [u32],
    (t, sums): (&mut Tally, &mut S),
    pass_rows: usize,
) {
    if medium_avx2_short::takes::<T>(V) {
        // SAFETY: as this function's, and the short-row kernel takes `V`.
        return unsafe { medium_avx2_short::diagnose_rows::<T, V, S>(m, b, out, (t, sums), pass_rows) };
    }
    let (k, w, accept) = (m.cols(), T::W512 / 2, T::accepted(b));
    assert!(vectors::<T>(k) == Some(V) && out.len() == m.rows() && t.per_sensor.len() == k);
    assert!(k >= w && accept[0].len() >= k && accept[1].len() >= k);
    assert!(pass_rows > 0 && pass_rows < 1 << 32);
    let mut read = *sums;
    let rows_at = |first: usize, end: usize| Rows::of(m, first..end, accept);
    // "Falsified only by" in `V` more counters (see `counts_alone`) for
    // rows of four and five f64 vectors, else one add in memory per row at
    // the row's lowest rejecting sensor (index 64, 128 or 256, past the row:
    // no rejecting sensor, never counted).
    let mut only_by = [0u64; 257];
    // Whether the last block's rows were all candidates (before the first
    // block, the first four rows): then the next block's verdicts come first.
    let mut quiet = m.rows() > 0 && all_candidates::<T, V>(rows_at(0, m.rows().min(4)));
    for first in (0..m.rows()).step_by(pass_rows) {
        let end = (first + pass_rows).min(m.rows());
        let mut c = Counters { accepting: [_mm256_setzero_si256(); V], alone: [_mm256_setzero_si256(); V], invalid: 0 };
        let mut candidates = 0u64;
        for block in (first..end).step_by(BLOCK_ROWS) {
            let block_end = (block + BLOCK_ROWS).min(end);
            let rows = rows_at(block, block_end);
            // A candidate row needs its verdict only.
            if candidates_first::<T, V, S>(quiet, rows, &mut out[block..block_end], &mut read) {
                candidates += rows.n as u64;
                continue;
            }
            diagnose_block::<T, V, S>(rows, &mut out[block..block_end], (&mut c, &mut only_by), &mut read);
            quiet = out[block..block_end].iter().all(|&n| n == 0);
        }
        // Rows attributed: the blocks of candidates told apart first are not.
        let rows = (end - first) as u64 - candidates;
        for (total, count) in t.per_sensor.iter_mut().zip(sensor_counts::<T, V>(&c.accepting, k)) {
            *total += rows - count;
        }
        if counts_alone::<T>(V) {
            for (total, count) in only_by.iter_mut().zip(sensor_counts::<T, V>(&c.alone, k)) {
                *total += count;
            }
        }
        t.invalid += c.invalid;
    }
    for (total, &count) in t.only_by.iter_mut().zip(&only_by[..k]) {
        *total += count;
    }
    *sums = read;
}

/// A pass's per-lane counters: accepting sensors, and rows falsified only by
/// the lane's sensor (rows of four and five f64 vectors, `counts_alone`);
/// and its NaN rows.
struct Counters<const V: usize> {
    accepting: [__m256i; V],
    alone: [__m256i; V],
    invalid: u64,
}

/// Diagnoses `rows` into `out` (their rejecting-sensor counts), the counters
/// `c` and `only_by`; tells `read` each row read. Not inlined into
/// [`diagnose_rows`], whose blocks of candidates take `candidates_first`
/// (as `medium_avx2_short::diagnose_block`): in one function, float32 rows of
/// 33 and float64 rows of 17 not all candidates ran 0.82-0.87 times as fast
/// alone on a core (`benches/results-long-rows.txt`, "session 34").
///
/// # Safety
/// AVX2 and POPCNT are available; the rows are readable; `out.len() ==
/// rows.n`; `vectors::<T>(rows.k) == Some(V)`.
#[inline(never)]
#[target_feature(enable = "avx2,popcnt")]
unsafe fn diagnose_block<T: Prediction, const V: usize, S: RowsRead>(
    rows: Rows<T>,
    out: &mut [u32],
    (c, only_by): (&mut Counters<V>, &mut [u64; 257]),
    read: &mut S,
) {
    let (k, w) = (rows.k, T::W512 / 2);
    // The last vector ends where the row does (k >= w): a whole load, no
    // mask and no branch; its lanes also in the vector before are tested
    // twice (the same verdict) and counted from that vector only.
    let start = |v: usize| if v + 1 < V { v * w } else { k - w };
    // Rows of more than 64 lanes keep their string in a u128 (whose shifts
    // and counts take two instructions), the others in a u64; f32 rows of
    // more than 128 in four u64 words, each vector's bits in one word (see
    // `repeated`).
    let (two_words, four_words) = (V * w > 64 && V * w <= 128, V * w > 128);
    let row_lanes = u64::MAX >> (64 - k.min(64));
    let row_lanes2 = u128::MAX >> (128 - k.min(128));
    let row_lanes4: [u64; 4] = std::array::from_fn(|i| match k.saturating_sub(64 * i) {
        0 => 0,
        n if n >= 64 => u64::MAX,
        n => u64::MAX >> (64 - n),
    });
    // Four words: the last vector's bits past the vector before, shifted
    // down to the lane after it, so that every vector's bits start at a
    // multiple of `w` (a constant) and none straddles two words.
    let repeated = V * w - k;
    let alone_in_lanes = counts_alone::<T>(V);
    let pf = Prefetch::FIXED;
    // The intervals loaded once a block: read in the loop, they were loaded
    // again on every row (the compiler cannot tell the stores to `out` from
    // them). Alone on a core, rows of 9-64 sensors with diagnostics ran
    // 0.99-1.16 times as fast (AMD EPYC Zen 4; `benches/results-short-rows.txt`,
    // "session 30: the AVX2 intervals in registers").
    let lows: [T::V256; V] = std::array::from_fn(|v| T::load256(rows.intervals.0.add(start(v))));
    let highs: [T::V256; V] = std::array::from_fn(|v| T::load256(rows.intervals.1.add(start(v))));
    let (mut accepting, mut alone, mut invalid) = (c.accepting, c.alone, c.invalid);
    // f64: the even vector's accepting lanes, until the odd one's.
    let mut even = _mm256_setzero_si256();
    let mut p = rows.p;
    for n_out in out.iter_mut() {
        // Two sums: half the chain of additions.
        let (mut inside, mut inside2, mut inside4, mut sum) = (0u64, 0u128, [0u64; 4], [T::zero256(); 2]);
        // Each vector's accepting lanes, until the row's count is known.
        let mut yes_lanes = [_mm256_setzero_si256(); V];
        unrolled!(V, |v| {
            if v % 2 == 0 {
                // A line ahead every 64 bytes of the row.
                pf.line(p.wrapping_add(v * w));
            }
            let j = start(v);
            let x = T::load256(p.add(j));
            let yes = T::inside_lanes256(x, lows[v], highs[v]);
            if std::mem::size_of::<T>() == 8 {
                // f64: vectors 2q and 2q + 1 share counter q (see `pair_lanes`).
                if v % 2 == 0 {
                    even = yes;
                }
                if v % 2 == 1 || v + 1 == V {
                    let odd = if v % 2 == 1 { yes } else { _mm256_setzero_si256() };
                    accepting[v / 2] = _mm256_sub_epi32(accepting[v / 2], pair_lanes(even, odd));
                }
            } else {
                accepting[v] = count::<T>(accepting[v], yes);
            }
            if four_words {
                let bits = sign_bits::<T>(yes) >> if v + 1 < V { 0 } else { repeated };
                inside4[v * w / 64] |= u64::from(bits) << (v * w % 64);
            } else if two_words {
                inside2 |= u128::from(sign_bits::<T>(yes)) << j;
            } else {
                inside |= u64::from(sign_bits::<T>(yes)) << j;
            }
            yes_lanes[v] = yes;
            sum[v % 2] = T::add256(sum[v % 2], x);
        });
        read.rows_read(p.add(k) as *const u8);
        // The count and the lowest rejecting sensor (64, 128 or 256 if none).
        let (n, lowest) = if four_words {
            let rejects: [u64; 4] = std::array::from_fn(|i| !inside4[i] & row_lanes4[i]);
            let n = rejects.iter().map(|r| r.count_ones()).sum::<u32>();
            // The lowest word with a rejection, without a branch.
            let mut lowest = 256;
            for i in (0..4).rev() {
                lowest = if rejects[i] != 0 { 64 * i as u32 + rejects[i].trailing_zeros() } else { lowest };
            }
            (n, lowest)
        } else if two_words {
            let rejects = !inside2 & row_lanes2;
            (rejects.count_ones(), rejects.trailing_zeros())
        } else {
            let rejects = !inside & row_lanes;
            (rejects.count_ones(), rejects.trailing_zeros())
        };
        if alone_in_lanes {
            // The row's rejecting lanes if it has one rejecting sensor.
            let single = _mm256_set1_epi32(-i32::from(n == 1));
            unrolled!(V, |v| {
                let rejecting = _mm256_andnot_si256(yes_lanes[v], single);
                if std::mem::size_of::<T>() == 8 {
                    if v % 2 == 1 || v + 1 == V {
                        // Lanes of a vector past the row's are never read.
                        let even = _mm256_andnot_si256(yes_lanes[v - v % 2], single);
                        alone[v / 2] = _mm256_sub_epi32(alone[v / 2], pair_lanes(even, rejecting));
                    }
                } else {
                    alone[v] = _mm256_sub_epi32(alone[v], rejecting);
                }
            });
        } else {
            only_by[lowest as usize] += u64::from(n == 1);
        }
        // The row's sum is NaN iff a value is (or, rarely, infinities
        // cancel). Looked for inline: a call here, even never made, had
        // the counters stored and reloaded around it on every row.
        invalid += u64::from(
            T::nan256(T::add256(sum[0], sum[1])) != 0
                && std::slice::from_raw_parts(p, k).iter().any(|x| x.to_f64().is_nan()),
        );
        *n_out = n;
        // The view's bounds are checked when it is made: the next row starts
        // `stride` values on (wrapping past the last row, never read).
        p = p.wrapping_add(rows.stride);
    }
    (c.accepting, c.alone, c.invalid) = (accepting, alone, invalid);
}

/// `counter` plus one in each lane where `inside` is all ones (subtracting
/// -1): f32 counters, one per vector.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn count<T: Prediction>(counter: __m256i, inside: __m256i) -> __m256i {
    _mm256_sub_epi32(counter, inside)
}

/// The accepting lanes of two f64 vectors as one vector of 32-bit lanes:
/// lane 2e all ones iff lane e of `even` is, lane 2e + 1 iff lane e of
/// `odd` is (each 64-bit lane is all ones or all zeros, so either half
/// stands for it). Subtracted from one counter, two vectors cost one
/// counter register. With one counter per vector, rows of more than eight
/// f64 vectors (33-64 sensors) left too few of AVX2's 16 registers, and
/// the compiler kept vectors on the stack, loading and storing them on
/// every row (46 stack moves a row for rows of 50, 28 now); alone on a
/// core, f64 rows of 33 and 50 with diagnostics then ran 1.06-1.08 times
/// as fast, f32 rows (unchanged code) 0.99-1.01 (AMD EPYC Zen 4;
/// `benches/results-long-rows.txt`, "session 29: AVX2 f64 counters").
#[inline]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn pair_lanes(even: __m256i, odd: __m256i) -> __m256i {
    _mm256_blend_epi32::<0b1010_1010>(even, odd)
}

/// Each sensor's count of f64 vector `v`: counter `v / 2`, lanes
/// `2e + v % 2` (see [`pair_lanes`]).
///
/// # Safety
/// AVX2 is available.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn pair_counts<const V: usize>(accepting: &[__m256i; V], v: usize) -> [u64; 8] {
    let mut narrow = [0u32; 8];
    _mm256_storeu_si256(narrow.as_mut_ptr() as *mut __m256i, accepting[v / 2]);
    let mut lanes = [0u64; 8];
    for (e, lane) in lanes.iter_mut().take(4).enumerate() {
        *lane = u64::from(narrow[2 * e + v % 2]);
    }
    lanes
}

/// One bit per lane of `inside` (its sign bit).
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn sign_bits<T: Prediction>(inside: __m256i) -> u32 {
    if std::mem::size_of::<T>() == 8 {
        _mm256_movemask_pd(_mm256_castsi256_pd(inside)) as u32
    } else {
        _mm256_movemask_ps(_mm256_castsi256_ps(inside)) as u32
    }
}

/// Each of the `k` sensors' count in `counters` (counted per lane, as
/// `accepting` is): vector `v` holds sensors `v * w ..`, the last one
/// sensors `k - w ..`, of which those past the vector before are taken.
///
/// # Safety
/// AVX2 is available.
#[inline]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn sensor_counts<T: Prediction, const V: usize>(counters: &[__m256i; V], k: usize) -> [u64; 256] {
    let w = T::W512 / 2;
    let mut counts = [0u64; 256];
    for (v, acc) in counters.iter().enumerate() {
        let lanes = if std::mem::size_of::<T>() == 8 {
            pair_counts(counters, v)
        } else {
            let mut narrow = [0u32; 8];
            _mm256_storeu_si256(narrow.as_mut_ptr() as *mut __m256i, *acc);
            narrow.map(u64::from)
        };
        let (first, skip) = if v + 1 < V { (v * w, 0) } else { ((V - 1) * w, V * w - k) };
        for (count, &c) in counts[first..k].iter_mut().zip(&lanes[skip..w]) {
            *count = c;
        }
    }
    counts
}

/// Whether rows of `v` vectors count "falsified only by" in vector lanes
/// (`medium_avx2_short`): each row subtracts its rejecting lanes where it has
/// one rejecting sensor (a broadcast, then an and-not and a subtraction a
/// vector, no branch), rather than one add in memory per row at the row's
/// lowest rejecting sensor. That add, at an address known only once the
/// row is tested, chains the rows, and cost short rows a third of their
/// time: alone on a core, with diagnostics, f32 rows of 17 and 25 and f64
/// rows of 9 and 17 ran 1.22-1.57 times as fast in every case (every row a
/// candidate, 5 %, or half the rows rejected by one random sensor), and
/// through memory at 0.59-0.97 of the floor against 0.38-0.84 (AMD EPYC
/// Zen 4; `benches/results-short-rows.txt`, "session 30: falsified only
/// by"). Longer rows hide the chain behind their own work, and more
/// counters would not fit AVX2's 16 registers. A branch on the row's count
/// instead ran faster alone but slower through memory in the typical case.
pub(super) fn counts_alone<T: Prediction>(v: usize) -> bool {
    v <= if std::mem::size_of::<T>() == 8 { 5 } else { 4 }
}
