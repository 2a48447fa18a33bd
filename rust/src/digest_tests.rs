//! The checksum's definition against its vector levels, its independence of
//! chunking, dtype and layout, and the accidental changes it must catch.

use super::*;
use crate::testing::uniform;

fn pool() -> ThreadPool {
    rayon::ThreadPoolBuilder::new().num_threads(3).build().unwrap()
}

fn random(n: usize, state: &mut u64) -> Vec<f64> {
    (0..n).map(|_| (uniform(state) - 0.5) * 1e3).collect()
}

/// Blocks and partial of `data` (row-major, `cols` wide) fed in chunks of `step` rows.
fn digest_in_chunks(data: &[f64], cols: usize, step: usize) -> (Vec<u128>, Option<u128>) {
    let rows = data.len() / cols;
    let all = Matrix::row_major(data, rows, cols).unwrap();
    let mut d = RowDigest::new();
    let p = pool();
    let mut s = 0;
    while s < rows {
        let e = (s + step).min(rows);
        d.update(all.slice_rows(s, e), &p).unwrap();
        s = e;
    }
    assert_eq!(d.n_rows(), rows as u64);
    (d.blocks().to_vec(), d.partial())
}

#[test]
fn every_level_gives_the_sums_of_the_definition() {
    let mut state = 0xDEAD_BEEF_1234_5678u64;
    let values = random(5000, &mut state);
    let narrow: Vec<f32> = values.iter().map(|&v| v as f32).collect();
    let levels = Isa::available();
    assert!(levels.contains(&Isa::Portable));
    for trial in 0..200 {
        let len = if trial % 10 == 0 {
            4000
        } else {
            (uniform(&mut state) * 80.0) as usize
        };
        let start = (uniform(&mut state) * 900.0) as usize;
        let k0 = (uniform(&mut state) * 3e9) as u64; // large steps: the weights wrap
        let mut want = Sums::default();
        literal(&values[start..start + len], k0, &mut want);
        let mut want32 = Sums::default();
        literal(&narrow[start..start + len], k0, &mut want32);
        for &isa in &levels {
            let mut got = Sums::default();
            sum_with(isa, &values[start..start + len], k0, &mut got);
            assert_eq!(got, want, "{isa:?}, {len} values from word {k0}");
            let mut got32 = Sums::default();
            sum_with(isa, &narrow[start..start + len], k0, &mut got32);
            assert_eq!(got32, want32, "{isa:?} float32, {len} values from word {k0}");
        }
    }
}

#[test]
fn sums_of_parts_add_up_to_the_sums_of_the_whole() {
    let mut state = 99u64;
    let values = random(777, &mut state);
    let narrow: Vec<f32> = values.iter().map(|&v| v as f32).collect();
    // From unit 26 (a float64 starts a word) and 13 (mid-word: only the definition fits).
    for u0 in [26, 13] {
        let (mut whole, mut whole32) = (Sums::default(), Sums::default());
        literal(&values, u0, &mut whole);
        literal(&narrow, u0, &mut whole32);
        let (mut parts, mut parts32) = (Sums::default(), Sums::default());
        for (a, b) in [(0, 5), (5, 400), (400, 777)] {
            sum_with(Isa::detect(), &values[a..b], u0 + 2 * a as u64, &mut parts);
            sum_with(Isa::detect(), &narrow[a..b], u0 + a as u64, &mut parts32);
        }
        assert_eq!(parts, whole, "float64 from unit {u0}");
        assert_eq!(parts32, whole32, "float32 from unit {u0}");
        assert_eq!((whole.units, whole32.units), (2 * 777, 777));
    }
}

#[test]
fn the_digest_does_not_depend_on_chunking() {
    let cols = 3;
    let rows = 2 * BLOCK_ROWS + 777;
    let data: Vec<f64> = (0..rows * cols).map(|k| (k as f64).sin()).collect();
    let want = digest_in_chunks(&data, cols, rows);
    assert_eq!(want.0.len(), 2);
    assert!(want.1.is_some());
    for step in [1, 999, PIECE_ROWS, PIECE_ROWS + 1, BLOCK_ROWS - 3, BLOCK_ROWS] {
        assert_eq!(digest_in_chunks(&data, cols, step), want, "step {step}");
    }
}

