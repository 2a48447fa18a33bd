//! Unit tests of the row kernels: every instruction-set level against the
//! portable, literal residual test.

use super::*;

/// The bit-writing kernels at `isa` against the per-row counts `want` and
/// tally `tw` of the portable kernel: candidate bits (written from bit
/// `offset`, in two pieces split at row `split`), counts when asked for,
/// the same tally whether or not counts are kept, and screening's bits.
fn check_bits<T: Prediction>(
    isa: Isa,
    m: Matrix<'_, T>,
    b: &SensorBounds,
    plan: &ScreenPlan,
    want: &[u32],
    tw: &Tally,
    what: &str,
) {
    let rows = m.rows();
    for (offset, split) in [(0usize, 0usize), (5, rows / 2), (64, rows / 3), (67, rows)] {
        let expect: Vec<bool> = want.iter().map(|&n| n == 0).collect();
        let bit = |w: &[u64], i: usize| (w[(offset + i) / 64] >> ((offset + i) % 64)) & 1 == 1;
        for keep in [false, true] {
            let mut words = vec![0u64; (offset + rows).div_ceil(64) + 1];
            let (mut counts, mut t) = (vec![7u32; rows], Tally::zeros(b.len()));
            for (r0, r1) in [(0, split), (split, rows)] {
                let mut sink = BitSink::new(&mut words, offset + r0);
                let c = if keep { Some(&mut counts[r0..r1]) } else { None };
                diagnose_bits_with(isa, m.slice_rows(r0, r1), b, c, &mut sink, &mut t);
                sink.finish();
            }
            let got: Vec<bool> = (0..rows).map(|i| bit(&words, i)).collect();
            assert_eq!(got, expect, "{isa:?} {what}: diagnose bits, keep {keep}, offset {offset}");
            assert_eq!(crate::candidates::count_bits(&words), expect.iter().filter(|&&c| c).count());
            assert_eq!(&t, tw, "{isa:?} {what}: tally, keep {keep}");
            if keep {
                assert_eq!(counts, want, "{isa:?} {what}: counts");
            }
        }
        let mut words = vec![0u64; (offset + rows).div_ceil(64) + 1];
        for (r0, r1) in [(0, split), (split, rows)] {
            let mut sink = BitSink::new(&mut words, offset + r0);
            screen_bits_with(isa, m.slice_rows(r0, r1), b, plan, &mut sink);
            sink.finish();
        }
        let got: Vec<bool> = (0..rows).map(|i| bit(&words, i)).collect();
        assert_eq!(got, expect, "{isa:?} {what}: screen bits, offset {offset}");
    }
}

/// Vector and portable kernels agree for every row width (lane remainders,
/// short rows held in registers, partial blocks), with ties on the bounds,
/// NaN and infinities, and the portable kernel's blocks screened out of
/// column order.
#[test]
fn vector_kernels_match_portable_ones() {
    let specials = [0.5, -0.5, 0.25, f64::NAN, f64::INFINITY, -2.0, 0.0, 1.0, -0.49];
    // The portable kernel stops at the first rejecting block and the vector
    // kernels test whole rows: both, with rows of partial blocks.
    for k in (1..=50usize).chain([63, 64, 65, 80, 96, 97, 113, 127, 128, 129, 130, 300]) {
        // Bounds differ from sensor to sensor, so a lane reading another
        // sensor's bounds shows up.
        let y: Vec<f64> = (0..k).map(|j| 0.25 * (j % 3) as f64).collect();
        let lo: Vec<f64> = (0..k).map(|j| -0.25 - 0.25 * (j % 2) as f64).collect();
        let hi: Vec<f64> = (0..k).map(|j| 0.5 + 0.25 * (j % 4) as f64).collect();
        let b = SensorBounds::new(&y, &lo, &hi).unwrap();
        let rows = 71; // not a whole number of tiles
                       // About two special values per row (drawn at random), so that some
                       // rows are candidates and others not, whatever their width.
        let mut state = 0x2545_F491_4F6C_DD1Du64 ^ k as u64;
        let data: Vec<f64> = (0..rows * k)
            .map(|i| {
                let u = crate::testing::uniform(&mut state);
                let special = specials[(u * 1e6) as usize % specials.len()];
                y[i % k] + if u < 2.0 / k as f64 { special } else { 0.0 }
            })
            .collect();
        let data32: Vec<f32> = data.iter().map(|&v| v as f32).collect();
        let m = Matrix::row_major(&data, rows, k).unwrap();
        let m32 = Matrix::row_major(&data32, rows, k).unwrap();
        let rejections: Vec<u64> = (0..k as u64).map(|j| j * j % 11).collect();
        let plan = ScreenPlan::new(&b, &rejections);
        let (mut a, mut c) = (vec![0u32; rows], vec![0u32; rows]);
        for isa in Isa::available() {
            let (mut ta, mut tc) = (Tally::zeros(k), Tally::zeros(k));
            diagnose_with(isa, m, &b, &mut a, &mut ta);
            diagnose_with(Isa::Portable, m, &b, &mut c, &mut tc);
            assert_eq!((&a, &ta), (&c, &tc), "{isa:?} f64 diagnose, {k} sensors");
            diagnose_with(isa, m32, &b, &mut a, &mut ta);
            diagnose_with(Isa::Portable, m32, &b, &mut c, &mut tc);
            assert_eq!((&a, &ta), (&c, &tc), "{isa:?} f32 diagnose, {k} sensors");
            screen_with(isa, m32, &b, &plan, &mut a);
            screen_with(Isa::Portable, m32, &b, &plan, &mut c);
            assert_eq!(a, c, "{isa:?} f32 screen, {k} sensors");
            screen_with(isa, m, &b, &plan, &mut a);
            screen_with(Isa::Portable, m, &b, &plan, &mut c);
            assert_eq!(a, c, "{isa:?} screen, {k} sensors");
            let (mut want, mut tw) = (vec![0u32; rows], Tally::zeros(k));
            diagnose_with(Isa::Portable, m, &b, &mut want, &mut tw);
            check_bits(isa, m, &b, &plan, &want, &tw, &format!("f64, {k} sensors"));
            let mut tw = Tally::zeros(k);
            diagnose_with(Isa::Portable, m32, &b, &mut want, &mut tw);
            check_bits(isa, m32, &b, &plan, &want, &tw, &format!("f32, {k} sensors"));
        }
        let rejected = c.iter().filter(|&&r| r > 0).count();
        assert!(
            0 < rejected && rejected < rows,
            "{rejected} of {rows} rejected, {k} sensors"
        );
        let flags: Vec<u32> = (0..rows).map(|i| (c[i] > 0) as u32).collect();
        diagnose_with(Isa::Portable, m, &b, &mut c, &mut Tally::zeros(k));
        assert_eq!(flags, c.iter().map(|&n| (n > 0) as u32).collect::<Vec<_>>());
        let transposed: Vec<f64> = (0..k)
            .flat_map(|j| (0..rows).map(move |i| (i, j)))
            .map(|(i, j)| data[i * k + j])
            .collect();
        let mf = Matrix::col_major(&transposed, rows, k).unwrap();
        let (mut tf, mut tc) = (Tally::zeros(k), Tally::zeros(k));
        let mut f = vec![0u32; rows];
        diagnose(mf, &b, &mut f, &mut tf);
        diagnose_with(Isa::Portable, m, &b, &mut c, &mut tc);
        assert_eq!((&f, &tf), (&c, &tc), "column-major, {k} sensors");
    }
}

