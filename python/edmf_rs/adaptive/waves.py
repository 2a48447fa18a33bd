"""Adaptive EDMF in waves (issue 16): the emulator proposes, the model decides.

1. A scrambled Sobol' design over the domain, run with the real model.
2. A Gaussian process per sensor (:mod:`.emulator`), checked by leave-one-out.
3. A fixed screening sample of the domain (then as many points over the box
   around the kept ones, to resolve a small region) is screened (:mod:`.screen`, Rust):
   a point stays while, at every sensor, its emulated residual is within the
   thresholds widened by c emulator standard deviations.
4. The next wave's real runs go to the kept region: first the edges, where
   the candidate ranges are decided (the ``EDGE_POINTS`` kept points with the
   lowest and the highest value of each parameter, each walked on the
   emulator's mean to that parameter's extreme of the region where the mean
   passes Eq. 8, :mod:`.edges`), then greedy farthest points. A wave whose emulator failed validation is spread over the
   whole domain instead (fallback). Repeat until the kept volume is stable and
   sigma is small against the threshold widths, or the budget is spent.
5. A final wave spread over the kept region; the candidate model set is Eq. 8
   (:func:`edmf_rs.falsify`) over every real run, never the emulator.
"""

from __future__ import annotations

import math
import numbers
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from ..engine._validate import check_seed, finite_vector, positive_int
from ..engine.durable import readonly as _readonly
from ..engine.falsify import falsify
from ..engine.model import evaluate
from ..engine.sampling import Parameter
from ..engine.sensors import sensor_match
from ..engine.thresholds import Thresholds
from .basis import VARIANCE_KEPT, emulators
from .design import (BUDGET_HINT, RunStore, budget_problem, closest, edge_rows, extremes, farthest_points,
                     pool_size, sobol_points)
from .edges import push, walk
from .emulator import EmulatorError
from .result import AdaptiveResult, WaveRecord
from .screen import required_margin, screen

#: Kept points recorded per wave for plots.
KEPT_SAMPLE = 400

#: Kept points taken at each end of each parameter's range in every wave
#: (then pushed to the mean's Eq. 8 boundary along that parameter): the
#: candidate ranges are decided at these edges, and a thin kept region reaches
#: its extreme at a corner that one point, or space-filling, finds slowly.
EDGE_POINTS = 3

#: Walk the edge points to the extreme of their parameter (:func:`edmf_rs.adaptive.edges.walk`).
WALK = True

#: With ``basis = "auto"``, more sensors than this are emulated on principal components.
PCA_SENSORS = 10

#: When the emulator keeps no point, its exact deviation is also computed at the first this many
#: points of the screening sample (a Sobol' net over the domain), besides those nearest to passing.
SPREAD = 4096


def _parameters(bounds) -> tuple[Parameter, ...]:
    if isinstance(bounds, Sequence) and bounds and all(isinstance(b, Parameter) for b in bounds):
        return tuple(bounds)
    try:
        arr = np.asarray(bounds, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError("bounds: expected a (p, 2) array of [low, high] rows or a sequence of "
                        "edmf_rs.sampling.Parameter") from None
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] == 0:
        raise ValueError(f"bounds: expected a (p, 2) array of [low, high] rows, got shape {arr.shape}")
    try:
        return tuple(Parameter(f"theta{j}", lo, hi) for j, (lo, hi) in enumerate(arr))
    except ValueError as exc:
        raise ValueError(f"bounds: {exc}") from None


def _real(value, name: str, low: float, high: float = math.inf) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not low <= value <= high:
        raise ValueError(f"{name}: expected a number in [{low:g}, {high:g}], got {value!r}")
    return float(value)


