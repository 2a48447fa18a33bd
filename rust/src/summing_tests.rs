//! The sums a kernel adds as it reads (`part_after` with the summed kernels)
//! are the separate pass's (`digest::part`), and its verdicts the plain
//! kernel's, at every level, for rows that start anywhere in a block.

use super::*;
use crate::kernel::{diagnose_bits_with, screen_bits_with};
use crate::testing::uniform;

/// Predictions mostly inside `[-1, 1]` (some rows candidates, some not),
/// with a NaN, and the middle third of the rows candidates but for one (runs
/// of candidate rows, which some kernels test for their verdicts first).
fn rows_of<T: Value + From<f32>>(rows: usize, n_m: usize, state: &mut u64) -> Vec<T> {
    let middle = rows / 3 * n_m..2 * rows / 3 * n_m;
    let mut v: Vec<T> = (0..rows * n_m)
        .map(|i| match (middle.contains(&i), i == middle.start + middle.len() / 2) {
            (true, true) => T::from(2.0),
            (true, false) => T::from((uniform(state) * 1.8 - 0.9) as f32),
            _ => T::from((uniform(state) * 2.3 - 1.15) as f32),
        })
        .collect();
    if let Some(x) = v.get_mut(rows * n_m / 3) {
        *x = T::from(f32::NAN);
    }
    v
}

/// Candidate words, tally and part of `rows` (instance `first_row` on) through
/// `part_after`, with the summed kernels when `summed`, else the plain ones.
fn run<T: Prediction + Value>(
    isa: Isa,
    m: Matrix<'_, T>,
    (b, plan): (&SensorBounds, Option<&ScreenPlan>),
    first_row: u64,
    summed: bool,
) -> (Vec<u64>, Tally, Part, usize) {
    let mut words = vec![0u64; m.rows().div_ceil(64)];
    let (mut tally, mut buf, mut fused) = (Tally::zeros(b.len()), Vec::new(), 0);
    let part = part_after(
        m,
        first_row,
        &mut buf,
        summed && kernel_sums(isa, m, b),
        |r0, r1, sum| {
            let (mut sink, rows) = (BitSink::new(&mut words, r0), m.slice_rows(r0, r1));
            let s = match (plan, summed && sum) {
                (Some(p), true) => screen_bits_summed_with(isa, rows, b, p, &mut sink),
                (None, true) => diagnose_bits_summed_with(isa, rows, b, None, &mut sink, &mut tally),
                (Some(p), false) => {
                    screen_bits_with(isa, rows, b, p, &mut sink);
                    Summed::default()
                }
                (None, false) => {
                    diagnose_bits_with(isa, rows, b, None, &mut sink, &mut tally);
                    Summed::default()
                }
            };
            sink.finish();
            fused += s.rows;
            s
        },
    );
    (words, tally, part, fused)
}

/// Rows per run.
const ROWS: usize = 3 * PIECE_ROWS + 37;

/// Checks rows of `n_m` starting at several places in a block; the fewest
/// rows the kernel summed itself in a run at AVX-512 and at AVX2 (`ROWS`
/// where the level does not run).
fn check<T: Prediction + Value + From<f32>>(n_m: usize, state: &mut u64) -> [usize; 2] {
    let b = SensorBounds::new(&vec![0.0; n_m], &vec![-1.0; n_m], &vec![1.0; n_m]).unwrap();
    let plan = ScreenPlan::new(&b, &vec![0; n_m]);
    let mut fused = [ROWS; 2];
    // Rows crossing a block boundary, and pieces starting on and off a group.
    let rows = ROWS;
    let data = rows_of::<T>(rows, n_m, state);
    let m = Matrix::row_major(&data, rows, n_m).unwrap();
    for first_row in [
        0,
        1,
        3,
        8,
        16 * 7,
        BLOCK_ROWS as u64 - 1500,
        5 * BLOCK_ROWS as u64 - 2 * PIECE_ROWS as u64 + 3,
    ] {
        let mut buf = Vec::new();
        let want = digest::part(m, first_row, &mut buf);
        for isa in Isa::available() {
            for plan in [None, Some(&plan)] {
                let plain = run(isa, m, (&b, plan), first_row, false);
                let got = run(isa, m, (&b, plan), first_row, true);
                let what = format!(
                    "{isa:?}, rows of {n_m} {}, from {first_row}",
                    std::any::type_name::<T>()
                );
                assert_eq!(got.2, want, "sums, {what}");
                assert_eq!(plain.2, want, "sums of the plain pass, {what}");
                assert_eq!(got.0, plain.0, "candidates, {what}");
                assert_eq!(got.1, plain.1, "tally, {what}");
                match isa {
                    Isa::Avx512 => fused[0] = fused[0].min(got.3),
                    Isa::Avx2 => fused[1] = fused[1].min(got.3),
                    Isa::Portable => assert_eq!(got.3, 0, "{what}"),
                }
            }
        }
    }
    fused
}