/// Predictions one float step either side of the rounded bounds, where
/// the acceptance intervals of the vector kernels must reproduce the
/// residual test's rounding exactly (f64 and f32 predictions).
#[test]
fn vector_kernels_round_like_the_residual_test() {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut uniform = || crate::testing::uniform(&mut state);
    for k in [3, 8, 17, 33] {
        let y: Vec<f64> = (0..k).map(|_| (uniform() - 0.5) * 1e3).collect();
        let lo: Vec<f64> = (0..k).map(|_| -uniform() * 1e-3).collect();
        let hi: Vec<f64> = (0..k).map(|_| uniform() * 1e-3).collect();
        let b = SensorBounds::new(&y, &lo, &hi).unwrap();
        let rows = 96;
        let data: Vec<f64> = (0..rows * k)
            .map(|i| {
                let j = i % k;
                let edge = if (i / k) % 2 == 0 {
                    y[j] + lo[j]
                } else {
                    y[j] + hi[j]
                };
                let steps = (i / (2 * k)) as i64 % 5 - 2;
                f64::from_bits((edge.to_bits() as i64 + steps) as u64)
            })
            .collect();
        let data32: Vec<f32> = data.iter().map(|&v| v as f32).collect();
        let plan = ScreenPlan::new(&b, &vec![0; k]);
        for isa in Isa::available() {
            let (mut a, mut c) = (vec![0u32; rows], vec![0u32; rows]);
            let (mut ta, mut tc) = (Tally::zeros(k), Tally::zeros(k));
            let m = Matrix::row_major(&data, rows, k).unwrap();
            diagnose_with(isa, m, &b, &mut a, &mut ta);
            diagnose_with(Isa::Portable, m, &b, &mut c, &mut tc);
            assert_eq!((&a, &ta), (&c, &tc), "{isa:?} f64, {k} sensors");
            assert!(c.iter().any(|&n| n > 0) && ta.per_sensor.iter().any(|&n| n < rows as u64));
            let m32 = Matrix::row_major(&data32, rows, k).unwrap();
            diagnose_with(isa, m32, &b, &mut a, &mut ta);
            diagnose_with(Isa::Portable, m32, &b, &mut c, &mut tc);
            assert_eq!((&a, &ta), (&c, &tc), "{isa:?} f32, {k} sensors");
            screen_with(isa, m, &b, &plan, &mut a);
            screen_with(Isa::Portable, m, &b, &plan, &mut c);
            assert_eq!(a, c, "{isa:?} f64 screen, {k} sensors");
        }
    }
}

