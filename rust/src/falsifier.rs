//! Streaming accumulator: feed it chunks of model-instance predictions in
//! order and it keeps the candidate model set and the diagnostics, so memory
//! grows with the number of candidates, not the number of instances.
//!
//! Work inside a chunk is split into slabs (32 MB of predictions). The
//! caller's `stop` check runs between slabs on the calling thread, which is how
//! the Python layer delivers Ctrl-C; an interrupted chunk leaves no trace.
//!
//! A checkpointed run also needs the checksum of every row (see
//! [`crate::digest`]); `update_digested` sums each kernel block's rows in the
//! task that screens them ([`crate::summing`]): in the kernel's own pass
//! where it can, else right after, while they are in that core's cache,
//! instead of reading the whole chunk from memory again.

use crate::candidates::{count_bits, reserve, BitSink, CandidateSet, Segment};
use crate::digest::{Part, Pending, RowDigest, Value, PIECE_ROWS};
use crate::error::{EdmfError, Result};
use crate::kernel::{diagnose_bits_with, screen_bits_with, Isa, Prediction, ScreenPlan, SensorBounds, Tally};
use crate::matrix::Matrix;
use crate::summing::{self, Summed};
use crate::thresholds::Thresholds;
use crate::violations::Violations;
use rayon::prelude::*;
use rayon::ThreadPool;

/// Rows of a block, the unit of candidate counts and checksum parts; a rayon
/// task takes one or more (see [`TASK_BYTES`]).
const BLOCK_ROWS: usize = 1024;
/// Bytes of predictions per slab between two `stop` checks: a few
/// milliseconds of work, large enough that handing each slab to the pool
/// costs little. In bytes, not values, so f32 rows pay that hand-over as
/// rarely as f64 ones: it took 20-41 µs a slab, against about 0.5 ms to read
/// 32 MB at 70 GB/s (one thread, AMD EPYC (Zen 4), `cargo bench --
/// falsify_short` with slabs of 2^18 values; see `docs/performance.md`).
const SLAB_BYTES: usize = 32 << 20;
/// Predictions in a slab below which it runs on the calling thread: waking
/// the pool's threads for it costs more than sharing the work (a hand-over
/// to a sleeping pool took 0.1-0.2 ms on a 2-core VM, AMD EPYC: `falsify`
/// of 100 rows of 10 sensors spent 0.24 ms of its 0.31 ms there). The
/// blocks and their results are the same either way.
const SERIAL_ELEMENTS: usize = 1 << 16;
/// Rows diagnosed to learn the screening order: enough to rank the sensors,
/// few enough that the slower full visit costs nothing measurable.
const LEARN_ROWS: usize = 16 * BLOCK_ROWS;
// Kernel block k of a chunk is the digest's piece k (same rows).
const _: () = assert!(BLOCK_ROWS == PIECE_ROWS);

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Visit every sensor of every instance: candidates plus per-sensor counts,
    /// per-instance violation counts and invalid instances.
    Diagnose,
    /// Candidates only (no per-sensor counts, no per-instance values): fastest.
    Screen,
}

#[derive(Debug)]
pub struct Falsifier {
    bounds: SensorBounds,
    /// Visiting order for `Screen`, learned from the first slab.
    screen_plan: Option<ScreenPlan>,
    mode: Mode,
    keep_violations: bool,
    n_instances: u64,
    tally: Tally,
    candidates: CandidateSet,
    /// Per-instance counts, one to four bytes each (see `violations`).
    violations: Violations,
    /// Per-row verdicts of the current slab, reused from slab to slab.
    scratch: Vec<u32>,
    /// Candidate bits of the current slab (`BLOCK_ROWS / 64` words a block),
    /// written by each block's task while its verdicts are in L1.
    slab_words: Vec<u64>,
    /// Candidates found by each block of the current slab.
    block_counts: Vec<usize>,
    /// Checksum sums of each block of the current slab (`update_digested`).
    block_parts: Vec<Part>,
}

