"""Simulators: models that are external programs or need many processes.

``command`` runs a program once per model instance in its own work folder
(input decks from ``template``s, results read by ``parsers``); ``pool``
evaluates in parallel; ``store`` keeps every evaluated instance so a run can
be resumed or repeated with other uncertainties without evaluating again;
``failures`` records failed runs as data; ``evaluator`` puts them together
behind the call signature of a Python model; ``columns`` matches a model's
named outputs to the sensors and ``cluster`` evaluates on a Dask scheduler.
Depends on ``stream`` and on ``engine.sensors`` (matching by name).
"""

from .command import CommandModel, CommandSpec
from .evaluator import Evaluator
from .failures import Failure, FailurePolicy, SimulationError
from .store import PredictionStore
from .template import TemplateError

__all__ = ["CommandModel", "CommandSpec", "Evaluator", "Failure", "FailurePolicy", "PredictionStore",
           "SimulationError", "TemplateError"]
