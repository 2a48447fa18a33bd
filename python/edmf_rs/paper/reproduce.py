"""Reproduce Goulet & Smith (2013) end to end: Fig. 3, Figs. 6-8 and Table 1.

The paper judges each method on one noise draw. Here every method x scenario
x n_m is judged over many independent draws of the sensor noise (``seeds``,
default 200) and the correct rate is reported; Table 1 is then derived from
the rates. The rules (also returned as `RULES` and written to
results.json):

Least squares (wls)
    Weighted least squares over the 101 model instances with
    W = diag(y)^-2 (Eq. 15). Correct when |E_hat - E*| <= 5 % of E*.

Bayesian inference (bayes)
    Uniform prior over the 101 instances (Eq. 16), Gaussian likelihood
    (Eq. 17) with the combined-uncertainty mean per sensor and a diagonal
    covariance of the combined variances (the paper's independence
    assumption). Correct when the 95 % highest-posterior-density set (instances
    by decreasing posterior until the cumulative mass reaches 0.95) contains
    the grid point nearest E*. E* = 70e3 MPa lies midway between the grid
    points 69.6e3 and 70.4e3, so either of the two counts.

Error-domain model falsification (edmf)
    phi = 0.95, Sidak correction, thresholds from the exact combined normal of
    each draw (Eq. 6), falsification by Eq. 8. Correct when the candidate
    model set is non-empty and E* lies within its range, widened by half a
    grid step at each end; in scenario 3 (unrecognised errors) also when the
    candidate set is empty, since the model class is then rightly falsified.

Table 1
    A method is correct (✓) in a scenario when its correct rate at the
    largest n_m (50) is at least 0.5, i.e. it identifies correctly in most
    draws provided a sufficient number of measurements is used; otherwise ×.

Median candidate-set size (median_cms_size)
    edmf: the median number of candidate models; bayes: the median size of
    the 95 % HPD set; wls: 1 (a single optimum).

Draws
    The sensor noise of draw k for a given n_m is row k of
    ``numpy.random.default_rng([seed, n_m]).normal(0, 0.02, (seeds, n_m))``; the
    same noise is used in the three scenarios (common random numbers), and
    the figures show draw 0. Fig. 3 uses 1000 draws per panel as in the paper.
"""

from __future__ import annotations

import json
import numbers
import time
from dataclasses import asdict, dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
from scipy import stats

from ..engine._validate import finite_vector
from ..engine.falsify import falsify
from ..engine.result import FalsificationResult
from ..engine.thresholds import Thresholds, threshold_bounds
from ..stream.atomic import write_text
from . import cantilever as cl
from . import coverage as cov
from .out_folder import check_out
from .baselines import (
    LeastSquaresResult,
    PosteriorResult,
    bayesian_posterior,
    least_squares,
)

PHI = 0.95
HPD_MASS = 0.95
LS_TOLERANCE = 0.05   # of E*
TABLE_MIN_RATE = 0.5  # at the largest n_m
METHODS = ("wls", "bayes", "edmf")
METHOD_NAMES = {
    "wls": "Residual minimization",
    "bayes": "Bayesian inference",
    "edmf": "Error-domain model falsification",
}
#: Table 1 of the paper: True is ✓, False is ×.
PAPER_TABLE1 = {
    1: {"wls": True, "bayes": True, "edmf": True},
    2: {"wls": False, "bayes": False, "edmf": True},
    3: {"wls": False, "bayes": False, "edmf": True},
}
RULES = {
    "wls": "Weighted least squares with W = diag(y)^-2 (Eq. 15); correct when |E_hat - E*| <= 5 % of E*.",
    "bayes": ("Uniform prior, Gaussian likelihood (Eq. 17) with the combined mean and a diagonal covariance "
              "of the combined variances (independence assumed); correct when the 95 % highest-posterior-"
              "density set contains the grid point nearest E* (either of the two equidistant ones)."),
    "edmf": ("phi = 0.95, Sidak, thresholds from the exact combined normal of each draw (Eq. 6, 8); correct "
             "when the candidate model set is non-empty and E* lies within its range (to half a grid step); "
             "in scenario 3 also when the candidate set is empty (model class falsified)."),
    "table": ("A method is correct (✓) in a scenario when its correct rate at the largest n_m (50) is at "
              "least 0.5: it identifies correctly in most draws provided a sufficient number of "
              "measurements is used; otherwise ×."),
    "median_cms_size": ("edmf: median number of candidate models; bayes: median size of the 95 % HPD set; "
                        "wls: 1 (a single optimum)."),
    "draws": ("Draw k for a given n_m uses row k of numpy.random.default_rng([seed, n_m]) normal noise, "
              "shared by the three scenarios; the figures show draw 0; Fig. 3 uses 1000 draws per panel."),
}
FIGURES = {1: "fig6_scenario1.png", 2: "fig7_scenario2.png", 3: "fig8_scenario3.png"}
COVERAGE_FIGURE = "fig3_coverage.png"
MARK = {True: "✓", False: "×"}


