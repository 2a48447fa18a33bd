//! The digest a `Falsifier` computes in the same pass as the falsification
//! (`update_digested`) is the one a separate `RowDigest` pass gives, whatever
//! the chunking, thread count, mode, dtype or layout.

use crate::digest::{RowDigest, BLOCK_ROWS, PIECE_ROWS as LEAF_ROWS};
use crate::falsifier::{Falsifier, Mode};
use crate::matrix::Matrix;
use crate::testing::uniform;
use crate::thresholds::Thresholds;
use crate::EdmfError;
use rayon::ThreadPool;

fn pool(n: usize) -> ThreadPool {
    rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap()
}

fn falsifier(n_m: usize, mode: Mode) -> Falsifier {
    let thr = Thresholds::new(vec![-1.0; n_m], vec![1.0; n_m]).unwrap();
    Falsifier::new(&vec![0.0; n_m], &thr, mode, mode == Mode::Diagnose).unwrap()
}

/// Random chunk lengths (some short, some longer than a piece or a slab).
fn chunking(rows: usize, state: &mut u64) -> Vec<usize> {
    let mut cuts = Vec::new();
    let mut left = rows;
    while left > 0 {
        let scale = [7.0, 3000.0, 70_000.0][(uniform(state) * 3.0) as usize];
        let step = ((uniform(state) * scale) as usize + 1).min(left);
        cuts.push(step);
        left -= step;
    }
    cuts
}

/// Blocks and partial of the separate pass (one chunk, one thread).
fn separate<T: crate::digest::Value>(m: Matrix<'_, T>) -> (Vec<u128>, Option<u128>) {
    let mut d = RowDigest::new();
    d.update(m, &pool(1)).unwrap();
    (d.blocks().to_vec(), d.partial())
}

#[test]
fn the_in_pass_digest_is_the_separate_pass_digest() {
    let (rows, n_m) = (2 * BLOCK_ROWS + 3 * LEAF_ROWS + 77, 3);
    let mut state = 0x1234_5678_9ABC_DEF1u64;
    let data: Vec<f64> = (0..rows * n_m).map(|_| uniform(&mut state) * 2.4 - 1.2).collect();
    let all = Matrix::row_major(&data, rows, n_m).unwrap();
    let want = separate(all);
    assert_eq!(want.0.len(), 2);
    let reference = {
        let mut f = falsifier(n_m, Mode::Diagnose);
        f.update(all, &pool(1), &mut || false).unwrap();
        f.candidates_since(0)
    };
    for trial in 0..6 {
        let threads = 1 + trial % 3;
        let mode = if trial % 2 == 0 {
            Mode::Screen
        } else {
            Mode::Diagnose
        };
        let p = pool(threads);
        let mut f = falsifier(n_m, mode);
        let mut d = RowDigest::new();
        let mut s = 0;
        for step in chunking(rows, &mut state) {
            f.update_digested(all.slice_rows(s, s + step), &p, &mut || false, &mut d)
                .unwrap();
            s += step;
            assert_eq!(d.n_rows(), s as u64);
        }
        assert_eq!(
            (d.blocks().to_vec(), d.partial()),
            want,
            "trial {trial}, {threads} threads"
        );
        assert_eq!(f.candidates_since(0), reference[..], "trial {trial}");
    }
}

