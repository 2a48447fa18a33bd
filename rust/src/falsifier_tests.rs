//! Tests of the streaming accumulator: results independent of chunking,
//! threads and mode; candidate collection; interruption leaves no trace.

use super::*;
use crate::testing::uniform;

fn pool(n: usize) -> ThreadPool {
    rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap()
}

/// Deterministic pseudo-random predictions around the measurements.
fn predictions(n: usize, n_m: usize) -> Vec<f64> {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    (0..n * n_m).map(|_| uniform(&mut state) * 2.2 - 1.1).collect()
}

fn run(data: &[f64], n_m: usize, chunk_rows: usize, threads: usize, mode: Mode) -> Falsifier {
    let thr = Thresholds::new(vec![-1.0; n_m], vec![1.0; n_m]).unwrap();
    let keep = mode == Mode::Diagnose;
    let mut f = Falsifier::new(&vec![0.0; n_m], &thr, mode, keep).unwrap();
    let p = pool(threads);
    for chunk in data.chunks(chunk_rows * n_m) {
        let m = Matrix::row_major(chunk, chunk.len() / n_m, n_m).unwrap();
        f.update(m, &p, &mut || false).unwrap();
    }
    f
}

#[test]
fn result_is_independent_of_chunking_threads_and_mode() {
    let (n, n_m) = (40_000, 3);
    // Whole: one slab, shared by the pool; in chunks of 777 or 1500 rows:
    // each slab on the calling thread.
    assert!(n * n_m > SERIAL_ELEMENTS && 1500 * n_m < SERIAL_ELEMENTS);
    let data = predictions(n, n_m);
    let a = run(&data, n_m, n, 1, Mode::Diagnose);
    let b = run(&data, n_m, 777, 2, Mode::Diagnose);
    let c = run(&data, n_m, 1500, 2, Mode::Screen);
    // One chunk: the learning slab, then screening slabs within the chunk.
    let d = run(&data, n_m, n, 2, Mode::Screen);
    assert!(n > LEARN_ROWS);
    assert_eq!(a.n_instances(), n as u64);
    assert_eq!(a.candidates_since(0), b.candidates_since(0));
    assert_eq!(a.candidates_since(0), c.candidates_since(0));
    assert_eq!(a.candidates_since(0), d.candidates_since(0));
    assert_eq!(a.tally(), b.tally());
    assert_eq!(a.violations().unwrap(), b.violations().unwrap());
    assert!(c.tally().is_none());
    // Brute force: a candidate has every residual within [-1, 1].
    let expected: Vec<u64> = (0..n)
        .filter(|&i| data[i * n_m..(i + 1) * n_m].iter().all(|r| r.abs() <= 1.0))
        .map(|i| i as u64)
        .collect();
    assert!(!expected.is_empty() && expected.len() < n);
    assert_eq!(a.candidates_since(0), expected[..]);
    // Chunks of several tasks of several blocks (short rows: one task reads
    // at least TASK_BYTES), on the pool (25,000 rows) and on this thread
    // (9,000), after larger chunks: every block counted afresh.
    assert!(blocks_per_task::<f64>(n_m) > 1 && 9_000 * n_m < SERIAL_ELEMENTS);
    assert!(25_000 * n_m > SERIAL_ELEMENTS);
    for rows in [9_000, 25_000] {
        for mode in [Mode::Diagnose, Mode::Screen] {
            let e = run(&data, n_m, rows, 2, mode);
            assert_eq!(e.candidates_since(0), expected[..]);
            assert_eq!(e.n_candidates(), expected.len() as u64);
            if mode == Mode::Diagnose {
                assert_eq!(e.tally(), a.tally());
                assert_eq!(e.violations().unwrap(), a.violations().unwrap());
            }
        }
    }
    for f in [&a, &b, &c, &d] {
        assert_eq!(f.n_candidates(), expected.len() as u64);
    }
}

