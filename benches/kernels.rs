//! Criterion benchmarks of the core kernels, no Python involved:
//! `cargo bench` (or `cargo bench -- falsify` for one group).
//!
//! Cases follow the paper's use: "worst" keeps every instance (no early exit),
//! "typical" falsifies over 90 % of them.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use edmf_core::kernel::{
    diagnose_bits_with, diagnose_with, screen_bits_with, screen_with, BitSink, ScreenPlan, SensorBounds,
};
use edmf_core::digest::Value;
use edmf_core::{shortest_intervals, Falsifier, Isa, Matrix, Mode, Prediction, Tally, Thresholds};
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

/// One falsifier over `m` (no counts per instance kept): its candidate count.
fn falsify_once<T: Prediction + Value>(
    m: Matrix<'_, T>,
    measured: &[f64],
    thr: &Thresholds,
    mode: Mode,
    p: &rayon::ThreadPool,
) -> u64 {
    let mut f = Falsifier::new(measured, thr, mode, false).unwrap();
    f.update(black_box(m), p, &mut || false).unwrap();
    f.n_candidates()
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
                    b.iter(|| falsify_once(m, &measured, &thr, mode, &p))
                });
            }
            let id = BenchmarkId::new(format!("{case}/diagnose/f32"), threads);
            group.bench_function(id, |b| {
                let m = Matrix::row_major(&data32, n, n_m).unwrap();
                b.iter(|| falsify_once(m, &measured, &thr, Mode::Diagnose, &p))
            });
        }
    }
    group.finish();
}

/// Short rows (5 and 10 sensors, f64 and f32, worst and typical as in
/// `short_rows`) through the falsifier with diagnostics, one thread, 8 MB of
/// f64 or 4 MB of f32:
/// slabs, tasks and a kernel call per task on top of the kernel, so its cost
/// over `short_rows`' "diagnose_bits" is what the falsifier adds.
/// `cargo bench -- falsify_short`.
fn falsify_short(c: &mut Criterion) {
    let p = pool(1);
    for n_m in [5usize, 10] {
        let n = (1 << 20) / n_m;
        let data = values(n * n_m);
        let data32: Vec<f32> = data.iter().map(|&v| v as f32).collect();
        let mut group = c.benchmark_group(format!("falsify_short_{n_m}"));
        group.throughput(Throughput::Elements(n as u64));
        for (case, half_width) in [("worst", 10.0), ("typical", 1.5)] {
            let thr = Thresholds::new(vec![-half_width; n_m], vec![half_width; n_m]).unwrap();
            let measured = vec![0.0; n_m];
            group.bench_function(BenchmarkId::new(format!("{case}/diagnose"), "f64"), |b| {
                let m = Matrix::row_major(&data, n, n_m).unwrap();
                b.iter(|| falsify_once(m, &measured, &thr, Mode::Diagnose, &p))
            });
            group.bench_function(BenchmarkId::new(format!("{case}/diagnose"), "f32"), |b| {
                let m = Matrix::row_major(&data32, n, n_m).unwrap();
                b.iter(|| falsify_once(m, &measured, &thr, Mode::Diagnose, &p))
            });
        }
        group.finish();
    }
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
            bench.iter(|| screen_with(isa, black_box(m), &b, &plan, &mut out))
        });
    }
    group.finish();
}

/// One pass of the bit-writing diagnostics over `m` (f64) or `m32` (f32),
/// no count per row, as `falsify` runs without `keep_violations`.
fn diagnose_bits_once(
    isa: Isa,
    m: Matrix<'_, f64>,
    m32: Matrix<'_, f32>,
    is32: bool,
    b: &SensorBounds,
    words: &mut [u64],
) -> u64 {
    let mut t = Tally::zeros(b.len());
    let mut sink = BitSink::new(words, 0);
    if is32 {
        diagnose_bits_with(isa, black_box(m32), b, None, &mut sink, &mut t);
    } else {
        diagnose_bits_with(isa, black_box(m), b, None, &mut sink, &mut t);
    }
    sink.finish();
    t.invalid
}

/// One pass of screening into candidate bits over `m` (f64) or `m32` (f32),
/// as `falsify` screens.
fn screen_bits_once(
    isa: Isa,
    m: Matrix<'_, f64>,
    m32: Matrix<'_, f32>,
    is32: bool,
    (b, plan): (&SensorBounds, &ScreenPlan),
    words: &mut [u64],
) {
    let mut sink = BitSink::new(words, 0);
    if is32 {
        screen_bits_with(isa, black_box(m32), b, plan, &mut sink);
    } else {
        screen_bits_with(isa, black_box(m), b, plan, &mut sink);
    }
    sink.finish();
}

