"""``[sampling] method = "adaptive"`` in a project file (issue 16, step 4).

The project runner reads the options here (:func:`adaptive_sampling`) and
hands the run over (:func:`run_adaptive`): :func:`edmf_rs.adaptive_falsify`
with the project's model, domain, measurements and thresholds; the real runs
then feed the usual diagnostics, so the report and summary.json are those of
a sampled run plus the record of each wave (runs per wave, kept region per
wave on a scatter matrix, emulator validation).

Options (all but ``method`` optional)::

    [sampling]
    method = "adaptive"
    budget = 400          # most real model runs (default 40 x n_params + 200)
    n_initial = 60        # initial Sobol' design (default 20 x n_params)
    wave_size = 30        # runs per wave (default 10 x n_params)
    n_screen = 1048576    # emulator screening sample
    c = 3.0               # screening margin, emulator standard deviations
    seed = 0
    basis = "auto"        # emulators per sensor ("sensors") or on principal components
                          # of the outputs ("pca"); "auto": "pca" above 10 sensors
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from html import escape
from pathlib import Path

import numpy as np

from ..adaptive.design import BUDGET_HINT, budget_problem
from ..adaptive.result import AdaptiveResult
from ..adaptive.waves import adaptive_falsify
from ..stream.atomic import write_bytes, write_text
from .format import json_safe
from .result import ADAPTIVE_FILES, Identification
from .table import ProjectError

KEYS = ("method", "budget", "n_initial", "wave_size", "n_screen", "c", "seed", "basis")


@dataclass(frozen=True)
class AdaptiveSampling:
    """The [sampling] table of an adaptive project (``n`` is the budget)."""

    parameters: tuple
    budget: int
    n_initial: int | None = None
    wave_size: int | None = None
    n_screen: int = 2**20
    c: float = 3.0
    seed: int = 0
    basis: str = "auto"
    method: str = "adaptive"
    points: None = None

    @property
    def n(self) -> int:
        return self.budget

    def head(self, k: int = 2) -> np.ndarray:
        """The first ``k`` runs of the initial design (to check the model and the
        prognoses on before a run, as ``Sampling.head`` does)."""
        from ..adaptive.design import sobol_points

        u = sobol_points(k, len(self.parameters), self.seed)
        return np.column_stack([q.from_unit(u[:, j]) for j, q in enumerate(self.parameters)])

    def describe(self) -> str:
        return f"adaptive (emulator-steered waves), budget {self.budget:,} runs, seed {self.seed}"


def adaptive_sampling(table, parameters) -> AdaptiveSampling:
    """Reads [sampling] with method = "adaptive" (``table``: a project_schema.Table)."""
    table.check_keys(KEYS)
    p = len(parameters)

    def count(key, default, least=1):
        value = table.get(key, "int", default, what=f"an integer >= {least}")
        if value is not None and value < least:
            raise table.error(key, f"an integer >= {least}", value)
        return value

    c = table.get("c", "number", 3.0, what="a number >= 0")
    if c < 0:
        raise table.error("c", "a number >= 0", c)
    budget = count("budget", 40 * p + 200)
    n_initial, wave_size = count("n_initial", None, p + 1), count("wave_size", None)
    problem = budget_problem(p, budget, n_initial, wave_size)
    if problem is not None:
        raise ProjectError(f"{table.error('budget', problem, budget)}; {BUDGET_HINT}")
    return AdaptiveSampling(parameters, budget=budget, n_initial=n_initial,
                            wave_size=wave_size, n_screen=count("n_screen", 2**20),
                            c=c, seed=table.get("seed", "seed", 0),
                            basis=table.get("basis", "choice", "auto", choices=("auto", "sensors", "pca")))


def adaptive_evaluator(project, out, workers):
    """The simulators' evaluator for the real runs of an adaptive project, or None.

    As for a sampled project (:func:`edmf_rs.project.external.make_evaluator`:
    external programs, workers, failures), but its prediction store finds a
    run by its parameters, not its position in a sample: where the waves put
    runs depends on the thresholds, so a rerun with another phi or another
    uncertainty source reuses every run it asks for again, and a killed run
    resumes without repeating one.
    """
    from ..simulators import FailurePolicy
    from ..simulators.keyed import KeyedEvaluator

    m = project.model
    workers = m.workers if workers is None else workers
    if m.predictions is not None or (out is None and project.command is None and workers == 1):
        return None
    names = [s.name for s in project.all_sensors]
    # Where the runs go does not change what the model gives there: only the names key the store.
    sampling = {"method": "adaptive", "parameters": list(project.parameter_names), "sensors": names}
    return KeyedEvaluator(project.parameter_names, names, project.sampling.budget, command=project.command,
                          function=project.model_function, ref=m.function or "", path=m.path, options=m.options,
                          workers=workers, out=out, sampling=sampling, store=m.store,
                          policy=FailurePolicy(m.stop_after_failures, m.max_failure_rate))


def run_adaptive(project, *, progress: bool = True, out=None, workers: int | None = None):
    """Runs an adaptive project: the waves, then the diagnostics on every real run.

    With ``out`` (or an external program, or ``workers`` > 1) every real run
    goes through the simulators' evaluator and its prediction store
    (:func:`adaptive_evaluator`); failed runs (external programs) are NaN rows:
    neither candidates nor falsified, listed in failures.csv.
    """
    from ..engine.thresholds import threshold_bounds
    from .candidates import CandidateWriter
    from .diagnostics import SensitivityTracker, leave_one_out
    from .evaluation import checked_model
    from .qoi import prognosis_of
    from .result import PlotSample
    from .schema import ProjectError

    start = time.perf_counter()
    s = project.sampling
    combined = project.combined_uncertainty()
    thresholds = threshold_bounds(combined, project.phi, project.correction)
    evaluator = adaptive_evaluator(project, out, workers)
    try:
        model = checked_model(project, evaluator)  # outputs matched to the sensors by name, failures named
        result = adaptive_falsify(model, project.parameters, project.measured, thresholds, budget=s.budget,
                                  n_initial=s.n_initial, wave_size=s.wave_size, n_screen=s.n_screen, c=s.c,
                                  seed=s.seed, basis=s.basis, nan="falsify" if project.command else project.model.nan)
    except ProjectError:
        raise
    except ValueError as exc:
        raise ProjectError(f"{project.file}: sampling: {exc}") from None
    finally:
        if evaluator is not None:
            evaluator.close()
    tracker = SensitivityTracker(thresholds, combined, project.measured)
    sample = PlotSample(result.n_runs)
    tracker(0, result.run_parameters, result.run_predictions)
    falsification = tracker.discount(result.falsification)  # failed runs: neither candidates nor falsified
    sample(0, result.run_parameters, result.run_predictions)
    writer = CandidateWriter(None, project.parameter_names, project.sensor_names)  # a few hundred real runs
    writer.add(falsification.candidate_indices, falsification.candidate_parameters,
               falsification.candidate_predictions)
    candidates = writer.finish()
    prognoses = ()
    if falsification.n_candidates:
        prognoses = tuple(prognosis_of(project, spec, func, falsification.candidate_parameters)
                          for spec, func in project.prognosis)
    ident = Identification(project=project, combined=combined, thresholds=thresholds, falsification=falsification,
                           leave_one_out=leave_one_out(falsification, project.sensor_names, tracker.nan_at),
                           sensitivity=tracker.finish(), candidate_set=candidates, prognoses=prognoses,
                           sample=sample.finish(falsification.candidate_mask), elapsed=time.perf_counter() - start,
                           evaluation=evaluator.stats() if evaluator is not None else None)
    return AdaptiveIdentification(**{f: getattr(ident, f) for f in ident.__dataclass_fields__}, adaptive=result)


@dataclass(frozen=True, eq=False)
class AdaptiveIdentification(Identification):
    """An :class:`~edmf_rs.project_result.Identification` from adaptive
    sampling: ``adaptive`` records the waves; summary.json gains an
    ``adaptive`` entry and the report an "Adaptive sampling" section."""

    adaptive: AdaptiveResult | None = None

    def summary(self) -> str:
        return super().summary() + "\n" + self.adaptive.summary()

    def summary_dict(self) -> dict:
        out = super().summary_dict()
        out["adaptive"] = json_safe(self.adaptive.as_dict())
        return out

    def output_files(self) -> tuple[str, ...]:
        return (*super().output_files(), *ADAPTIVE_FILES)

    def write(self, out_dir) -> Path:
        from .report import plots as report_plots

        out = super().write(out_dir)
        png = report_plots._png(waves_figure(self))
        write_bytes(out / "adaptive_waves.png", png)
        html = (out / "report.html").read_text(encoding="utf-8")
        html = html.replace("<h2>Parameters</h2>", waves_section(self, png) + "<h2>Parameters</h2>", 1)
        (out / "summary.json").unlink(missing_ok=True)  # summary.json last: a complete folder
        write_text(out / "report.html", html)
        write_text(out / "summary.json", json.dumps(self.summary_dict(), indent=2) + "\n")
        return out


def waves_section(ident, png: bytes) -> str:
    """The report's "Adaptive sampling" section: a table of waves and the kept regions."""
    import base64

    r = ident.adaptive
    rows = "".join(
        f"<tr><td>{w.index}</td><td class='l'>{escape(w.kind)}</td><td>{w.n_runs}</td><td>{w.n_runs_total}</td>"
        f"<td>{w.n_candidates}</td><td>{'' if w.kept_fraction is None else f'{w.kept_fraction:.3g}'}</td>"
        f"<td>{'' if w.validated is None else ('yes' if w.validated else '<b>FAILED</b>')}</td>"
        f"<td>{'' if w.loo_error is None else f'{np.max(w.loo_error):.3g}'}</td>"
        f"<td>{'' if w.sigma_ratio is None else f'{w.sigma_ratio:.3g}'}</td>"
        f"<td class='l'>{escape('; '.join(w.problems))}</td></tr>" for w in r.waves)
    head = ("<tr><th>wave</th><th class='l'>runs placed</th><th>runs</th><th>runs so far</th><th>candidates so far</th>"
            "<th>kept share of the domain</th><th>emulator validated</th><th>worst LOO error / threshold width</th>"
            "<th>sigma / width (95 %)</th><th class='l'>emulator problems</th></tr>")
    text = (f"<p>{r.n_runs} real model runs in {len(r.waves)} waves (stopped: {escape(r.stop_reason)}). The "
            f"emulators ({escape(r.emulator_description())}) only chose where to run the model; the candidates "
            "are decided by Eq. 8 on the real model outputs.</p>")
    if r.confidence:
        text += f"<p>{escape(r.confidence)}</p>"
    img = base64.b64encode(png).decode()
    return (f"<h2>Adaptive sampling</h2>{text}<table>{head}{rows}</table><figure><img src='data:image/png;base64,{img}'>"
            "<figcaption>Kept region of each wave's emulator (sample of the kept screening points) over the real "
            "runs of that wave, parameter by parameter.</figcaption></figure>")


