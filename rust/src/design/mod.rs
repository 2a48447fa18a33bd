//! Measurement-system design: where to put sensors so that EDMF falsifies
//! the most model instances.
//!
//! - [`entropy`]: joint entropy of the binned predictions of a set of
//!   locations (Papadopoulou, Raphael, Smith & Sekhar 2014, Entropy 16:5078).
//! - [`placement`]: hierarchical (greedy, lazily evaluated) placement by joint
//!   entropy, per unit cost, within a budget and per-type quotas (Bertola,
//!   Papadopoulou, Vernay & Smith 2017, Sensors 17:2904); [`bins`] holds the
//!   labels of every location computed once, [`tiles`] the streaming
//!   evaluator used when they would not fit in memory.
//! - [`identifiability`]: expected candidate-set sizes of a set of sensors by
//!   simulating measurements (Goulet & Smith 2013, Eqs. 4 and 8).

pub mod bins;
pub mod entropy;
pub mod identifiability;
pub mod options;
pub mod partition;
pub mod placement;
pub mod tiles;

pub use entropy::joint_entropy;
pub use identifiability::candidate_counts;
pub use placement::{place, Placement, PlacementOptions, DEFAULT_BIN_MEMORY, TIE};
