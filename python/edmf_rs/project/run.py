"""An identification described by a project file (TOML), run end to end.

``Project.from_toml(path)`` reads and checks the file and everything it names
(measurements, model function, precomputed instances); ``.run()`` samples the
parameters, streams the instances through the model and the falsification
(Eq. 8) in batches, and returns an :class:`~edmf_rs.project_result.Identification`
with the candidates, thresholds and diagnostics; ``.write(out)`` saves them.
The ``edmf-rs run`` command is :func:`run_cli`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from ..engine.model import falsify_model
from ..engine.thresholds import threshold_bounds
from ..engine.uncertainty import CombinedUncertainty
from .diagnostics import SensitivityTracker, leave_one_out
from .inputs import (
    CheckedModel,
    check_sensors,
    import_function,
    match_columns,
    read_measurements,
    read_table,
    table_columns,
)
from .prognosis import predict
from .result import Identification, PlotSample
from .sampling import Parameter, Sampling
from .schema import ModelSpec, PrognosisSpec, ProjectError, Sensor, read_spec
from .sources import UncertaintySource, combine_sources, frozen, resolve_sources
from ..simulators import CommandModel, Evaluator, FailurePolicy

__all__ = ["Project", "ProjectError", "run_cli"]


@dataclass(frozen=True, eq=False)
class Project:
    """A checked project: parameters and their sampling, model, sensors, uncertainty sources.

    ``sensors`` are those used by the identification (``excluded`` ones are
    in the measurements but left out). Build it with :meth:`from_toml`.
    """

    file: Path
    name: str
    description: str
    phi: float
    correction: str
    n_samples: int
    seed: int
    parameters: tuple[Parameter, ...]
    sampling: Sampling | None
    sensors: tuple[Sensor, ...]
    excluded: tuple[Sensor, ...]
    uncertainty: tuple[UncertaintySource, ...]
    model: ModelSpec
    model_function: Callable | None
    n_model_columns: int
    kept: tuple[int, ...]
    prognosis: tuple[tuple[PrognosisSpec, Callable], ...]
    command: CommandModel | None = None  # [model] command: an external program

    @classmethod
    def from_toml(cls, path: str | Path) -> Project:
        """Reads and checks a project file; raises :class:`ProjectError` naming the file and key."""
        spec = read_spec(path)
        label = str(spec.file)
        if spec.measurements_file is not None:
            all_sensors = read_measurements(spec.measurements_file)
            where = str(spec.measurements_file)
        else:
            all_sensors, where = spec.inline_sensors, f"{label}: measurements.sensors"
        kept = check_sensors(all_sensors, spec.exclude, where, label)
        names = {p.name for p in spec.parameters}
        clash = [s.name for s in all_sensors if s.name in names]
        if clash:
            raise ProjectError(f"{where}: sensor '{clash[0]}' has the name of a parameter; expected distinct "
                               "names (they name the columns of candidates.parquet)")
        reserved = [n for n in [*names, *(s.name for s in all_sensors)] if n == "instance"]
        if reserved:
            raise ProjectError(f"{label}: 'instance' names the index of candidates.parquet; expected another "
                               "name for that parameter or sensor")
        sensors = tuple(all_sensors[i] for i in kept)
        model_function = command = None
        if spec.model.command is not None:
            command = _command_model(spec, all_sensors, label)
        elif spec.model.function is not None:
            model_function = import_function(spec.model.function, spec.model.path, label, "model.function")
        else:
            _check_precomputed(spec.model, spec.parameters, all_sensors, sensors, label)
        prognosis = tuple((p, import_function(p.function, p.path, label, f"{p.key}.function"))
                          for p in spec.prognosis)
        return cls(
            file=spec.file, name=spec.name, description=spec.description, phi=spec.phi,
            correction=spec.correction, n_samples=spec.n_samples, seed=spec.seed,
            parameters=spec.parameters, sampling=spec.sampling, sensors=sensors,
            excluded=tuple(s for i, s in enumerate(all_sensors) if i not in kept),
            uncertainty=resolve_sources(spec.uncertainty, all_sensors, kept, label),
            model=spec.model, model_function=model_function, n_model_columns=len(all_sensors), kept=kept,
            prognosis=prognosis, command=command,
        )

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def sensor_names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.sensors)

    @property
    def measured(self) -> np.ndarray:
        """y, one value per sensor used."""
        return np.array([s.value for s in self.sensors])

    def combined_uncertainty(self) -> CombinedUncertainty:
        """U_c per sensor from the [[uncertainty]] sources (Eq. 4)."""
        try:
            combined = combine_sources(self.uncertainty, self.measured, n_samples=self.n_samples, seed=self.seed,
                                       streams=self.kept)
            threshold_bounds(combined, self.phi, self.correction) if not combined.exact else None
        except ValueError as exc:
            if "samples are needed" not in str(exc):
                raise
            raise ProjectError(f"{self.file}: identification.n_samples: {exc}") from None
        return combined

    def run(self, *, progress: bool = True, out: str | Path | None = None,
            workers: int | None = None) -> Identification:
        """Thresholds, falsification of every instance and diagnostics, in one pass.

        ``out``: the output folder, where the evaluated instances are stored
        as they arrive (``out/store``, reused by the next run with the same
        model and sampling) with failed runs in ``out/failures.csv``;
        ``workers``: parallel model runs (default: ``[model] workers``).
        """
        start = time.perf_counter()
        combined = self.combined_uncertainty()
        thresholds = threshold_bounds(combined, self.phi, self.correction)
        evaluator = self._evaluator(out, workers)
        try:
            return self._run(start, combined, thresholds, evaluator, progress)
        finally:
            if evaluator is not None:
                evaluator.close()

    def _run(self, start, combined, thresholds, evaluator, progress) -> Identification:
        model, parameters, n_instances = self._instances(evaluator)
        tracker = SensitivityTracker(thresholds, combined, self.measured)
        sample = PlotSample(n_instances)

        def on_batch(offset, theta, predictions):
            tracker(offset, theta, predictions)
            sample(offset, theta, predictions)

        result = falsify_model(model, parameters, self.measured, thresholds, batch_size=self.model.batch_size,
                               progress=progress, nan="falsify" if self.command else self.model.nan,
                               on_batch=on_batch)
        if self.command is not None and result.n_invalid and result.per_sensor_falsified is not None:
            # A failed run's row is all NaN, which the falsification counts against every sensor;
            # failed instances are neither candidates nor falsified.
            result = replace(result, per_sensor_falsified=result.per_sensor_falsified - result.n_invalid)
        candidates = pd.DataFrame(
            np.hstack([result.candidate_parameters, result.candidate_predictions]),
            columns=[*self.parameter_names, *self.sensor_names],
            index=pd.Index(result.candidate_indices, name="instance"),
        )
        prognoses = ()
        if result.n_candidates:
            prognoses = tuple(self._prognosis(spec, func, result.candidate_parameters)
                              for spec, func in self.prognosis)
        return Identification(
            project=self, combined=combined, thresholds=thresholds, falsification=result,
            leave_one_out=leave_one_out(result, self.sensor_names), sensitivity=tracker.finish(),
            candidates=candidates, prognoses=prognoses, sample=sample.finish(result.candidate_mask),
            elapsed=time.perf_counter() - start, evaluation=evaluator.stats() if evaluator else None,
        )

    def _evaluator(self, out, workers) -> Evaluator | None:
        """The simulators' evaluator (store, parallel runs, external programs), or None when not needed."""
        m = self.model
        workers = m.workers if workers is None else workers
        if m.predictions is not None or (out is None and self.command is None and workers == 1):
            return None
        names = [None] * self.n_model_columns
        for i, s in zip(self.kept, self.sensors):
            names[i] = s.name
        rest = iter(s.name for s in self.excluded)
        names = [n if n is not None else next(rest) for n in names]
        sampling = {"method": self.sampling.method, "seed": self.sampling.seed, "points": self.sampling.points,
                    "n": self.sampling.n if self.sampling.method == "lhs" else None,  # Sobol' and grids extend
                    "parameters": [(p.name, p.low, p.high, p.scale) for p in self.parameters], "sensors": names}
        return Evaluator(self.parameter_names, names, self.sampling.n, command=self.command,
                         function=self.model_function, ref=m.function or "", path=m.path, options=m.options,
                         workers=workers, out=out, sampling=sampling, store=m.store,
                         policy=FailurePolicy(m.stop_after_failures, m.max_failure_rate))

    def _instances(self, evaluator: Evaluator | None = None):
        """(model callable, parameters, N) for falsify_model."""
        what = f"command = {list(self.command.spec.command)}" if self.command else f"function = '{self.model.function}'"
        where = f"{self.file}: model.{what}"
        if self.model_function is not None or evaluator is not None:
            function, options = (evaluator, {}) if evaluator is not None else (self.model_function, self.model.options)
            model = CheckedModel(function, options, n_columns=self.n_model_columns,
                                 kept=self.kept, parameter_names=self.parameter_names,
                                 nan="falsify" if self.command else self.model.nan, where=where)
            return model, self.sampling.batches(self.model.batch_size), self.sampling.n
        theta, predictions = _read_precomputed(self)
        offset = 0

        def lookup(batch: np.ndarray) -> np.ndarray:  # batches come in order
            nonlocal offset
            rows = predictions[offset:offset + batch.shape[0]]
            bad = np.flatnonzero(np.isnan(rows).any(axis=1)) if self.model.nan == "raise" else ()
            if len(bad):
                raise ProjectError(f"{self.model.predictions}: row {offset + bad[0]}: expected finite predictions, "
                                   "got NaN (or set nan = \"falsify\" under [model])")
            offset += batch.shape[0]
            return rows

        return lookup, theta, theta.shape[0]

    def _prognosis(self, spec: PrognosisSpec, func: Callable, theta: np.ndarray):
        uncertainty = frozen(*spec.uncertainty) if spec.uncertainty is not None else None
        try:
            return predict(lambda t: func(t, **spec.options), theta, uncertainty=uncertainty,
                           probability=spec.probability, name=spec.name, unit=spec.unit)
        except ValueError as exc:
            raise ProjectError(f"{self.file}: {spec.key}.function = '{spec.function}': {exc}") from None