#[test]
fn bounds_are_inclusive_and_nan_is_outside() {
    let b = SensorBounds::new(&[1.0, 1.0], &[-0.5, -0.5], &[0.5, 0.5]).unwrap();
    // rows: on both bounds, one sensor out, NaN, both out
    let p = [0.5, 1.5, 0.49, 1.0, f64::NAN, 1.0, 3.0, -3.0];
    let m = Matrix::row_major(&p, 4, 2).unwrap();
    let mut out = [9u32; 4];
    let mut t = Tally::zeros(2);
    diagnose(m, &b, &mut out, &mut t);
    assert_eq!(out, [0, 1, 1, 2]);
    assert_eq!(t.per_sensor, vec![3, 1]);
    assert_eq!(t.only_by, vec![2, 0]);
    assert_eq!(t.invalid, 1);
    let mut flags = [9u32; 4];
    screen(m, &b, &ScreenPlan::new(&b, &[0, 5]), &mut flags);
    assert_eq!(flags, [0, 1, 1, 1]);
}

#[test]
fn f32_residuals_are_formed_in_f64() {
    // 0.1f32 is not 0.1; the residual must use its exact f64 value.
    let x = 0.1f32;
    let b = SensorBounds::new(&[0.0], &[x as f64], &[x as f64]).unwrap();
    let m = Matrix::row_major(std::slice::from_ref(&x), 1, 1).unwrap();
    let mut out = [9u32];
    diagnose(m, &b, &mut out, &mut Tally::zeros(1));
    assert_eq!(out, [0]);
}

#[test]
fn strided_view_matches_contiguous() {
    let b = SensorBounds::new(&[0.0, 0.0, 0.0], &[-1.0; 3], &[1.0; 3]).unwrap();
    let c = [0.0, 2.0, 0.5, -0.5, 0.0, 0.9, 5.0, 5.0, 5.0];
    let f = [0.0, -0.5, 5.0, 2.0, 0.0, 5.0, 0.5, 0.9, 5.0];
    let (mut oc, mut of) = ([0u32; 3], [0u32; 3]);
    let (mut tc, mut tf) = (Tally::zeros(3), Tally::zeros(3));
    diagnose(Matrix::row_major(&c, 3, 3).unwrap(), &b, &mut oc, &mut tc);
    diagnose(Matrix::col_major(&f, 3, 3).unwrap(), &b, &mut of, &mut tf);
    assert_eq!(oc, of);
    assert_eq!(tc, tf);
    assert_eq!(oc, [1, 0, 3]);
}

#[test]
fn levels_are_named_for_the_environment_variable() {
    assert_eq!(Isa::from_name("AVX512"), Some(Isa::Avx512));
    assert_eq!(Isa::from_name(" avx2"), Some(Isa::Avx2));
    assert_eq!(Isa::from_name("portable"), Some(Isa::Portable));
    assert_eq!(Isa::from_name("sse9"), None);
}

/// Short rows (up to two vectors) in every layout the short-row kernels
/// read: back to back (packed several to a vector), with a gap after each
/// row (one row per vector), and column-major (portable path); row counts
/// that leave a partial unit; all-candidate, all-falsified and mixed blocks.
#[test]
fn short_rows_match_portable_in_every_layout() {
    let specials = [
        0.5,
        -0.5,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        -2.0,
        0.0,
        1.0,
    ];
    for k in 1..=40usize {
        let y: Vec<f64> = (0..k).map(|j| 0.25 * (j % 3) as f64).collect();
        let lo: Vec<f64> = (0..k).map(|j| -0.25 - 0.25 * (j % 2) as f64).collect();
        let hi: Vec<f64> = (0..k).map(|j| 0.5 + 0.25 * (j % 4) as f64).collect();
        let b = SensorBounds::new(&y, &lo, &hi).unwrap();
        let plan = ScreenPlan::new(&b, &vec![0; k]);
        for (rows, rate) in [(37usize, 1.0), (200, 0.0), (203, 100.0), (1, 2.0), (0, 1.0)] {
            let mut state = 0x1234_5678_9ABC_DEF1u64 ^ (k * 1000 + rows) as u64;
            let gap = 3; // values between rows in the strided layout
            let mut wide = vec![0f64; rows * (k + gap)];
            for i in 0..rows {
                for j in 0..k {
                    let u = crate::testing::uniform(&mut state);
                    let special = specials[(u * 1e6) as usize % specials.len()];
                    wide[i * (k + gap) + j] = y[j] + if u < rate / k as f64 { special } else { 0.0 };
                }
            }
            let packed: Vec<f64> = (0..rows * k).map(|e| wide[(e / k) * (k + gap) + e % k]).collect();
            let wide32: Vec<f32> = wide.iter().map(|&v| v as f32).collect();
            let packed32: Vec<f32> = packed.iter().map(|&v| v as f32).collect();
            let cm: Vec<f64> = (0..rows * k)
                .map(|e| packed[(e % rows.max(1)) * k + e / rows.max(1)])
                .collect();
            let mc = Matrix::row_major(&packed, rows, k).unwrap();
            let views64 = [
                Matrix::new(&wide, rows, k, k + gap, 1).unwrap(),
                Matrix::col_major(&cm, rows, k).unwrap(),
                mc,
            ];
            let views32 = [
                Matrix::row_major(&packed32, rows, k).unwrap(),
                Matrix::new(&wide32, rows, k, k + gap, 1).unwrap(),
            ];
            let (mut want, mut tw) = (vec![0u32; rows], Tally::zeros(k));
            diagnose_with(Isa::Portable, mc, &b, &mut want, &mut tw);
            let mut flags = vec![0u32; rows];
            screen_with(Isa::Portable, mc, &b, &plan, &mut flags);
            assert_eq!(flags, want.iter().map(|&n| (n > 0) as u32).collect::<Vec<_>>());
            for isa in Isa::available() {
                let mut got = vec![9u32; rows];
                let check = |got: &[u32], t: &Tally, what: &str| {
                    assert_eq!(
                        (got, t),
                        (&want[..], &tw),
                        "{isa:?} {what}, {k} sensors, {rows} rows"
                    )
                };
                for (v, m) in views64.iter().enumerate() {
                    let mut t = Tally::zeros(k);
                    diagnose_with(isa, *m, &b, &mut got, &mut t);
                    check(&got, &t, &format!("f64 view {v}"));
                    check_bits(isa, *m, &b, &plan, &want, &tw, &format!("f64 view {v}, {k} sensors, {rows} rows"));
                    screen_with(isa, *m, &b, &plan, &mut got);
                    assert_eq!(got, flags, "{isa:?} screen f64 view {v}, {k} sensors");
                }
                // f32 predictions have their own verdicts: compare with the portable f32 kernel.
                for (v, m) in views32.iter().enumerate() {
                    let (mut w32, mut t32) = (vec![0u32; rows], Tally::zeros(k));
                    diagnose_with(Isa::Portable, *m, &b, &mut w32, &mut t32);
                    let mut t = Tally::zeros(k);
                    diagnose_with(isa, *m, &b, &mut got, &mut t);
                    assert_eq!((&got, &t), (&w32, &t32), "{isa:?} f32 view {v}, {k} sensors");
                    check_bits(isa, *m, &b, &plan, &w32, &t32, &format!("f32 view {v}, {k} sensors, {rows} rows"));
                    screen_with(isa, *m, &b, &plan, &mut got);
                    let f32_flags: Vec<u32> = w32.iter().map(|&n| (n > 0) as u32).collect();
                    assert_eq!(got, f32_flags, "{isa:?} screen f32 view {v}, {k} sensors");
                }
            }
            if rows == 37 {
                let rejected = want.iter().filter(|&&n| n > 0).count();
                assert!(
                    0 < rejected && rejected < rows,
                    "{k} sensors: {rejected} rejected"
                );
            }
            if rows == 200 {
                assert!(want.iter().all(|&n| n == 0), "all candidates");
            }
        }
    }
}