@dataclass(frozen=True, eq=False)
class Identification:
    """The three methods applied to one set of measurements of one scenario."""

    scenario: cl.Scenario
    x: np.ndarray
    measurements: np.ndarray
    least_squares: LeastSquaresResult
    posterior: PosteriorResult
    falsification: FalsificationResult

    @property
    def n_sensors(self) -> int:
        return int(self.x.shape[0])


@dataclass(frozen=True)
class Rate:
    """Share of draws in which ``method`` (``"wls"``, ``"bayes"``, ``"edmf"``) identified correctly.

    One row of results.json; ``median_cms_size`` is the median candidate-set
    (edmf) or HPD-set (bayes) size, 1 for wls.

    Attributes
    ----------
    scenario, n_m, method, correct_rate, seeds, median_cms_size
        As above. Examples: see `identification_rates`.
    """

    scenario: int
    n_m: int
    method: str
    correct_rate: float
    seeds: int
    median_cms_size: float


@dataclass(frozen=True, eq=False)
class Reproduction:
    """Everything `reproduce` computed and the files it wrote.

    Attributes
    ----------
    coverage, rates, table, files, seconds
        Fig. 3 results, `Rate` rows, Table 1, the paths written, the time taken. Examples: see `reproduce`.
    """

    coverage: tuple[cov.CoverageResult, ...]
    rates: tuple[Rate, ...]
    table: dict[int, dict[str, bool]]
    files: dict[str, Path]
    seconds: float


@lru_cache(maxsize=None)
def _setup(n_m: int) -> tuple[np.ndarray, np.ndarray, Thresholds]:
    """Sensor positions, grid predictions (101, n_m) and the thresholds of a
    standard normal per sensor for n_m sensors (cached: the same for every draw)."""
    x = cl.sensor_positions(n_m)
    g = np.ascontiguousarray(cl.predictions(x))
    x.flags.writeable = g.flags.writeable = False
    standard = threshold_bounds(stats.norm(loc=np.zeros(n_m), scale=np.ones(n_m)), phi=PHI, correction="sidak")
    return x, g, standard


def edmf_thresholds(mean: np.ndarray, sd: np.ndarray, standard: Thresholds) -> Thresholds:
    """Thresholds of the exact combined normal N(mean, sd) per sensor (Eq. 6).

    A normal is a location-scale family, so F^-1(p) = mean + sd * Phi^-1(p):
    the bounds of the standard normal (computed once per n_m by
    :func:`edmf_rs.threshold_bounds`) shifted and scaled per draw. Identical to
    ``threshold_bounds(combine(...))`` without building 2 n_m scipy objects per draw.
    """
    return Thresholds(mean + sd * standard.low, mean + sd * standard.high,
                      phi=standard.phi, probability=standard.probability, correction=standard.correction)


def identify(scenario: cl.Scenario, measurements) -> Identification:
    """Least squares, Bayesian inference and EDMF for one set of measurements
    at the sensors of :func:`cantilever.sensor_positions` (n_m = len(measurements))."""
    y = finite_vector(measurements, "measurements")
    x, g, standard = _setup(int(y.shape[0]))
    mean, sd = cl.combined_moments(scenario, y)
    return Identification(
        scenario=scenario,
        x=x,
        measurements=y,
        least_squares=least_squares(g, y, parameters=cl.E_GRID),
        posterior=bayesian_posterior(g, y, sd**2, mean=mean, mass=HPD_MASS),
        falsification=falsify(g, y, edmf_thresholds(mean, sd, standard), diagnostics=False),
    )


_NEAREST = np.abs(cl.E_GRID - cl.E_TRUE) <= 0.5 * cl.GRID_STEP * (1 + 1e-9)


def judge(ident: Identification) -> dict[str, bool]:
    """Whether each method identified correctly, by the rules of this module."""
    scn = ident.scenario
    candidates = ident.falsification.candidate_indices
    if candidates.size:
        half = 0.5 * cl.GRID_STEP
        edmf = bool(cl.E_GRID[candidates[0]] - half <= cl.E_TRUE <= cl.E_GRID[candidates[-1]] + half)
    else:
        edmf = scn.has_model_error and not scn.model_uncertainty_recognised  # scenario 3
    return {
        "wls": bool(abs(cl.E_GRID[ident.least_squares.index] - cl.E_TRUE) <= LS_TOLERANCE * cl.E_TRUE),
        "bayes": bool(np.any(ident.posterior.hpd_mask & _NEAREST)),
        "edmf": edmf,
    }


