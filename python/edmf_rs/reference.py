"""Plain NumPy/SciPy EDMF, written for clarity rather than speed.

This is the oracle the Rust core is tested against: every function here
follows the paper's equations line by line.
"""

from __future__ import annotations

import math

import numpy as np

from .result import FalsificationResult
from .thresholds import Thresholds


def sensor_probability(phi: float, n_sensors: int, correction: str = "sidak") -> float:
    if not 0.0 < phi < 1.0:
        raise ValueError(f"phi: expected a value in (0, 1), got {phi}")
    return {
        "sidak": lambda: phi ** (1.0 / n_sensors),  # Eq. 5
        "bonferroni": lambda: 1.0 - (1.0 - phi) / n_sensors,
        "none": lambda: phi,
    }[correction]()


def shortest_interval(samples: np.ndarray, probability: float) -> tuple[float, float]:
    """Shortest interval holding ceil(p * n) of the samples (lowest one on ties)."""
    x = np.sort(np.asarray(samples, dtype=np.float64))
    n = x.size
    if n < math.ceil(1.0 / (1.0 - probability)):
        raise ValueError(f"combined: too few samples ({n}) for probability {probability}")
    k = min(max(math.ceil(probability * n), 1), n)
    widths = x[k - 1:] - x[: n - k + 1]
    i = int(np.argmin(widths))
    return float(x[i]), float(x[i + k - 1])


def shortest_interval_of(dist, probability: float, grid: int = 20001) -> tuple[float, float]:
    """Shortest interval of a frozen distribution by brute force over the lower tail mass."""
    a = np.linspace(0.0, 1.0 - probability, grid)[1:-1]
    widths = dist.ppf(a + probability) - dist.ppf(a)
    i = int(np.nanargmin(widths))
    return float(dist.ppf(a[i])), float(dist.ppf(a[i] + probability))


def threshold_bounds(combined, phi: float = 0.95, correction: str = "sidak") -> Thresholds:
    """Eq. 5 per sensor, from samples (n_samples, n_m) or a list of frozen distributions."""
    if isinstance(combined, (list, tuple)) and combined and hasattr(combined[0], "ppf"):
        p = sensor_probability(phi, len(combined), correction)
        bounds = [shortest_interval_of(d, p) for d in combined]
    else:
        samples = np.asarray(combined, dtype=np.float64)
        p = sensor_probability(phi, samples.shape[1], correction)
        bounds = [shortest_interval(samples[:, j], p) for j in range(samples.shape[1])]
    low, high = np.array(bounds).T
    return Thresholds(low, high, phi=phi, probability=p, correction=correction)


def falsify(predictions, measurements, thresholds: Thresholds) -> FalsificationResult:
    """Eq. 8 for every instance at once."""
    g = np.asarray(predictions).astype(np.float64)
    y = np.asarray(measurements, dtype=np.float64)
    residuals = g - y  # Eq. 14
    inside = (thresholds.low <= residuals) & (residuals <= thresholds.high)
    violated = ~inside
    n_violated = violated.sum(axis=1)
    return FalsificationResult(
        thresholds=thresholds,
        measurements=y,
        n_instances=g.shape[0],
        candidate_indices=np.flatnonzero(inside.all(axis=1)).astype(np.int64),
        per_sensor_falsified=violated.sum(axis=0).astype(np.int64),
        falsified_only_by=violated[n_violated == 1].sum(axis=0).astype(np.int64),
        n_invalid=int(np.isnan(g).any(axis=1).sum()),
        n_violated=n_violated.astype(np.int32),
    )
# Measurement-system design (joint entropy, greedy placement, expected identifiability):
from .design.reference import candidate_counts, draw_simulations, expected_identifiability, joint_entropy, place_sensors  # noqa: E402,F401,E501
