//! Criterion benchmarks of the design kernels (no Python): greedy placement
//! by joint entropy and expected-identifiability counts.
//! `cargo bench --bench design_kernels`.

use criterion::{criterion_group, criterion_main, Criterion};
use edmf_core::design::{candidate_counts, place, PlacementOptions};
use edmf_core::Matrix;
use std::hint::black_box;
use std::time::Duration;

/// A smooth 3-parameter response along a beam, deterministic, with near-ties.
fn predictions(n: usize, l: usize) -> Vec<f64> {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut g = Vec::with_capacity(n * l);
    for _ in 0..n {
        let (a, b, c) = (0.5 + uniform(), 0.5 + uniform(), 0.5 + uniform());
        for j in 0..l {
            let x = j as f64 / (l - 1) as f64;
            g.push(a * (std::f64::consts::PI * x).sin() + b * x * x + c * (3.0 * x).cos());
        }
    }
    g
}

fn design(c: &mut Criterion) {
    let (n, l, k) = (20_000, 200, 10);
    let data = predictions(n, l);
    let g = Matrix::row_major(&data, n, l).unwrap();
    let widths = vec![0.02; l];
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    let mut group = c.benchmark_group("design");
    group.sample_size(10).measurement_time(Duration::from_secs(5));
    group.bench_function("place/20000x200/k10", |b| {
        let opts = PlacementOptions {
            k,
            ..Default::default()
        };
        b.iter(|| {
            place(black_box(g), &widths, &opts, &pool, &mut || false)
                .unwrap()
                .order
        })
    });
    let sensors: Vec<usize> = (0..k).map(|i| i * 19).collect();
    let sims = 200;
    let truth: Vec<u64> = (0..sims as u64).map(|s| (s * 7919) % n as u64).collect();
    let residuals = vec![0.001; sims * k];
    let res = Matrix::row_major(&residuals, sims, k).unwrap();
    group.bench_function("candidate_counts/20000/200sims/10sensors", |b| {
        b.iter(|| {
            candidate_counts(
                black_box(g),
                &sensors,
                &truth,
                res,
                &[-0.01; 10],
                &[0.01; 10],
                &pool,
                &mut || false,
            )
            .unwrap()
        })
    });
    group.finish();
}

criterion_group!(benches, design);
criterion_main!(benches);
