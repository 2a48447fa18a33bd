//! The row kernels through memory, without Python: 800 MB of predictions
//! falsified by two threads, side by side with the floor (the same array read
//! once by two threads at once, each OR-ing its half), in alternating rounds.
//! `benches/throughput.py --floor` measures the same through `falsify`; this
//! one takes Python and NumPy out, and times the kernel two ways, so where the
//! time goes can be told apart:
//! - `falsify`: `Falsifier::update` in a pool of two threads (slabs, 1 MiB
//!   tasks, candidate bits, as the extension runs it);
//! - `halves`: each of two threads runs the kernel over its own half, 1 MiB
//!   at a time, no pool.
//!
//! `cargo bench --bench core_memory`; `CORE_MEMORY=f64:200,f32:10` picks the
//! cases, `CORE_MEMORY_ROUNDS=9` the rounds. Prints, per case and method, the
//! median over rounds of floor time / method time (1.0 = at the floor) and
//! its range; the CPU model is printed first.

use edmf_core::candidates::BitSink;
use edmf_core::kernel::{diagnose_bits_with, screen_bits_with, ScreenPlan, SensorBounds};
use edmf_core::{Falsifier, Isa, Matrix, Mode, Prediction, Tally, Thresholds};
use std::hint::black_box;
use std::time::Instant;

const BYTES: usize = 800_000_000;
const PIECE: usize = 1 << 20;

/// Deterministic values in [0, 1) (xorshift64), no RNG crate needed.
fn uniforms(n: usize) -> Vec<f64> {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    (0..n)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        })
        .collect()
}

/// OR of every 64-bit word of `words` (AVX-512 when the CPU has it).
fn or_all(words: &[u64]) -> u64 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx512f") {
        // SAFETY: AVX-512F checked just above.
        return unsafe { or_all_avx512(words) };
    }
    words.iter().fold(0, |a, &w| a | w)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn or_all_avx512(words: &[u64]) -> u64 {
    use std::arch::x86_64::*;
    let mut acc = [_mm512_setzero_si512(); 4];
    let blocks = words.chunks_exact(32);
    let tail = blocks.remainder().iter().fold(0, |a, &w| a | w);
    for b in blocks {
        for (k, a) in acc.iter_mut().enumerate() {
            *a = _mm512_or_si512(*a, _mm512_loadu_si512(b.as_ptr().add(8 * k) as *const __m512i));
        }
    }
    let v = _mm512_or_si512(_mm512_or_si512(acc[0], acc[1]), _mm512_or_si512(acc[2], acc[3]));
    _mm512_reduce_or_epi64(v) as u64 | tail
}

/// Seconds for two threads to read `data` once, each its half.
fn floor<T>(data: &[T]) -> f64 {
    // SAFETY: any bytes are valid u64 words; the length is rounded down.
    let words = unsafe { std::slice::from_raw_parts(data.as_ptr() as *const u64, std::mem::size_of_val(data) / 8) };
    let (a, b) = words.split_at(words.len() / 2);
    let start = Instant::now();
    std::thread::scope(|s| {
        let h = s.spawn(|| black_box(or_all(a)));
        black_box(or_all(b));
        h.join().unwrap();
    });
    start.elapsed().as_secs_f64()
}

/// Seconds for `Falsifier::update` over `data` in a pool of two threads.
fn falsify<T: Prediction + edmf_core::digest::Value>(m: Matrix<'_, T>, thr: &Thresholds, mode: Mode, p: &rayon::ThreadPool) -> f64 {
    let mut f = Falsifier::new(&vec![0.0; m.cols()], thr, mode, false).unwrap();
    let start = Instant::now();
    f.update(black_box(m), p, &mut || false).unwrap();
    let t = start.elapsed().as_secs_f64();
    black_box(f.n_candidates());
    t
}