#[test]
fn sums_taken_in_the_kernels_pass_are_the_separate_passes() {
    let mut state = 0x5EED_00FC_0FFEu64;
    for n_m in [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 16, 17, 20, 24, 31, 33, 40, 50, 63, 64, 65, 130, 201] {
        let fused64 = check::<f64>(n_m, &mut state);
        let fused32 = check::<f32>(n_m, &mut state);
        // The kernels sum every width of rows stored back to back: at
        // AVX-512 the periodic kernel, the short-row kernels and the
        // row-at-a-time kernels; at AVX2 the periodic kernel (rows of up to
        // eight sensors and those with a period, where `pext` is fast) and the
        // long-row kernel (rows of more than eight). So the fused path is what
        // is tested; and they sum all but a few rows wherever the rows start: a
        // first piece up to a group (< 16 rows) and the rows after the last
        // whole period (< 32: periods of up to 32 rows) or group (< 16).
        let levels = [
            Isa::Avx512.supported(),
            Isa::Avx2.supported() && (n_m > 8 || crate::simd::periodic_avx2::fast_pext()),
        ];
        for (level, (runs, name)) in levels.into_iter().zip(["AVX-512", "AVX2"]).enumerate() {
            let (f64_rows, f32_rows) = (fused64[level], fused32[level]);
            assert!(
                !runs || f64_rows.min(f32_rows) >= ROWS - 48,
                "{name}, rows of {n_m}: {f64_rows} and {f32_rows} of {ROWS} summed in the kernel"
            );
        }
    }
}

/// The AVX-512 short-row kernels tell the sums every row they read: the
/// groups added are exactly those of the rows summed, for each layout (rows
/// packed several to a vector, rows of one or two vectors). The falsifier
/// reaches the packed layout only where the periodic kernel cannot run (no
/// BMI2 or AVX-512BW), so it is run here directly.
#[test]
#[cfg(target_arch = "x86_64")]
fn short_row_kernels_add_the_groups_of_the_rows_they_read() {
    use crate::simd::checksum::{groups_avx512, Fletcher, FletcherRows, GroupSums};
    use crate::simd::short::ShortRows;

    fn check<T: Prediction + Value + From<f32>>(k: usize, state: &mut u64) {
        let rows = 1000 + k;
        let data = rows_of::<T>(rows, k, state);
        let m = Matrix::row_major(&data, rows, k).unwrap();
        let b = SensorBounds::new(&vec![0.0; k], &vec![-1.0; k], &vec![1.0; k]).unwrap();
        let (base, row_bytes) = (data.as_ptr() as *const u8, k * std::mem::size_of::<T>());
        for diagnose in [false, true] {
            let mut words = vec![0u64; rows.div_ceil(64)];
            let mut sink = BitSink::new(&mut words, 0);
            // SAFETY: AVX-512F and POPCNT run (checked by the caller); the
            // rows are back to back and ShortRows fits their width.
            let (summed, got, want) = unsafe {
                let (mut read, n) = FletcherRows::new(Fletcher::new(), base, rows, row_bytes);
                let kernel = ShortRows::<T>::new(&b, true);
                if diagnose {
                    kernel.diagnose(m, None, &mut sink, (&mut Tally::zeros(k), &mut read));
                } else {
                    kernel.screen(m, &mut sink, &mut read);
                }
                (n, read.sums().lane_sums(), groups_avx512(base, n * row_bytes / 64))
            };
            sink.finish();
            let name = std::any::type_name::<T>();
            assert!(summed + 16 > rows, "rows of {k} {name}: {summed} of {rows} summed");
            assert_eq!(got, want, "rows of {k} {name}, diagnostics {diagnose}");
        }
    }

    if !Isa::Avx512.supported() {
        return; // this CPU runs none of these kernels
    }
    let mut state = 0xFEED_5EED_u64;
    for k in 1..=32 {
        if ShortRows::<f64>::fits(k) {
            check::<f64>(k, &mut state);
        }
        if ShortRows::<f32>::fits(k) {
            check::<f32>(k, &mut state);
        }
    }
}
