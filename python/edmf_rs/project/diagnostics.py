"""Diagnostics of a falsification, from the same single pass over the instances.

Leave-one-sensor-out
    ``candidates_without_sensor[i] = n_candidates + falsified_only_by[i]``:
    the candidate set size when sensor i is ignored. When every instance is
    falsified but ignoring one sensor leaves candidates, that sensor alone
    falsifies the model class: a possible outlier or faulty sensor.

Sensitivity to the size of the uncertainties (scale factor s)
    Thresholds are scaled about their centre ``c = (T_low + T_high) / 2`` (the
    mean of U_c when it is normal): ``T_low(s) = c + s (T_low - c)``,
    ``T_high(s) = c + s (T_high - c)``. This is the same as scaling the spread
    of every uncertainty by s while keeping the systematic bias c. An instance
    with residuals ``r = g(theta) - y`` is a candidate at scale s iff
    ``s >= s_min = max_i |r_i - c_i| / h_i`` with ``h = (T_high - T_low) / 2``.

Sensitivity to phi
    Thresholds widen as phi grows, so each instance is a candidate for every
    phi at or above its ``phi_min``. For a normal U_c (exact combination) this
    is exact: with ``d = max_i |r_i - mu_i| / sigma_i`` the per-sensor
    probability needed is ``p = 1 - 2 sf(d)`` (Eq. 6 inverted), and phi_min
    inverts the correction (Sidak: ``p ** n_m``, Eq. 5). For Monte Carlo U_c,
    thresholds are recomputed from the samples at a grid of phi values and
    instances counted at each; ``phi_min`` is then known to the grid.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy import stats

from .. import _core
from ..engine.result import FalsificationResult
from ..engine.thresholds import Thresholds, sensor_probability
from ..engine.uncertainty import CombinedUncertainty
from .format import in_domain, plural

#: Scale factors s at which the candidate set is counted (log-spaced; 0.5, 1 and 2 included).
SCALES = np.unique(np.append(np.geomspace(0.1, 10.0, 201), [0.5, 1.0, 2.0]))
_PHIS = np.concatenate([np.linspace(0.02, 0.98, 49), [0.985, 0.99, 0.995, 0.998, 0.999, 0.9995, 0.9999]])


def phi_grid(phi: float) -> np.ndarray:
    """The phi values at which the candidate set is counted (the identification's phi included)."""
    return np.unique(np.append(_PHIS, phi))


@dataclass(frozen=True, eq=False)
class LeaveOneOut:
    """Per-sensor falsification counts and the candidate set size without each sensor.

    The counts are of valid instances: an instance with a NaN prediction (a
    diverged or failed model run) is invalid, neither a candidate nor
    falsified; ``n_invalid`` counts them and ``nan_at`` their NaN per sensor.
    """

    sensors: tuple[str, ...]
    n_instances: int
    n_candidates: int
    per_sensor_falsified: np.ndarray
    falsified_only_by: np.ndarray
    n_invalid: int = 0
    nan_at: np.ndarray | None = None

    @property
    def candidates_without_sensor(self) -> np.ndarray:
        return self.n_candidates + self.falsified_only_by

    @property
    def suspects(self) -> tuple[int, ...]:
        """Sensors that alone falsify the model class: ignoring any one of them leaves candidates."""
        if self.n_candidates:
            return ()
        return tuple(int(i) for i in np.flatnonzero(self.candidates_without_sensor > 0))


def leave_one_out(result: FalsificationResult, sensors, nan_at=None) -> LeaveOneOut:
    """Leave-one-sensor-out counts of a result computed with ``diagnostics=True``
    (its invalid instances taken out by `SensitivityTracker.discount`; ``nan_at``:
    the invalid instances' NaN per sensor, `SensitivityTracker.nan_at`)."""
    if result.falsified_only_by is None:
        raise ValueError("result: expected a falsification run with diagnostics=True")
    sensors = tuple(sensors)
    if len(sensors) != result.n_sensors:
        raise ValueError(f"sensors: expected {result.n_sensors} names, got {len(sensors)}")
    return LeaveOneOut(sensors, result.n_instances, result.n_candidates,
                       result.per_sensor_falsified, result.falsified_only_by, int(result.n_invalid or 0),
                       None if nan_at is None else np.asarray(nan_at))


@dataclass(frozen=True, eq=False)
class Sensitivity:
    """Candidate set size against the scale s of the uncertainties and against phi.

    ``smallest_scale`` is the smallest s admitting any instance (inf when no
    instance has finite predictions); ``smallest_phi`` the smallest phi
    admitting any instance (exact when ``phi_exact``, else the first grid
    phi that admits one, or nan when none does). ``closest_*`` describe the
    instance needing the smallest s and ``closest_violated`` the sensors it
    violates; ``fewest_violated`` is the fewest sensors any valid instance violates
    at the identification's thresholds.
    """

    scales: np.ndarray
    candidates_at_scale: np.ndarray
    phis: np.ndarray
    candidates_at_phi: np.ndarray
    phi_exact: bool
    smallest_scale: float
    smallest_phi: float
    closest_instance: int | None
    closest_parameters: np.ndarray | None
    closest_predictions: np.ndarray | None
    closest_violated: tuple[int, ...]
    fewest_violated: int | None

    def candidates_at(self, scale: float) -> int:
        """Candidates at the grid scale nearest ``scale``."""
        return int(self.candidates_at_scale[np.argmin(np.abs(np.log(self.scales / scale)))])


class SensitivityTracker:
    """Accumulates :class:`Sensitivity` batch by batch: pass it as ``on_batch`` to
    :func:`edmf_rs.falsify_model`. Memory does not grow with the instances.

    It also counts what the invalid instances (a NaN prediction) add to the
    falsification's per-sensor counts, which count a NaN as out of bounds,
    so that `discount` can take them out.
    """

    def __init__(self, thresholds: Thresholds, combined: CombinedUncertainty, measurements,
                 *, scales=SCALES, phis=None):
        t = thresholds
        self.y = np.asarray(measurements, dtype=np.float64)
        self.low, self.high = t.low, t.high
        self.centre, self.half = 0.5 * (t.low + t.high), 0.5 * (t.high - t.low)
        self.scales = np.asarray(scales, dtype=np.float64)
        self.phi = t.phi if t.phi is not None else 0.95
        self.correction = t.correction or "sidak"
        self.phis = np.asarray(phi_grid(self.phi) if phis is None else phis, dtype=np.float64)
        self.exact = combined.exact
        if self.exact:
            self.mean, self.sd = combined.mean, combined.std
        else:
            self.phis, self.grid_low, self.grid_high = _monte_carlo_bounds(combined.samples, self.phis, t)
        self.at_scale = np.zeros(self.scales.size, dtype=np.int64)
        self.at_phi = np.zeros(self.phis.size, dtype=np.int64)
        self.best_scale, self.best_phi = math.inf, math.inf
        self.closest = (None, None, None)
        self.fewest = None
        n_m = self.y.size
        self.nan_at = np.zeros(n_m, dtype=np.int64)  # NaN predictions per sensor, of invalid instances
        self.invalid_falsified = np.zeros(n_m, dtype=np.int64)  # invalid instances out of bounds at each sensor
        self.invalid_only = np.zeros(n_m, dtype=np.int64)  # ... and at no other
        self.n_invalid = 0

    def __call__(self, offset: int, parameters: np.ndarray, predictions: np.ndarray) -> None:
        if predictions.shape[0] == 0:
            return
        r = np.asarray(predictions, dtype=np.float64) - self.y  # Eq. 14
        invalid = np.isnan(r).any(axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratio = np.abs(r - self.centre) / self.half
        ratio[np.isnan(ratio)] = 0.0  # 0/0: a zero-width threshold the residual sits on
        s_min = ratio.max(axis=1)
        s_min[invalid] = np.inf
        self.at_scale += np.searchsorted(np.sort(s_min), self.scales, side="right")
        k = int(np.argmin(s_min))
        if s_min[k] < self.best_scale:
            self.best_scale = float(s_min[k])
            self.closest = (offset + k, parameters[k].copy(), predictions[k].astype(np.float64))
        violated = ((r < self.low) | (r > self.high)).sum(axis=1)
        if not invalid.all():
            least = int(violated[~invalid].min())
            self.fewest = least if self.fewest is None else min(self.fewest, least)
        if invalid.any():  # the falsification's verdict on them: out of bounds unless low <= r <= high
            bad = ~((self.low <= r[invalid]) & (r[invalid] <= self.high))
            self.n_invalid += int(invalid.sum())
            self.nan_at += np.isnan(r[invalid]).sum(axis=0)
            self.invalid_falsified += bad.sum(axis=0)
            self.invalid_only += bad[bad.sum(axis=1) == 1].sum(axis=0)
        if self.exact:
            d = np.max(np.abs(r - self.mean) / self.sd, axis=1)
            phi_min = _phi_from_tail(2.0 * stats.norm.sf(d), r.shape[1], self.correction)
            phi_min[invalid] = np.inf
            self.at_phi += np.searchsorted(np.sort(phi_min), self.phis, side="right")
            self.best_phi = min(self.best_phi, float(phi_min.min()))
        else:
            for k, (lo, hi) in enumerate(zip(self.grid_low, self.grid_high)):
                self.at_phi[k] += int(np.count_nonzero(((lo <= r) & (r <= hi)).all(axis=1)))

    def discount(self, result: FalsificationResult) -> FalsificationResult:
        """``result`` with the invalid instances taken out of the per-sensor counts
        (``per_sensor_falsified``, ``falsified_only_by``): they are neither
        candidates nor falsified (failed model runs, NaN predictions)."""
        if not self.n_invalid or result.per_sensor_falsified is None:
            return result
        return replace(result, per_sensor_falsified=result.per_sensor_falsified - self.invalid_falsified,
                       falsified_only_by=result.falsified_only_by - self.invalid_only)

    def finish(self) -> Sensitivity:
        if self.exact:
            smallest_phi = self.best_phi if math.isfinite(self.best_phi) else math.nan
        else:
            admitted = np.flatnonzero(self.at_phi > 0)
            smallest_phi = float(self.phis[admitted[0]]) if admitted.size else math.nan
        index, params, preds = self.closest
        violated = () if preds is None else tuple(
            int(i) for i in np.flatnonzero(~((self.low <= preds - self.y) & (preds - self.y <= self.high))))
        return Sensitivity(self.scales, self.at_scale.copy(), self.phis, self.at_phi.copy(), self.exact,
                           self.best_scale, smallest_phi, index, params, preds, violated, self.fewest)


def _phi_from_tail(tail: np.ndarray, n_sensors: int, correction: str) -> np.ndarray:
    """phi whose per-sensor probability is 1 - tail (the inverse of sensor_probability)."""
    tail = np.minimum(tail, 1.0)
    if correction == "sidak":
        with np.errstate(divide="ignore"):  # tail 1 (a residual at the centre) gives phi 0
            return np.exp(n_sensors * np.log1p(-tail))  # p ** n_m, accurate for p near 1
    if correction == "bonferroni":
        return np.maximum(1.0 - n_sensors * tail, 0.0)
    return 1.0 - tail


def _monte_carlo_bounds(samples: np.ndarray, phis: np.ndarray, thresholds: Thresholds):
    """Shortest intervals of the samples at each phi the samples can resolve (the
    Rust core, in parallel over sensors). At the identification's phi the
    thresholds themselves are used so both agree exactly there."""
    n, n_m = samples.shape
    keep, lows, highs = [], [], []
    for phi in phis:
        if thresholds.phi is not None and phi == thresholds.phi:
            low, high = thresholds.low, thresholds.high
        else:
            try:
                p = sensor_probability(float(phi), n_m, thresholds.correction or "sidak")
            except ValueError:
                continue  # phi too close to 1 for n_m sensors
            if n < _core.min_samples(p):
                continue  # too few samples for so high a probability
            low, high = _core.shortest_intervals(samples, p)
        keep.append(phi)
        lows.append(low)
        highs.append(high)
    return np.array(keep), np.array(lows), np.array(highs)


def invalid_text(loo: LeaveOneOut) -> str:
    """The invalid instances (NaN predictions), in words; empty when there are none."""
    if not loo.n_invalid:
        return ""
    at = ""
    if loo.nan_at is not None and loo.nan_at.any():
        hit = np.flatnonzero(loo.nan_at)
        at = " at " + ", ".join(f"{loo.sensors[i]} ({loo.nan_at[i]:,})" for i in hit[:5]) + (
            f" and {plural(hit.size - 5, 'other sensor')}" if hit.size > 5 else "")
    if loo.n_invalid == loo.n_instances:
        return (f"Every instance is invalid: the model's predictions hold NaN{at}, so no instance could be "
                "compared with the measurements and none is a candidate or falsified; this says nothing about "
                "the model class or the sensors: check the model (a diverged or failed run).")
    return (f"{loo.n_invalid:,} of {plural(loo.n_instances, 'instance')} {'is' if loo.n_invalid == 1 else 'are'} "
            f"invalid (NaN predictions{at}): neither candidates nor falsified, they are left out of the "
            "per-sensor counts and of leaving one sensor out.")


def findings(loo: LeaveOneOut, sensitivity: Sensitivity | None = None, phi: float | None = None) -> list[str]:
    """What the counts say, in words, for the summary and the report."""
    names = loo.sensors
    out = [invalid_text(loo)] if loo.n_invalid else []
    if loo.n_invalid == loo.n_instances:
        return out
    every = "every valid instance" if loo.n_invalid else "every instance"
    if loo.n_candidates == 0:
        suspects = loo.suspects
        without = loo.candidates_without_sensor
        if len(names) == 1:
            out.append(
                f"The only sensor, {names[0]}, falsifies {every}: check its measured value, the model class and "
                "the uncertainties (there is no other sensor to compare it with, so leaving it out would leave "
                "nothing to identify the parameters from)."
            )
        elif len(suspects) == 1:
            i = suspects[0]
            out.append(
                f"Sensor {names[i]} alone falsifies the model class: ignoring it leaves "
                f"{plural(without[i], 'candidate')}. "
                f"{names[i]} may be faulty or an outlier: check it before concluding that the model class is "
                f"wrong (to leave it out, add exclude = [\"{names[i]}\"] under [measurements])."
            )
        elif suspects:
            listed = ", ".join(f"{names[i]} ({without[i]:,})" for i in suspects)
            out.append(f"Ignoring any one of these sensors would leave candidates: {listed}. "
                       "Each alone falsifies the model class: check them for outliers or faults.")
        else:
            fewest = f"at least {plural(sensitivity.fewest_violated, 'sensor')}" \
                if sensitivity and sensitivity.fewest_violated else "several sensors"
            out.append(f"No single sensor explains the falsification: {every} violates {fewest}. "
                       "The model class or its uncertainties need review (Sec. 3.3).")
        if sensitivity is not None and math.isfinite(sensitivity.smallest_scale):
            violated = ", ".join(names[i] for i in sensitivity.closest_violated)
            text = (f"The closest instance (#{sensitivity.closest_instance}, which violates {violated}) becomes "
                    f"a candidate when the uncertainties are scaled by {sensitivity.smallest_scale:.3g}")
            if math.isfinite(sensitivity.smallest_phi) and sensitivity.smallest_phi < 1.0:
                exact = "" if sensitivity.phi_exact else " (to the grid)"
                text += f", and some instance at phi >= {sensitivity.smallest_phi:.6g}{exact}"
            elif sensitivity.phi_exact:
                text += "; no phi below 1 admits any instance"
            else:
                text += "; no phi that the Monte Carlo samples resolve admits any instance"
            out.append(text + ".")
        return out
    share = 100.0 * loo.n_candidates / loo.n_instances
    out.append(f"{loo.n_candidates:,} of {plural(loo.n_instances, 'instance')} ({share:.3g} %) "
               f"{'is a candidate model' if loo.n_candidates == 1 else 'are candidate models'}.")
    i = int(np.argmax(loo.per_sensor_falsified))
    if loo.per_sensor_falsified[i]:
        out.append(f"Sensor {names[i]} falsifies the most instances ({loo.per_sensor_falsified[i]:,}).")
    idle = [names[j] for j in np.flatnonzero(loo.falsified_only_by == 0)]
    if idle and len(idle) < len(names):
        out.append(f"Leaving out {idle[0]} would not change the candidate set (every instance it falsifies, "
                   "another sensor falsifies too)." if len(idle) == 1 else
                   f"Leaving out any one of {', '.join(idle)} would not change the candidate set "
                   "(every instance they falsify, another sensor falsifies too).")
    if sensitivity is not None:
        half, double = sensitivity.candidates_at(0.5), sensitivity.candidates_at(2.0)
        out.append(f"With the uncertainties halved the candidate set would hold {plural(half, 'instance')}; "
                   f"doubled, {double:,}.")
    return out


def parameter_findings(parameters, ranges) -> list[str]:
    """Parameters hardly identified, or whose candidates reach an end of the domain
    (``ranges``: each parameter's candidate (min, max), or None)."""
    out = []
    for p, span in zip(parameters, ranges):
        if span is None:
            continue
        lo, hi = p.to_unit(np.array(span))
        if hi - lo > 0.9:
            out.append(f"{p.name} is hardly identified: the candidates span {100 * (hi - lo):.0f} % of its domain.")
        elif lo <= 0.01 or hi >= 0.99:
            bound = in_domain(p.low if lo <= 0.01 else p.high, p.low, p.high)
            edge = f"{'lower' if lo <= 0.01 else 'upper'} bound ({bound})"
            out.append(f"The candidates reach the {edge} of {p.name}: its true value may lie outside the "
                       "domain; consider widening it.")
    return out
