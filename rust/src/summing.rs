//! A checkpointed run's pass over its rows: every row falsified and added to
//! its block's checksum ([`crate::digest`]) once, while it is in cache.
//!
//! The vector kernels sum rows stored back to back themselves, in their own
//! pass:
//! - where a kernel reads the rows as whole 64-byte vectors (the periodic
//!   kernel for short rows, at AVX-512 and AVX2), each vector it loads is one
//!   group of the checksum, so it adds it to the sums as it compares it:
//!   nothing is read twice;
//! - where it reads a row, or sixteen rows, at a time (the other AVX-512
//!   kernels, the AVX2 long-row kernel), it adds each group once the rows
//!   read so far fill it, reloaded from L1 (`checksum::FletcherRows`).
//!
//! The additions fill gaps in the kernel's own work. Other rows (rows not
//! stored back to back, rows of up to eight sensors at AVX2 where `pext` is
//! slow, every row at the portable level) are summed right after the kernel
//! has read them, from L2.

use crate::candidates::BitSink;
use crate::digest::{self, add_groups, first_unit, Groups, Part, Value, BLOCK_ROWS, PIECE_ROWS, STEP_UNITS};
use crate::kernel::{self, Isa, Prediction, ScreenPlan, SensorBounds, Tally};
use crate::matrix::Matrix;

/// Rows a kernel call summed as it read them: rows `0..rows` of the call,
/// whose groups' lane sums are `sums` (no rows: nothing summed).
#[derive(Debug, Clone, Copy, Default)]
pub struct Summed {
    pub rows: usize,
    pub sums: Groups,
}

/// [`kernel::diagnose_bits_with`], summing the leading rows its kernel reads
/// (see the module docs). Row 0 of `m` must start a group of its block (see
/// [`part_after`]) for the sums to be the block's.
pub fn diagnose_bits_summed_with<T: Prediction>(
    isa: Isa,
    m: Matrix<'_, T>,
    b: &SensorBounds,
    counts: Option<&mut [u32]>,
    sink: &mut BitSink,
    tally: &mut Tally,
) -> Summed {
    assert!(m.cols() == b.len() && counts.as_ref().is_none_or(|c| c.len() == m.rows()));
    #[cfg(target_arch = "x86_64")]
    if isa != Isa::Portable && isa.supported() {
        use crate::simd::{avx2, avx512, checksum::{Fletcher, Fletcher2}};
        // SAFETY: the CPU runs the level (checked by `supported`).
        return unsafe {
            if isa == Isa::Avx512 {
                summed(Fletcher::new(), |f| avx512::diagnose_bits_summed(m, b, counts, sink, (tally, f)))
            } else {
                summed(Fletcher2::new(), |f| avx2::diagnose_bits_summed(m, b, counts, sink, (tally, f)))
            }
        };
    }
    kernel::diagnose_bits_with(isa, m, b, counts, sink, tally);
    Summed::default()
}

/// [`kernel::screen_bits_with`], summing as [`diagnose_bits_summed_with`].
pub fn screen_bits_summed_with<T: Prediction>(
    isa: Isa,
    m: Matrix<'_, T>,
    b: &SensorBounds,
    plan: &ScreenPlan,
    sink: &mut BitSink,
) -> Summed {
    assert!(m.cols() == b.len(), "one column per sensor");
    #[cfg(target_arch = "x86_64")]
    if isa != Isa::Portable && isa.supported() {
        use crate::simd::{avx2, avx512, checksum::{Fletcher, Fletcher2}};
        // SAFETY: the CPU runs the level (checked by `supported`).
        return unsafe {
            if isa == Isa::Avx512 {
                summed(Fletcher::new(), |f| avx512::screen_bits_summed(m, (b, plan), sink, f))
            } else {
                summed(Fletcher2::new(), |f| avx2::screen_bits_summed(m, (b, plan), sink, f))
            }
        };
    }
    kernel::screen_bits_with(isa, m, b, plan, sink);
    Summed::default()
}

/// The rows a summed kernel, run with the empty sums `sums`, summed and their lane sums.
///
/// # Safety
/// The sums' level is available.
#[cfg(target_arch = "x86_64")]
unsafe fn summed<F: crate::simd::checksum::GroupSums>(mut sums: F, kernel: impl FnOnce(&mut F) -> usize) -> Summed {
    let rows = kernel(&mut sums);
    // SAFETY: the level is available (the caller's contract).
    Summed { rows, sums: unsafe { sums.lane_sums() } }
}