#[test]
fn float32_and_column_major_chunks_digest_their_values() {
    let (rows, n_m) = (BLOCK_ROWS + 2 * LEAF_ROWS + 5, 4);
    let mut state = 77u64;
    let c: Vec<f32> = (0..rows * n_m)
        .map(|_| (uniform(&mut state) * 2.4 - 1.2) as f32)
        .collect();
    let mut fortran = vec![0.0f64; rows * n_m]; // float64 values, Fortran order
    for i in 0..rows {
        for j in 0..n_m {
            fortran[j * rows + i] = f64::from(c[i * n_m + j]) + 0.5;
        }
    }
    let row_major: Vec<f64> = (0..rows * n_m).map(|k| fortran[(k % n_m) * rows + k / n_m]).collect();
    let want = separate(Matrix::row_major(&c, rows, n_m).unwrap());
    let want64 = separate(Matrix::row_major(&row_major, rows, n_m).unwrap());
    let p = pool(2);
    for (first, second) in [(LEAF_ROWS + 3, 999), (500, LEAF_ROWS)] {
        let mut f32_digest = RowDigest::new();
        let mut f64_digest = RowDigest::new();
        let mut f = falsifier(n_m, Mode::Screen);
        let mut g = falsifier(n_m, Mode::Diagnose);
        let f32s = Matrix::row_major(&c, rows, n_m).unwrap();
        let f64s = Matrix::col_major(&fortran, rows, n_m).unwrap();
        for (s, e) in [(0, first), (first, first + second), (first + second, rows)] {
            f.update_digested(f32s.slice_rows(s, e), &p, &mut || false, &mut f32_digest)
                .unwrap();
            g.update_digested(f64s.slice_rows(s, e), &p, &mut || false, &mut f64_digest)
                .unwrap();
        }
        assert_eq!((f32_digest.blocks().to_vec(), f32_digest.partial()), want);
        assert_eq!((f64_digest.blocks().to_vec(), f64_digest.partial()), want64);
    }
}

#[test]
fn an_interrupted_or_refused_chunk_leaves_the_digest_alone() {
    let n_m = 2;
    let rows = (1 << 22) + 100; // more than two slabs of two sensors
    let data = vec![0.5; rows * n_m];
    let m = Matrix::row_major(&data, rows, n_m).unwrap();
    let p = pool(2);
    let mut f = falsifier(n_m, Mode::Diagnose);
    let mut d = RowDigest::new();
    f.update_digested(m.slice_rows(0, 10), &p, &mut || false, &mut d)
        .unwrap();
    let before = (d.n_rows(), d.blocks().to_vec(), d.partial());
    // Ctrl-C from the first poll on: a poll every 10 ms while the chunk runs,
    // and one after it, so the chunk is interrupted however fast it runs
    // (answering only the second poll, the test failed whenever the chunk
    // took less than 10 ms).
    let mut asked = 0;
    let mut pressed = || {
        asked += 1;
        true
    };
    let got = f.update_digested(m.slice_rows(10, rows), &p, &mut pressed, &mut d);
    assert!(asked >= 1);
    assert_eq!(got, Err(EdmfError::Interrupted));
    assert_eq!((d.n_rows(), d.blocks().to_vec(), d.partial()), before);
    // A digest of another width refuses the chunk before the falsifier takes it.
    let wide = vec![0.5; 3 * 10];
    let mut other = RowDigest::new();
    other
        .update(Matrix::row_major(&wide, 10, 3).unwrap(), &p)
        .unwrap();
    assert!(f
        .update_digested(m.slice_rows(10, 20), &p, &mut || false, &mut other)
        .is_err());
    assert_eq!(f.n_instances(), 10);
    // Resumed from the same row, the digest is the one of a single pass.
    f.update_digested(m.slice_rows(10, rows), &p, &mut || false, &mut d)
        .unwrap();
    assert_eq!((d.blocks().to_vec(), d.partial()), separate(m));
}

#[test]
fn tasks_of_several_blocks_sum_each_block_once_whatever_the_grouping() {
    // Rows of one sensor: 16 blocks a task, fewer when a slab has too few for
    // 8 threads, so the grouping changes from chunk to chunk and a slot left
    // from an earlier chunk would be added again.
    let (n_m, chunks) = (1, [70_000, 300_000, 70_000, 133_333, 9]);
    let rows: usize = chunks.iter().sum();
    let mut state = 0x0DD_B10C_5EEDu64;
    let data: Vec<f64> = (0..rows * n_m).map(|_| uniform(&mut state) * 2.4 - 1.2).collect();
    let all = Matrix::row_major(&data, rows, n_m).unwrap();
    let want = separate(all);
    for mode in [Mode::Screen, Mode::Diagnose] {
        let (p, mut f, mut d) = (pool(8), falsifier(n_m, mode), RowDigest::new());
        let mut s = 0;
        for step in chunks {
            f.update_digested(all.slice_rows(s, s + step), &p, &mut || false, &mut d)
                .unwrap();
            s += step;
        }
        assert_eq!((d.blocks().to_vec(), d.partial()), want, "{mode:?}");
    }
}