/// An acceptance interval no prediction reaches (empty for f32: a zero-width
/// threshold between two floats) beside NaN predictions: the periodic
/// kernel then cannot tell NaN by "outside on both sides" and must count
/// invalid rows by the NaN test itself. The medium kernel (rows of 17-64
/// f64, 33-128 f32), which counts accepting sensors, and the long-row kernel
/// are held to the same (rows of 17-130).
#[test]
fn empty_intervals_and_nan_rows_match_portable() {
    for k in [3usize, 5, 6, 9, 10, 12, 16, 20, 17, 33, 50, 64, 65, 130] {
        let y: Vec<f64> = (0..k).map(|j| 0.1 + 0.25 * j as f64).collect();
        let mut lo: Vec<f64> = vec![-0.5; k];
        let mut hi: Vec<f64> = vec![0.5; k];
        (lo[k / 2], hi[k / 2]) = (1e-12, 1e-12); // no f32 prediction lands on it
        let b = SensorBounds::new(&y, &lo, &hi).unwrap();
        assert!(!(b.accept32[0][k / 2] <= b.accept32[1][k / 2]), "an empty f32 interval");
        let plan = ScreenPlan::new(&b, &vec![0; k]);
        let rows = 300;
        let mut state = 0xABCD_EF01_2345_6789u64 ^ k as u64;
        let data: Vec<f64> = (0..rows * k)
            .map(|i| {
                let u = crate::testing::uniform(&mut state);
                if u < 0.03 {
                    f64::NAN
                } else {
                    y[i % k] + (u - 0.5) * 1.2
                }
            })
            .collect();
        let data32: Vec<f32> = data.iter().map(|&v| v as f32).collect();
        let m = Matrix::row_major(&data, rows, k).unwrap();
        let m32 = Matrix::row_major(&data32, rows, k).unwrap();
        for isa in Isa::available() {
            let (mut want, mut tw) = (vec![0u32; rows], Tally::zeros(k));
            diagnose_with(Isa::Portable, m32, &b, &mut want, &mut tw);
            assert!(tw.invalid > 0 && want.iter().all(|&n| n > 0), "every f32 row rejected, some NaN");
            check_bits(isa, m32, &b, &plan, &want, &tw, &format!("f32 empty interval, {k} sensors"));
            let (mut want, mut tw) = (vec![0u32; rows], Tally::zeros(k));
            diagnose_with(Isa::Portable, m, &b, &mut want, &mut tw);
            check_bits(isa, m, &b, &plan, &want, &tw, &format!("f64, {k} sensors"));
        }
    }
}