/// A chunk with fewer blocks than a task would take times the pool's
/// threads is cut into a task per thread: same candidates, tally and
/// counts as one thread and as brute force.
#[test]
fn short_slabs_on_many_threads_give_the_same_result() {
    let (n, n_m) = (30 * BLOCK_ROWS + 11, 3);
    assert!(blocks_per_task::<f64>(n_m) * 7 > n.div_ceil(BLOCK_ROWS) && n * n_m > SERIAL_ELEMENTS);
    let data = predictions(n, n_m);
    let one = run(&data, n_m, n, 1, Mode::Diagnose);
    let expected: Vec<u64> = (0..n)
        .filter(|&i| data[i * n_m..(i + 1) * n_m].iter().all(|r| r.abs() <= 1.0))
        .map(|i| i as u64)
        .collect();
    assert_eq!(one.candidates_since(0), expected[..]);
    for threads in [7, 16] {
        let many = run(&data, n_m, n, threads, Mode::Diagnose);
        assert_eq!(many.candidates_since(0), expected[..]);
        assert_eq!(many.n_candidates(), expected.len() as u64);
        assert_eq!(many.tally(), one.tally());
        assert_eq!(many.violations().unwrap(), one.violations().unwrap());
        assert_eq!(run(&data, n_m, n, threads, Mode::Screen).candidates_since(0), expected[..]);
    }
}

#[test]
fn whole_blocks_of_candidates_and_partial_ones_are_collected() {
    // Block 0 all candidates, block 1 all but row 1500, a short last block all
    // candidates; then a second chunk with none.
    let (n, n_m) = (2 * BLOCK_ROWS + 952, 2);
    let mut data = vec![0.5; n * n_m];
    data[1500 * n_m + 1] = 3.0;
    for mode in [Mode::Diagnose, Mode::Screen] {
        let f = run(&data, n_m, n, 2, mode);
        let expected: Vec<u64> = (0..n as u64).filter(|&i| i != 1500).collect();
        assert_eq!(f.candidates_since(0), expected[..]);
    }
    let mut f = run(&data, n_m, n, 1, Mode::Screen);
    let none = vec![5.0; 100 * n_m];
    f.update(Matrix::row_major(&none, 100, n_m).unwrap(), &pool(2), &mut || {
        false
    })
    .unwrap();
    assert_eq!(f.n_candidates(), (n - 1) as u64);
    assert_eq!(f.n_instances(), (n + 100) as u64);
}

#[test]
fn stop_is_polled_by_every_call() {
    // One slab: polled once, after it. Several (the learning slab, then the
    // rest, run as one job in the pool): polled while they run and once
    // after, so a Ctrl-C during any call is seen.
    let n_m = 4;
    let thr = Thresholds::new(vec![-1.0; n_m], vec![1.0; n_m]).unwrap();
    let data = predictions(LEARN_ROWS + 1, n_m);
    let m = Matrix::row_major(&data, LEARN_ROWS + 1, n_m).unwrap();
    let reference = run(&data, n_m, 1000, 1, Mode::Diagnose);
    for (mode, slabs) in [(Mode::Diagnose, 1), (Mode::Screen, 2)] {
        let mut f = Falsifier::new(&vec![0.0; n_m], &thr, mode, false).unwrap();
        assert_eq!(m.rows() <= f.first_slab_rows::<f64>(&pool(2)), slabs == 1);
        let mut polls = 0;
        f.update(m, &pool(2), &mut || {
            polls += 1;
            false
        })
        .unwrap();
        assert!(if slabs == 1 { polls == 1 } else { polls >= 1 }, "{mode:?}: {polls} polls");
        assert_eq!(f.candidates_since(0), reference.candidates_since(0));
    }
}

#[test]
fn wrong_width_is_an_error_and_interruption_leaves_no_trace() {
    let thr = Thresholds::new(vec![-1.0; 2], vec![1.0; 2]).unwrap();
    let mut f = Falsifier::new(&[0.0, 0.0], &thr, Mode::Diagnose, true).unwrap();
    let p = pool(1);
    let bad = [0.0; 3];
    assert!(f
        .update(Matrix::row_major(&bad, 1, 3).unwrap(), &p, &mut || false)
        .is_err());
    // Stopped at the first poll, in a chunk of two slabs or of one: the
    // chunk's candidates and counts go too, and the next chunk is taken.
    let rows = SLAB_BYTES / 8; // two slabs of two f64 sensors
    let data = vec![0.0; 2 * rows];
    for rows in [rows, 100] {
        let m = Matrix::row_major(&data[..2 * rows], rows, 2).unwrap();
        let mut asked = 0;
        let mut first = || {
            asked += 1;
            true
        };
        assert_eq!(f.update(m, &p, &mut first), Err(EdmfError::Interrupted));
        assert_eq!(asked, 1);
        assert_eq!(f.n_instances(), 0);
        assert!(f.candidates().is_empty());
        assert_eq!(f.violations().unwrap().unwrap().len(), 0);
    }
    f.update(Matrix::row_major(&data[..200], 100, 2).unwrap(), &p, &mut || false).unwrap();
    assert_eq!((f.n_instances(), f.n_candidates()), (100, 100));
    assert_eq!(f.violations().unwrap().unwrap(), vec![0; 100]);
}

