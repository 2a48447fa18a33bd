//! The short-row AVX2 kernel against the portable one, where its shortcuts
//! could go wrong: 16-bit counters over more rows than they hold, and NaN
//! looked for once a block of rows; and the blocks of candidates told apart
//! first, in it and in `medium_avx2`'s loop of longer rows.

use super::BLOCK_ROWS;
use crate::kernel::{diagnose_with, Isa, Prediction, SensorBounds, Tally};
use crate::matrix::Matrix;
use crate::simd::checksum::NoSums;
use crate::simd::medium_avx2::{diagnose_in_passes, vectors};

/// `medium_avx2`'s diagnostics (flushed every `pass_rows` rows; the short-row
/// kernel flushes at least every 65,535) on `m` equal the portable kernel's:
/// counts, tally, invalid rows; `short` says which kernel the width takes.
fn check<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, (pass_rows, short): (usize, bool), what: &str) -> Tally {
    let (rows, k) = (m.rows(), m.cols());
    let (mut want, mut tw) = (vec![0u32; rows], Tally::zeros(k));
    diagnose_with(Isa::Portable, m, b, &mut want, &mut tw);
    let (mut got, mut t) = (vec![0u32; rows], Tally::zeros(k));
    assert_eq!(super::takes::<T>(vectors::<T>(k).unwrap()), short, "{what}: which kernel");
    // SAFETY: AVX2 and POPCNT are available (checked by the callers), rows
    // are contiguous, and `vectors` takes the width (checked above).
    unsafe { diagnose_in_passes(m, b, &mut got, (&mut t, &mut NoSums), pass_rows) };
    assert_eq!((&got, &t), (&want, &tw), "{what}, {}", std::any::type_name::<T>());
    tw
}

/// Widths of every vector count the kernel takes: f32 rows of 9, 17 and 31
/// (two to four vectors), f64 rows of 9, 11 and 12 (three).
const F32_WIDTHS: [usize; 3] = [9, 17, 31];
const F64_WIDTHS: [usize; 3] = [9, 11, 12];
/// Widths `medium_avx2`'s own loop takes: f32 rows of five to eight vectors,
/// f64 rows of four to sixteen (four and five count "falsified only by" in
/// lanes).
const F32_LONGER: [usize; 3] = [33, 50, 64];
const F64_LONGER: [usize; 4] = [13, 17, 33, 64];

/// 140,000 rows, in one pass of the kernel's own length (65,535 rows): sensor
/// 0 rejects nine rows in ten alone (its "falsified only by" count, the
/// counters' high halves, passes 65,535 in a pass of 1 << 20), the other
/// sensors accept nearly every row (their acceptances, the low halves, pass it
/// too); every tenth row is rejected by another sensor alone, by two, or is NaN.
#[test]
fn counts_survive_more_rows_than_sixteen_bits_hold() {
    if !Isa::Avx2.supported() {
        return; // the level does not run here
    }
    let short = true;
    for (k, f64_rows) in F32_WIDTHS.map(|k| (k, false)).into_iter().chain(F64_WIDTHS.map(|k| (k, true))) {
        let rows = 140_000;
        let b = SensorBounds::new(&vec![0.0; k], &vec![-1.0; k], &vec![1.0; k]).unwrap();
        let mut data = vec![0.25f64; rows * k];
        for (r, row) in data.chunks_exact_mut(k).enumerate() {
            match (r % 10, r / 10 % 4) {
                (0, 0) => row[r / 40 % k] = 3.0,
                (0, 1) => (row[1], row[k - 1]) = (-3.0, 3.0),
                (0, 2) => row[k / 2] = f64::NAN,
                (0, _) => {}
                _ => row[0] = 2.0,
            }
        }
        let what = format!("rows of {k}");
        let tw = if f64_rows {
            check(Matrix::row_major(&data, rows, k).unwrap(), &b, (1 << 20, short), &what)
        } else {
            let data32: Vec<f32> = data.iter().map(|&v| v as f32).collect();
            check(Matrix::row_major(&data32, rows, k).unwrap(), &b, (1 << 20, short), &what)
        };
        assert!(tw.only_by[0] > u16::MAX as u64 && rows as u64 - tw.per_sensor[2] > u16::MAX as u64, "{what}");
        assert_eq!(tw.invalid, rows as u64 / 40, "{what}");
    }
}

