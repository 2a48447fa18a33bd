"""The project's hook into :mod:`edmf_rs.simulators`: an external program as the
model, and the evaluator that stores every evaluated instance, runs models in
parallel workers and records failed runs (``[model] command``, ``workers``,
``store``, ``max_failure_rate``)."""

from __future__ import annotations

from pathlib import Path

from ..simulators import CommandModel, Evaluator, FailurePolicy
from ..simulators.cluster import SchedulerUnreachable
from ..simulators.columns import StoreColumns
from ..simulators.evaluator import store_fingerprint
from .schema import ProjectError


def command_model(spec, all_sensors, label: str) -> CommandModel:
    """The external program, checked before anything runs (program, templates, placeholders, parser)."""
    try:
        return CommandModel(spec.model.command, [p.name for p in spec.parameters], [s.name for s in all_sensors])
    except ValueError as exc:
        raise ProjectError(f"{label}: model.{exc}") from None


def sampling_key(project) -> dict:
    """The sampling as the prediction store's fingerprint records it (with every sensor's name and,
    when ``[model] sensors`` gives it, the sensor of each column of a bare model array: the store
    keeps columns matched through it, so another order must not read them)."""
    key = {"method": project.sampling.method, "seed": project.sampling.seed, "points": project.sampling.points,
           "n": project.sampling.n if project.sampling.method == "lhs" else None,  # Sobol' and grids extend
           "parameters": [(p.name, p.low, p.high, p.scale) for p in project.parameters],
           "sensors": [s.name for s in project.all_sensors]}
    if project.model.sensors is not None:  # absent: the measurements' order, already in "sensors"
        key["model_sensors"] = list(project.model.sensors)
    return key


def project_fingerprint(project) -> dict:
    """The fingerprint of the project's prediction store (model and sampling), as `make_evaluator` keys it."""
    m = project.model
    return store_fingerprint(project.command, project.model_function, m.function or "", m.options,
                             sampling_key(project))


def make_evaluator(project, out, workers, scheduler: str | None = None, retry_failures: bool = False,
                   store=None) -> Evaluator | None:
    """The simulators' evaluator (store, parallel runs, a Dask cluster, external programs), or None
    when not needed. ``scheduler`` (``--scheduler``) overrides ``[compute] scheduler``; with
    ``store`` (a store folder ``<root>/<key>``), one that reads every instance from it and
    evaluates none."""
    m = project.model
    workers = m.workers if workers is None else workers
    if store is None and scheduler is not None and not str(scheduler).strip():  # `--scheduler ""`
        raise ProjectError(f"{project.file}: --scheduler {scheduler!r}: empty address; expected a Dask "
                           "scheduler address such as tcp://host:8786 (or leave --scheduler out to run locally)")
    scheduler = None if store is not None else scheduler if scheduler is not None else m.scheduler
    if scheduler is not None and project.model_function is None:
        raise ProjectError(f"{project.file}: --scheduler {scheduler}: a Dask scheduler evaluates only a Python "
                           "model (model.function)")
    if store is None and (m.predictions is not None or
                          (out is None and project.command is None and workers == 1 and scheduler is None)):
        return None
    names = [s.name for s in project.all_sensors]
    positional, source = project.positional_sensors
    columns = StoreColumns(names, required=project.sensor_names, positional=positional, positional_source=source,
                           where=f"{project.file}: model.function = '{m.function}'")
    try:
        return Evaluator(project.parameter_names, names, project.sampling.n, command=project.command,
                         function=project.model_function, ref=m.function or "", path=m.path, options=m.options,
                         workers=1 if store is not None else workers, out=out, sampling=sampling_key(project),
                         store=m.store or store is not None,
                         policy=FailurePolicy(m.stop_after_failures, m.max_failure_rate), columns=columns,
                         scheduler=scheduler, retry_failures=retry_failures,
                         store_root=None if store is None else Path(store).parent, reuse_only=store is not None)
    except SchedulerUnreachable as exc:
        where = "--scheduler" if scheduler != m.scheduler else "compute.scheduler"
        raise ProjectError(f"{project.file}: {where}: {exc}") from None
