//! The row kernels alone on one core, from L2: 240 KiB of rows a call,
//! 2,000 calls a round, best of 15 rounds, at every instruction-set level
//! this CPU runs; GB/s read. No Python and no pool, so a change to a kernel
//! shows whole (`benches/core_rate.py` times the same through
//! `Falsifier.update`, whose own work per call adds to every call's time).
//! `cargo bench --bench core_kernels`; `CORE_KERNELS=f32:10,f64:7` picks
//! the cases (any widths).
//!
//! Cases as in `core_rate.py`: "worst", every residual inside its interval
//! (all candidates); "typical", residuals N(0, s) with s such that a row is
//! a candidate with probability 5 %, every sensor rejecting some rows. And
//! "singles": each row, at random with probability 1/2, rejected by exactly
//! one sensor (drawn at random), else a candidate: the least predictable
//! pattern for a branch on a row's verdict or its "falsified only by"
//! sensor. `CORE_KERNELS_CASES=worst,singles` picks the cases.

use edmf_core::kernel::{diagnose_bits_with, screen_bits_with, BitSink, ScreenPlan, SensorBounds};
use edmf_core::{Isa, Matrix, Prediction, Tally};
use std::hint::black_box;
use std::time::Instant;

const BYTES: usize = 240 * 1024;

/// Deterministic N(0, 1)-ish values (a sum of 12 uniforms), no RNG crate needed.
fn normals(n: usize) -> Vec<f64> {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    (0..n)
        .map(|_| {
            (0..12)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    (state >> 11) as f64 / (1u64 << 53) as f64
                })
                .sum::<f64>()
                - 6.0
        })
        .collect()
}

/// z with P(|Z| < z) = q for a standard normal Z (bisection on a midpoint sum).
fn two_sided(q: f64) -> f64 {
    let coverage = |z: f64| {
        let steps = 4000;
        let h = z / steps as f64;
        2.0 * (0..steps).map(|i| (-((i as f64 + 0.5) * h).powi(2) / 2.0).exp()).sum::<f64>() * h
            / (2.0 * std::f64::consts::PI).sqrt()
    };
    let (mut lo, mut hi) = (0.0, 10.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if coverage(mid) < q {
            lo = mid
        } else {
            hi = mid
        }
    }
    0.5 * (lo + hi)
}

/// Rows of `n_m` values all inside (-1, 1): each, with probability 1/2,
/// gets one sensor, drawn at random, moved to 2 (rejected by it alone).
fn single_rejections(values: &mut [f64], n_m: usize) {
    let draws = normals(values.len() / n_m);
    for (row, d) in values.chunks_exact_mut(n_m).zip(draws) {
        // The fraction's digits as a uniform draw (independent of its sign).
        let u = (d.abs() * 1e6).fract();
        if u < 0.5 {
            row[((u * 2.0 * n_m as f64) as usize).min(n_m - 1)] = 2.0;
        }
    }
}

/// GB/s of the best round of `calls` calls of diagnostics (or screening) over `data`.
fn rate<T: Prediction>(isa: Isa, data: &[T], n_m: usize, diagnostics: bool) -> f64 {
    let n = data.len() / n_m;
    let m = Matrix::row_major(data, n, n_m).unwrap();
    let b = SensorBounds::new(&vec![0.0; n_m], &vec![-1.0; n_m], &vec![1.0; n_m]).unwrap();
    let plan = ScreenPlan::new(&b, &vec![0; n_m]);
    let mut words = vec![0u64; n / 64 + 2];
    let calls = 2000;
    let mut best = f64::INFINITY;
    for _ in 0..15 {
        let start = Instant::now();
        for _ in 0..calls {
            let mut sink = BitSink::new(&mut words, 0);
            if diagnostics {
                let mut t = Tally::zeros(n_m);
                diagnose_bits_with(isa, black_box(m), &b, None, &mut sink, &mut t);
                black_box(t.invalid);
            } else {
                screen_bits_with(isa, black_box(m), &b, &plan, &mut sink);
            }
            sink.finish();
        }
        best = best.min(start.elapsed().as_secs_f64() / calls as f64);
    }
    std::mem::size_of_val(data) as f64 / best / 1e9
}

fn main() {
    let picked = std::env::var("CORE_KERNELS").ok();
    let cpu = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = cpu.lines().find(|l| l.starts_with("model name")).unwrap_or("model name: unknown");
    println!("{model}; one thread; {} KiB a call, 2000 calls a round, best of 15 rounds", BYTES / 1024);
    let cases = std::env::var("CORE_KERNELS_CASES").unwrap_or_else(|_| "worst,typical".into());
    for isa in Isa::available().into_iter().filter(|&i| i != Isa::Portable) {
        println!("{isa:?}: dtype n_m case diagnostics screen (GB/s)");
        let default = "f64:5,f64:10,f64:16,f64:20,f32:5,f32:10,f32:16,f32:20";
        for case in picked.as_deref().unwrap_or(default).split(',') {
            let Some((dtype, n_m)) = case.split_once(':').and_then(|(d, n)| Some((d, n.parse::<usize>().ok()?)))
            else {
                panic!("CORE_KERNELS: expected dtype:n_m pairs such as f32:10, got {case:?}");
            };
            assert!(matches!(dtype, "f32" | "f64") && n_m > 0, "CORE_KERNELS: {case:?}");
            for case in cases.split(',') {
                let size = if dtype == "f32" { 4 } else { 8 };
                let z = two_sided(0.05f64.powf(1.0 / n_m as f64));
                let mut values: Vec<f64> = normals(BYTES / (n_m * size) * n_m)
                    .into_iter()
                    .map(|v| if case == "typical" { v / z } else { (v / 10.0).clamp(-0.99, 0.99) })
                    .collect();
                if case == "singles" {
                    single_rejections(&mut values, n_m);
                } else {
                    assert!(matches!(case, "worst" | "typical"), "CORE_KERNELS_CASES: unknown case {case:?}");
                }
                let (on, off) = if dtype == "f32" {
                    let v: Vec<f32> = values.iter().map(|&x| x as f32).collect();
                    (rate(isa, &v, n_m, true), rate(isa, &v, n_m, false))
                } else {
                    (rate(isa, &values, n_m, true), rate(isa, &values, n_m, false))
                };
                println!("{isa:?} {dtype} {n_m:3} {case:8} {on:6.1} {off:6.1}");
            }
        }
    }
}