#[test]
fn a_caller_on_the_pools_own_thread_is_served_slab_by_slab() {
    // A one-thread pool whose only thread calls: a job in the pool would never run.
    let (n, n_m) = (LEARN_ROWS + 1, 4);
    let data = predictions(n, n_m);
    let reference = run(&data, n_m, 1000, 1, Mode::Screen);
    let thr = Thresholds::new(vec![-1.0; n_m], vec![1.0; n_m]).unwrap();
    let p = pool(1);
    let f = p.install(|| {
        let mut f = Falsifier::new(&vec![0.0; n_m], &thr, Mode::Screen, false).unwrap();
        f.update(Matrix::row_major(&data, n, n_m).unwrap(), &p, &mut || false).unwrap();
        f
    });
    assert_eq!(f.candidates_since(0), reference.candidates_since(0));
}

#[test]
fn a_cancelled_job_stops_before_its_next_slab() {
    let thr = Thresholds::new(vec![-1.0; 2], vec![1.0; 2]).unwrap();
    let mut f = Falsifier::new(&[0.0, 0.0], &thr, Mode::Diagnose, true).unwrap();
    let data = vec![0.0; 200];
    let m = Matrix::row_major(&data, 100, 2).unwrap();
    assert_eq!(f.slabs(m, &pool(1), &AtomicBool::new(true), None).err(), Some(EdmfError::Interrupted));
    assert!(f.candidates().is_empty());
}

#[test]
fn measurements_must_match_and_be_finite() {
    let thr = Thresholds::new(vec![-1.0; 2], vec![1.0; 2]).unwrap();
    assert!(Falsifier::new(&[0.0], &thr, Mode::Diagnose, false).is_err());
    assert!(Falsifier::new(&[0.0, f64::INFINITY], &thr, Mode::Diagnose, false).is_err());
    assert!(Falsifier::new(&[0.0, 0.0], &thr, Mode::Screen, true).is_err());
}

/// Long rows over several slabs whose size depends on the pool (whole rounds
/// of blocks for its threads): the same candidates, counts, violations and
/// block checksums with 1, 4 and 5 threads, diagnosed or screened, as brute
/// force and a separate checksum pass give.
#[test]
fn slabs_sized_for_the_pool_change_no_result() {
    let (n, n_m) = (16_000, 700); // slabs of 6, 8 and 10 blocks: 3, 2 and 2 slabs
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    // About 0.1 % of values outside [-1, 1]: half the rows of 700 are candidates.
    let data: Vec<f32> = (0..n * n_m).map(|_| ((uniform(&mut state) * 2.0 - 1.0) * 1.001) as f32).collect();
    let thr = Thresholds::new(vec![-1.0; n_m], vec![1.0; n_m]).unwrap();
    let m = Matrix::row_major(&data, n, n_m).unwrap();
    // The checksum of every block, summed in the same pass, is the separate pass's.
    let mut separate = crate::digest::RowDigest::new();
    separate.update(m, &pool(1)).unwrap();
    let run = |threads: usize, mode: Mode| {
        let mut f = Falsifier::new(&vec![0.0; n_m], &thr, mode, mode == Mode::Diagnose).unwrap();
        let mut d = crate::digest::RowDigest::new();
        f.update_digested(m, &pool(threads), &mut || false, &mut d).unwrap();
        assert_eq!((d.blocks(), d.partial()), (separate.blocks(), separate.partial()), "{threads} threads");
        f
    };
    let expected: Vec<u64> = (0..n)
        .filter(|&i| data[i * n_m..(i + 1) * n_m].iter().all(|&v| f64::from(v).abs() <= 1.0))
        .map(|i| i as u64)
        .collect();
    assert!(expected.len() > n / 4 && expected.len() < 3 * n / 4);
    let one = run(1, Mode::Diagnose);
    assert_eq!(one.candidates_since(0), expected[..]);
    for threads in [4, 5] {
        let many = run(threads, Mode::Diagnose);
        assert_eq!(many.candidates_since(0), expected[..]);
        assert_eq!(many.tally(), one.tally());
        assert_eq!(many.violations().unwrap(), one.violations().unwrap());
        assert_eq!(run(threads, Mode::Screen).candidates_since(0), expected[..]);
    }
}
