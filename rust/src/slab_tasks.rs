//! The tasks of a slab: its rows cut into runs of kernel blocks, shared by
//! the pool's threads, each task's verdicts, candidate bits and checksum
//! sums written into its own slots ([`crate::falsifier`] runs the slabs).

use crate::candidates::{count_bits, BitSink};
use crate::digest::{Part, Value};
use crate::falsifier::BLOCK_ROWS;
use crate::kernel::{diagnose_bits_with, screen_bits_with, Isa, Prediction, ScreenPlan, SensorBounds, Tally};
use crate::matrix::Matrix;
use crate::summing::{self, Summed};
use rayon::prelude::*;

/// When summing: the instance index of the slab's first row; and one slot
/// per block of the slab for its checksum sums (left alone when not summing).
pub(crate) type Summing<'b> = (Option<u64>, &'b mut [Part]);

/// Rows of a slab, their rejecting-sensor counts (empty when not kept),
/// each block's candidate count, and the slab's candidate bits
/// (`BLOCK_ROWS / 64` words a block).
pub(crate) type Verdicts<'a> = (usize, &'a mut [u32], &'a mut [usize], &'a mut [u64]);

/// One task: its index, its rows' counts (empty when not kept), its blocks'
/// candidate counts, its candidate words and its blocks' checksum slots.
type Task<'a> = (usize, (((&'a mut [u32], &'a mut [usize]), &'a mut [u64]), &'a mut [Part]));

/// Bytes of predictions a task reads, at least: each task pays a fixed cost
/// (rayon's hand-over, the kernel's set-up, the diagnostics' per-sensor
/// totals). A block of 1,024 short rows (20 KB for f32 rows of 5) did not
/// amortise it (`cargo bench -- falsify_short`), nor did 128 KB, about 5 µs
/// of reading a thread: through `falsify`, 1 MiB tasks ran short rows with
/// diagnostics at 0.95-1.02 of the read floor where 128 KiB gave 0.86-0.98
/// (AMD EPYC, Zen 4, 2 cores; `docs/performance.md`, "session 25").
pub(crate) const TASK_BYTES: usize = 1 << 20;

/// Blocks per task for rows of `n_m` values of `T`: enough for
/// [`TASK_BYTES`]. A task of 64 blocks or fewer lies in at most two
/// checksum blocks, which one [`Part`] holds, so summing tasks are as long
/// (one block each, until session 17, paid the per-call cost every 1,024
/// rows: the in-pass checksum cost 1.2 times the falsifier alone from cache).
pub(crate) fn blocks_per_task<T>(n_m: usize) -> usize {
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
pub(crate) fn diagnose_parallel<T: Prediction + Value>(
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
    // Split down to single tasks: rayon otherwise hands each thread pieces
    // of a quarter slab, and a thread done with its own waited for the
    // other's last piece at every slab's end (through `falsify` on a 2-core
    // VM: one thread busy 10 % less than the other; 0.5-3 % faster now).
    tasks
        .into_par_iter()
        .with_max_len(1)
        .fold(|| (Tally::zeros(n_m), Vec::new()), task)
        .map(|(t, _)| t)
        .reduce(|| Tally::zeros(n_m), Tally::merge)
}

/// [`diagnose_parallel`] without diagnostics.
pub(crate) fn screen_parallel<T: Prediction + Value>(
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
        tasks.into_par_iter().with_max_len(1).for_each_init(Vec::new, task); // as in `diagnose_parallel`
    }
}
