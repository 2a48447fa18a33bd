//! edmf-core: error-domain model falsification (Goulet & Smith 2013) in pure Rust.
//!
//! - [`thresholds`]: per-sensor threshold bounds from Monte Carlo samples of the
//!   combined uncertainty (shortest intervals, Eq. 5).
//! - [`kernel`] and [`falsifier`]: the falsification rule (Eq. 8) over millions of
//!   model instances, in parallel and streaming, deterministic whatever the
//!   thread count and chunking.
//! - [`screening`]: emulator screening for adaptive EDMF (Eq. 8 widened by c sigma).
//! - [`ellipse`]: Mahalanobis distances for the ellipsoidal-bounds comparison (Eq. 9).
//!
//! No Python here: the `edmf_rs` package wraps this crate through a thin PyO3 layer.

pub mod acceptance;
pub mod bounds;
pub mod candidates;
pub mod design;
pub mod digest;
pub mod ellipse;
pub mod error;
pub mod falsifier;
#[cfg(test)]
mod falsifier_digest_tests;
pub mod kernel;
pub mod matrix;
mod polling;
pub mod screening;
mod slab_tasks;
pub mod summing;
#[cfg(target_arch = "x86_64")]
mod simd;
#[cfg(test)]
mod testing;
pub mod thresholds;
pub mod violations;

pub use error::{EdmfError, Result};
pub use falsifier::{Falsifier, Mode};
pub use kernel::{Isa, Prediction, Tally};
pub use matrix::Matrix;
pub use screening::{screen, Screened};
pub use thresholds::{min_samples, shortest_interval, shortest_intervals, Thresholds};
/// How the vector kernels prefetch (x86-64): chosen per CPU, settable to
/// compare.
#[cfg(target_arch = "x86_64")]
pub use simd::prefetch::{Prefetch, PREFETCH_ENV};