def _command_model(spec, all_sensors, label: str) -> CommandModel:
    """The external program, checked before anything runs (program, templates, placeholders, parser)."""
    try:
        return CommandModel(spec.model.command, [p.name for p in spec.parameters], [s.name for s in all_sensors])
    except ValueError as exc:
        raise ProjectError(f"{label}: model.{exc}") from None


def _check_precomputed(model: ModelSpec, parameters, all_sensors, sensors, label: str) -> None:
    """The precomputed files exist and their columns match the parameters and sensors."""
    names = [p.name for p in parameters]
    found = table_columns(model.parameters, "model.parameters", label)
    match_columns(found, names, set(names), model.parameters, "parameters")
    found = table_columns(model.predictions, "model.predictions", label)
    match_columns(found, [s.name for s in sensors], {s.name for s in all_sensors}, model.predictions, "sensors")


def _read_precomputed(project: Project) -> tuple[np.ndarray, np.ndarray]:
    m = project.model
    theta = read_table(m.parameters, list(project.parameter_names), "model.parameters")
    predictions = read_table(m.predictions, list(project.sensor_names), "model.predictions")
    if m.predictions.suffix.lower() == ".npy":
        predictions = predictions[:, list(project.kept)]
    if theta.shape[0] != predictions.shape[0]:
        raise ProjectError(f"{m.predictions}: expected {theta.shape[0]} rows (one per parameter set of "
                           f"{m.parameters.name}), got {predictions.shape[0]}")
    if theta.shape[0] == 0:
        raise ProjectError(f"{m.parameters}: expected at least one model instance, the file has none")
    for j, p in enumerate(project.parameters):
        bad = np.flatnonzero(~((theta[:, j] >= p.low) & (theta[:, j] <= p.high)))
        if bad.size:
            raise ProjectError(f"{m.parameters}: row {bad[0]}: {p.name} = {theta[bad[0], j]:g} is outside "
                               f"[parameters.{p.name}] = [{p.low:g}, {p.high:g}]; expected values in the domain")
    return theta, predictions


def default_out(project_file: str | Path) -> Path:
    """The output folder next to the project file, named after it."""
    project_file = Path(project_file)
    return project_file.with_name(project_file.stem)


def run_cli(project_path: str, out: str | None = None, progress: bool = True, workers: int | None = None) -> int:
    """``edmf-rs run PROJECT.toml [--out DIR] [--workers N]``: run, write the outputs, print a short summary."""
    started = time.perf_counter()
    project = Project.from_toml(project_path)
    out_dir = Path(out) if out is not None else default_out(project_path)
    identification = project.run(progress=progress, out=out_dir, workers=workers)
    identification.write(out_dir)
    print(identification.summary())
    print(f"wrote {out_dir}/ (report.html, summary.json, candidates.parquet, thresholds.csv, plots) "
          f"in {time.perf_counter() - started:.1f} s")
    return 0