impl Falsifier {
    pub fn new(measured: &[f64], thresholds: &Thresholds, mode: Mode, keep_violations: bool) -> Result<Self> {
        let n_m = thresholds.n_sensors();
        if measured.len() != n_m {
            return Err(EdmfError::invalid(
                "measurements",
                format!("one value per sensor ({n_m} thresholds), got {}", measured.len()),
            ));
        }
        if let Some((i, y)) = measured.iter().enumerate().find(|(_, y)| !y.is_finite()) {
            return Err(EdmfError::invalid(
                "measurements",
                format!("finite values, got {y} at sensor {i}"),
            ));
        }
        if keep_violations && mode == Mode::Screen {
            return Err(EdmfError::invalid(
                "keep_violations",
                "False when diagnostics are off (screening counts no violations)",
            ));
        }
        Ok(Falsifier {
            bounds: SensorBounds::new(measured, thresholds.low(), thresholds.high())?,
            screen_plan: None,
            mode,
            keep_violations,
            n_instances: 0,
            tally: Tally::zeros(n_m),
            candidates: CandidateSet::new(),
            violations: Violations::for_sensors(n_m),
            scratch: Vec::new(),
            slab_words: Vec::new(),
            block_counts: Vec::new(),
            block_parts: Vec::new(),
        })
    }

    pub fn n_sensors(&self) -> usize {
        self.bounds.len()
    }

    pub fn n_instances(&self) -> u64 {
        self.n_instances
    }

    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The candidates so far (a bitmap where they are dense).
    pub fn candidates(&self) -> &CandidateSet {
        &self.candidates
    }

    /// Number of candidates so far.
    pub fn n_candidates(&self) -> u64 {
        self.candidates.len()
    }

    /// Global indices of the candidates at instance `since` or later,
    /// ascending (derived from the stored set: 8 bytes per index).
    pub fn candidates_since(&self, since: u64) -> Vec<u64> {
        self.candidates.indices_since(since)
    }

    /// The candidates among instances `since .. since + rows` as a bitmap
    /// (see [`CandidateSet::bitmap`]).
    pub fn candidate_bitmap(&self, since: u64, rows: u64) -> Vec<u64> {
        self.candidates.bitmap(since, rows)
    }

    /// Takes the candidates, leaving the accumulator without them.
    pub fn take_candidates(&mut self) -> Vec<Segment> {
        self.candidates.take()
    }

    /// Per-sensor diagnostics; `None` when screening (not every sensor is visited).
    pub fn tally(&self) -> Option<&Tally> {
        (self.mode == Mode::Diagnose).then_some(&self.tally)
    }

    /// Rejecting-sensor count of every instance so far, if kept.
    pub fn violations(&self) -> Result<Option<Vec<u32>>> {
        self.keep_violations.then(|| self.violations.to_u32()).transpose()
    }

    /// Takes the stored per-instance counts, leaving the accumulator without them.
    pub fn take_violations(&mut self) -> Result<Option<Vec<u32>>> {
        self.keep_violations.then(|| self.violations.take_u32()).transpose()
    }

    /// Falsifies the next `chunk` of instances (rows; one column per sensor).
    pub fn update<T: Prediction + Value>(
        &mut self,
        chunk: Matrix<'_, T>,
        pool: &ThreadPool,
        stop: &mut dyn FnMut() -> bool,
    ) -> Result<()> {
        self.update_with(chunk, pool, stop, None)
    }

    /// Like [`update`](Self::update), and feeds the chunk to `digest` in the
    /// same pass (the digest is the one `digest.update(chunk)` gives, whatever
    /// the chunking, threads or dtype). An interrupted chunk leaves no trace
    /// in the digest either.
    pub fn update_digested<T: Prediction + Value>(
        &mut self,
        chunk: Matrix<'_, T>,
        pool: &ThreadPool,
        stop: &mut dyn FnMut() -> bool,
        digest: &mut RowDigest,
    ) -> Result<()> {
        self.update_with(chunk, pool, stop, Some(digest))
    }