/// NaN is looked for where a block of rows sums to NaN: NaN rows at the
/// blocks' edges and in a short last block are each counted once; +inf and
/// -inf in two rows of one block (a NaN sum, no NaN value) count none; and
/// passes that end inside a block (flushed every 100 rows) change nothing.
#[test]
fn nan_rows_are_counted_once_a_block() {
    if !Isa::Avx2.supported() {
        return; // the level does not run here
    }
    let short = true;
    for (k, f64_rows) in F32_WIDTHS.map(|k| (k, false)).into_iter().chain(F64_WIDTHS.map(|k| (k, true))) {
        let rows = BLOCK_ROWS * 3 + 7;
        let b = SensorBounds::new(&vec![0.0; k], &vec![-1.0; k], &vec![1.0; k]).unwrap();
        let mut state = 0x5EED_0F_B10C_u64 ^ k as u64;
        let mut data: Vec<f64> = (0..rows * k).map(|_| 2.2 * (crate::testing::uniform(&mut state) - 0.5)).collect();
        let b0 = BLOCK_ROWS;
        let nan_rows = [0usize, b0 - 1, b0, 2 * b0 - 1, 2 * b0, 2 * b0 + 50, rows - 1];
        for (i, &r) in nan_rows.iter().enumerate() {
            data[r * k + i % k] = f64::NAN;
        }
        // Infinities that cancel in one lane of a block's sum.
        (data[(b0 + 2) * k + 3], data[(b0 + 12) * k + 3]) = (f64::INFINITY, f64::NEG_INFINITY);
        let what = format!("rows of {k}");
        for pass_rows in [100, 1 << 20] {
            let tw = if f64_rows {
                check(Matrix::row_major(&data, rows, k).unwrap(), &b, (pass_rows, short), &what)
            } else {
                let data32: Vec<f32> = data.iter().map(|&v| v as f32).collect();
                check(Matrix::row_major(&data32, rows, k).unwrap(), &b, (pass_rows, short), &what)
            };
            assert_eq!(tw.invalid, nan_rows.len() as u64, "{what}");
        }
    }
}

/// After a block of candidates the next block is tested for its verdicts
/// first, and diagnosed only if a row is rejected: runs of candidates of
/// every length from 1 to 3 blocks and a half, each ended by one rejected
/// row (by one sensor, by two, by a NaN), so a rejected row falls at every
/// place in a block, in the first four rows of a call and not; and calls that
/// start with candidates and with a rejected row; in passes of 300 rows and of
/// the kernel's own length; in the short-row kernel and in `medium_avx2`'s
/// loop of longer rows.
#[test]
fn blocks_of_candidates_lose_no_rejected_row() {
    if !Isa::Avx2.supported() {
        return; // the level does not run here
    }
    let short = F32_WIDTHS.map(|k| (k, false, true)).into_iter().chain(F64_WIDTHS.map(|k| (k, true, true)));
    let longer = F32_LONGER.map(|k| (k, false, false)).into_iter().chain(F64_LONGER.map(|k| (k, true, false)));
    for (k, f64_rows, short) in short.chain(longer) {
        let b = SensorBounds::new(&vec![0.0; k], &vec![-1.0; k], &vec![1.0; k]).unwrap();
        let mut state = 0xB10C_CA4D_u64 ^ k as u64;
        let mut data = Vec::new();
        let mut rejected = 0;
        for run in (1..BLOCK_ROWS * 7 / 2).step_by(37).chain([BLOCK_ROWS - 1, BLOCK_ROWS, BLOCK_ROWS + 1]) {
            for _ in 0..run {
                data.extend((0..k).map(|_| 1.8 * (crate::testing::uniform(&mut state) - 0.5)));
            }
            let mut row = vec![0.5; k];
            match rejected % 3 {
                0 => row[rejected % k] = -1.5,
                1 => (row[0], row[k - 1]) = (1.5, 1.5),
                _ => row[k / 3] = f64::NAN,
            }
            data.extend(row);
            rejected += 1;
        }
        let rows = data.len() / k;
        for skip in [0, rows - BLOCK_ROWS * 2 - 3] {
            let part = &data[skip * k..];
            let what = format!("rows of {k} from row {skip}");
            for pass_rows in [300, 1 << 20] {
                let tw = if f64_rows {
                    check(Matrix::row_major(part, rows - skip, k).unwrap(), &b, (pass_rows, short), &what)
                } else {
                    let data32: Vec<f32> = part.iter().map(|&v| v as f32).collect();
                    check(Matrix::row_major(&data32, rows - skip, k).unwrap(), &b, (pass_rows, short), &what)
                };
                assert!(tw.only_by.iter().sum::<u64>() > 0 && tw.invalid > 0, "{what}");
            }
        }
    }
}