/// Short rows (5, 10 and 16 sensors; f64 and f32), the kernels alone on one
/// thread at every level, worst case (every row a candidate) and typical (a
/// few per cent candidates): 8 MB of predictions, so the cost per row shows
/// rather than the memory's. "diagnose" keeps a count per row
/// (`keep_violations`), "diagnose_bits" does not; "screen_bits" writes
/// candidate bits as `falsify` does, "screen" one verdict per row.
/// `cargo bench -- short_rows`.
fn short_rows(c: &mut Criterion) {
    for n_m in [5usize, 10, 16] {
        let n = (1 << 20) / n_m;
        let data = values(n * n_m);
        let data32: Vec<f32> = data.iter().map(|&v| v as f32).collect();
        let mut out = vec![0u32; n];
        let mut group = c.benchmark_group(format!("short_rows_{n_m}"));
        group.throughput(Throughput::Elements(n as u64));
        for (case, half_width) in [("worst", 10.0), ("typical", 1.5)] {
            let b =
                SensorBounds::new(&vec![0.0; n_m], &vec![-half_width; n_m], &vec![half_width; n_m]).unwrap();
            let plan = ScreenPlan::new(&b, &vec![0; n_m]);
            for isa in Isa::available() {
                let m = Matrix::row_major(&data, n, n_m).unwrap();
                let m32 = Matrix::row_major(&data32, n, n_m).unwrap();
                for (dtype, is32) in [("f64", false), ("f32", true)] {
                    let id = BenchmarkId::new(format!("{case}/diagnose/{dtype}"), format!("{isa:?}"));
                    group.bench_function(id, |bench| {
                        bench.iter(|| {
                            let mut t = Tally::zeros(n_m);
                            if is32 {
                                diagnose_with(isa, black_box(m32), &b, &mut out, &mut t);
                            } else {
                                diagnose_with(isa, black_box(m), &b, &mut out, &mut t);
                            }
                            t.invalid
                        })
                    });
                    // As `falsify` runs without `keep_violations`: candidate
                    // bits and the tally, no count per row.
                    let id = BenchmarkId::new(format!("{case}/diagnose_bits/{dtype}"), format!("{isa:?}"));
                    let mut words = vec![0u64; n.div_ceil(64)];
                    group.bench_function(id, |bench| {
                        bench.iter(|| diagnose_bits_once(isa, m, m32, is32, &b, &mut words))
                    });
                    // As `falsify` screens: candidate bits.
                    let id = BenchmarkId::new(format!("{case}/screen_bits/{dtype}"), format!("{isa:?}"));
                    group.bench_function(id, |bench| {
                        bench.iter(|| screen_bits_once(isa, m, m32, is32, (&b, &plan), &mut words))
                    });
                    let id = BenchmarkId::new(format!("{case}/screen/{dtype}"), format!("{isa:?}"));
                    group.bench_function(id, |bench| {
                        bench.iter(|| {
                            if is32 {
                                screen_with(isa, black_box(m32), &b, &plan, &mut out)
                            } else {
                                screen_with(isa, black_box(m), &b, &plan, &mut out)
                            }
                        })
                    });
                }
            }
        }
        group.finish();
    }
}