    fn update_with<T: Prediction + Value>(
        &mut self,
        chunk: Matrix<'_, T>,
        pool: &ThreadPool,
        stop: &mut dyn FnMut() -> bool,
        digest: Option<&mut RowDigest>,
    ) -> Result<()> {
        let n_m = self.n_sensors();
        if chunk.cols() != n_m {
            return Err(EdmfError::invalid(
                "predictions",
                format!(
                    "{n_m} columns (one per sensor), got a chunk of width {}",
                    chunk.cols()
                ),
            ));
        }
        let mut pending = match &digest {
            Some(d) => {
                d.check_width(chunk.cols())?; // before any work: a chunk is taken whole or not at all
                Some(d.begin(chunk.rows())?)
            }
            None => None,
        };
        let kept_violations = self.violations.len();
        match self.falsify_slabs(chunk, pool, stop, pending.as_mut()) {
            Ok(chunk_tally) => {
                self.tally.add(&chunk_tally);
                self.n_instances += chunk.rows() as u64;
                if let (Some(d), Some(p)) = (digest, pending) {
                    d.commit(chunk.cols(), p)?; // width checked above: cannot fail
                }
                Ok(())
            }
            Err(e) => {
                // Whatever stopped the chunk (Ctrl-C, out of memory), it leaves
                // no trace: callers resume from the chunk's first row.
                self.candidates.truncate(self.n_instances);
                self.violations.truncate(kept_violations);
                Err(e)
            }
        }
    }

    /// The slabs of one chunk; the chunk's tally, or the error that stopped it.
    fn falsify_slabs<T: Prediction + Value>(
        &mut self,
        chunk: Matrix<'_, T>,
        pool: &ThreadPool,
        stop: &mut dyn FnMut() -> bool,
        mut pending: Option<&mut Pending>,
    ) -> Result<Tally> {
        let (rows, n_m) = (chunk.rows(), self.n_sensors());
        // Whole rounds of tasks for the pool's threads: with an odd count
        // one thread works alone at the end of every slab (rows of 200
        // sensors: 21 blocks a slab, the last one, about 5 % of the work,
        // on one of 2 threads while the other waits).
        let threads = pool.current_num_threads().max(1);
        let per_task = blocks_per_task::<T>(n_m);
        let task_rows = per_task * BLOCK_ROWS;
        let slab_values = SLAB_BYTES / std::mem::size_of::<T>();
        let slab_rows = (slab_values / n_m).div_ceil(task_rows).max(1).next_multiple_of(threads) * task_rows;
        let mut chunk_tally = Tally::zeros(n_m);
        let mut first = 0;
        while first < rows {
            // Until the screening order is known, a short slab is diagnosed to learn it.
            let learning = self.mode == Mode::Screen && self.screen_plan.is_none();
            let last = (first
                + if learning {
                    LEARN_ROWS.min(slab_rows)
                } else {
                    slab_rows
                })
            .min(rows);
            let slab = chunk.slice_rows(first, last);
            // Per-row counts only when kept: else the kernels write candidate bits alone.
            let keep = self.keep_violations && self.mode == Mode::Diagnose;
            if keep && self.scratch.len() < last - first {
                reserve(&mut self.scratch, last - first, "per-instance violation counts")?;
                self.scratch.resize(last - first, 0);
            }
            let out = &mut self.scratch[..if keep { last - first } else { 0 }];
            let slab_len = last - first;
            let n_blocks = slab_len.div_ceil(BLOCK_ROWS);
            self.block_counts.resize(n_blocks, 0);
            let n_words = slab_len.div_ceil(64);
            let have = self.slab_words.len();
            if have < n_words {
                reserve(&mut self.slab_words, n_words - have, "candidate bitmap")?;
                self.slab_words.resize(n_words, 0);
            }
            let words = &mut self.slab_words[..n_words];
            self.block_parts.resize(n_blocks, Part::default());
            let counts = &mut self.block_counts[..];
            // Slabs start on block boundaries: block k of this slab is rows first + k * BLOCK_ROWS ..
            let summing = (
                pending.as_ref().map(|p| p.first_row() + first as u64),
                &mut self.block_parts[..n_blocks],
            );
            let base = self.n_instances + first as u64;
            let (bounds, plan) = (&self.bounds, &self.screen_plan);
            let verdicts = (slab_len, &mut *out, &mut *counts, &mut *words);
            // One hand-over to the pool per slab: waking it costs more than a
            // slab's scheduling inside it; a small slab stays on this thread.
            let serial = slab_len * n_m < SERIAL_ELEMENTS;
            // A task for every thread in a short slab (a small chunk, many threads).
            let group = if serial { per_task } else { per_task.min((n_blocks / threads).max(1)) };
            let run = || match (self.mode, plan) {
                (Mode::Screen, Some(plan)) => {
                    screen_parallel(slab, bounds, plan, verdicts, (summing, group), serial);
                    None
                }
                _ => Some(diagnose_parallel(slab, bounds, verdicts, (summing, group), serial)),
            };
            let tally = if serial { run() } else { pool.install(run) };
            let found = counts.iter().sum::<usize>() as u64;
            self.candidates.append(base, slab_len as u64, words, found)?;
            if let Some(p) = pending.as_deref_mut() {
                for (k, part) in self.block_parts[..n_blocks].iter().enumerate() {
                    p.add(first + k * BLOCK_ROWS, part);
                }
            }
            match (self.mode, tally) {
                (Mode::Diagnose, Some(t)) => {
                    chunk_tally.add(&t);
                    if keep {
                        self.violations.extend(out)?;
                    }
                }
                // Learn which sensors reject most; candidates do not depend on it.
                (Mode::Screen, Some(t)) => {
                    self.screen_plan = Some(ScreenPlan::new(&self.bounds, &t.per_sensor))
                }
                _ => {}
            }
            first = last;
            if stop() {
                return Err(EdmfError::Interrupted);
            }
        }
        Ok(chunk_tally)
    }
}

