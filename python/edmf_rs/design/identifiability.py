"""Expected identifiability of a sensor set (Bertola, Papadopoulou, Vernay &
Smith 2017, Sensors 17(12):2904, Sec. 2.4; Goulet & Smith 2013, Eqs. 4-8).

Each simulation draws a true model instance j uniformly among the N, one
residual u_i per sensor from its combined uncertainty U_c,i (the one the
falsification uses), sets ``y = G[j, S] - u`` (Eq. 4), takes the Šidák
thresholds for |S| sensors (Eq. 5) and counts the instances that pass Eq. 8 on
S. The candidate-set sizes over the simulations show how far the sensors are
expected to narrow the model instances down. Along a greedy order the curve can
turn back up: each added sensor widens every sensor's bounds (Šidák).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy import stats

from .. import _core
from ..engine._validate import positive_int
from ..engine.thresholds import threshold_bounds
from ..engine.uncertainty import CombinedUncertainty
from . import _checks
from .reference import draw_simulations

__all__ = ["Identifiability", "IdentifiabilityCurve", "expected_identifiability", "identifiability_curve",
           "subset"]


def subset(combined: CombinedUncertainty, sensors) -> CombinedUncertainty:
    """U_c of the locations ``sensors`` only, every per-sensor field kept.

    The exact marginals, the sources (numerical convolution), the symmetric
    and Gaussian flags and the names are taken for those locations, so
    :func:`edmf_rs.threshold_bounds` gives each the bounds it has in the full
    U_c (for the same per-sensor probability), the bounds the falsification
    uses, and its warnings name the locations (their index in the full U_c
    when it has no names).

    Examples
    --------
    >>> import edmf_rs, scipy.stats as st
    >>> u = edmf_rs.combine(measurement=[st.norm(0, [1.0, 2.0, 3.0])])
    >>> sub = subset(u, [2, 0])
    >>> sub.n_sensors, sub.std.tolist(), sub.sensor_names
    (2, [3.0, 1.0], ('2', '0'))
    """
    sensors = list(sensors)
    at = np.asarray(sensors, dtype=np.int64)

    def pick(values):
        return None if values is None else tuple(values[j] for j in sensors)

    names = tuple(combined.sensor_name(j) for j in sensors)
    flags = {key: None if getattr(combined, key) is None else np.asarray(getattr(combined, key))[at].copy()
             for key in ("symmetric", "gaussian")}
    if combined.exact:
        return replace(combined, n_sensors=len(sensors), sensor_names=names, sources=pick(combined.sources),
                       marginals=pick(combined.marginals), samples=None, **flags,
                       distribution=stats.norm(loc=combined.mean[at], scale=combined.std[at]))
    return replace(combined, n_sensors=len(sensors), sensor_names=names, sources=pick(combined.sources),
                   marginals=pick(combined.marginals), samples=np.ascontiguousarray(combined.samples[:, at]), **flags)


@dataclass(frozen=True, eq=False)
class Identifiability:
    """Candidate-set sizes of simulated measurements on a set of sensors.

    Attributes
    ----------
    sensors : numpy.ndarray of int64
    sizes : numpy.ndarray of int64
        One candidate-set size per simulation.
    n_instances : int

    Examples
    --------
    >>> import numpy as np
    >>> r = Identifiability(np.array([0]), np.array([1, 2, 3, 10]), n_instances=20)
    >>> r.mean, r.median, r.summary()["mean_fraction"]
    (4.0, 2.5, 0.2)
    """

    sensors: np.ndarray
    sizes: np.ndarray
    n_instances: int

    @property
    def mean(self) -> float:
        return float(self.sizes.mean())

    @property
    def median(self) -> float:
        return float(np.median(self.sizes))

    @property
    def p95(self) -> float:
        """95th percentile of the candidate-set size."""
        return float(np.percentile(self.sizes, 95))

    def summary(self) -> dict:
        """Mean, median and 95th percentile, as counts and as fractions of N."""
        out = {"mean": self.mean, "median": self.median, "p95": self.p95}
        out.update({f"{k}_fraction": v / self.n_instances for k, v in list(out.items())})
        return out


@dataclass(frozen=True, eq=False)
class IdentifiabilityCurve:
    """Expected identifiability after the first 1, 2, ..., k sensors of an order.

    Attributes
    ----------
    order : numpy.ndarray
        The locations, in the order they are added.
    sizes : numpy.ndarray, shape (k, n_simulations)
        ``sizes[m - 1]``: the candidate-set sizes with the first m sensors;
        every m uses the same simulations (true instances and residual draws).
    n_instances : int
        N, the number of model instances.

    Examples
    --------
    >>> import numpy as np
    >>> c = IdentifiabilityCurve(np.array([3, 1]), np.array([[9, 7], [4, 6]]), n_instances=10)
    >>> c.mean.tolist(), c.best
    ([8.0, 5.0], 2)
    """

    order: np.ndarray
    sizes: np.ndarray
    n_instances: int

    @property
    def n_sensors(self) -> np.ndarray:
        return np.arange(1, self.order.size + 1)

    @property
    def mean(self) -> np.ndarray:
        return self.sizes.mean(axis=1)

    @property
    def median(self) -> np.ndarray:
        return np.median(self.sizes, axis=1)

    @property
    def p95(self) -> np.ndarray:
        return np.percentile(self.sizes, 95, axis=1)

    @property
    def best(self) -> int:
        """Number of sensors with the smallest mean candidate-set size (fewest on ties)."""
        return int(np.argmin(self.mean)) + 1


def _inputs(predictions, combined, n_simulations):
    # NaN would fail every comparison of Eq. 8: such an instance could never be a candidate, even when true.
    g = _checks.finite_predictions(_checks.predictions_array(predictions),
                                   "leave out the instances without predictions (expected identifiability has no "
                                   "bin for NaN, unlike place_sensors' nan_policy='bin')")
    if not isinstance(combined, CombinedUncertainty):
        raise TypeError(f"combined: expected the CombinedUncertainty of all locations (edmf_rs.combine), "
                        f"got {type(combined).__name__}")
    if combined.n_sensors != g.shape[1]:
        raise ValueError(f"combined: expected the uncertainty of all {g.shape[1]} locations, "
                         f"got {combined.n_sensors}")
    return g, positive_int(n_simulations, "n_simulations")


def _counts(g, combined, sensors, truth, residuals, phi, correction) -> np.ndarray:
    t = threshold_bounds(subset(combined, sensors), phi=phi, correction=correction)  # Eq. 5, |S| sensors
    res = np.ascontiguousarray(residuals[:, sensors])
    return np.asarray(_core.design_candidate_counts(g, list(sensors), truth, res, t.low, t.high), dtype=np.int64)


def expected_identifiability(predictions, combined, sensors, *, n_simulations: int = 1000, phi: float = 0.95,
                             correction: str = "sidak", seed=0) -> Identifiability:
    """Distribution of the candidate-set size when measuring at ``sensors``.

    Parameters
    ----------
    predictions : array of shape (N, L)
        Predictions of the N model instances at all L candidate locations.
    combined : CombinedUncertainty
        U_c of all L locations, as :func:`edmf_rs.combine` makes it.
    sensors : sequence of int
        The chosen location indices S (distinct).
    n_simulations : int
        Simulated measurements.
    phi, correction
        Target probability and multiple-comparison correction of the
        thresholds (as in :func:`edmf_rs.threshold_bounds`), for |S| sensors.
    seed : int >= 0, sequence of them, None, or numpy Generator / SeedSequence
        Seed of the draws (:func:`edmf_rs.design.reference.draw_simulations`).

    Returns
    -------
    Identifiability
        ``.sizes``: one candidate-set size per simulation.

    Raises
    ------
    ValueError
        Sensors out of range or repeated, ``combined`` of another number of
        locations, a negative ``seed``.
    TypeError
        A ``seed`` that is not an integer >= 0, a sequence of them, None or a
        numpy Generator/SeedSequence.

    Examples
    --------
    >>> import numpy as np, edmf_rs, scipy.stats as st
    >>> g = np.linspace(0, 10, 101)[:, None]
    >>> u = edmf_rs.combine(measurement=[st.norm(0, 0.5)], n_sensors=1)
    >>> r = expected_identifiability(g, u, [0], n_simulations=200)
    >>> 15 < r.mean < 21
    True
    """
    g, n_sim = _inputs(predictions, combined, n_simulations)
    sensors = _checks.locations(sensors, "sensors", g.shape[1])
    if not sensors:
        raise ValueError("sensors: expected at least one location")
    truth, residuals = draw_simulations(combined, g.shape[0], n_sim, _checks.seed(seed))
    sizes = _counts(g, combined, sensors, truth, residuals, phi, correction)
    return Identifiability(np.asarray(sensors, dtype=np.int64), sizes, g.shape[0])


def identifiability_curve(predictions, combined, order, *, n_simulations: int = 1000, phi: float = 0.95,
                          correction: str = "sidak", seed=0) -> IdentifiabilityCurve:
    """Expected identifiability after the first 1, 2, ..., k sensors of ``order``.

    Every prefix uses the same simulations, so point m equals
    ``expected_identifiability(predictions, combined, order[:m], seed=seed)``.
    Šidák widens the bounds as sensors are added, so the curve can turn back up.

    Parameters
    ----------
    predictions : array_like, shape (N, L)
        Predictions of the N model instances at the L candidate locations.
    combined : CombinedUncertainty
        U_c of all L locations (Eq. 4), as `edmf_rs.combine` makes it.
    order : sequence of int
        Locations in the order they are added (e.g. ``place_sensors(...).order``).
    n_simulations, phi, correction, seed
        As in :func:`expected_identifiability`.

    Returns
    -------
    IdentifiabilityCurve
        ``sizes`` of shape (len(order), n_simulations): candidate-set sizes
        after each added sensor.

    Raises
    ------
    ValueError
        If ``order`` is empty, out of range or repeated, or the inputs are
        invalid (see :func:`expected_identifiability`).

    Examples
    --------
    >>> import numpy as np, edmf_rs, scipy.stats as st
    >>> g = np.random.default_rng(0).normal(size=(500, 4))
    >>> u = edmf_rs.combine(measurement=[st.norm(0, 0.3)], n_sensors=4)
    >>> c = identifiability_curve(g, u, [0, 1, 2], n_simulations=50)
    >>> c.sizes.shape
    (3, 50)
    """
    g, n_sim = _inputs(predictions, combined, n_simulations)
    order = _checks.locations(order, "order", g.shape[1])
    if not order:
        raise ValueError("order: expected at least one location")
    truth, residuals = draw_simulations(combined, g.shape[0], n_sim, _checks.seed(seed))
    sizes = np.stack([_counts(g, combined, order[:m], truth, residuals, phi, correction)
                      for m in range(1, len(order) + 1)])
    return IdentifiabilityCurve(np.asarray(order, dtype=np.int64), sizes, g.shape[0])