def waves_figure(ident):
    """Kept region per wave on a scatter matrix (lower triangle), real runs marked per wave."""
    from matplotlib.figure import Figure

    r = ident.adaptive
    params = r.parameters
    p = len(params)
    fig = Figure(figsize=(2.6 * max(p - 1, 1) + 1, 2.6 * max(p - 1, 1)))
    waves = [w for w in r.waves if w.kept_sample is not None and w.kept_sample.shape[0]]
    colors = [f"C{k % 10}" for k in range(len(r.waves))]

    def unit(theta, j):
        return params[j].to_unit(theta[:, j])

    pairs = [(i, j) for i in range(1, p) for j in range(i)] if p > 1 else [(0, 0)]
    n = max(p - 1, 1)
    for i, j in pairs:
        ax = fig.add_subplot(n, n, (i - 1) * n + j + 1 if p > 1 else 1)
        for w in waves:
            ax.scatter(unit(w.kept_sample, j), unit(w.kept_sample, i) if p > 1 else np.zeros(len(w.kept_sample)),
                       s=3, alpha=0.25, color=colors[w.index], label=f"kept after wave {w.index}")
        for k, w in enumerate(r.waves):
            runs = r.run_parameters[r.run_wave == w.index]
            if runs.shape[0]:
                ax.scatter(unit(runs, j), unit(runs, i) if p > 1 else np.zeros(len(runs)), s=9, marker="x",
                           color=colors[k], label=f"runs of wave {w.index}")
        ax.set_xlim(0, 1)
        ax.set_ylim(0, 1)
        ax.set_xlabel(f"{params[j].name} (share of domain)", fontsize=8)
        ax.set_ylabel(f"{params[i].name}" if p > 1 else "", fontsize=8)
    handles, labels = fig.axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper right", fontsize=7, markerscale=2)
    fig.tight_layout()
    return fig
