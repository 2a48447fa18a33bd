"""edmf_rs: error-domain model falsification (Goulet & Smith 2013) with a Rust core.

Typical use::

    import edmf_rs, scipy.stats as st
    combined = edmf_rs.combine(model=[...], measurement=[st.norm(0, 0.02)], n_sensors=n_m)
    thresholds = edmf_rs.threshold_bounds(combined, phi=0.95)
    result = edmf_rs.falsify(predictions, measured, thresholds)
    print(result.summary())
"""

from . import baselines, coverage, examples, reference
from ._core import get_num_threads, set_num_threads
from .checkpoint import CheckpointError
from .baselines import LeastSquaresResult, PosteriorResult, bayesian_posterior, least_squares
from .coverage import CoverageResult
from .falsify import falsify
from .model import falsify_model
from .result import FalsificationResult, concatenate
from .thresholds import Thresholds, sensor_probability, threshold_bounds
from .uncertainty import CombinedUncertainty, combine, relative_to_measured

__all__ = [
    "CheckpointError",
    "CombinedUncertainty",
    "CoverageResult",
    "LeastSquaresResult",
    "PosteriorResult",
    "Prognosis",
    "Project",
    "ProjectError",
    "adaptive_falsify",
    "baselines",
    "bayesian_posterior",
    "coverage",
    "examples",
    "least_squares",
    "predict",
    "FalsificationResult",
    "Thresholds",
    "combine",
    "concatenate",
    "falsify",
    "falsify_model",
    "get_num_threads",
    "reference",
    "relative_to_measured",
    "sensor_probability",
    "set_num_threads",
    "threshold_bounds",
]
__version__ = "0.1.0"

# Project runs need pandas; import them on first use so `import edmf_rs` stays light.
_LAZY = {"adaptive_falsify": "adaptive",
         "Project": "project", "ProjectError": "project", "Prognosis": "prognosis", "predict": "prognosis"}


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module 'edmf_rs' has no attribute {name!r}")