/// The kernels look for NaN only where values sum to NaN (a period, a batch
/// of rows, or a row): +inf and -inf in one period or row (a NaN sum, no NaN
/// value) must count no invalid row, and a NaN next to them must count one;
/// at every level.
#[test]
fn infinities_that_cancel_are_not_nan() {
    // 9 and 16 (and f32 17 and 25): rows read one per unit, NaN looked for
    // where a batch of rows sums to NaN; -inf under a +inf one row down makes
    // such a sum without a NaN. 33-200: the medium and long-row kernels sum
    // each row lane by lane, so -inf also at sensor 16, in sensor 0's lane
    // (vectors of 4, 8 and 16 from the row's start).
    for k in [3usize, 5, 7, 9, 10, 12, 16, 17, 25, 33, 50, 64, 65, 100, 200] {
        let y = vec![0.0; k];
        let b = SensorBounds::new(&y, &vec![-1.0; k], &vec![1.0; k]).unwrap();
        let rows = 200;
        for with_nan in [false, true] {
            let mut data: Vec<f64> = (0..rows * k).map(|i| ((i * 7) % 13) as f64 * 0.25 - 1.5).collect();
            for r in (0..rows).step_by(9) {
                data[r * k] = f64::INFINITY;
                data[r * k + k - 1] = f64::NEG_INFINITY;
                data[(r + 1) * k] = f64::NEG_INFINITY;
                if k > 32 {
                    data[r * k + 16] = f64::NEG_INFINITY;
                }
                if with_nan && r % 2 == 0 {
                    data[r * k + k / 2] = f64::NAN;
                }
            }
            let tw = every_level_as_portable(&data, (rows, k), &b, &format!("infinities, {k} sensors"));
            assert_eq!(tw.invalid, if with_nan { rows.div_ceil(18) as u64 } else { 0 });
        }
    }
}

/// The periodic kernel counts rejections and "falsified only by" per bit of
/// a period in byte lanes, moved to wide totals every 255 periods: one call
/// over more periods than that, in which one sensor rejects every row (alone
/// in most), gives the portable kernel's tally at every level.
#[test]
fn periodic_byte_counts_survive_flushes() {
    // 8, 16, 24, 32 and 48: rows of whole vectors (periods of several rows at
    // AVX2); 2, 3, 4, 6, 8 and 12: patterns repeated in a period (`Period::new`).
    for k in [2usize, 3, 4, 5, 6, 7, 8, 10, 12, 14, 16, 24, 32, 48] {
        // 500 periods or more of every period length these widths take.
        let rows = 16_000 - 16_000 % (16 * k) + 7;
        let b = SensorBounds::new(&vec![0.0; k], &vec![-1.0; k], &vec![1.0; k]).unwrap();
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        // Sensor 1 also holds NaN, and infinities of both signs in rows far apart.
        let data: Vec<f64> = (0..rows * k)
            .map(|i| match (i % k, (i / k) % 997, (i / k) % 1499) {
                (0, _, _) => 2.0,
                (1, 13, _) => f64::NAN,
                (1, _, 7) => f64::INFINITY,
                (1, _, 700) => f64::NEG_INFINITY,
                _ => (2.1 * crate::testing::uniform(&mut state) - 1.05) * if (i / k) % 3 == 0 { 1.0 } else { 0.5 },
            })
            .collect();
        let tw = every_level_as_portable(&data, (rows, k), &b, &format!("byte counts, {k} sensors"));
        assert_eq!(tw.per_sensor[0], rows as u64);
        assert!(tw.only_by[0] > 2 * rows as u64 / 3 - 1 && tw.only_by[0] < rows as u64);
        assert_eq!(tw.invalid, (0..rows).filter(|r| r % 997 == 13).count() as u64);
    }
}

/// Rows `data` (`rows` x `k`, and the same as f32) at every level give the
/// portable kernel's f64 verdicts, counts and tally, which it returns.
fn every_level_as_portable(data: &[f64], (rows, k): (usize, usize), b: &SensorBounds, what: &str) -> Tally {
    let data32: Vec<f32> = data.iter().map(|&v| v as f32).collect();
    let (m, m32) = (Matrix::row_major(data, rows, k).unwrap(), Matrix::row_major(&data32, rows, k).unwrap());
    let plan = ScreenPlan::new(b, &vec![0; k]);
    let (mut want, mut tw) = (vec![0u32; rows], Tally::zeros(k));
    diagnose_with(Isa::Portable, m, b, &mut want, &mut tw);
    for isa in Isa::available() {
        check_bits(isa, m, b, &plan, &want, &tw, &format!("f64 {what}"));
        check_bits(isa, m32, b, &plan, &want, &tw, &format!("f32 {what}"));
    }
    tw
}

/// NaN rows are counted once whatever the period they fall in, across the
/// periodic kernel's flushes of its byte counts (every 255 periods with a
/// rejected row): every other row has a NaN, so every period of two rows or
/// more holds one, and infinities of both signs in rows far apart.
#[test]
fn periodic_nan_rows_are_counted_once_across_flushes() {
    for k in [1usize, 2, 3, 4, 5, 6, 7, 10, 12, 14, 20] {
        let rows = 600 * 16 + 5;
        let b = SensorBounds::new(&vec![0.0; k], &vec![-1.0; k], &vec![1.0; k]).unwrap();
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let data: Vec<f64> = (0..rows * k)
            .map(|i| match ((i / k) % 2, i % k == (i / k) % k, (i / k) % 301) {
                (0, true, _) => f64::NAN,
                (1, true, 17) => f64::INFINITY,
                (1, true, 150) => f64::NEG_INFINITY,
                _ => 2.4 * crate::testing::uniform(&mut state) - 1.2,
            })
            .collect();
        let tw = every_level_as_portable(&data, (rows, k), &b, &format!("NaN rows, {k} sensors"));
        assert_eq!(tw.invalid, rows.div_ceil(2) as u64);
    }
}

