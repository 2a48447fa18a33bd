//! Errors as values. Every variant names the argument the user passed, so the
//! binding layer can turn it into a `ValueError` that says what was expected.

use std::fmt;

#[derive(Debug, Clone, PartialEq)]
pub enum EdmfError {
    /// An argument has a value or shape the method cannot use.
    InvalidArgument { name: &'static str, expected: String },
    /// Too few Monte Carlo samples to resolve the per-sensor probability.
    TooFewSamples {
        needed: usize,
        got: usize,
        probability: f64,
    },
    /// The caller's stop check asked to abandon the call (e.g. Ctrl-C).
    Interrupted,
    /// Memory for the results (candidates, per-instance counts) ran out.
    OutOfMemory { what: &'static str, elements: usize },
}

impl EdmfError {
    pub fn invalid(name: &'static str, expected: impl Into<String>) -> Self {
        EdmfError::InvalidArgument {
            name,
            expected: expected.into(),
        }
    }
}

impl fmt::Display for EdmfError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EdmfError::InvalidArgument { name, expected } => write!(f, "{name}: {expected}"),
            EdmfError::TooFewSamples {
                needed,
                got,
                probability,
            } => write!(
                f,
                "combined: {got} Monte Carlo samples cannot resolve a per-sensor probability of \
                 {probability}; at least {needed} samples are needed (1/(1-p))"
            ),
            EdmfError::Interrupted => write!(f, "interrupted"),
            EdmfError::OutOfMemory { what, elements } => write!(
                f,
                "out of memory keeping {elements} more {what}; pass keep_violations=False, or \
                 diagnostics=False, or stream the instances in parts"
            ),
        }
    }
}

impl std::error::Error for EdmfError {}

pub type Result<T> = std::result::Result<T, EdmfError>;