def measurement_draws(scenario: cl.Scenario, n_m: int, seeds: int, seed: int = 0) -> np.ndarray:
    """Independent simulated measurements (seeds, n_m) of Eq. 13 (see "Draws" above)."""
    x, _, _ = _setup(n_m)
    return cl.simulate_measurements(x, scenario.K, np.random.default_rng([seed, n_m]), size=seeds)


def identification_rates(seeds: int = 200, seed: int = 0, *, scenarios=cl.SCENARIOS,
                         n_sensors=cl.N_SENSORS) -> tuple[Rate, ...]:
    """Correct rate of each method x scenario x n_m over ``seeds`` noise draws.

    Parameters
    ----------
    seeds, seed : int
        Noise draws per scenario and n_m (default 200); base seed (default 0, see "Draws" above).
    scenarios, n_sensors : tuple
        Which scenarios and numbers of sensors.

    Returns
    -------
    tuple of Rate

    Raises
    ------
    TypeError, ValueError
        If ``seeds`` is not a positive integer.

    Examples
    --------
    >>> from edmf_rs.paper import reproduce as rp
    >>> rates = rp.identification_rates(seeds=4, n_sensors=(50,))
    >>> rp.table1(rates)[2]
    {'wls': False, 'bayes': False, 'edmf': True}
    """
    seeds = _seeds(seeds)
    rates = []
    for scn in scenarios:
        for n_m in n_sensors:
            correct = {m: 0 for m in METHODS}
            cms, hpd = [], []
            for y in measurement_draws(scn, n_m, seeds, seed):
                ident = identify(scn, y)
                for method, ok in judge(ident).items():
                    correct[method] += ok
                cms.append(ident.falsification.n_candidates)
                hpd.append(ident.posterior.hpd_size)
            size = {"wls": 1.0, "bayes": float(np.median(hpd)), "edmf": float(np.median(cms))}
            rates.extend(Rate(scn.number, n_m, m, correct[m] / seeds, seeds, size[m]) for m in METHODS)
    return tuple(rates)


def table1(rates, min_rate: float = TABLE_MIN_RATE) -> dict[int, dict[str, bool]]:
    """Table 1 from the rates: correct when the rate at the largest n_m is >= min_rate.

    Parameters
    ----------
    rates : sequence of Rate
    min_rate : float, default 0.5

    Returns
    -------
    dict
        Scenario -> method -> correct. Examples: see `identification_rates`.
    """
    table: dict[int, dict[str, bool]] = {}
    for scenario in sorted({r.scenario for r in rates}):
        rows = [r for r in rates if r.scenario == scenario]
        largest = max(r.n_m for r in rows)
        table[scenario] = {r.method: r.correct_rate >= min_rate for r in rows if r.n_m == largest}
    return table


def example_identifications(scenario: cl.Scenario, seed: int = 0, n_sensors=cl.N_SENSORS):
    """Draw 0 of each n_m: what Figs. 6-8 show."""
    return tuple(identify(scenario, measurement_draws(scenario, n_m, 1, seed)[0]) for n_m in n_sensors)


def format_table1(table) -> str:
    names = {s.number: s.name for s in cl.SCENARIOS}
    lines = ["| Scenario | " + " | ".join(METHOD_NAMES[m] for m in METHODS) + " |",
             "|---|" + "---|" * len(METHODS)]
    for scenario, row in sorted(table.items()):
        lines.append(f"| {scenario}. {names[scenario]} | " + " | ".join(MARK[row[m]] for m in METHODS) + " |")
    return "\n".join(lines)