/// Long rows keep their per-sensor counts in narrow lanes between flushes
/// (AVX-512: u32 lanes every 65,536 rows; AVX2: byte lanes every 255 rows,
/// in registers up to 64 sensors), and take the verdict first after
/// candidates: calls over more rows than that, with runs of candidates
/// between rejected rows, with counts kept and without, give the portable
/// kernel's tally and counts.
#[test]
fn long_row_counts_survive_flushes() {
    // f32 rows of 201 and 260: the AVX2 long-row kernel's since f32 rows of up to 200 take `medium_avx2`.
    for (k, rows) in [(65usize, 70_000usize), (33, 3_000), (50, 3_000), (130, 3_000), (201, 3_000), (260, 3_000)] {
        long_row_counts_survive_flushes_of(k, rows);
    }
}

fn long_row_counts_survive_flushes_of(k: usize, rows: usize) {
    let b = SensorBounds::new(&vec![0.0; k], &vec![-1.0; k], &vec![1.0; k]).unwrap();
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    // Runs of ten candidates (the verdict-first path) every fifty rows, the
    // other rows mostly rejected.
    let data: Vec<f64> = (0..rows * k)
        .map(|i| (2.2 * crate::testing::uniform(&mut state) - 1.1) * if (i / k) % 50 < 10 { 0.5 } else { 1.0 })
        .collect();
    let data32: Vec<f32> = data.iter().map(|&v| v as f32).collect();
    let (m, m32) = (Matrix::row_major(&data, rows, k).unwrap(), Matrix::row_major(&data32, rows, k).unwrap());
    let plan = ScreenPlan::new(&b, &vec![0; k]);
    for isa in Isa::available() {
        let (mut want, mut tw) = (vec![0u32; rows], Tally::zeros(k));
        diagnose_with(Isa::Portable, m, &b, &mut want, &mut tw);
        assert!(tw.per_sensor.iter().all(|&c| c > 0) && want.iter().any(|&n| n == 0));
        check_bits(isa, m, &b, &plan, &want, &tw, &format!("f64 rows of {k}, past a flush"));
        let mut tw = Tally::zeros(k);
        diagnose_with(Isa::Portable, m32, &b, &mut want, &mut tw);
        check_bits(isa, m32, &b, &plan, &want, &tw, &format!("f32 rows of {k}, past a flush"));
    }
}

/// Rows read one per unit (f64 and f32 rows of 9 and 16, f32 rows of 17 and
/// 25) count "falsified only by" in bit planes emptied after 255 batches of
/// 16 rows holding such rows: over 12,000 rows, most rejected by a single
/// sensor, the tally matches the portable kernel's, in a row-major and a
/// strided layout (f64 rows of 17 and 25 take the medium kernel).
#[test]
fn single_rejections_survive_plane_flushes() {
    for k in [9usize, 16, 17, 25] {
        let rows = 16 * 255 * 3 + 37;
        let b = SensorBounds::new(&vec![0.0; k], &vec![-1.0; k], &vec![1.0; k]).unwrap();
        let plan = ScreenPlan::new(&b, &vec![0; k]);
        let mut state = 0x0123_4567_89AB_CDEFu64 ^ k as u64;
        let gap = 2;
        let mut wide = vec![0f64; rows * (k + gap)];
        for i in 0..rows {
            for j in 0..k {
                wide[i * (k + gap) + j] = crate::testing::uniform(&mut state) - 0.5;
            }
            // Mostly one rejecting sensor, sometimes two, sometimes none;
            // sensor 0 more than 255 times in each of the 16 lanes of a batch.
            let u = crate::testing::uniform(&mut state);
            let j = if u < 0.6 { 0 } else { (u * 1e6) as usize % k };
            if u < 0.9 {
                wide[i * (k + gap) + j] = 1.5;
            }
            if u < 0.1 {
                wide[i * (k + gap) + (j + 1) % k] = -3.0;
            }
        }
        let packed: Vec<f64> = (0..rows * k).map(|e| wide[(e / k) * (k + gap) + e % k]).collect();
        let (packed32, wide32): (Vec<f32>, Vec<f32>) =
            (packed.iter().map(|&v| v as f32).collect(), wide.iter().map(|&v| v as f32).collect());
        let views = [Matrix::row_major(&packed, rows, k).unwrap(), Matrix::new(&wide, rows, k, k + gap, 1).unwrap()];
        let views32 = [Matrix::row_major(&packed32, rows, k).unwrap(), Matrix::new(&wide32, rows, k, k + gap, 1).unwrap()];
        let (mut want, mut tw) = (vec![0u32; rows], Tally::zeros(k));
        diagnose_with(Isa::Portable, views[0], &b, &mut want, &mut tw);
        assert!(tw.only_by.iter().sum::<u64>() > (rows as u64) * 7 / 10, "{k} sensors: mostly single rejections");
        for isa in Isa::available() {
            for (v, m) in views.iter().enumerate() {
                check_bits(isa, *m, &b, &plan, &want, &tw, &format!("f64 view {v}, {k} sensors, single rejections"));
            }
            for (v, m) in views32.iter().enumerate() {
                check_bits(isa, *m, &b, &plan, &want, &tw, &format!("f32 view {v}, {k} sensors, single rejections"));
            }
        }
    }
}