/// Seconds for two threads, each over its half of `m`, a piece of 1 MiB at a time.
fn halves<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, plan: &ScreenPlan, diagnostics: bool) -> f64 {
    let rows = m.rows();
    let piece = (PIECE / (m.cols() * std::mem::size_of::<T>())).max(64) / 64 * 64;
    let half = rows / 2 / 64 * 64;
    let run = |r0: usize, r1: usize| {
        let mut words = vec![0u64; piece / 64 + 2];
        let mut t = Tally::zeros(m.cols());
        for s in (r0..r1).step_by(piece) {
            let part = m.slice_rows(s, (s + piece).min(r1));
            let mut sink = BitSink::new(&mut words, 0);
            if diagnostics {
                diagnose_bits_with(Isa::detect(), part, b, None, &mut sink, &mut t);
            } else {
                screen_bits_with(Isa::detect(), part, b, plan, &mut sink);
            }
            sink.finish();
        }
        black_box(t.invalid);
    };
    let start = Instant::now();
    std::thread::scope(|s| {
        let h = s.spawn(|| run(0, half));
        run(half, rows);
        h.join().unwrap();
    });
    start.elapsed().as_secs_f64()
}

fn median_range(mut v: Vec<f64>) -> (f64, f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[v.len() / 2], v[0], v[v.len() - 1])
}

fn case<T: Prediction + edmf_core::digest::Value>(data: &[T], n_m: usize, label: &str, rounds: usize) {
    let rows = data.len() / n_m;
    let m = Matrix::row_major(data, rows, n_m).unwrap();
    let thr = Thresholds::new(vec![-1.0; n_m], vec![1.0; n_m]).unwrap();
    let b = SensorBounds::new(&vec![0.0; n_m], &vec![-1.0; n_m], &vec![1.0; n_m]).unwrap();
    let plan = ScreenPlan::new(&b, &vec![0; n_m]);
    let p = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    let methods = ["falsify diag", "falsify scr", "halves diag", "halves scr"];
    let mut ratios = vec![Vec::new(); methods.len()];
    let mut floors = Vec::new();
    for round in 0..rounds {
        let f = floor(data);
        floors.push(f);
        // Each round starts at another method, so none always runs first
        // after the floor (whose read leaves the caches and prefetchers in
        // a state of its own).
        for k in 0..methods.len() {
            let which = (round + k) % methods.len();
            let t = match which {
                0 => falsify(m, &thr, Mode::Diagnose, &p),
                1 => falsify(m, &thr, Mode::Screen, &p),
                2 => halves(m, &b, &plan, true),
                _ => halves(m, &b, &plan, false),
            };
            ratios[which].push(f / t);
        }
    }
    let (fm, flo, fhi) = median_range(floors);
    println!("{label}: floor {:.1} ms ({:.1}-{:.1})", fm * 1e3, flo * 1e3, fhi * 1e3);
    for (name, r) in methods.iter().zip(ratios) {
        let (m, lo, hi) = median_range(r);
        println!("  {name:13} speed / floor {m:.2} ({lo:.2}-{hi:.2})");
    }
}

fn main() {
    let cpu = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = cpu.lines().find(|l| l.starts_with("model name")).unwrap_or("model name: unknown");
    let rounds: usize = std::env::var("CORE_MEMORY_ROUNDS").ok().and_then(|r| r.parse().ok()).unwrap_or(9);
    println!("{model}; {:?}; 2 threads; {} MB; median (range) of {rounds} alternating rounds", Isa::detect(), BYTES / 1_000_000);
    let picked = std::env::var("CORE_MEMORY").unwrap_or_else(|_| "f64:200,f64:50,f32:200,f64:10".into());
    for spec in picked.split(',') {
        let Some((dtype, n_m)) = spec.split_once(':').and_then(|(d, n)| Some((d, n.parse::<usize>().ok()?))) else {
            panic!("CORE_MEMORY: expected dtype:n_m pairs such as f64:200, got {spec:?}");
        };
        assert!(matches!(dtype, "f32" | "f64") && n_m > 0, "CORE_MEMORY: {spec:?}");
        for which in ["worst", "typical"] {
            let size = if dtype == "f32" { 4 } else { 8 };
            let n = BYTES / (n_m * size) * n_m;
            // Worst: every residual inside (all candidates); typical: uniform
            // on +-w with w such that a row is a candidate with probability 5 %.
            let w = if which == "worst" { 0.99 } else { 1.0 / 0.05f64.powf(1.0 / n_m as f64) };
            let values = uniforms(n).into_iter().map(|u| (2.0 * u - 1.0) * w);
            let label = format!("{dtype} rows of {n_m}, {which}");
            if dtype == "f32" {
                let v: Vec<f32> = values.map(|x| x as f32).collect();
                case(&v, n_m, &label, rounds);
            } else {
                let v: Vec<f64> = values.collect();
                case(&v, n_m, &label, rounds);
            }
        }
    }
}
