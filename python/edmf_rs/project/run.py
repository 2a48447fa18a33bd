"""An identification described by a project file (TOML), run end to end.

``Project.from_toml(path)`` reads and checks the file and everything it names
(measurements, model function, precomputed instances); ``.run()`` samples the
parameters, streams the instances through the model and the falsification
(Eq. 8) in batches, and returns an :class:`~edmf_rs.project.result.Identification`
with the candidates, thresholds and diagnostics; ``.write(out)`` saves them.
The ``edmf-rs run`` command is :func:`edmf_rs.project.command.run_cli`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..engine.borderline import BorderlineCounter
from ..engine.sampling import Parameter, Sampling
from ..engine.thresholds import threshold_bounds
from ..engine.uncertainty import CombinedUncertainty
from ..simulators import CommandModel
from .candidates import CandidateWriter
from .diagnostics import SensitivityTracker, leave_one_out
from .evaluation import checked_model, model_instances
from .external import command_model, make_evaluator
from .identification import IdentificationTable, identification_fields
from .inputs import check_model_sensors, check_sensors, import_function
from .measurements import read_measurements
from .plan import Plan, check_estimate
from .precomputed import check_precomputed, count_rows, first_parameters
from .progress import Progress
from .qoi import PrognosisStream, call_prognosis
from .result import Identification, PlotSample
from .schema import ModelSpec, PrognosisSpec, ProjectError, Sensor, read_spec
from .sources import UncertaintySource, check_relative, combine_sources, resolve_sources
from .streaming import falsify_streaming

__all__ = ["Project", "ProjectError"]


@dataclass(frozen=True, eq=False)
class Project(IdentificationTable):
    """A checked project: parameters and their sampling, model, sensors, uncertainty sources.

    Build it with `from_toml` from a project file (the format is on the
    documentation's project-file page), then `run` it.

    Attributes
    ----------
    file : pathlib.Path
        The project file.
    name, description : str
        From ``[identification]``.
    phi : float
        Target identification probability.
    correction : str
        ``"sidak"``, ``"bonferroni"`` or ``"none"``.
    n_samples, seed : int
        Monte Carlo samples of U_c (when a source is not normal) and their seed.
    parameters : tuple of Parameter
        The parameters, with their domains, in the model's column order.
    sampling : Sampling or None
        How the instances are drawn; None for precomputed instances.
    sensors, excluded : tuple of Sensor
        The sensors used by the identification, and those in the measurements
        but left out (``exclude``).
    uncertainty : tuple of UncertaintySource
        The ``[[uncertainty]]`` sources, resolved against the sensors.
    parameter_names, sensor_names : tuple of str
        Names of the parameters and of the sensors used.
    measured : numpy.ndarray
        y, one value per sensor used.

    Examples
    --------
    >>> import edmf_rs
    >>> from edmf_rs import cli
    >>> project = edmf_rs.Project.from_toml(cli.EXAMPLES / "cantilever.toml")
    >>> project.parameter_names, len(project.sensor_names), project.phi
    (('E',), 10, 0.95)
    """

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
    inputs: tuple[Path, ...] = ()  # the files it reads (never overwritten by an output)
    command: CommandModel | None = None  # [model] command: an external program

    @classmethod
    def from_toml(cls, path: str | Path) -> Project:
        """Reads and checks a project file and everything it names.

        Parameters
        ----------
        path : str or pathlib.Path
            The project file (TOML).

        Returns
        -------
        Project
            The checked project; the measurements are read and the model
            function imported.

        Raises
        ------
        ProjectError
            On the first problem, naming the file, the key or line, and what
            was expected (a missing file, invalid TOML, an unknown key, a value
            out of range, a sensor no source covers, a model that cannot be
            imported, ...).

        Examples
        --------
        >>> import edmf_rs
        >>> from edmf_rs import cli
        >>> project = edmf_rs.Project.from_toml(cli.EXAMPLES / "girder.toml")
        >>> project.parameter_names
        ('E', 'K_rot', 'k_h')
        """
        spec = read_spec(path)
        label = str(spec.file)
        if spec.measurements_file is not None:
            all_sensors = read_measurements(spec.measurements_file, label=label, decimal=spec.decimal,
                                            encoding=spec.encoding)
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
        check_model_sensors(spec.model.sensors, sensors, label)
        model_function = command = None
        if spec.model.command is not None:
            command = command_model(spec, all_sensors, label)
        elif spec.model.function is not None:
            model_function = import_function(spec.model.function, spec.model.path, label, "model.function")
        else:
            check_precomputed(spec.model, spec.parameters, all_sensors, sensors, label)
        prognosis = tuple((p, import_function(p.function, p.path, label, f"{p.key}.function"))
                          for p in spec.prognosis)
        uncertainty = resolve_sources(spec.uncertainty, all_sensors, kept, label)
        check_relative(uncertainty, sensors, label)
        return cls(
            **identification_fields(spec), parameters=spec.parameters, sampling=spec.sampling, sensors=sensors,
            excluded=tuple(s for i, s in enumerate(all_sensors) if i not in kept),
            uncertainty=uncertainty,
            model=spec.model, model_function=model_function, n_model_columns=len(all_sensors), kept=kept,
            prognosis=prognosis, command=command,
            inputs=tuple(f for f in (spec.file, spec.measurements_file, spec.model.predictions, spec.model.parameters)
                         if f is not None),
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
        """U_c per sensor from the ``[[uncertainty]]`` sources (Eq. 4).

        Returns
        -------
        CombinedUncertainty
            Exact when every source is normal, else ``n_samples`` Monte Carlo
            samples per sensor.

        Raises
        ------
        ProjectError
            If ``n_samples`` is too small for the per-sensor probability, or
            the sources cannot be combined at a sensor (named).

        Examples
        --------
        >>> import edmf_rs
        >>> from edmf_rs import cli
        >>> edmf_rs.Project.from_toml(cli.EXAMPLES / "cantilever.toml").combined_uncertainty().exact
        True
        """
        try:
            combined = combine_sources(self.uncertainty, self.measured, n_samples=self.n_samples, seed=self.seed,
                                       streams=self.kept, sensor_names=self.sensor_names)
            threshold_bounds(combined, self.phi, self.correction) if not combined.exact else None
        except ValueError as exc:  # e.g. a relative source at a reading of 0, if Project was built by hand
            key = "identification.n_samples" if "samples are needed" in str(exc) else "uncertainty"
            raise ProjectError(f"{self.file}: {key}: {exc}") from None
        return combined

    @property
    def positional_sensors(self) -> tuple[tuple[str, ...], str]:
        """The sensor of each column of a bare model array, and where that order comes from."""
        if self.model.sensors is not None:
            return self.model.sensors, "[model] sensors"
        return tuple(s.name for s in self.all_sensors), "the measurements' order"

    @property
    def all_sensors(self) -> tuple[Sensor, ...]:
        """Every sensor of the measurements, excluded ones included, in their order."""
        by_index = dict(zip(self.kept, self.sensors))
        others = iter(self.excluded)
        return tuple(by_index[i] if i in by_index else next(others) for i in range(self.n_model_columns))

    @property
    def n_instances(self) -> int:
        """N, the number of model instances (rows of the precomputed files)."""
        if self.sampling is not None:
            return self.sampling.n
        return count_rows(self.model.predictions, "model.predictions")

    def check(self, workers: int | None = None) -> Plan:
        """Calls the model and every prognosis function on two instances and
        returns the run's plan; evaluates nothing else (``edmf-rs run --dry-run``).

        Parameters
        ----------
        workers : int, optional
            Parallel model runs (default: ``[model] workers``); with more than
            one, the model is left to the worker processes.

        Returns
        -------
        Plan
            The instances, sensors, model, prognoses and the model's time per
            instance measured on the two instances.

        Raises
        ------
        ProjectError
            When what they return does not fit the sensors.
        UserCodeError
            When the model or a prognosis function raises.

        Examples
        --------
        >>> import edmf_rs
        >>> from edmf_rs import cli
        >>> plan = edmf_rs.Project.from_toml(cli.EXAMPLES / "cantilever.toml").check()
        >>> plan.n_instances, plan.n_sensors
        (101, 10)
        """
        seconds = None
        workers = self.model.workers if workers is None else workers
        if self.model_function is not None and (workers > 1 or self.model.scheduler):
            # The model runs only in the worker processes: one that crashes its process (a segfaulting
            # solver, the OOM killer) must not take edmf-rs down. Its first batch is the check.
            theta = self.sampling.head(2)
        elif self.model_function is not None:
            theta = self.sampling.head(2)
            model = checked_model(self)
            model(theta)
            seconds = model.seconds / max(model.instances, 1)
        elif self.command is not None:  # checked before it runs (program, templates, parser); each run costs
            theta = self.sampling.head(2)
        else:
            theta = first_parameters(self, 2)
        for spec, func in self.prognosis:
            call_prognosis(self, spec, func, theta, what="instance")
        instances = self.sampling.describe() if self.sampling is not None else \
            f"precomputed in {self.model.predictions.name}"
        return Plan(project=str(self.file), n_instances=self.n_instances, n_sensors=len(self.sensors),
                    n_parameters=len(self.parameters), instances=instances,
                    model=self.model.function or (" ".join(self.command.spec.command) if self.command else
                                                  f"predictions {self.model.predictions.name}"),
                    batch_size=self.model.batch_size, prognoses=tuple(spec.name for spec, _ in self.prognosis),
                    seconds_per_instance=seconds)

    def run(self, *, progress: bool | Progress = True, max_seconds: float | None = None,
            out: str | Path | None = None, workers: int | None = None, scheduler: str | None = None,
            retry_failures: bool = False, store: str | Path | None = None) -> Identification:
        """Thresholds, falsification of every instance and diagnostics, in one pass.

        Samples the parameters (or, with ``method = "adaptive"``, runs EDMF in
        waves: `edmf_rs.adaptive_falsify`), evaluates the model in batches of
        ``model.batch_size`` while falsifying (Eq. 8), and predicts the
        ``[[prognosis]]`` quantities over the candidates.

        Parameters
        ----------
        progress : bool or Progress, default True
            True shows instances done of N with an ETA on stderr once the run
            lasts a few seconds; or pass a :class:`Progress`.
        max_seconds : float, optional
            Stop after the first batch when that batch's time, scaled to every
            instance, is above it (:class:`~edmf_rs.project.plan.RunTooLarge`).
        out : path, optional
            The output folder, where the evaluated instances are stored as they
            arrive (``out/store``, reused by the next run with the same model
            and sampling) with failed runs in ``out/failures.csv``, and the
            candidates stream to a temporary file that ``write(out)`` renames
            to ``candidates.parquet`` (without ``out``: a temporary folder).
        workers : int, optional
            Parallel model runs (default: ``[model] workers``).
        scheduler : str, optional
            A Dask scheduler's address that evaluates the Python model
            (default: ``[compute] scheduler``).
        retry_failures : bool, default False
            Run again every failed instance the prediction store holds (by
            default only those that timed out under a shorter ``timeout``).
        store : path, optional
            A prediction store folder to read every instance from, evaluating
            none (``edmf-rs falsify``; checked by `edmf_rs.project.refalsify`).

        Returns
        -------
        Identification
            The falsification result, thresholds, diagnostics, candidates (in
            a Parquet file; ``.candidates`` reads them as a DataFrame) and
            prognoses; ``.write(folder)`` saves the report. Memory does not
            grow with the instances nor with the candidates.

        Raises
        ------
        ProjectError
            If precomputed predictions hold NaN (with ``nan = "raise"``) or a
            prognosis cannot be computed.
        UserCodeError
            If the model or a prognosis function raises (naming the batch,
            the instances and the first failing instance's parameters).

        Examples
        --------
        >>> import edmf_rs
        >>> from edmf_rs import cli
        >>> identification = edmf_rs.Project.from_toml(cli.EXAMPLES / "cantilever.toml").run(progress=False)
        >>> identification.falsification.n_instances, identification.model_class_falsified
        (101, False)
        """
        if getattr(self.sampling, "method", None) == "adaptive":  # waves of real runs (issue 16)
            from .adaptive import run_adaptive

            return run_adaptive(self, progress=progress, out=out, workers=workers)
        start = time.perf_counter()
        combined = self.combined_uncertainty()
        thresholds = threshold_bounds(combined, self.phi, self.correction)
        evaluator = make_evaluator(self, out, workers, scheduler, retry_failures, store)
        try:
            return self._run(start, combined, thresholds, evaluator, progress, max_seconds, out)
        finally:
            if evaluator is not None:
                evaluator.close()

    def _run(self, start, combined, thresholds, evaluator, progress, max_seconds, out) -> Identification:
        model, parameters, n_instances = model_instances(self, evaluator)
        tracker = SensitivityTracker(thresholds, combined, self.measured)
        sample = PlotSample(n_instances)
        borderline = BorderlineCounter(thresholds, self.measured)
        first_batch = [max_seconds is not None and (self.model_function is not None or self.command is not None)]
        began = time.perf_counter()

        def on_batch(offset, theta, predictions):
            if first_batch[0]:
                first_batch[0] = False
                elapsed = time.perf_counter() - began
                check_estimate(elapsed / theta.shape[0] * n_instances, theta.shape[0], elapsed, n_instances,
                               max_seconds)
            tracker(offset, theta, predictions)
            sample(offset, theta, predictions)
            borderline(offset, theta, predictions)
            if reporter is not None:
                reporter.update(theta.shape[0])

        reporter = progress if isinstance(progress, Progress) else Progress(n_instances) if progress else None
        writer = CandidateWriter(out, self.parameter_names, self.sensor_names)
        streams = [PrognosisStream(self, spec, func) for spec, func in self.prognosis]

        def sink(indices, theta, predictions):  # each batch's candidates, streamed out (never all in memory)
            if indices.size:
                writer.add(indices, theta, predictions)
                sample.mark(indices)
                for stream in streams:
                    stream.add(theta, indices)

        try:
            result = falsify_streaming(model, parameters, self.measured, thresholds, sink=sink, on_batch=on_batch,
                                       candidate_indices=writer.candidate_indices,
                                       nan="falsify" if self.command else self.model.nan)
            candidate_set = writer.finish()
        except BaseException:
            writer.abort()
            for stream in streams:
                stream.close()
            raise
        finally:
            if reporter is not None:
                reporter.close()
        try:
            prognoses = tuple(s.finish() for s in streams) if result.n_candidates else ()
        finally:
            for stream in streams:  # their temporary files, also without a candidate
                stream.close()
        result = tracker.discount(result)  # NaN rows (failed or diverged runs): neither candidates nor falsified
        mapping = (self.command is None and getattr(evaluator, "mapping", None)) or getattr(model, "mapping", None)
        return Identification(
            project=self, combined=combined, thresholds=thresholds, falsification=result,
            leave_one_out=leave_one_out(result, self.sensor_names, tracker.nan_at), sensitivity=tracker.finish(),
            candidate_set=candidate_set, prognoses=prognoses,
            sample=sample.finish(), elapsed=time.perf_counter() - start, borderline=borderline.count,
            sensor_mapping=mapping, evaluation=evaluator.stats() if evaluator else None,
        )