/// The digest of rows `c` (row-major) fed in two chunks in C order, Fortran
/// order and with a row stride of `cols + 2`: all three must agree.
fn digest_in_layouts<T: Value + Default>(c: &[T], rows: usize, cols: usize) -> Option<u128> {
    let mut f = vec![T::default(); rows * cols];
    let mut padded = vec![T::default(); rows * (cols + 2)];
    for i in 0..rows {
        for j in 0..cols {
            f[j * rows + i] = c[i * cols + j];
            padded[i * (cols + 2) + j] = c[i * cols + j];
        }
    }
    let p = pool();
    let feed = |m: Matrix<'_, T>| {
        let mut d = RowDigest::new();
        d.update(m.slice_rows(0, 1000), &p).unwrap();
        d.update(m.slice_rows(1000, rows), &p).unwrap();
        d.partial()
    };
    let want = feed(Matrix::row_major(c, rows, cols).unwrap());
    assert!(want.is_some());
    assert_eq!(feed(Matrix::col_major(&f, rows, cols).unwrap()), want);
    assert_eq!(feed(Matrix::new(&padded, rows, cols, cols + 2, 1).unwrap()), want);
    want
}

#[test]
fn layout_does_not_change_the_digest_and_the_dtype_does() {
    // Odd widths: float32 rows start mid-word.
    for (rows, cols) in [(3 * PIECE_ROWS + 5, 5), (2 * PIECE_ROWS + 1, 7)] {
        let c: Vec<f32> = (0..rows * cols).map(|k| k as f32 * 0.25 - 7.0).collect();
        let wide: Vec<f64> = c.iter().map(|&v| f64::from(v)).collect();
        let narrow = digest_in_layouts(&c, rows, cols);
        // The definition, unit by unit: a float32 row starts at unit row * cols.
        let mut s = Sums::default();
        literal(&c, 0, &mut s);
        assert_eq!(narrow, Some(finish(cols, rows, &s)));
        // The same values stored as float64 are another input.
        assert_ne!(digest_in_layouts(&wide, rows, cols), narrow);
    }
}

#[test]
fn one_changed_value_changes_its_block_only() {
    let cols = 2;
    let rows = 3 * BLOCK_ROWS;
    let mut data: Vec<f64> = (0..rows * cols).map(|k| k as f64).collect();
    let (before, _) = digest_in_chunks(&data, cols, 5000);
    data[(BLOCK_ROWS + 12345) * cols + 1] += 0.5;
    let (after, _) = digest_in_chunks(&data, cols, 5000);
    assert_eq!(before[0], after[0]);
    assert_ne!(before[1], after[1]);
    assert_eq!(before[2], after[2]);
}

/// The checksum of one block (`data` row-major, `cols` wide).
fn block<T: Value>(data: &[T], cols: usize) -> u128 {
    let rows = data.len() / cols;
    let mut d = RowDigest::new();
    let p = pool();
    for s in (0..rows).step_by(4096) {
        let m = Matrix::row_major(data, rows, cols).unwrap();
        d.update(m.slice_rows(s, (s + 4096).min(rows)), &p).unwrap();
    }
    d.partial().unwrap_or_else(|| d.blocks()[0])
}

#[test]
fn swapped_rows_swapped_columns_and_flipped_bits_are_detected() {
    let mut state = 2024u64;
    for cols in [1, 3, 8, 10, 50] {
        let rows = if cols == 50 { 5000 } else { BLOCK_ROWS };
        let data = random(rows * cols, &mut state);
        let want = block(&data, cols);
        for _ in 0..4 {
            let (r1, r2) = (
                (uniform(&mut state) * rows as f64) as usize,
                (uniform(&mut state) * rows as f64) as usize,
            );
            if r1 != r2 {
                let mut swapped = data.clone();
                for c in 0..cols {
                    swapped.swap(r1 * cols + c, r2 * cols + c);
                }
                assert_ne!(
                    block(&swapped, cols),
                    want,
                    "rows {r1}, {r2} of {cols} columns swapped"
                );
            }
            let word = (uniform(&mut state) * (rows * cols) as f64) as usize;
            let bit = (uniform(&mut state) * 64.0) as u32;
            let mut flipped = data.clone();
            flipped[word] = f64::from_bits(flipped[word].to_bits() ^ (1 << bit));
            assert_ne!(block(&flipped, cols), want, "bit {bit} of word {word} flipped");
        }
        if cols > 1 {
            for (c1, c2) in [(0, 1), (0, cols - 1)] {
                let mut swapped = data.clone();
                for r in 0..rows {
                    swapped.swap(r * cols + c1, r * cols + c2);
                }
                assert_ne!(
                    block(&swapped, cols),
                    want,
                    "columns {c1}, {c2} of {cols} swapped"
                );
            }
        }
        // The sign of a whole column: the changes are all 2^63, which plain
        // 64-bit sums would lose in pairs.
        let mut negated = data.clone();
        for r in 0..rows {
            negated[r * cols] = -negated[r * cols];
        }
        assert_ne!(block(&negated, cols), want, "column 0 of {cols} negated");
    }
}

