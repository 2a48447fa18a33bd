//! What the greedy placement may choose, and its result.

use crate::error::{EdmfError, Result};

/// Gains (bits, or bits per unit cost) this close to the best are ties.
pub const TIE: f64 = 1e-9;

/// What the greedy placement may choose and when it stops.
#[derive(Debug, Clone, Default)]
pub struct PlacementOptions {
    /// Most sensors in the design, fixed ones included.
    pub k: usize,
    /// Locations every design starts with, in this order.
    pub fixed: Vec<usize>,
    /// Cost of each location (> 0); gains are divided by it.
    pub costs: Option<Vec<f64>>,
    /// Total cost the design may not exceed (needs `costs`).
    pub budget: Option<f64>,
    /// Stop when the best gain (bits) falls below this by more than [`TIE`].
    pub tolerance: Option<f64>,
    /// NaN predictions form a bin of their own (else they are refused).
    pub nan_bin: bool,
    /// Sensor type of each location (an index into `max_per_type`); empty
    /// when there are no quotas.
    pub type_of: Vec<usize>,
    /// Most sensors of each type (fixed ones included).
    pub max_per_type: Vec<usize>,
    /// Evaluate every remaining location at every step (plain greedy)
    /// instead of lazily; the result is the same, only slower.
    pub exhaustive: bool,
    /// Most bytes the precomputed labels of every location may take
    /// ([`DEFAULT_BIN_MEMORY`] when `None`); above it bins are computed from
    /// the predictions at each evaluation (O(N) working space).
    pub bin_memory: Option<usize>,
}

/// Default bound on the precomputed labels: 1 GiB (10^9 one-byte labels,
/// e.g. 10^6 instances x 1,000 locations of up to 256 bins).
pub const DEFAULT_BIN_MEMORY: usize = 1 << 30;

/// The chosen locations in order and the joint entropy after each one.
#[derive(Debug, Clone, PartialEq)]
pub struct Placement {
    pub order: Vec<usize>,
    pub entropy: Vec<f64>,
    /// (step, location) pairs whose entropy was evaluated.
    pub evaluations: u64,
}

pub(crate) fn check(opts: &PlacementOptions, l: usize) -> Result<()> {
    if opts.k > l {
        return Err(EdmfError::invalid(
            "k",
            format!("at most {l} sensors (the candidate locations), got {}", opts.k),
        ));
    }
    let mut seen = vec![false; l];
    for &i in &opts.fixed {
        if i >= l {
            return Err(EdmfError::invalid(
                "fixed",
                format!("location indices below {l}, got {i}"),
            ));
        }
        if std::mem::replace(&mut seen[i], true) {
            return Err(EdmfError::invalid(
                "fixed",
                format!("distinct locations, got {i} twice"),
            ));
        }
    }
    if opts.fixed.len() > opts.k {
        return Err(EdmfError::invalid(
            "k",
            format!("at least the {} fixed sensors, got {}", opts.fixed.len(), opts.k),
        ));
    }
    if let Some(costs) = &opts.costs {
        if costs.len() != l {
            return Err(EdmfError::invalid(
                "costs",
                format!("one cost per location ({l}), got {}", costs.len()),
            ));
        }
        if let Some((i, c)) = costs
            .iter()
            .enumerate()
            .find(|(_, c)| !(c.is_finite() && **c > 0.0))
        {
            return Err(EdmfError::invalid(
                "costs",
                format!("finite costs > 0, got {c} at location {i}"),
            ));
        }
    }
    if let Some(b) = opts.budget {
        let Some(costs) = &opts.costs else {
            return Err(EdmfError::invalid("budget", "costs to go with it"));
        };
        let cheapest = costs.iter().copied().fold(f64::INFINITY, f64::min);
        if !(b.is_finite() && b >= cheapest) {
            return Err(EdmfError::invalid(
                "budget",
                format!("a finite budget of at least the cheapest sensor ({cheapest}), got {b}"),
            ));
        }
        let fixed: f64 = opts.fixed.iter().map(|&i| costs[i]).sum();
        if fixed > b {
            return Err(EdmfError::invalid(
                "budget",
                format!("at least the cost of the fixed sensors ({fixed}), got {b}"),
            ));
        }
    }
    if !opts.max_per_type.is_empty() {
        if opts.type_of.len() != l {
            return Err(EdmfError::invalid(
                "types",
                format!("one type per location ({l}), got {}", opts.type_of.len()),
            ));
        }
        if let Some(&t) = opts.type_of.iter().find(|&&t| t >= opts.max_per_type.len()) {
            return Err(EdmfError::invalid(
                "types",
                format!("type indices below {}, got {t}", opts.max_per_type.len()),
            ));
        }
        let mut used = vec![0usize; opts.max_per_type.len()];
        for &i in &opts.fixed {
            used[opts.type_of[i]] += 1;
        }
        if let Some(t) = (0..used.len()).find(|&t| used[t] > opts.max_per_type[t]) {
            return Err(EdmfError::invalid(
                "max_per_type",
                format!(
                    "at least the {} fixed sensors of type {t}, got {}",
                    used[t], opts.max_per_type[t]
                ),
            ));
        }
    }
    if let Some(t) = opts.tolerance {
        if !(t.is_finite() && t >= 0.0) {
            return Err(EdmfError::invalid(
                "tolerance",
                format!("a finite gain >= 0 (bits), got {t}"),
            ));
        }
    }
    Ok(())
}