/// Calls over more rows than a kernel pass counts in u32 lanes are split
/// into passes: split every 1,000 rows here (not 2^31, too slow for a test),
/// bits, counts and tally equal the portable kernel's for packed, periodic
/// and one-row-per-unit widths.
#[cfg(target_arch = "x86_64")]
#[test]
fn calls_split_into_passes_match_portable() {
    if !Isa::Avx512.supported() {
        return; // no other level splits
    }
    for k in [3usize, 10, 16, 40] {
        let rows = 2_345;
        let b = SensorBounds::new(&vec![0.0; k], &vec![-1.0; k], &vec![1.0; k]).unwrap();
        let mut state = 0x5555_AAAA_1234_4321u64 ^ k as u64;
        let data: Vec<f64> = (0..rows * k).map(|_| 2.3 * crate::testing::uniform(&mut state) - 1.15).collect();
        let m = Matrix::row_major(&data, rows, k).unwrap();
        let (mut want, mut tw) = (vec![0u32; rows], Tally::zeros(k));
        diagnose_with(Isa::Portable, m, &b, &mut want, &mut tw);
        let mut words = vec![0u64; rows.div_ceil(64) + 1];
        let (mut counts, mut t) = (vec![0u32; rows], Tally::zeros(k));
        let mut sink = BitSink::new(&mut words, 3);
        // SAFETY: AVX-512F, POPCNT and BMI1 are available (checked above).
        unsafe {
            crate::simd::avx512::diagnose_bits_in_passes(m, &b, Some(&mut counts), &mut sink, &mut t, 1_000)
        };
        sink.finish();
        let bits: Vec<bool> = (0..rows).map(|i| (words[(i + 3) / 64] >> ((i + 3) % 64)) & 1 == 1).collect();
        assert_eq!(bits, want.iter().map(|&n| n == 0).collect::<Vec<_>>(), "{k} sensors: bits");
        assert_eq!((&counts, &t), (&want, &tw), "{k} sensors: counts and tally");
        assert!(0 < tw.only_by.iter().sum::<u64>() && want.iter().any(|&n| n == 0), "{k} sensors: mixed rows");
    }
}

/// The AVX2 medium kernel (rows of 9-96 f64 sensors, 9-200 f32) counts accepting sensors
/// in 32-bit lanes (f64: two vectors to a counter, odd and even vector
/// counts both checked here), moved to the tally between passes: flushed every 1,000 rows here, over rows of
/// the vector counts where its loop changes (f32 9-200 sensors: 2-25 vectors, the row's string in one, two or
/// four words; f64 9-96: 3-24), some rejected by one sensor, some NaN, a run of 400 candidates, counts and tally
/// equal the portable kernel's.
#[cfg(target_arch = "x86_64")]
#[test]
fn medium_avx2_counts_survive_passes() {
    use crate::simd::medium_avx2::diagnose_in_passes;
    if !Isa::Avx2.supported() {
        return; // the level does not run here
    }
    fn check<T: Prediction>(m: Matrix<'_, T>, b: &SensorBounds, want: &[u32], tw: &Tally) {
        let k = m.cols();
        let (mut got, mut t) = (vec![0u32; m.rows()], Tally::zeros(k));
        // SAFETY: AVX2 and POPCNT are available (checked above); widths the kernel takes, rows contiguous.
        unsafe { diagnose_in_passes(m, b, &mut got, (&mut t, &mut crate::simd::checksum::NoSums), 1_000) };
        assert_eq!((&got[..], &t), (want, tw), "{k} sensors, {}", std::any::type_name::<T>());
    }
    for k in [9usize, 16, 17, 31, 33, 48, 50, 63, 64, 65, 71, 96, 97, 100, 121, 128, 129, 150, 191, 192, 193, 200, 201] {
        let rows = 3_456;
        let b = SensorBounds::new(&vec![0.0; k], &vec![-1.0; k], &vec![1.0; k]).unwrap();
        let mut state = 0x1357_9BDF_2468_ACE0u64 ^ k as u64;
        let data: Vec<f64> = (0..rows * k)
            .map(|i| {
                let u = crate::testing::uniform(&mut state);
                match (u * 1e6) as usize % 200 {
                    // A run of candidates: the blocks after the first whole one take `candidates_first`.
                    _ if (1_000..1_400).contains(&(i / k)) => u - 0.5,
                    0 => f64::NAN,
                    1..=3 => 1.5 * if i % 2 == 0 { 1.0 } else { -1.0 },
                    _ => u - 0.5,
                }
            })
            .collect();
        let data32: Vec<f32> = data.iter().map(|&v| v as f32).collect();
        let (m, m32) = (Matrix::row_major(&data, rows, k).unwrap(), Matrix::row_major(&data32, rows, k).unwrap());
        let (mut want, mut tw) = (vec![0u32; rows], Tally::zeros(k));
        diagnose_with(Isa::Portable, m, &b, &mut want, &mut tw);
        assert!(tw.invalid > 0 && tw.only_by.iter().sum::<u64>() > 0 && want.iter().any(|&n| n == 0), "{k} sensors: mixed rows");
        assert!(tw.per_sensor.iter().all(|&c| c > 3), "{k} sensors: every sensor rejects in several passes");
        if k <= 96 {
            check(m, &b, &want, &tw); // f64 rows of more than 96 are not this kernel's
        }
        if k <= 200 {
            let mut tw = Tally::zeros(k);
            diagnose_with(Isa::Portable, m32, &b, &mut want, &mut tw);
            check(m32, &b, &want, &tw); // f32 rows of more than 200 are not this kernel's
        }
    }
}

