"""The outcome of running a project: candidates, thresholds, diagnostics, and
the files ``edmf-rs run`` writes (summary.json last, so a folder holding a
summary.json holds a complete run)."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import pandas as pd

from ..engine.result import FalsificationResult
from ..engine.sensors import SensorMapping
from ..engine.thresholds import Thresholds
from ..engine.uncertainty import CombinedUncertainty
from ..stream.atomic import write_bytes, write_text
from .candidates import CandidateSet
from .diagnostics import LeaveOneOut, Sensitivity, findings, parameter_findings
from .format import in_domain, json_safe, plural
from .prognosis import Prognosis, predict
from .sample import PLOT_SAMPLE, InstanceSample, PlotSample  # noqa: F401 (re-exported)

SUMMARY_SCHEMA = "edmf_rs.project-summary/3"  # /2: threshold_low, threshold_high (were low, high);
# /3: identification.combined_uncertainty maps how the bounds were found to the sensors (was one string)
#: How a sensor's threshold bounds were found, by the `Thresholds.method` it has.
BOUND_METHODS = {"exact": "exact", "convolution": "convolution"}  # any other method: "monte_carlo"
#: The files ``Identification.write`` writes (summary.json last).
FIGURES = ("leave_one_out", "residuals", "scatter_matrix", "parallel_coordinates", "sensitivity")
OUTPUT_FILES = (*(f"{name}.png" for name in FIGURES), "candidates.parquet", "thresholds.csv", "report.html",
                "summary.json")
#: Written by adaptive runs only, besides OUTPUT_FILES (``project.adaptive``).
ADAPTIVE_FILES = ("adaptive_waves.png",)


@dataclass(frozen=True, eq=False)
class Identification:
    """A project's identification, as returned by `Project.run`.

    Attributes
    ----------
    project : Project
        The project that was run.
    combined : CombinedUncertainty
        U_c per sensor (Eq. 4).
    thresholds : Thresholds
        The threshold bounds (Eqs. 5-7).
    falsification : FalsificationResult
        The candidate model set and per-sensor counts (Eq. 8).
    leave_one_out : LeaveOneOut
        Candidate set sizes with each sensor left out, and suspect sensors.
    sensitivity : Sensitivity
        Candidate set size against a scale factor on all uncertainties and
        against phi.
    candidate_set : CandidateSet
        The candidates, streamed to a Parquet file during the run, with their
        exact count and parameter ranges and a bounded sample for the plots.
    candidates : pandas.DataFrame
        The candidates' parameters and predictions, indexed by instance (read
        from the candidate file when first asked for: it holds every candidate).
    prognoses : tuple of Prognosis
        The ``[[prognosis]]`` quantities over the candidates.
    sample : InstanceSample
        Every k-th instance, for plots.
    elapsed : float
        Seconds the run took.
    model_class_falsified : bool
        True when no candidate is left.

    Examples
    --------
    >>> import edmf_rs
    >>> from edmf_rs import cli
    >>> ident = edmf_rs.Project.from_toml(cli.EXAMPLES / "cantilever.toml").run(progress=False)
    >>> list(ident.candidates.columns[:3])
    ['E', 'D1', 'D2']
    """

    project: object
    combined: CombinedUncertainty
    thresholds: Thresholds
    falsification: FalsificationResult
    leave_one_out: LeaveOneOut
    sensitivity: Sensitivity
    candidate_set: CandidateSet
    prognoses: tuple[Prognosis, ...]
    sample: InstanceSample
    elapsed: float
    borderline: int = 0  # instances whose verdict changes within +-2 SE of Monte Carlo bounds
    sensor_mapping: SensorMapping | None = None
    #: model_evaluations, reused_evaluations, failed_instances, prediction_store (None: no evaluator used)
    evaluation: dict | None = None

    @property
    def model_class_falsified(self) -> bool:
        return self.falsification.model_class_falsified

    @cached_property
    def candidates(self) -> pd.DataFrame:
        """Every candidate's parameters and predictions, indexed by instance (read from the file)."""
        return self.candidate_set.frame()

    def predict(self, qoi_model: Callable, uncertainty=None, *, probability: float = 0.95,
                name: str = "quantity of interest", unit: str = "") -> Prognosis:
        """Range of a quantity of interest over the candidates (see `edmf_rs.predict`).

        Parameters
        ----------
        qoi_model : callable
            Vectorised: (n_c, p) parameters -> (n_c,) values.
        uncertainty : scipy.stats frozen distribution, optional
            The QoI model's error (prediction minus true value).
        probability : float, default 0.95
            Of the central interval of ``uncertainty``.
        name, unit : str
            For reports.

        Returns
        -------
        Prognosis

        Raises
        ------
        ValueError
            If the model class is falsified (no candidates) or the QoI model
            returns the wrong shape.

        Examples
        --------
        >>> import edmf_rs
        >>> from edmf_rs import cli
        >>> ident = edmf_rs.Project.from_toml(cli.EXAMPLES / "cantilever.toml").run(progress=False)
        >>> q = ident.predict(lambda theta: theta[:, 0] / 1e3, name="E", unit="GPa")
        >>> q.model_low <= 70 <= q.model_high
        True
        """
        return predict(qoi_model, self.candidate_set.parameters(), uncertainty=uncertainty,
                       probability=probability, name=name, unit=unit)

    def parameter_ranges(self) -> dict[str, tuple[float, float] | None]:
        """Each parameter's [min, max] over the candidates.

        Returns
        -------
        dict
            Parameter name -> (min, max), or None without candidates (exact:
        computed over every candidate as they streamed to the file).

        Examples
        --------
        >>> import edmf_rs
        >>> from edmf_rs import cli
        >>> ident = edmf_rs.Project.from_toml(cli.EXAMPLES / "cantilever.toml").run(progress=False)
        >>> list(ident.parameter_ranges())
        ['E']
        """
        return {p.name: self.candidate_set.ranges[p.name] for p in self.project.parameters}

    def findings(self) -> list[str]:
        """Diagnostics in words: sensors, sensitivity, and parameters at their domain's edge.

        Returns
        -------
        list of str
            One sentence per finding (empty when there is nothing to say).

        Examples
        --------
        >>> import edmf_rs
        >>> from edmf_rs import cli
        >>> ident = edmf_rs.Project.from_toml(cli.EXAMPLES / "cantilever.toml").run(progress=False)
        >>> isinstance(ident.findings(), list)
        True
        """
        return findings(self.leave_one_out, self.sensitivity, self.thresholds.phi) + parameter_findings(
            self.project.parameters, self.parameter_ranges().values())

    def mapping_text(self) -> str:
        """How the model's outputs were matched to the sensors, in words.

        Returns
        -------
        str
            E.g. ``"by name (D10 -> D1, D1 -> D10)"``; empty when no mapping was needed.
        """
        m = self.sensor_mapping
        if m is None:
            return ""
        pairs = [f"{col} -> {name}" for col, name in zip(m.columns, self.project.sensor_names) if col != name]
        text = m.how + (f" ({', '.join(pairs)})" if pairs else "")
        if m.ignored:
            text += f"; outputs not used (no such sensor measured, or excluded): {', '.join(m.ignored)}"
        return text

    def thresholds_table(self) -> pd.DataFrame:
        """Per sensor: measured value, U_c moments, threshold bounds and leave-one-out counts.

        Returns
        -------
        pandas.DataFrame
            One row per sensor (the content of ``thresholds.csv``).

        Examples
        --------
        >>> import edmf_rs
        >>> from edmf_rs import cli
        >>> ident = edmf_rs.Project.from_toml(cli.EXAMPLES / "cantilever.toml").run(progress=False)
        >>> ident.thresholds_table().shape
        (10, 15)
        """
        s, loo = self.project.sensors, self.leave_one_out
        return pd.DataFrame({
            "sensor": [x.name for x in s], "type": [x.type for x in s],
            "location": [x.location for x in s], "unit": [x.unit for x in s],
            "measured": [x.value for x in s],
            "uc_mean": self.combined.mean, "uc_sd": self.combined.std,
            "threshold_low": self.thresholds.low, "threshold_high": self.thresholds.high,
            "threshold_low_se": _se(self.thresholds.se_low, len(s)),
            "threshold_high_se": _se(self.thresholds.se_high, len(s)),
            "method": list(self.thresholds.method or ("exact",) * len(s)),
            "falsified": loo.per_sensor_falsified, "falsified_only_by": loo.falsified_only_by,
            "candidates_without_sensor": loo.candidates_without_sensor,
        })

    def bound_methods(self) -> dict[str, list[str]]:
        """How each sensor's threshold bounds were found, as ``thresholds.csv``'s ``method`` column says.

        Returns
        -------
        dict
            ``"exact"`` (closed form: every source normal, or a single source),
            ``"convolution"`` (numerical convolution of the sources' densities)
            and ``"monte_carlo"`` (from the Monte Carlo samples: a source that
            cannot be convolved), each with its sensors in order; kinds no
            sensor has are left out.

        Examples
        --------
        >>> import edmf_rs
        >>> from edmf_rs import cli
        >>> ident = edmf_rs.Project.from_toml(cli.EXAMPLES / "cantilever.toml").run(progress=False)
        >>> list(ident.bound_methods()), len(ident.bound_methods()["exact"])
        (['exact'], 10)
        """
        methods = self.thresholds.method or ("exact",) * len(self.project.sensors)
        out: dict[str, list[str]] = {"exact": [], "convolution": [], "monte_carlo": []}
        for sensor, method in zip(self.project.sensors, methods):
            out[BOUND_METHODS.get(method, "monte_carlo")].append(sensor.name)
        return {kind: names for kind, names in out.items() if names}

    def summary(self) -> str:
        """A few lines for the terminal: instances, candidates, parameter ranges, findings.

        Returns
        -------
        str

        Examples
        --------
        >>> import edmf_rs
        >>> from edmf_rs import cli
        >>> ident = edmf_rs.Project.from_toml(cli.EXAMPLES / "cantilever.toml").run(progress=False)
        >>> print(ident.summary().splitlines()[0])
        Cantilever beam, scenario 2: 101 model instances, 10 sensors, phi = 0.95 (sidak correction), combined uncertainty exact (normal)
        """
        p, r = self.project, self.falsification
        methods = self.bound_methods()
        if self.combined.exact:
            combined = "exact (normal)"
        else:
            how = {"exact": "exact", "convolution": "numerical convolution of the sources",
                   "monte_carlo": f"Monte Carlo ({p.n_samples:,} samples)"}
            combined = how[next(iter(methods))] if len(methods) == 1 else ", ".join(
                f"{how[kind]} at {plural(len(names), 'sensor')}" for kind, names in methods.items())
        lines = [f"{p.name}: {plural(r.n_instances, 'model instance')}, {plural(r.n_sensors, 'sensor')}, "
                 f"phi = {p.phi:g} ({p.correction} correction), combined uncertainty {combined}"]
        if r.model_class_falsified and r.n_invalid == r.n_instances:
            lines.append("candidate model set: EMPTY - every instance is invalid (NaN predictions), "
                         "none could be compared with the measurements")
        elif r.model_class_falsified:
            lines.append(f"candidate model set: EMPTY - every {'valid ' if r.n_invalid else ''}instance is "
                         "falsified, so is the model class")
        else:
            lines.append(f"candidate model set: {plural(r.n_candidates, 'instance')} "
                         f"({100.0 * r.n_candidates / r.n_instances:.3g} %)")
            for param, (lo, hi) in zip(p.parameters, self.parameter_ranges().values()):
                unit = f" [{param.unit}]" if param.unit else ""
                lo, hi, low, high = (in_domain(v, param.low, param.high) for v in (lo, hi, param.low, param.high))
                lines.append(f"  {param.name}{unit}: {lo} .. {hi}  (domain {low} .. {high})")
        lines.append(f"guarantee: {self.thresholds.guarantee()}")
        if self.thresholds.monte_carlo:
            lines.append(f"borderline instances (verdict changes within 2 Monte Carlo SE of the bounds): "
                         f"{self.borderline:,}")
        ev = self.evaluation or {}
        if ev.get("failed_instances"):
            lines.append(f"failed model runs (neither candidates nor falsified, see failures.csv): "
                         f"{ev['failed_instances']:,}")
        if r.n_invalid and r.n_invalid != ev.get("failed_instances"):
            lines.append(f"invalid instances (NaN predictions; neither candidates nor falsified): {r.n_invalid:,}")
        if ev:
            lines.append(f"model evaluations: {ev['model_evaluations']:,}, reused from the prediction store: "
                         f"{ev['reused_evaluations']:,}")
        if self.sensor_mapping is not None:
            lines.append(f"model outputs matched to the sensors {self.mapping_text()}")
        lines += [f"- {text}" for text in self.findings()]
        lines += [f"prognosis: {prog.summary()}" for prog in self.prognoses]
        return "\n".join(lines)

    def summary_dict(self) -> dict:
        """The content of ``summary.json``.

        Returns
        -------
        dict
            JSON-safe (NumPy scalars as Python numbers, non-finite values as None).

        Examples
        --------
        >>> import edmf_rs
        >>> from edmf_rs import cli
        >>> ident = edmf_rs.Project.from_toml(cli.EXAMPLES / "cantilever.toml").run(progress=False)
        >>> ident.summary_dict()["instances"]
        101
        """
        p, r, t = self.project, self.falsification, self.thresholds
        sens = self.sensitivity
        ranges = self.parameter_ranges()
        return json_safe({
            "schema": SUMMARY_SCHEMA,
            "project": {"name": p.name, "file": p.file.name, "description": p.description},
            "instances": r.n_instances, "candidates": r.n_candidates, "invalid": r.n_invalid,
            "model_class_falsified": r.model_class_falsified,
            "model_evaluations": (self.evaluation or {}).get("model_evaluations"),
            "reused_evaluations": (self.evaluation or {}).get("reused_evaluations"),
            "failed_instances": (self.evaluation or {}).get("failed_instances", 0),
            "identification": {
                "phi": p.phi, "correction": p.correction, "per_sensor_probability": t.probability,
                "combined_uncertainty": self.bound_methods(),
                "monte_carlo_samples": None if self.combined.exact else p.n_samples,
                "monte_carlo_seed": None if self.combined.exact else p.seed,
                "monte_carlo_confidence": t.confidence,
                "guaranteed_probability": t.guaranteed_probability, "guarantee": t.guarantee(),
                "borderline_instances": self.borderline,
                "sensor_mapping": None if self.sensor_mapping is None else {
                    "how": self.sensor_mapping.how, "columns": list(self.sensor_mapping.columns),
                    "ignored": list(self.sensor_mapping.ignored)},
            },
            "sampling": ({"method": "precomputed", "n": r.n_instances} if p.sampling is None else
                         {"method": p.sampling.method, "n": p.sampling.n, "seed": p.sampling.seed,
                          "points": dict(zip(p.parameter_names, p.sampling.points)) if p.sampling.points else None}),
            "parameters": {param.name: {"unit": param.unit, "scale": param.scale, "low": param.low,
                                        "high": param.high,
                                        "candidates": None if ranges[param.name] is None else
                                        {"min": ranges[param.name][0], "max": ranges[param.name][1]}}
                           for param in p.parameters},
            "thresholds": self.thresholds_table().to_dict(orient="records"),
            "excluded_sensors": [s.name for s in p.excluded],
            "diagnostics": {
                "findings": self.findings(),
                "suspect_sensors": [p.sensors[i].name for i in self.leave_one_out.suspects],
                "fewest_sensors_violated": sens.fewest_violated,
                "smallest_scale": sens.smallest_scale, "smallest_phi": sens.smallest_phi,
                "phi_exact": sens.phi_exact,
                "sensitivity": {"scale": sens.scales.tolist(), "candidates_at_scale": sens.candidates_at_scale.tolist(),
                                "phi": sens.phis.tolist(), "candidates_at_phi": sens.candidates_at_phi.tolist()},
            },
            "prognosis": [prog.as_dict() for prog in self.prognoses],
            "elapsed_seconds": round(self.elapsed, 3),
        })

    def output_files(self) -> tuple[str, ...]:
        """The names of the files `write` writes.

        Returns
        -------
        tuple of str
            File names in the output folder (an adaptive run's adds its waves figure).

        Examples
        --------
        >>> import edmf_rs
        >>> from edmf_rs import cli
        >>> ident = edmf_rs.Project.from_toml(cli.EXAMPLES / "cantilever.toml").run(progress=False)
        >>> "summary.json" in ident.output_files(), "adaptive_waves.png" in ident.output_files()
        (True, False)
        """
        return OUTPUT_FILES

    def write(self, out_dir: str | Path) -> Path:
        """Writes plots, candidates.parquet, thresholds.csv, report.html, then summary.json.

        Each file is written atomically; an earlier summary.json is removed
        first, so an interrupted write never leaves one that looks complete.

        Parameters
        ----------
        out_dir : str or pathlib.Path
            The output folder, created if missing.

        Returns
        -------
        pathlib.Path
            The output folder.

        Raises
        ------
        OSError
            If a file cannot be written.

        Examples
        --------
        >>> import edmf_rs
        >>> from edmf_rs import cli
        >>> ident = edmf_rs.Project.from_toml(cli.EXAMPLES / "cantilever.toml").run(progress=False)
        >>> import tempfile
        >>> out = ident.write(tempfile.mkdtemp())
        >>> (out / "summary.json").is_file(), (out / "report.html").is_file()
        (True, True)
        """
        from .report import html as report  # matplotlib only when writing
        from .report import plots as report_plots

        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        (out / "summary.json").unlink(missing_ok=True)
        figures = report_plots.figures(self)
        for name, png in figures.items():
            write_bytes(out / f"{name}.png", png)
        self.candidate_set.save(out / "candidates.parquet")  # renamed from its temporary name, or copied
        write_text(out / "thresholds.csv", self.thresholds_table().to_csv(index=False))
        write_text(out / "report.html", report.render(self, figures))
        write_text(out / "summary.json", json.dumps(self.summary_dict(), indent=2) + "\n")
        return out


def _se(values, n: int) -> list:
    """Per-sensor standard errors of the bounds (0 for exact bounds)."""
    return [0.0] * n if values is None else [float(v) for v in values]