/// Whether the summed kernels at `isa` sum rows `m` themselves (every row
/// but those after their last whole period or group), so that the rows need
/// not stay in cache for [`part_after`] to sum them.
pub fn kernel_sums<T: Prediction>(isa: Isa, m: Matrix<'_, T>, b: &SensorBounds) -> bool {
    #[cfg(target_arch = "x86_64")]
    if isa == Isa::Avx512 && isa.supported() {
        return crate::simd::avx512::kernel_sums(m);
    }
    #[cfg(target_arch = "x86_64")]
    if isa == Isa::Avx2 && isa.supported() {
        return crate::simd::avx2::kernel_sums(m, b);
    }
    let _ = (isa, m, b);
    false
}

/// Bytes of input summed right after the kernel has read them: small enough
/// to be still in L2 (1-2 MiB per core on current x86), large enough that
/// the kernel is called on long runs of rows. Measured on an AMD EPYC (Zen 4),
/// one thread, CPU time of falsifier + checksum over falsifier alone, median
/// of 24 cases, load average 2-4: 1.51-1.53 at 16 KiB (in L1, but the kernel then restarts
/// every ~200 short rows), 1.25-1.27 at 128 KiB, 1.30-1.35 per whole block.
const INTERLEAVE_BYTES: usize = 128 << 10;

/// [`digest::part`] of the rows of `m` (the first being instance
/// `first_row`), a piece at a time within a block: calls `kernel(r0, r1,
/// sum)` on rows `r0..r1` of `m` (every row once, in order), with `sum` true
/// when row `r0` starts a group of its block, so that the kernel may sum
/// leading rows itself (as [`diagnose_bits_summed_with`]; it must return
/// [`Summed::default`] otherwise); sums the rest. Pieces are
/// [`INTERLEAVE_BYTES`], or as long as the block where `kernel_sums` (as
/// [`kernel_sums`] says): a call of the kernel costs set-up and totals, and
/// the few rows left to sum are the last it read.
pub fn part_after<T: Value>(
    m: Matrix<'_, T>,
    first_row: u64,
    buf: &mut Vec<T>,
    kernel_sums: bool,
    mut kernel: impl FnMut(usize, usize, bool) -> Summed,
) -> Part {
    let isa = Isa::detect();
    let (cols, row_bytes) = (m.cols(), (m.cols() * std::mem::size_of::<T>()).max(1));
    let step = if kernel_sums {
        BLOCK_ROWS
    } else {
        (INTERLEAVE_BYTES / row_bytes).clamp(16, PIECE_ROWS) / 16 * 16
    };
    let block = |row: u64| row / BLOCK_ROWS as u64;
    let mut p = Part::default();
    let mut r = 0;
    while r < m.rows() {
        let row = first_row + r as u64;
        let in_block = (row % BLOCK_ROWS as u64) as usize;
        // A piece within one block (its sums are that block's), and one that
        // starts off a group only as far as the next row that starts one, so
        // that the pieces after it start on groups too (`step` is a multiple
        // of 16 rows) and their kernel may sum them: a chunk may start
        // anywhere in a block.
        let u0 = first_unit::<T>(in_block, cols);
        let to_group = (0..STEP_UNITS as usize)
            .find(|&j| first_unit::<T>(in_block + j, cols).is_multiple_of(STEP_UNITS))
            .unwrap_or(step);
        let e = (r + step).min(m.rows()).min(r + BLOCK_ROWS - in_block);
        let e = if to_group > 0 { e.min(r + to_group) } else { e };
        let on_group = u0.is_multiple_of(STEP_UNITS);
        let summed = kernel(r, e, on_group);
        assert!(summed.rows <= e - r && (summed.rows == 0 || on_group));
        let s = if block(row) == block(first_row) {
            &mut p.first
        } else {
            &mut p.second
        };
        if summed.rows > 0 {
            // The kernel read whole vectors: `rows * cols` values fill whole groups.
            let units = first_unit::<T>(summed.rows, cols);
            assert!(units.is_multiple_of(STEP_UNITS));
            add_groups(s, &summed.sums, (units / STEP_UNITS) as usize, u0 / STEP_UNITS);
        }
        let rest = digest::part_with(
            isa,
            m.slice_rows(r + summed.rows, e),
            row + summed.rows as u64,
            buf,
        );
        s.add(&rest.first); // (rest.second is empty: the piece lies in one block)
        r = e;
    }
    p
}

#[cfg(test)]
#[path = "summing_tests.rs"]
mod tests;
