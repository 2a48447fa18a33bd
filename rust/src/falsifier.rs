//! Streaming accumulator: feed it chunks of model-instance predictions in
//! order and it keeps the candidate model set and the diagnostics, so memory
//! grows with the number of candidates, not the number of instances.
//!
//! Work inside a chunk is split into slabs (32 MB of predictions), each
//! shared by the pool's threads in tasks. A chunk of several slabs runs as one
//! job in the pool while the calling thread polls the caller's `stop` check,
//! which is how the Python layer delivers Ctrl-C; the job stops before its
//! next slab, and an interrupted chunk leaves no trace.
//!
//! A checkpointed run also needs the checksum of every row (see
//! [`crate::digest`]); `update_digested` sums each kernel block's rows in the
//! task that screens them ([`crate::summing`]): in the kernel's own pass
//! where it can, else right after, while they are in that core's cache,
//! instead of reading the whole chunk from memory again.

use crate::candidates::{reserve, CandidateSet, Segment};
use crate::digest::{Part, Pending, RowDigest, Value, PIECE_ROWS};
use crate::error::{EdmfError, Result};
use crate::kernel::{Prediction, ScreenPlan, SensorBounds, Tally};
use crate::matrix::Matrix;
use crate::polling::run_polling;
use crate::slab_tasks::{blocks_per_task, diagnose_parallel, screen_parallel};
use crate::thresholds::Thresholds;
use crate::violations::Violations;
use rayon::ThreadPool;
use std::sync::atomic::{AtomicBool, Ordering};

/// Rows of a block, the unit of candidate counts and checksum parts; a rayon
/// task takes one or more (see [`crate::slab_tasks::TASK_BYTES`]).
pub(crate) const BLOCK_ROWS: usize = 1024;
/// Bytes of predictions per slab: a few milliseconds of work, large enough
/// that sharing each slab among the pool's threads costs little (a chunk of
/// one slab is handed to the pool from the calling thread: it took 20-41 µs
/// a slab, against about 0.5 ms to read 32 MB at 70 GB/s; one thread, AMD
/// EPYC (Zen 4), `cargo bench -- falsify_short` with slabs of 2^18 values),
/// small enough for its per-row buffers (through `falsify`, slabs of 128 MB
/// took 0.992-1.220 times as long, the most for f32 rows of 5:
/// `benches/results-short-rows.txt`, "session 19: where the time went"). In
/// bytes, not values, so f32 rows are shared as rarely as f64 ones.
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
    ///
    /// A chunk of several slabs runs as one job in the pool while this
    /// thread only polls `stop` ([`run_polling`]): handing each slab to
    /// the pool from here and waiting for it kept each of the pool's threads
    /// idle 13-19 µs at a slab's start and 31-67 µs at its end on a 2-core VM
    /// (AMD EPYC; `benches/results-short-rows.txt`, "session 19: where the
    /// time went"), 5-10 % of reading 32 MB there. `stop` is also polled once
    /// the chunk is done, so a Ctrl-C during the call is never missed.
    fn falsify_slabs<T: Prediction + Value>(
        &mut self,
        chunk: Matrix<'_, T>,
        pool: &ThreadPool,
        stop: &mut dyn FnMut() -> bool,
        pending: Option<&mut Pending>,
    ) -> Result<Tally> {
        let cancel = AtomicBool::new(false);
        let result = if chunk.rows() <= self.first_slab_rows::<T>(pool) {
            self.slabs(chunk, pool, &cancel, pending)
        } else {
            let (this, flag) = (&mut *self, &cancel);
            run_polling(pool, flag, stop, move || this.slabs(chunk, pool, flag, pending))
                .unwrap_or(Err(EdmfError::Interrupted))
        };
        match result {
            // Done, but a Ctrl-C came meanwhile: the chunk goes too.
            Ok(_) if cancel.load(Ordering::Relaxed) || stop() => Err(EdmfError::Interrupted),
            done_or_error => done_or_error,
        }
    }

    /// Rows of a slab of `T` (see [`SLAB_BYTES`]), whole rounds of tasks for
    /// the pool's threads: with an odd count one thread works alone at the
    /// end of every slab (rows of 200 sensors: 21 blocks a slab, the last
    /// one, about 5 % of the work, on one of 2 threads while the other waits).
    fn slab_rows<T>(&self, pool: &ThreadPool) -> usize {
        let n_m = self.n_sensors();
        let threads = pool.current_num_threads().max(1);
        let task_rows = blocks_per_task::<T>(n_m) * BLOCK_ROWS;
        let slab_values = SLAB_BYTES / std::mem::size_of::<T>();
        (slab_values / n_m).div_ceil(task_rows).max(1).next_multiple_of(threads) * task_rows
    }

    /// Rows of the next slab: until the screening order is known, a short
    /// slab is diagnosed to learn it.
    fn first_slab_rows<T>(&self, pool: &ThreadPool) -> usize {
        let slab_rows = self.slab_rows::<T>(pool);
        if self.mode == Mode::Screen && self.screen_plan.is_none() {
            LEARN_ROWS.min(slab_rows)
        } else {
            slab_rows
        }
    }

    /// The slabs of a chunk one after the other, until done or `cancel`.
    fn slabs<T: Prediction + Value>(
        &mut self,
        chunk: Matrix<'_, T>,
        pool: &ThreadPool,
        cancel: &AtomicBool,
        mut pending: Option<&mut Pending>,
    ) -> Result<Tally> {
        let (rows, n_m) = (chunk.rows(), self.n_sensors());
        let threads = pool.current_num_threads().max(1);
        let per_task = blocks_per_task::<T>(n_m);
        let mut chunk_tally = Tally::zeros(n_m);
        let mut first = 0;
        while first < rows {
            if cancel.load(Ordering::Relaxed) {
                return Err(EdmfError::Interrupted);
            }
            let last = (first + self.first_slab_rows::<T>(pool)).min(rows);
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
        }
        Ok(chunk_tally)
    }
}

#[cfg(test)]
#[path = "falsifier_tests.rs"]
mod tests;