/// When summing: the instance index of the slab's first row; and one slot
/// per block of the slab for its checksum sums (left alone when not summing).
type Summing<'b> = (Option<u64>, &'b mut [Part]);

/// Rows of a slab, their rejecting-sensor counts (empty when not kept),
/// each block's candidate count, and the slab's candidate bits
/// (`BLOCK_ROWS / 64` words a block).
type Verdicts<'a> = (usize, &'a mut [u32], &'a mut [usize], &'a mut [u64]);

/// One task: its index, its rows' counts (empty when not kept), its blocks'
/// candidate counts, its candidate words and its blocks' checksum slots.
type Task<'a> = (usize, (((&'a mut [u32], &'a mut [usize]), &'a mut [u64]), &'a mut [Part]));

/// Bytes of predictions a task reads, at least: the kernels pay a fixed cost
/// per call (set-up, and the diagnostics' per-sensor totals), which a block
/// of 1,024 short rows (20 KB for f32 rows of 5) does not amortise (`cargo
/// bench -- falsify_short`; see `docs/performance.md`).
const TASK_BYTES: usize = 128 << 10;

/// Blocks per task for rows of `n_m` values of `T`: enough for
/// [`TASK_BYTES`]. A task of 64 blocks or fewer lies in at most two
/// checksum blocks, which one [`Part`] holds, so summing tasks are as long
/// (one block each, until session 17, paid the per-call cost every 1,024
/// rows: the in-pass checksum cost 1.2 times the falsifier alone from cache).
fn blocks_per_task<T>(n_m: usize) -> usize {
    let block_bytes = BLOCK_ROWS * n_m.max(1) * std::mem::size_of::<T>();
    TASK_BYTES.div_ceil(block_bytes).clamp(1, 64)
}

/// The tasks of a slab, `group` blocks each (see [`Task`]).
fn tasks<'a>(verdicts: Verdicts<'a>, slots: &'a mut [Part], group: usize) -> Vec<Task<'a>> {
    let (rows, out, counts, words) = verdicts;
    let task_rows = group * BLOCK_ROWS;
    // Counts, when kept, one task's rows a task like the rest; else empty slices.
    let n_tasks = rows.div_ceil(task_rows);
    let mut outs: Vec<&'a mut [u32]> = if out.is_empty() {
        Vec::new()
    } else {
        out.chunks_mut(task_rows).collect()
    };
    outs.resize_with(n_tasks, Default::default);
    outs.into_iter()
        .zip(counts.chunks_mut(group))
        .zip(words.chunks_mut(task_rows / 64))
        .zip(slots.chunks_mut(group))
        .enumerate()
        .collect()
}

/// Each block's candidate count from its words.
fn count_blocks(counts: &mut [usize], words: &[u64]) {
    for (count, w) in counts.iter_mut().zip(words.chunks(BLOCK_ROWS / 64)) {
        *count = count_bits(w);
    }
}

