"""Calling the project's model: outputs matched to the sensors, checked batch by batch.

The model is called as ``function(theta, **options)`` with theta of shape
(n, p). It may return a ``pandas.DataFrame``, a mapping of sensor name to
column or a structured array (matched to the measurements by name, in any
order; extra outputs are ignored and reported), or a bare (n, k) array
(matched by position to ``[model] sensors`` when given, else to the
measurements' order, excluded sensors included).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..engine._validate import real_array
from ..engine.model import non_finite
from ..engine.sensors import SensorMapping, SensorMatch, SensorMismatch
from .errors import call_user_code
from .precomputed import precomputed_instances
from .schema import ProjectError

if TYPE_CHECKING:
    from ..simulators import Evaluator
    from .run import Project


class CheckedModel:
    """The project's model function, with its output matched and checked.

    Batches arrive in instance order, so the running offset names instances.

    Parameters
    ----------
    function, options
        The model and its keyword arguments.
    sensors
        The sensors used, in the measurements' order (excluded ones left out).
    positional
        The sensor of each column of a bare array.
    positional_source
        Where ``positional`` comes from (``[model] sensors`` or the measurements).
    parameter_names, nan, where
        For messages: the parameters' names, the NaN policy, and what the
        model is (file and key).

    Examples
    --------
    >>> m = CheckedModel(lambda t: {"B": t[:, 0], "A": 2 * t[:, 0]}, {}, sensors=("A", "B"),
    ...                  positional=("A", "B"), parameter_names=("x",), nan="raise", where="m")
    >>> m(np.array([[1.0]]))
    array([[2., 1.]])
    """

    def __init__(self, function: Callable, options: dict, *, sensors: Sequence[str], positional: Sequence[str],
                 parameter_names: tuple[str, ...], nan: str, where: str,
                 positional_source: str = "the measurements' order"):
        self.function, self.options = function, dict(options)
        self.match = SensorMatch(sensors, positional, positional_source)
        self.parameter_names, self.nan, self.where = parameter_names, nan, where
        self.offset = 0
        self.batch = 0
        self.seconds = 0.0  # spent in the model
        self.instances = 0

    @property
    def mapping(self) -> SensorMapping | None:
        """How the outputs were matched to the sensors (None before the first call)."""
        return self.match.mapping

    def describe(self, theta_row) -> str:
        """``a=1, b=2``: one instance's parameters, for messages."""
        return ", ".join(f"{n}={v:g}" for n, v in zip(self.parameter_names, theta_row))

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        last = self.offset + theta.shape[0] - 1
        started = time.perf_counter()
        out = call_user_code(lambda t: self.function(t, **self.options), theta, what=self.where,
                             where=f"batch {self.batch} (instances {self.offset}..{last})", first=self.offset,
                             describe=self.describe)
        self.seconds += time.perf_counter() - started
        self.instances += theta.shape[0]
        try:
            out = self.match(out, theta.shape[0])
            if getattr(out, "dtype", None) == np.bool_:  # True/False: a comparison, not a prediction
                raise TypeError("boolean predictions")
            out = real_array(out, "model", copy=False)  # complex: refused, not cast to its real part
        except SensorMismatch as exc:
            raise ProjectError(f"{self.where}: {exc}") from None
        except (TypeError, ValueError):
            kind = f" of dtype {out.dtype}" if hasattr(out, "dtype") else ""
            raise ProjectError(f"{self.where}: returned {type(out).__name__}{kind}, expected an array of real numbers "
                               f"of shape ({len(theta)}, {len(self.match.sensors)}) or a DataFrame with a "
                               "column per sensor") from None
        if self.nan == "raise":  # inf too: an overflow or a diverged solver, not a prediction
            bad = np.flatnonzero(~np.isfinite(out).all(axis=1))
            if bad.size:
                raise ProjectError(f"{self.where}: returned {non_finite(out[bad[0]])} for instance "
                                   f"{self.offset + bad[0]} ({self.describe(theta[bad[0]])}); expected finite "
                                   "predictions (or set nan = \"falsify\" under [model])")
        self.offset += theta.shape[0]
        self.batch += 1
        return out


def checked_model(project: Project, evaluator: Evaluator | None = None) -> CheckedModel:
    """The project's model (or the evaluator of external runs) with its outputs matched to the sensors by name."""
    positional, source = project.positional_sensors
    if evaluator is not None:  # it returns every sensor's column, matched by name, in the measurements' order
        function, options = evaluator, {}
        positional, source = evaluator.sensors, "the measurements' order"
    else:
        function, options = project.model_function, project.model.options
    what = (f"command = {list(project.command.spec.command)}" if project.command
            else f"function = '{project.model.function}'")
    return CheckedModel(function, options, sensors=project.sensor_names,
                        positional=positional, positional_source=source,
                        parameter_names=project.parameter_names,
                        nan="falsify" if project.command else project.model.nan, where=f"{project.file}: model.{what}")


def model_instances(project: Project, evaluator: Evaluator | None = None):
    """(model callable, parameters, N) for falsify_model: the checked model and the
    sampling's batches, or the precomputed predictions."""
    if project.model_function is not None or evaluator is not None:
        return checked_model(project, evaluator), project.sampling.batches(project.model.batch_size), project.sampling.n
    return precomputed_instances(project)
