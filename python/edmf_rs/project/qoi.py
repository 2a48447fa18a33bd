"""The ``[[prognosis]]`` functions of a project: called on the candidates with
their failures named after them (the function, the instances, the first
failing instance's parameters), checked to give one number per instance, and
turned into a :class:`~edmf_rs.project.prognosis.Prognosis`."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .errors import call_user_code
from .prognosis import predict
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
    try:
        arr = np.asarray(q, dtype=np.float64)
    except (TypeError, ValueError):
        raise ProjectError(f"{where}: returned {type(q).__name__}, expected one number per {what}") from None
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