/// The row-batch kernel is compiled for two constant prefetch hints and for
/// one chosen per line (`row_batches::run_rows`): whichever is in use, its
/// verdicts, counts and tally are the portable kernel's (a prefetch is a
/// hint). Rows of the widths it takes, with NaN, in f32 and f64.
#[cfg(target_arch = "x86_64")]
#[test]
fn row_batches_agree_under_every_prefetch() {
    use crate::Prefetch;
    if !Isa::Avx512.supported() {
        return; // the level does not run here
    }
    let before = Prefetch::current();
    for name in ["t1:8192", "nta:4096", "t0:0", "t2:64", "off"] {
        Prefetch::from_name(name).expect("a valid prefetch").set();
        for k in [9usize, 11, 17, 25, 31] {
            let rows = 1_000;
            let b = SensorBounds::new(&vec![0.0; k], &vec![-1.0; k], &vec![1.0; k]).unwrap();
            let mut state = 0x0DDB_1A5E_5BAD_5EEDu64 ^ k as u64;
            let data: Vec<f64> = (0..rows * k)
                .map(|_| {
                    let u = crate::testing::uniform(&mut state);
                    if u < 0.001 { f64::NAN } else { 2.1 * (u - 0.5) }
                })
                .collect();
            let data32: Vec<f32> = data.iter().map(|&v| v as f32).collect();
            let (m, m32) = (Matrix::row_major(&data, rows, k).unwrap(), Matrix::row_major(&data32, rows, k).unwrap());
            let (mut want, mut tw) = (vec![0u32; rows], Tally::zeros(k));
            let (mut got, mut t) = (vec![0u32; rows], Tally::zeros(k));
            diagnose_with(Isa::Portable, m, &b, &mut want, &mut tw);
            diagnose_with(Isa::Avx512, m, &b, &mut got, &mut t);
            assert_eq!((&got, &t), (&want, &tw), "{name}: f64 rows of {k}");
            assert!(tw.invalid > 0 && want.iter().any(|&n| n == 0) && want.iter().any(|&n| n > 0), "{k}: mixed rows");
            let (mut want, mut tw) = (vec![0u32; rows], Tally::zeros(k));
            let (mut got, mut t) = (vec![0u32; rows], Tally::zeros(k));
            diagnose_with(Isa::Portable, m32, &b, &mut want, &mut tw);
            diagnose_with(Isa::Avx512, m32, &b, &mut got, &mut t);
            assert_eq!((&got, &t), (&want, &tw), "{name}: f32 rows of {k}");
            let plan = ScreenPlan::new(&b, &vec![0; k]);
            screen_with(Isa::Portable, m32, &b, &plan, &mut want);
            screen_with(Isa::Avx512, m32, &b, &plan, &mut got);
            assert_eq!(got, want, "{name}: f32 rows of {k}, screened");
        }
    }
    before.set();
}

/// Which rows the medium kernels take (the long-row kernels give the same
/// results, so the tests above cannot tell): at AVX-512 f32 rows of up to
/// 128 sensors (since session 36) and f64 rows of up to 64, from three
/// vectors; at AVX2 (since session 37) f32 rows of up to 200 and f64 rows
/// of up to 96, from nine sensors.
#[cfg(target_arch = "x86_64")]
#[test]
fn medium_kernels_take_the_widths_they_were_measured_on() {
    use crate::simd::{medium, medium_avx2};
    for k in 1..=260usize {
        let avx512_f32 = (33..=128).contains(&k).then(|| k.div_ceil(16));
        let avx512_f64 = (17..=64).contains(&k).then(|| k.div_ceil(8));
        assert_eq!((medium::vectors::<f32>(k), medium::vectors::<f64>(k)), (avx512_f32, avx512_f64), "{k} sensors");
        let avx2_f32 = (9..=200).contains(&k).then(|| k.div_ceil(8));
        let avx2_f64 = (9..=96).contains(&k).then(|| k.div_ceil(4));
        assert_eq!((medium_avx2::vectors::<f32>(k), medium_avx2::vectors::<f64>(k)), (avx2_f32, avx2_f64), "{k} sensors");
    }
}
