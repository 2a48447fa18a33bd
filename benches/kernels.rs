//! Criterion benchmarks of the core kernels, no Python involved:
//! `cargo bench` (or `cargo bench -- falsify` for one group).
//!
//! Cases follow the paper's use: "worst" keeps every instance (no early exit),
//! "typical" falsifies over 90 % of them.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use edmf_core::kernel::{diagnose_with, screen_with, ScreenPlan, SensorBounds};
use edmf_core::{shortest_intervals, Falsifier, Isa, Matrix, Mode, Tally, Thresholds};
use std::hint::black_box;
use std::time::Duration;

/// Deterministic standard-normal-ish values (sum of uniforms), no RNG crate needed.
fn values(n: usize) -> Vec<f64> {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    (0..n)
        .map(|_| (0..4).map(|_| uniform()).sum::<f64>() * 1.732 - 3.464)
        .collect()
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

fn falsify(c: &mut Criterion) {
    let (n, n_m) = (200_000, 50);
    let data = values(n * n_m);
    let data32: Vec<f32> = data.iter().map(|&v| v as f32).collect();
    let measured = vec![0.0; n_m];
    let mut group = c.benchmark_group("falsify");
    group.throughput(Throughput::Elements(n as u64));
    for (case, half_width) in [("worst", 10.0), ("typical", 2.0)] {
        let thr = Thresholds::new(vec![-half_width; n_m], vec![half_width; n_m]).unwrap();
        for threads in [1, 2] {
            let p = pool(threads);
            for (mode, name) in [(Mode::Diagnose, "diagnose"), (Mode::Screen, "screen")] {
                let id = BenchmarkId::new(format!("{case}/{name}/f64"), threads);
                group.bench_function(id, |b| {
                    let m = Matrix::row_major(&data, n, n_m).unwrap();
                    b.iter(|| {
                        let mut f = Falsifier::new(&measured, &thr, mode, false).unwrap();
                        f.update(black_box(m), &p, &mut || false).unwrap();
                        f.candidates().len()
                    })
                });
            }
            let id = BenchmarkId::new(format!("{case}/diagnose/f32"), threads);
            group.bench_function(id, |b| {
                let m = Matrix::row_major(&data32, n, n_m).unwrap();
                b.iter(|| {
                    let mut f = Falsifier::new(&measured, &thr, Mode::Diagnose, false).unwrap();
                    f.update(black_box(m), &p, &mut || false).unwrap();
                    f.candidates().len()
                })
            });
        }
    }
    group.finish();
}

/// The row kernels alone, one thread, at every instruction-set level this CPU
/// runs (portable, AVX2, AVX-512), so their ratios show in one run.
fn isa_levels(c: &mut Criterion) {
    let (n, n_m) = (100_000, 50);
    let data = values(n * n_m);
    let m = Matrix::row_major(&data, n, n_m).unwrap();
    let b = SensorBounds::new(&vec![0.0; n_m], &vec![-10.0; n_m], &vec![10.0; n_m]).unwrap();
    let plan = ScreenPlan::new(&b, &vec![0; n_m]);
    let mut out = vec![0u32; n];
    let mut group = c.benchmark_group("isa_worst_case");
    group.throughput(Throughput::Elements(n as u64));
    for isa in Isa::available() {
        group.bench_function(BenchmarkId::new("diagnose", format!("{isa:?}")), |bench| {
            bench.iter(|| {
                let mut t = Tally::zeros(n_m);
                diagnose_with(isa, black_box(m), &b, &mut out, &mut t);
                t.invalid
            })
        });
        group.bench_function(BenchmarkId::new("screen", format!("{isa:?}")), |bench| {
            bench.iter(|| screen_with(isa, black_box(m), &plan, &mut out))
        });
    }
    group.finish();
}

fn thresholds(c: &mut Criterion) {
    let (n, n_m) = (100_000, 10);
    let data = values(n * n_m);
    let m = Matrix::row_major(&data, n, n_m).unwrap();
    let mut group = c.benchmark_group("shortest_intervals");
    group.throughput(Throughput::Elements((n * n_m) as u64));
    for threads in [1, 2] {
        let p = pool(threads);
        group.bench_function(BenchmarkId::new("100k_x_10", threads), |b| {
            b.iter(|| shortest_intervals(black_box(m), 0.95f64.powf(0.1), &p, &mut || false).unwrap())
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10).measurement_time(Duration::from_secs(2)).warm_up_time(Duration::from_millis(500));
    targets = falsify, isa_levels, thresholds
}
criterion_main!(benches);
