"""edmf_rs: error-domain model falsification (Goulet & Smith 2013) with a Rust core.

Typical use::

    import edmf_rs, scipy.stats as st
    combined = edmf_rs.combine(model=[...], measurement=[st.norm(0, 0.02)], n_sensors=n_m)
    thresholds = edmf_rs.threshold_bounds(combined, phi=0.95)
    result = edmf_rs.falsify(predictions, measured, thresholds)
    print(result.summary())

The package is laid out in rooms, each with one job (see the README's Layout):
``engine`` (the method, re-exported here), ``stream`` (durable chunked I/O),
``project`` (project files), ``paper`` (the paper's reproduction),
``examples``, plus ``reference`` (the NumPy oracle) and ``dask``.
"""

__version__ = "0.1.0"

import sys as _sys


def _interrupted_while_importing(kind, value, tb, _previous=_sys.excepthook):
    """Ctrl-C while the ``edmf-rs`` command is still importing: one line, not a
    traceback of import internals. Installed only for the command, and removed
    once the import completes."""
    if issubclass(kind, KeyboardInterrupt):
        print("edmf-rs: interrupted", file=_sys.stderr)
    else:
        _previous(kind, value, tb)


_command = bool(_sys.argv) and (_sys.argv[0] == "-m" or _sys.argv[0].replace("\\", "/").endswith("/edmf-rs")
                                or _sys.argv[0] == "edmf-rs")
if _command:
    _sys.excepthook = _interrupted_while_importing

from . import design, examples, reference
from ._core import get_num_threads, set_num_threads
from .adaptive import adaptive_falsify
from .engine.falsify import falsify
from .engine.model import falsify_model
from .engine.result import FalsificationResult, concatenate
from .engine.thresholds import Thresholds, sensor_probability, threshold_bounds
from .engine.uncertainty import CombinedUncertainty, combine, relative_to_measured
from .paper import baselines, coverage
from .paper.baselines import (
    LeastSquaresResult,
    PosteriorResult,
    bayesian_posterior,
    least_squares,
)
from .paper.coverage import CoverageResult
from .project import Prognosis, Project, ProjectError, predict
from .stream.checkpoint import CheckpointError

if _command and _sys.excepthook is _interrupted_while_importing:
    _sys.excepthook = _interrupted_while_importing.__defaults__[0]
del _command

__all__ = [
    "CheckpointError",
    "CombinedUncertainty",
    "CoverageResult",
    "FalsificationResult",
    "LeastSquaresResult",
    "PosteriorResult",
    "Prognosis",
    "Project",
    "ProjectError",
    "Thresholds",
    "adaptive_falsify",
    "baselines",
    "bayesian_posterior",
    "combine",
    "concatenate",
    "coverage",
    "design",
    "examples",
    "falsify",
    "falsify_model",
    "get_num_threads",
    "least_squares",
    "predict",
    "reference",
    "relative_to_measured",
    "sensor_probability",
    "set_num_threads",
    "threshold_bounds",
]