/// Long rows (50, 100 and 200 sensors; f64 and f32) with diagnostics and
/// screening, the kernel alone on one thread at the widest level and at AVX2
/// (`long_avx2` there, whatever the width): worst case
/// (every row a candidate: the verdict-first path) and typical (about 1.2 %
/// of values outside each interval: 45 % of rows of 50 falsified, 70 % of
/// rows of 100, 91 % of rows of 200; every rejected row attributed), 8 MB
/// of predictions, bits into a sink as the falsifier writes them; with
/// diagnostics rows of 50 take the medium kernel (rows of up to 64 sensors
/// in registers), rows of 100 and 200 the long-row one.
/// `cargo bench -- long_rows`.
fn long_rows(c: &mut Criterion) {
    // The widest level, and AVX2 (the level of CPUs without AVX-512).
    let mut levels = vec![Isa::detect()];
    if Isa::Avx2.supported() && levels[0] != Isa::Avx2 {
        levels.push(Isa::Avx2);
    }
    for n_m in [50usize, 100, 200] {
        let n = (1 << 20) / n_m;
        let data = values(n * n_m);
        let data32: Vec<f32> = data.iter().map(|&v| v as f32).collect();
        let mut words = vec![0u64; n.div_ceil(64)];
        let mut group = c.benchmark_group(format!("long_rows_{n_m}"));
        group.throughput(Throughput::Elements(n as u64));
        // Typical: about 1.2 % of values outside each sensor's interval.
        for (case, half_width) in [("worst", 10.0), ("typical", 2.4)] {
            let b =
                SensorBounds::new(&vec![0.0; n_m], &vec![-half_width; n_m], &vec![half_width; n_m]).unwrap();
            let m = Matrix::row_major(&data, n, n_m).unwrap();
            let m32 = Matrix::row_major(&data32, n, n_m).unwrap();
            let runs = levels.iter().flat_map(|&i| [(i, ("f64", false)), (i, ("f32", true))]);
            for (isa, (dtype, is32)) in runs {
                group.bench_function(BenchmarkId::new(format!("{case}/diagnose/{dtype}"), format!("{isa:?}")), |bench| {
                    bench.iter(|| diagnose_bits_once(isa, m, m32, is32, &b, &mut words))
                });
                let plan = ScreenPlan::new(&b, &vec![0; n_m]);
                group.bench_function(BenchmarkId::new(format!("{case}/screen/{dtype}"), format!("{isa:?}")), |bench| {
                    bench.iter(|| screen_bits_once(isa, m, m32, is32, (&b, &plan), &mut words))
                });
            }
        }
        group.finish();
    }
}

/// A plain sum at the widest vectors this CPU has: the fastest way to read.
fn bare_sum(values: &[f64]) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx512f") {
        // SAFETY: AVX-512F was just detected.
        return unsafe { sum512(values) };
    }
    // Eight independent sums, so the adds never wait on each other.
    let mut acc = [0.0f64; 8];
    for v in values.chunks_exact(8) {
        for l in 0..8 {
            acc[l] += v[l];
        }
    }
    acc.iter().sum::<f64>() + values.chunks_exact(8).remainder().iter().sum::<f64>()
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn sum512(values: &[f64]) -> f64 {
    use std::arch::x86_64::*;
    let mut acc = [_mm512_setzero_pd(); 4];
    let blocks = values.chunks_exact(32);
    let rest: f64 = blocks.remainder().iter().sum();
    for b in blocks {
        for (k, a) in acc.iter_mut().enumerate() {
            // SAFETY: `b` holds 32 values, so 8 from 8k are in bounds.
            *a = _mm512_add_pd(*a, unsafe { _mm512_loadu_pd(b.as_ptr().add(8 * k)) });
        }
    }
    let total = _mm512_add_pd(_mm512_add_pd(acc[0], acc[1]), _mm512_add_pd(acc[2], acc[3]));
    _mm512_reduce_add_pd(total) + rest
}

/// The memory floor: falsifying 2,000,000 x 50 float64 (800 MB, far beyond
/// the caches) with every instance a candidate, beside a bare parallel sum
/// over the same bytes. Both report bytes/s; their ratio is how close the
/// kernel runs to the machine's read bandwidth.
fn memory_floor(c: &mut Criterion) {
    let (n, n_m) = (2_000_000, 50);
    let data: Vec<f64> = values(n * n_m).iter().map(|v| v * 0.1).collect();
    let thr = Thresholds::new(vec![-10.0; n_m], vec![10.0; n_m]).unwrap();
    let measured = vec![0.0; n_m];
    let p = pool(2);
    let mut group = c.benchmark_group("memory_floor");
    group.throughput(Throughput::Bytes((n * n_m * 8) as u64));
    group.bench_function("bare_sum_2_threads", |b| {
        b.iter(|| {
            p.install(|| {
                use rayon::prelude::*;
                black_box(&data).par_chunks(1 << 16).map(bare_sum).sum::<f64>()
            })
        })
    });
    group.bench_function("falsify_screen_2_threads", |b| {
        let m = Matrix::row_major(&data, n, n_m).unwrap();
        b.iter(|| {
            let mut f = Falsifier::new(&measured, &thr, Mode::Screen, false).unwrap();
            f.update(black_box(m), &p, &mut || false).unwrap();
            assert_eq!(f.n_candidates(), n as u64);
        })
    });
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
    targets = falsify, falsify_short, isa_levels, short_rows, long_rows, memory_floor, thresholds
}
criterion_main!(benches);
