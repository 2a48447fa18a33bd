//! Helpers shared by the unit tests (no RNG crate needed).

/// Deterministic uniform values in [0, 1) from a xorshift64 state.
pub fn uniform(state: &mut u64) -> f64 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    (*state >> 11) as f64 / (1u64 << 53) as f64
}