def adaptive_falsify(model: Callable, bounds, measurements, thresholds: Thresholds, *, budget: int,
                     n_initial: int | None = None, wave_size: int | None = None, n_screen: int = 10**6,
                     c: float = 3.0, seed: int = 0, final_size: int | None = None, max_waves: int = 20, volume_tolerance: float = 0.05,
                     sigma_tolerance: float = 0.05, validation_coverage: float = 0.9,
                     nan: str = "raise", basis: str = "auto", variance_kept: float = VARIANCE_KEPT,
                     sensors: Sequence[str] | None = None) -> AdaptiveResult:
    """EDMF with an emulator steering where the real model runs (issue 16).

    Parameters
    ----------
    model
        Vectorised model: (n, p) parameters -> (n, n_m) predictions.
    bounds
        The domain: a (p, 2) array of [low, high] rows, or a sequence of
        :class:`edmf_rs.sampling.Parameter` (log scales honoured).
    measurements, thresholds
        y and the threshold bounds of Eq. 8 (:func:`edmf_rs.threshold_bounds`).
    budget
        Most real model runs to spend, initial design and final wave included.
    n_initial
        Runs of the initial Sobol' design (default 20 x p; at least p + 1).
    wave_size
        Runs per wave (default 10 x p).
    final_size
        Runs of the final wave spread over the kept region (default
        2 x wave_size; fewer if the budget has fewer left): the candidate
        set's edges, and so the ranges and the prognosis, come from them.
    n_screen
        Points of the screening sample (a fixed scrambled Sobol' sample).
    c
        Screening margin in emulator standard deviations.
    seed
        Seed of the Sobol' designs, an integer >= 0; the same inputs give the same result.
    max_waves
        Most adaptive waves between the initial design and the final wave.
    volume_tolerance, sigma_tolerance
        Stop when the kept volume changed by at most ``volume_tolerance``
        (relative) since the previous wave and the emulator's sigma is at most
        ``sigma_tolerance`` threshold widths over the kept region.
    validation_coverage
        Least share of runs whose leave-one-out output must lie within c
        leave-one-out standard deviations, per sensor, for the emulator to be
        trusted; otherwise the next wave falls back to the whole domain.
    nan
        ``"raise"``: a NaN or infinite output is an error naming the run;
        ``"falsify"``: such runs are falsified and left out of the emulator.
    basis
        ``"sensors"``: a GP per sensor; ``"pca"``: GPs on the leading
        principal components of the standardised outputs, their variance
        propagated back to every sensor with the truncation residual
        (:mod:`edmf_rs.adaptive.basis`); ``"auto"`` (default): ``"pca"``
        when there are more than 10 sensors.
    variance_kept
        With the PCA basis, the share of the standardised outputs' variance
        the kept components explain (default 0.999).
    sensors
        The names of the sensors of ``measurements``, in order: the model
        may then return a ``pandas.DataFrame``, a mapping of sensor name to
        column or a structured array, matched by name as in
        :func:`edmf_rs.falsify_model` (outputs no sensor uses are ignored,
        with a warning). Without it, named outputs are refused.

    Returns
    -------
    AdaptiveResult
        Candidates, every real run, the record of each wave.

    Raises
    ------
    TypeError
        A model output with named columns but no ``sensors``; an argument of
        the wrong type.
    ValueError
        Too few initial runs, a budget smaller than the initial design plus
        one wave, NaN outputs with ``nan="raise"``, a sensor missing from
        named outputs, bad arguments.

    Examples
    --------
    >>> import numpy as np, edmf_rs
    >>> model = lambda t: np.column_stack([t[:, 0] + t[:, 1], t[:, 0] - t[:, 1]])
    >>> t = edmf_rs.Thresholds([-0.1, -0.1], [0.1, 0.1])
    >>> r = edmf_rs.adaptive_falsify(model, [[0, 1], [0, 1]], [1.0, 0.0], t, budget=120, n_screen=4096)
    >>> bool(r.n_candidates > 0 and r.n_runs <= 120)
    True
    """
    if not callable(model):
        raise TypeError(f"model: expected a callable, got {type(model).__name__}")
    if not isinstance(thresholds, Thresholds):
        raise TypeError(f"thresholds: expected edmf_rs.Thresholds, got {type(thresholds).__name__}")
    if nan not in ("raise", "falsify"):
        raise ValueError(f"nan: expected 'raise' or 'falsify', got {nan!r}")
    if basis not in ("auto", "sensors", "pca"):
        raise ValueError(f"basis: expected 'auto', 'sensors' or 'pca', got {basis!r}")
    params = _parameters(bounds)
    p = len(params)
    y = finite_vector(measurements, "measurements", n=thresholds.n_sensors)
    n_m = y.shape[0]
    match = sensor_match(sensors, n_m)
    n_initial = 20 * p if n_initial is None else positive_int(n_initial, "n_initial")
    if n_initial < p + 1:
        raise ValueError(f"n_initial: expected at least n_params + 1 = {p + 1} runs to fit an emulator over "
                         f"{p} parameters, got {n_initial}; the default is 20 x n_params = {20 * p}")
    if n_initial < 5 * p:
        warnings.warn(f"n_initial: {n_initial} runs for {p} parameters is a thin initial design; the emulator "
                      f"will likely fail validation at first (default 20 x n_params = {20 * p})", stacklevel=2)
    wave_size = 10 * p if wave_size is None else positive_int(wave_size, "wave_size")
    budget = positive_int(budget, "budget")
    problem = budget_problem(p, budget, n_initial, wave_size)
    if problem is not None:
        raise ValueError(f"budget: expected {problem}, got {budget}; {BUDGET_HINT}")
    final_size = 2 * wave_size if final_size is None else positive_int(final_size, "final_size")
    if budget < n_initial + wave_size + final_size:
        warnings.warn(f"budget: {budget} runs leave room for the initial design and the final wave only, no "
                      f"adaptive wave between (needs n_initial + wave_size + final_size = "
                      f"{n_initial + wave_size + final_size})", stacklevel=2)
    n_screen = positive_int(n_screen, "n_screen")
    c = _real(c, "c", 0.0)
    volume_tolerance = _real(volume_tolerance, "volume_tolerance", 0.0, 1.0)
    sigma_tolerance = _real(sigma_tolerance, "sigma_tolerance", 0.0)
    validation_coverage = _real(validation_coverage, "validation_coverage", 0.0, 1.0)
    variance_kept = _real(variance_kept, "variance_kept", 0.0, 1.0)
    if variance_kept == 0.0:
        raise ValueError("variance_kept: expected a share in (0, 1], got 0")
    if basis == "auto":
        basis = "pca" if n_m > PCA_SENSORS else "sensors"
    max_waves = positive_int(max_waves, "max_waves")
    seed = check_seed(seed)

    def to_domain(u: np.ndarray) -> np.ndarray:
        return np.column_stack([q.from_unit(u[:, j]) for j, q in enumerate(params)])

    store = RunStore(p, n_m)
    domain_used = [0]  # Sobol' points of the domain design used so far (initial + fallbacks)

    def run(u: np.ndarray, wave: int) -> int:
        theta = to_domain(u)
        fresh = store.new_rows(theta)
        if fresh.size == 0:
            return 0
        g = evaluate(model, theta[fresh], store.n_runs, n_m, nan, match=match)
        if match is not None and store.n_runs == 0 and match.mapping.ignored:
            warnings.warn(f"model outputs not among the sensors, ignored: {', '.join(match.mapping.ignored)}",
                          UserWarning, stacklevel=3)
        store.add(u[fresh], theta[fresh], g, wave)
        return int(fresh.size)

    def domain_design(n: int) -> np.ndarray:
        u = sobol_points(n, p, seed, skip=domain_used[0])
        domain_used[0] += n
        return u

    screening = sobol_points(n_screen, p, seed + 1)
    zoom_unit = sobol_points(n_screen, p, seed + 2)
    width = thresholds.width
    waves: list[WaveRecord] = []
    emulator = None
    optimized_at = [0]  # runs at the last hyperparameter search
    mean_at_kept = [None]  # the emulator's mean at the kept points of the last screening
    # With nothing kept: the points whose exact deviation is computed, nearest to passing on the mean
    # (twice what a wave draws from, so that the exact margins rank them).
    closest_pool = 2 * pool_size(max(wave_size, final_size))

    def mean_passes(u: np.ndarray) -> np.ndarray:
        """Eq. 8 on the current emulator's mean."""
        r = emulator.mean(u) - y
        return ((r >= thresholds.low) & (r <= thresholds.high)).all(axis=1)

    def screen_set(points: np.ndarray):
        """Screens ``points``: (kept, mean-kept (c = 0), min_required_c, sigma_ratio, nearest).

        The screening's deviations are the prior bound where the bound alone
        rejects a point (:meth:`predict_for_screening`), exact elsewhere, so
        every kept point has its exact deviation. When none is kept, the
        exact deviation is computed at a few thousand points only: the
        ``closest_pool`` whose mean is nearest to passing (in prior-bound
        deviations) and the first ``SPREAD`` of the sample; min_required_c is
        the smallest margin among them, sigma_ratio the deviations at the
        ``closest_pool / 2`` of them that need the smallest margins, and
        ``nearest`` (their indices, the margin each needs) is what
        :func:`~.design.closest` draws the next wave from.
        """
        bound = emulator.prior_std()
        kept, mean_kept, need_kept, ratios, mu_kept = [], [], [], [], []
        need_bound = np.empty(points.shape[0])  # margin with the bound: a lower bound of the exact one
        for first in range(0, points.shape[0], 8192):
            part = points[first:first + 8192]
            mu, sd = emulator.predict_for_screening(part, y, thresholds.low, thresholds.high, c)
            local = screen(mu, sd, y, thresholds, c)[0]
            kept.append(local + first)
            mu_kept.append(mu[local])
            mean_kept.append(screen(mu, np.zeros_like(sd), y, thresholds, 0.0)[0] + first)
            need_kept.append(required_margin(mu[local], sd[local], y, thresholds))
            ratios.append(sd[local] / width)
            need_bound[first:first + len(part)] = required_margin(mu, np.broadcast_to(bound, mu.shape), y, thresholds)
        mean_at_kept[0] = np.concatenate(mu_kept)
        kept, mean_kept = np.concatenate(kept), np.concatenate(mean_kept)
        if kept.size:  # every kept point has its exact deviation; the others need more than c
            ratio = np.concatenate(ratios)
            return kept, mean_kept, float(np.concatenate(need_kept).min()), \
                float(np.percentile(ratio, 95, axis=0).max()), None
        # The exact deviation at these points only: those nearest to passing on the mean, and the first
        # SPREAD points of the sample (a Sobol' net over it: the margin may be smallest far from every run).
        checked = np.union1d(np.argsort(need_bound, kind="stable")[:closest_pool],
                             np.arange(min(points.shape[0], SPREAD)))
        mu, sd = emulator.predict(points[checked])
        need = required_margin(mu, sd, y, thresholds)
        near = np.argsort(need, kind="stable")[:closest_pool // 2]  # the most nearly consistent of them
        return kept, mean_kept, float(need.min()), float(np.percentile(sd[near] / width, 95, axis=0).max()), \
            (checked, need)

    def fit_and_screen(index: int, kind: str, spent: int):
        """Refit after a wave, screen, record the wave.

        Returns (record, screening points used, kept, mean-kept, nearest: see ``screen_set``)."""
        nonlocal emulator
        finite = np.isfinite(store.g).all(axis=1)
        problems: list[str] = []
        try:
            # Hyperparameters are searched again when the runs grew by half since the
            # last search or the emulator failed validation; else only refactorised.
            optimize = (emulator is None or not waves or not waves[-1].validated
                        or finite.sum() >= 1.5 * optimized_at[0])
            began = time.perf_counter()
            emulator = emulators(store.u[finite], store.g[finite], basis, previous=emulator, optimize=optimize,
                                 variance_kept=variance_kept)
            fit_seconds = time.perf_counter() - began
            if optimize:
                optimized_at[0] = int(finite.sum())
            problems += emulator.problems
            validation = emulator.validate(width, c, validation_coverage)
            if not validation.ok:
                bad = np.flatnonzero(~validation.passed)
                problems.append("the emulator failed leave-one-out validation at sensor(s) "
                                + ", ".join(f"{j} (coverage {validation.coverage[j]:.2f})" for j in bad)
                                + "; the next wave falls back to runs over the whole domain")
        except EmulatorError as exc:
            emulator, validation = None, None
            problems.append(f"{exc}; the next wave falls back to runs over the whole domain")
        for text in problems:
            warnings.warn(f"adaptive_falsify, wave {index}: {text}", stacklevel=3)
        n_cand = _n_candidates(store.g, y, thresholds)
        if emulator is None:
            record = WaveRecord(index, kind, spent, store.n_runs, n_cand, validated=False,
                                problems=tuple(problems))
            return record, screening, None, None, None
        points, volume = screening, 1.0
        kept, mean_kept, min_c, sigma_ratio, nearest = screen_set(points)
        if kept.size:
            # Zoom: a second sample as dense over the box around the kept points
            # (widened by two sample spacings), so small kept regions are resolved.
            spacing = 2.0 * n_screen ** (-1.0 / p)
            lo = np.clip(screening[kept].min(axis=0) - spacing, 0.0, 1.0)
            hi = np.clip(screening[kept].max(axis=0) + spacing, 0.0, 1.0)
            if np.prod(hi - lo) < 0.5:
                volume = float(np.prod(hi - lo))
                points = lo + (hi - lo) * zoom_unit
                kept, mean_kept, min_c, sigma_ratio, nearest = screen_set(points)
        sample = kept[np.linspace(0, kept.size - 1, min(kept.size, KEPT_SAMPLE)).round().astype(np.int64)] \
            if kept.size else kept
        record = WaveRecord(index, kind, spent, store.n_runs, n_cand, kept_fraction=volume * kept.size / n_screen,
                            mean_kept_fraction=volume * mean_kept.size / n_screen, validated=validation.ok,
                            loo_error=validation.error, loo_coverage=validation.coverage, sigma_ratio=sigma_ratio,
                            min_required_c=min_c, kept_sample=to_domain(points[sample]),
                            problems=tuple(problems), components=getattr(emulator, "n_components", None),
                            fit_seconds=fit_seconds)
        return record, points, kept, mean_kept, nearest

    spent = run(domain_design(n_initial), 0)
    record, points, kept, mean_kept, nearest = fit_and_screen(0, "initial", spent)
    waves.append(record)
    stop_reason = "max_waves"
    for index in range(1, max_waves + 1):
        if store.n_runs + wave_size + final_size > budget:
            stop_reason = "budget"
            break
        if record.validated and len(waves) >= 2 and waves[-2].validated:
            before, now = waves[-2].kept_fraction, record.kept_fraction
            if now == 0 and before == 0:
                stop_reason = "empty kept region"
                break
            stable = abs(now - before) <= volume_tolerance * max(now, before)
            if stable and record.sigma_ratio <= sigma_tolerance:
                stop_reason = "converged"
                break
        if record.validated and kept.size:
            kind = "adaptive"
            u_next = _spread(points, kept, mean_kept, mean_at_kept[0], store.u, wave_size, mean_passes)
        elif record.validated:  # nothing kept: probe the most nearly consistent points
            kind = "adaptive"
            u_next = closest(points, nearest, store.u, wave_size)
        else:
            kind = "fallback"
            u_next = domain_design(wave_size)
        spent = run(u_next, index)
        record, points, kept, mean_kept, nearest = fit_and_screen(index, kind, spent)
        waves.append(record)

    # Final wave: spread over the kept region of the last emulator; the model decides.
    final_index = len(waves)
    n_final = min(final_size, budget - store.n_runs)
    if record.validated and kept.size:
        u_final = _spread(points, kept, mean_kept, mean_at_kept[0], store.u, n_final, mean_passes)
    elif record.validated:
        u_final = closest(points, nearest, store.u, n_final)
    else:
        u_final = domain_design(n_final)
    kind = "final"
    spent = run(u_final, final_index)
    waves.append(WaveRecord(final_index, kind, spent, store.n_runs, _n_candidates(store.g, y, thresholds)))

    result = falsify(store.g, y, thresholds, progress=False)  # Eq. 8 on real outputs only
    idx = result.candidate_indices
    result = replace(result, candidate_parameters=_readonly(store.theta[idx].copy()),
                     candidate_predictions=_readonly(store.g[idx].copy()))
    return AdaptiveResult(params, result, tuple(waves), _readonly(store.theta), _readonly(store.g),
                          _readonly(store.wave), stop_reason, n_screen, c, basis)


def _n_candidates(g: np.ndarray, y: np.ndarray, t: Thresholds) -> int:
    r = g - y  # Eq. 14, then Eq. 8
    return int(((r >= t.low) & (r <= t.high)).all(axis=1).sum())


def _spread(screening: np.ndarray, kept: np.ndarray, mean_kept: np.ndarray, mu_kept: np.ndarray,
            runs: np.ndarray, k: int, mean_passes: Callable | None = None) -> np.ndarray:
    """k points of the kept region: where the emulator's mean passes Eq. 8 (or,
    if nowhere, over the kept region), the ``EDGE_POINTS`` lowest and highest
    points of each parameter's range (each pushed along that parameter's axis to where the mean stops passing, by
    bisection: the screening sample alone resolves them only to its spacing)
    and of each sensor's predicted range (a quantity of interest usually
    follows some sensor, so its prognosis interval ends near theirs), then
    greedy farthest points from every run."""
    at = np.searchsorted(kept, mean_kept) if mean_kept.size else np.arange(kept.size)
    at = at[(at < kept.size) & (kept[np.minimum(at, kept.size - 1)] == (mean_kept if mean_kept.size else kept))]
    if at.size == 0:
        at = np.arange(kept.size)
    region = screening[kept[at]]
    # The EDGE_POINTS lowest and highest kept points of each parameter, each
    # pushed outwards along that parameter (repeats are dropped by farthest_points).
    edge, axes, signs = edge_rows(region, EDGE_POINTS)
    ends = region[edge]
    if mean_passes is not None and mean_kept.size:
        ends = walk(ends, axes, signs, mean_passes) if WALK else push(ends, axes, signs, mean_passes)
    sensor_ends = at[extremes(mu_kept[at])]
    pool = np.vstack([ends, screening[kept]])
    first = np.concatenate([np.arange(ends.shape[0]), ends.shape[0] + sensor_ends])
    picked = farthest_points(pool, runs, k, first=first)
    return pool[picked]
