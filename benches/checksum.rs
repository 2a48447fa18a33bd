//! Criterion benchmarks of the checkpoint's block checksum (`digest.rs`),
//! float64 and float32, beside XXH3-128 and the screening kernel it runs
//! next to, on the same bytes, one thread: `cargo bench --bench checksum`. Their ratio is the checksum's
//! least cost in a checkpointed run whose falsifier is not waiting on memory
//! (see `benches/hash_cost.py`). No Python involved.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use edmf_core::digest::{sum_with, Sums};
use edmf_core::kernel::{screen_with, ScreenPlan, SensorBounds};
use edmf_core::{Isa, Matrix};
use std::hint::black_box;
use std::time::Duration;

/// Rows of `N_M` sensors, the common short-row case.
const N_M: usize = 10;

fn checksum(c: &mut Criterion) {
    let mut group = c.benchmark_group("checksum");
    // In L1, in L2, in memory.
    for kib in [16usize, 256, 64 << 10] {
        let n = kib * 1024 / 8;
        let data: Vec<f64> = (0..n).map(|i| (i % 977) as f64 * 0.37 - 150.0).collect();
        // The same bytes as float32 values (summed at their own width since fletcher64x8/2).
        let narrow: Vec<f32> = (0..2 * n).map(|i| (i % 977) as f32 * 0.37 - 150.0).collect();
        group.throughput(Throughput::Bytes((n * 8) as u64));
        for isa in Isa::available() {
            group.bench_function(BenchmarkId::new(format!("sum/{isa:?}"), kib), |b| {
                b.iter(|| {
                    let mut s = Sums::default();
                    sum_with(isa, black_box(&data), 0, &mut s);
                    s
                })
            });
            group.bench_function(BenchmarkId::new(format!("sum32/{isa:?}"), kib), |b| {
                b.iter(|| {
                    let mut s = Sums::default();
                    sum_with(isa, black_box(&narrow), 0, &mut s);
                    s
                })
            });
        }
        // XXH3-128 of the same bytes, the hash the issue suggested: what a
        // hashed instead of summed block checksum would cost.
        let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
        group.bench_function(BenchmarkId::new("xxh3_128", kib), |b| {
            b.iter(|| twox_hash::XxHash3_128::oneshot(black_box(&bytes)))
        });
        // Screening the same bytes as rows of N_M sensors, every row a candidate (no early exit).
        let rows = n / N_M;
        let measured = vec![0.0; N_M];
        let bounds = SensorBounds::new(&measured, &[-1e9; N_M], &[1e9; N_M]).unwrap();
        let plan = ScreenPlan::new(&bounds, &[0; N_M]);
        let mut out = vec![0u32; rows];
        group.bench_function(BenchmarkId::new("screen/worst", kib), |b| {
            let m = Matrix::row_major(&data[..rows * N_M], rows, N_M).unwrap();
            b.iter(|| screen_with(Isa::detect(), black_box(m), &bounds, &plan, &mut out))
        });
    }
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().measurement_time(Duration::from_secs(2)).warm_up_time(Duration::from_millis(500));
    targets = checksum
}
criterion_main!(benches);
