//! The periods of short rows (`Period`), as the periodic kernels use them.

use crate::kernel::Period;

#[test]
fn periods_of_short_rows() {
    // (vectors, rows): rows of 5 and 10 sensors, f32 (16 a vector) and f64 (8).
    let period = |k, w| Period::new(k, w, true).map(|p| (p.vectors, p.rows));
    assert_eq!(period(5, 16), Some((5, 16)));
    assert_eq!(period(10, 16), Some((5, 8)));
    assert_eq!(period(5, 8), Some((5, 8)));
    assert_eq!(period(10, 8), Some((5, 4)));
    // Patterns of at most 32 bits repeated as often as a u64 string, six
    // vectors (`MAX_REPEATED_VECTORS`) and 32 rows allow.
    assert_eq!(period(3, 8), Some((6, 16)));
    assert_eq!(period(6, 8), Some((6, 8)));
    assert_eq!(period(12, 8), Some((6, 4)));
    assert_eq!(period(4, 8), Some((6, 12)));
    assert_eq!(period(2, 8), Some((6, 24)));
    assert_eq!(period(1, 8), Some((4, 32)));
    assert_eq!(period(8, 16), Some((4, 8)));
    assert_eq!(period(4, 16), Some((4, 16)));
    assert_eq!(period(2, 16), Some((4, 32)));
    assert_eq!(period(1, 16), Some((2, 32)));
    // Without the repeats (AVX2 screening): one pattern; whole rows kept.
    let once = |k, w| Period::new(k, w, true).map(|p| p.unrepeated(k, w)).map(|p| (p.vectors, p.rows));
    assert_eq!(once(4, 8), Some((1, 2)));
    assert_eq!(once(12, 8), Some((3, 2)));
    assert_eq!(once(8, 16), Some((1, 2)));
    assert_eq!(once(1, 16), Some((1, 16)));
    assert_eq!(once(5, 16), Some((5, 16)));
    let p = Period::whole_rows(16, 8, true).unwrap();
    assert_eq!(p.unrepeated(16, 8), p);
    let p = Period::new(3, 8, true).unwrap();
    let q = p.unrepeated(3, 8);
    assert_eq!((q.low_bits, q.top_bits), Period::fields(3, 8));
    assert_eq!(p.low_bits & 0xFF_FFFF, q.low_bits);
    // Longer patterns are not repeated: 48 bits, and 40 (a repeat is 80).
    assert_eq!(period(6, 16), Some((3, 8)));
    assert_eq!(period(12, 16), Some((3, 4)));
    assert_eq!(period(7, 8), Some((7, 8)));
    // Whole vectors per row, or a period too long: other kernels.
    assert_eq!(period(16, 8), None);
    assert_eq!(period(16, 16), None);
    assert_eq!(period(9, 8), None);
    assert_eq!(period(9, 16), None);
    // Rows of whole vectors, as many as 8 vectors and 128 bits hold (AVX2 only).
    let whole = |k, w| Period::whole_rows(k, w, true).map(|p| (p.vectors, p.rows));
    assert_eq!(whole(16, 8), Some((8, 4)));
    assert_eq!(whole(8, 8), Some((8, 8)));
    assert_eq!(whole(24, 8), Some((6, 2)));
    assert_eq!(whole(32, 8), Some((8, 2)));
    assert_eq!(whole(16, 16), Some((8, 8)));
    assert_eq!(whole(32, 16), Some((8, 4)));
    assert_eq!(whole(48, 16), Some((6, 2))); // 96 bits: a u128 string
    assert_eq!(whole(40, 8), None); // one row a period
    assert_eq!(whole(10, 8), None); // not whole vectors: `Period::new`
    assert_eq!(whole(64, 16), None);
    // Row 0's field of 5 bits: four low bits and the top one; 16 rows fill 80 bits.
    let p = Period::new(5, 16, true).unwrap();
    assert_eq!((p.low_bits & 0x1f, p.top_bits & 0x1f), (0xf, 0x10));
    assert_eq!((p.low_bits | p.top_bits), (1u128 << 80) - 1);
}
