//! Unit tests of the row kernels: every instruction-set level against the
//! portable, literal residual test.

use super::*;

/// Vector and portable kernels agree for every row width (lane remainders,
/// short rows held in registers, partial blocks), with ties on the bounds,
/// NaN and infinities, and blocks screened out of column order.
#[test]
fn vector_kernels_match_portable_ones() {
    let specials = [0.5, -0.5, 0.25, f64::NAN, f64::INFINITY, -2.0, 0.0, 1.0, -0.49];
    // Past 64 sensors screening stops at the first rejecting block (below,
    // whole rows are tested): both paths, with rows of partial blocks.
    for k in (1..=50usize).chain([63, 64, 65, 80, 97, 130]) {
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