/// Runs in the caller's pool (on this thread when `serial`), in tasks of
/// `group` blocks; each block's candidate count into
/// `counts`, and, when summing, the checksum sums of its rows into its slot.
fn diagnose_parallel<T: Prediction + Value>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    verdicts: Verdicts<'_>,
    (summing, group): (Summing<'_>, usize),
    serial: bool,
) -> Tally {
    let (n_m, isa, rows) = (b.len(), Isa::detect(), verdicts.0);
    let (sum_from, slots) = summing;
    let task = |(mut t, mut buf): (Tally, Vec<T>), (k, (((o, counts), w), slots)): Task<'_>| {
        let first = k * group * BLOCK_ROWS;
        let span = m.slice_rows(first, (first + group * BLOCK_ROWS).min(rows));
        w.fill(0);
        let keep = !o.is_empty();
        match sum_from {
            // Summed by the kernel as it reads them, or right after (in L2).
            Some(base) => {
                // The task's part in its first slot, the others empty (a task's
                // rows lie in at most two checksum blocks).
                slots.fill(Part::default());
                let fused = summing::kernel_sums(isa, span, b);
                slots[0] = summing::part_after(span, base + first as u64, &mut buf, fused, |r0, r1, sum| {
                    let mut sink = BitSink::new(w, r0);
                    let (c, rows) = (if keep { Some(&mut o[r0..r1]) } else { None }, span.slice_rows(r0, r1));
                    let summed = if sum {
                        summing::diagnose_bits_summed_with(isa, rows, b, c, &mut sink, &mut t)
                    } else {
                        diagnose_bits_with(isa, rows, b, c, &mut sink, &mut t);
                        Summed::default()
                    };
                    sink.finish();
                    summed
                })
            }
            None => {
                let mut sink = BitSink::new(w, 0);
                let c = if keep { Some(&mut o[..]) } else { None };
                diagnose_bits_with(isa, span, b, c, &mut sink, &mut t);
                sink.finish();
            }
        }
        count_blocks(counts, w);
        (t, buf)
    };
    let tasks = tasks(verdicts, slots, group);
    if serial {
        return tasks.into_iter().fold((Tally::zeros(n_m), Vec::new()), task).0;
    }
    tasks
        .into_par_iter()
        .fold(|| (Tally::zeros(n_m), Vec::new()), task)
        .map(|(t, _)| t)
        .reduce(|| Tally::zeros(n_m), Tally::merge)
}

/// [`diagnose_parallel`] without diagnostics.
fn screen_parallel<T: Prediction + Value>(
    m: Matrix<'_, T>,
    b: &SensorBounds,
    plan: &ScreenPlan,
    verdicts: Verdicts<'_>,
    (summing, group): (Summing<'_>, usize),
    serial: bool,
) {
    let (isa, rows) = (Isa::detect(), verdicts.0);
    let (sum_from, slots) = summing;
    let task = |buf: &mut Vec<T>, (k, (((_, counts), w), slots)): Task<'_>| {
        let first = k * group * BLOCK_ROWS;
        let span = m.slice_rows(first, (first + group * BLOCK_ROWS).min(rows));
        w.fill(0);
        match sum_from {
            // As in `diagnose_parallel`.
            Some(base) => {
                slots.fill(Part::default());
                let fused = summing::kernel_sums(isa, span, b);
                slots[0] = summing::part_after(span, base + first as u64, buf, fused, |r0, r1, sum| {
                    let (mut sink, rows) = (BitSink::new(w, r0), span.slice_rows(r0, r1));
                    let summed = if sum {
                        summing::screen_bits_summed_with(isa, rows, b, plan, &mut sink)
                    } else {
                        screen_bits_with(isa, rows, b, plan, &mut sink);
                        Summed::default()
                    };
                    sink.finish();
                    summed
                })
            }
            None => {
                let mut sink = BitSink::new(w, 0);
                screen_bits_with(isa, span, b, plan, &mut sink);
                sink.finish();
            }
        }
        count_blocks(counts, w);
    };
    let tasks = tasks(verdicts, slots, group);
    if serial {
        let mut buf = Vec::new();
        tasks.into_iter().for_each(|t| task(&mut buf, t));
    } else {
        tasks.into_par_iter().for_each_init(Vec::new, task);
    }
}

#[cfg(test)]
#[path = "falsifier_tests.rs"]
mod tests;
