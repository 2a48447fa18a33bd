"""The ``[[prognosis]]`` functions of a project: called on the candidates with
their failures named after them (the function, the instances, the first
failing instance's parameters), checked to give one number per instance, and
turned into a :class:`~edmf_rs.project.prognosis.Prognosis`."""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable

import numpy as np

from ..engine._validate import real_array
from .candidates import mapped
from .errors import call_user_code
from .prognosis import Prognosis, over_range, predict
from .schema import PrognosisSpec, ProjectError
from .sources import frozen


def describe(project, row) -> str:
    """An instance's parameters, e.g. ``E=43084.6, K=1e+09``."""
    return ", ".join(f"{n}={v:g}" for n, v in zip(project.parameter_names, row))


def call_prognosis(project, spec: PrognosisSpec, func: Callable, theta: np.ndarray, *, what: str = "candidate",
                   index=None) -> np.ndarray:
    """q(theta) of a prognosis function, its failures named after it; checked to be one number per row."""
    where = f"{project.file}: {spec.key}.function = '{spec.function}'"
    first = 0 if index is None else int(index[0])
    q = call_user_code(lambda t: func(t, **spec.options), theta, what=where, unit=what,
                       where=f"{theta.shape[0]:,} {what}s", first=first, describe=lambda row: describe(project, row))
    try:  # complex values are refused, not cast to their real part
        arr = real_array(q, "q", copy=False)
    except (TypeError, ValueError):
        shown = f"{type(q).__name__} of dtype {q.dtype}" if hasattr(q, "dtype") else type(q).__name__
        raise ProjectError(f"{where}: returned {shown}, expected one real number per {what}") from None
    if arr.shape not in ((theta.shape[0],), (theta.shape[0], 1)):
        raise ProjectError(f"{where}: returned shape {arr.shape} for {theta.shape[0]} {what}s, expected "
                           f"({theta.shape[0]},): one value per {what}")
    return arr


def prognosis_of(project, spec: PrognosisSpec, func: Callable, theta: np.ndarray, index=None):
    """The prognosis of ``spec`` over the candidates ``theta`` (with its own model uncertainty, if any)."""
    uncertainty = frozen(*spec.uncertainty) if spec.uncertainty is not None else None
    values = call_prognosis(project, spec, func, theta, index=index)
    try:
        return predict(lambda t: values, theta, uncertainty=uncertainty,
                       probability=spec.probability, name=spec.name, unit=spec.unit)
    except ValueError as exc:
        raise ProjectError(f"{project.file}: {spec.key}.function = '{spec.function}': {exc}") from None


class PrognosisStream:
    """A ``[[prognosis]]`` over candidates that arrive batch by batch (never all in memory).

    The range is exact: min and max are updated with every batch. The values
    go to an unlinked temporary file, memory-mapped as ``Prognosis.values``.
    """

    def __init__(self, project, spec: PrognosisSpec, func: Callable):
        self.project, self.spec, self.func = project, spec, func
        self.file = tempfile.TemporaryFile(prefix="edmf-rs-prognosis-")
        self.count, self.low, self.high = 0, math.inf, -math.inf

    def add(self, theta: np.ndarray, index: np.ndarray) -> None:
        """q(theta) of one batch of candidates (``index``: their instance numbers, for messages)."""
        q = call_prognosis(self.project, self.spec, self.func, theta, index=index).reshape(-1)
        bad = np.flatnonzero(~np.isfinite(q))
        if bad.size:
            i = int(bad[0])
            raise ProjectError(f"{self.project.file}: {self.spec.key}.function = '{self.spec.function}': "
                               f"{self.spec.name}: returned {q[i]} for candidate instance {int(index[i])} "
                               f"({describe(self.project, theta[i])}); expected a finite number")
        self.file.write(np.ascontiguousarray(q, dtype=np.float64).tobytes())
        self.count += q.size
        self.low, self.high = min(self.low, float(q.min())), max(self.high, float(q.max()))

    def finish(self) -> Prognosis:
        """The prognosis over every candidate added (at least one); closes the file (its values stay mapped)."""
        spec = self.spec
        uncertainty = frozen(*spec.uncertainty) if spec.uncertainty is not None else None
        values = mapped(self.file, self.count, np.float64)
        self.close()
        return over_range(values, self.low, self.high, uncertainty=uncertainty,
                          probability=spec.probability, name=spec.name, unit=spec.unit)

    def close(self) -> None:
        """Closes the temporary file (unlinked: nothing is left on disk); `finish` closes it too."""
        self.file.close()