def format_rates(rates) -> str:
    n_list = sorted({r.n_m for r in rates})
    lines = ["| Scenario | Method | " + " | ".join(f"n_m = {n}" for n in n_list) + " |",
             "|---|---|" + "---|" * len(n_list)]
    for scenario in sorted({r.scenario for r in rates}):
        for m in METHODS:
            cells = []
            for n in n_list:
                r = next(r for r in rates if (r.scenario, r.method, r.n_m) == (scenario, m, n))
                cells.append(f"{r.correct_rate:.3f}" + ("" if m == "wls" else f" ({r.median_cms_size:g})"))
            lines.append(f"| {scenario} | {m} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def format_coverage(results) -> str:
    lines = ["| rho true | rho assumed | P_M (ellipse) | P_T (Sidak rectangle) |", "|---|---|---|---|"]
    lines += [f"| {r.rho_true:g} | {r.rho_assumed:g} | {r.P_M:.3f} | {r.P_T:.3f} |" for r in results]
    return "\n".join(lines)


def _markdown(rates, table, coverage_results, seeds: int, seed: int) -> str:
    return "\n".join([
        "# Table 1: correct identification (Goulet & Smith 2013, cantilever beam)",
        "",
        format_table1(table),
        "",
        f"Rule: {RULES['table']}",
        "",
        f"## Correct rates over {seeds} noise draws (seed {seed})",
        "",
        "Cells: correct rate (median candidate-set size for edmf, median 95 % HPD-set size for bayes).",
        "",
        format_rates(rates),
        "",
        *(f"- {m}: {RULES[m]}" for m in METHODS),
        "",
        "## Fig. 3: share of draws inside the ellipse (P_M) and the rectangle (P_T)",
        "",
        format_coverage(coverage_results),
        "",
    ])


def _results_json(rates, table, coverage_results, seeds: int, seed: int) -> dict:
    return {
        "coverage": [{"rho_true": r.rho_true, "rho_assumed": r.rho_assumed, "P_M": r.P_M, "P_T": r.P_T}
                     for r in coverage_results],
        "identification": [asdict(r) for r in rates],
        "table1": {str(s): {m: MARK[v] for m, v in row.items()} for s, row in table.items()},
        "paper_table1": {str(s): {m: MARK[v] for m, v in row.items()} for s, row in PAPER_TABLE1.items()},
        "matches_paper": table == PAPER_TABLE1,
        "rules": RULES,
        "settings": {"seeds": seeds, "seed": seed, "phi": PHI, "hpd_mass": HPD_MASS,
                     "ls_tolerance": LS_TOLERANCE, "table_min_rate": TABLE_MIN_RATE,
                     "E_true": cl.E_TRUE, "E_grid": [cl.E_GRID[0], cl.E_GRID[-1], len(cl.E_GRID)],
                     "n_sensors": list(cl.N_SENSORS), "coverage_draws": cov.PAPER_N_DRAWS},
    }


def _seeds(seeds) -> int:
    if isinstance(seeds, bool) or not isinstance(seeds, numbers.Integral):
        raise TypeError(f"--seeds: expected a positive integer, got {type(seeds).__name__}")
    if seeds < 1:
        raise ValueError(f"--seeds: expected at least 1 noise draw, got {seeds}")
    return int(seeds)


def reproduce(out, seeds: int = 200, seed: int = 0, *, force: bool = False) -> Reproduction:
    """Compute everything and write the figures, table1.md and results.json into ``out``.

    Parameters
    ----------
    out : str or pathlib.Path
        Output folder, created if missing; refused when it holds files a
        reproduction does not write, unless ``force``.
    seeds, seed : int
        Noise draws per method, scenario and n_m (default 200); base seed (default 0).

    Returns
    -------
    Reproduction

    Raises
    ------
    TypeError, ValueError, OSError
        If ``seeds`` or ``seed`` is not a valid integer; if ``out`` is a file or
        holds other files (without ``force``); if a file cannot be written.

    Examples
    --------
    >>> import tempfile
    >>> from edmf_rs.paper import reproduce as rp
    >>> rep = rp.reproduce(tempfile.mkdtemp(), seeds=2)
    >>> sorted(rep.files)
    ['fig3', 'fig6', 'fig7', 'fig8', 'results', 'table1']
    """
    from . import figures as plots  # matplotlib only when figures are made

    start = time.perf_counter()
    seeds = _seeds(seeds)
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise ValueError(f"--seed: expected a non-negative integer, got {seed!r}")
    out = Path(out)
    check_out(out, {COVERAGE_FIGURE, *FIGURES.values(), "table1.md", "results.json"}, force)
    out.mkdir(parents=True, exist_ok=True)
    # results.json is written last: without it, a folder's outputs are known to be incomplete.
    (out / "results.json").unlink(missing_ok=True)

    coverage_results = cov.figure3_cases(n_draws=cov.PAPER_N_DRAWS, seed=seed)
    rates = identification_rates(seeds, seed)
    table = table1(rates)

    files = {"fig3": out / COVERAGE_FIGURE}
    plots.close(plots.coverage_figure(coverage_results, path=files["fig3"]))
    for scn in cl.SCENARIOS:
        files[f"fig{5 + scn.number}"] = out / FIGURES[scn.number]
        plots.close(plots.identification_figure(example_identifications(scn, seed),
                                                path=files[f"fig{5 + scn.number}"]))
    files["table1"] = out / "table1.md"
    write_text(files["table1"], _markdown(rates, table, coverage_results, seeds, seed))
    files["results"] = out / "results.json"
    payload = _results_json(rates, table, coverage_results, seeds, seed)
    write_text(files["results"], json.dumps(payload, indent=2, ensure_ascii=False) + "\n")
    return Reproduction(coverage_results, rates, table, files, time.perf_counter() - start)


__all__ = [
    "Identification", "Rate", "Reproduction", "RULES", "PAPER_TABLE1", "edmf_thresholds", "identify",
    "judge", "identification_rates", "table1", "example_identifications", "reproduce", "measurement_draws",
]