#[test]
fn any_change_of_two_words_in_a_lane_is_detected() {
    // Adversarial for plain 64-bit sums: x and -x (bits 2^63 apart), 1.0 and
    // 2.0 (2^52 apart) swapped, or two signs flipped, in one lane at step
    // distances that are powers of two (so weight times difference is 0 mod 2^64).
    let cols = 8;
    let data: Vec<f64> = (0..BLOCK_ROWS * cols)
        .map(|k| if k % 3 == 0 { 2.0 } else { -1.0 })
        .collect();
    for shift in [1usize, 2, 4096, 32768] {
        let (k1, k2) = (8 * 5 + 3, 8 * (5 + shift) + 3); // same lane, `shift` steps apart
        for (x, y) in [(1.5, -1.5), (1.0, 2.0)] {
            let mut one = data.clone();
            one[k1] = x;
            one[k2] = y;
            let mut other = data.clone();
            other[k1] = y;
            other[k2] = x;
            assert_ne!(
                block(&one, cols),
                block(&other, cols),
                "{x} and {y} swapped {shift} steps apart"
            );
        }
        let mut two_signs = data.clone();
        two_signs[k1] = -two_signs[k1];
        two_signs[k2] = -two_signs[k2];
        assert_ne!(
            block(&two_signs, cols),
            block(&data, cols),
            "two signs flipped {shift} steps apart"
        );
    }
    // float32: sixteen values a step (32768 in a block); odd values are high
    // halves, whose sign is bit 63.
    let narrow: Vec<f32> = data.iter().map(|&v| v as f32).collect();
    for shift in [1usize, 2, 4096, 16384] {
        for half in [6, 7] {
            let (k1, k2) = (16 * 5 + half, 16 * (5 + shift) + half);
            let mut one = narrow.clone();
            one[k1] = 1.5;
            one[k2] = -1.5;
            let mut other = narrow.clone();
            other[k1] = -1.5;
            other[k2] = 1.5;
            assert_ne!(block(&one, cols), block(&other, cols), "float32 swap {shift} steps apart");
            let mut two_signs = narrow.clone();
            two_signs[k1] = -two_signs[k1];
            two_signs[k2] = -two_signs[k2];
            assert_ne!(block(&two_signs, cols), block(&narrow, cols), "float32 signs {shift} steps apart");
        }
    }
}

#[test]
fn a_truncated_block_and_a_change_of_width_differ() {
    let data: Vec<f64> = (0..4000).map(|k| k as f64).collect();
    assert_ne!(block(&data[..3996], 4), block(&data, 4));
    assert_ne!(block(&data, 4), block(&data, 2)); // same words, other rows
    let zeros = vec![0.0f64; 4000];
    assert_ne!(block(&zeros[..3996], 4), block(&zeros, 4)); // sums all zero: the row count tells
    assert_ne!(block(&data[1..], 1), block(&data[..3999], 1)); // shifted by one value
}

#[test]
fn one_changed_word_of_the_sums_changes_both_halves_of_the_checksum() {
    let mut state = 5u64;
    let mut s = Sums::default();
    literal(&random(100, &mut state), 0, &mut s);
    let want = finish(3, 100, &s);
    for l in 0..LANES {
        let mut t = s;
        t.g[l] ^= 1;
        let got = finish(3, 100, &t);
        assert_ne!(got >> 64, want >> 64);
        assert_ne!(got as u64, want as u64);
    }
    assert_ne!(finish(4, 100, &s), want);
    assert_ne!(finish(3, 101, &s), want);
}

#[test]
fn a_change_of_width_is_an_error() {
    let data = [0.0f64; 12];
    let p = pool();
    let mut d = RowDigest::new();
    d.update(Matrix::row_major(&data, 4, 3).unwrap(), &p).unwrap();
    assert!(d.update(Matrix::row_major(&data, 3, 4).unwrap(), &p).is_err());
}
