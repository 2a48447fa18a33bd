"""Threshold bounds (Goulet & Smith 2013, Sec. 3.1).

Per sensor, the shortest interval of the combined uncertainty U_c holding the
per-sensor probability (Eq. 5). With the Sidak correction that probability is
``phi**(1/n_m)``, so the hyper-rectangle of all sensors holds at least ``phi``
whatever the dependencies between sensors (Eq. 7).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _core
from . import intervals
from ._validate import finite_vector, positive_int, probability

CORRECTIONS = ("sidak", "bonferroni", "none")


@dataclass(frozen=True, eq=False)
class Thresholds:
    """Per-sensor threshold bounds ``[low_i, high_i]`` on the residual ``g_i(theta) - y_i``.

    Made by `threshold_bounds`, or by hand, e.g. to reuse bounds computed by
    another tool (mind its sign convention: edmf_rs bounds ``g - y``, Eq. 8).

    Parameters
    ----------
    low, high : array_like
        T_low,i and T_high,i, one per sensor, finite, ``low <= high``.
    phi : float, optional
        Target identification probability the bounds were computed for.
    probability : float, optional
        Probability each sensor's interval holds.
    correction : str, optional
        ``"sidak"``, ``"bonferroni"`` or ``"none"``. ``phi``, ``probability``
        and ``correction`` are None for bounds given by hand.

    Attributes
    ----------
    n_sensors : int
        Number of sensors n_m.
    width : numpy.ndarray
        ``high - low`` per sensor.

    Raises
    ------
    ValueError
        If ``low`` or ``high`` is not a finite 1-D vector, they differ in
        length, or ``low > high`` at some sensor.

    Examples
    --------
    >>> import edmf_rs
    >>> t = edmf_rs.Thresholds(low=[-1.0, -2.0], high=[1.0, 0.5])
    >>> t.n_sensors, t.width.tolist()
    (2, [2.0, 2.5])
    >>> edmf_rs.Thresholds(low=[1.0], high=[0.0])
    Traceback (most recent call last):
    ...
    ValueError: low: expected low <= high, got low=1.0 > high=0.0 at sensor 0
    """

    low: np.ndarray
    high: np.ndarray
    phi: float | None = None
    probability: float | None = None
    correction: str | None = None

    def __post_init__(self):
        low = finite_vector(self.low, "low")
        high = finite_vector(self.high, "high", n=low.shape[0])
        bad = np.flatnonzero(low > high)
        if bad.size:
            i = bad[0]
            raise ValueError(f"low: expected low <= high, got low={low[i]} > high={high[i]} at sensor {i}")
        object.__setattr__(self, "low", low)
        object.__setattr__(self, "high", high)

    @property
    def n_sensors(self) -> int:
        return int(self.low.shape[0])

    @property
    def width(self) -> np.ndarray:
        return self.high - self.low

    def __repr__(self) -> str:
        how = f", phi={self.phi}, correction={self.correction!r}" if self.phi is not None else ""
        return f"Thresholds(n_sensors={self.n_sensors}{how})"


def sensor_probability(phi: float, n_sensors: int, correction: str = "sidak") -> float:
    """Probability each sensor's interval must hold for a joint target ``phi`` (Eqs. 5, 7).

    Parameters
    ----------
    phi : float
        Target identification probability, in (0, 1).
    n_sensors : int
        Number of sensors n_m, at least 1.
    correction : {"sidak", "bonferroni", "none"}, default "sidak"
        ``"sidak"``: ``phi**(1/n_m)`` (Eq. 5), the joint probability is
        exactly ``phi`` for independent sensors and at least ``phi`` for
        jointly Gaussian U_c whatever the correlations. ``"bonferroni"``:
        ``1 - (1 - phi)/n_m``, at least ``phi`` under any dependence.
        ``"none"``: ``phi`` per sensor.

    Returns
    -------
    float
        The per-sensor probability.

    Raises
    ------
    ValueError
        If ``phi`` is not in (0, 1), ``n_sensors`` is not a positive integer,
        ``correction`` is unknown, or the probability rounds to 1.

    Examples
    --------
    >>> import edmf_rs
    >>> round(edmf_rs.sensor_probability(0.95, 10), 6)
    0.994884
    >>> round(edmf_rs.sensor_probability(0.95, 10, "bonferroni"), 6)
    0.995
    """
    phi = probability(phi, "phi")
    n_sensors = positive_int(n_sensors, "n_sensors")
    if correction == "sidak":
        p = phi ** (1.0 / n_sensors)  # Eq. 5
    elif correction == "bonferroni":
        p = 1.0 - (1.0 - phi) / n_sensors
    elif correction == "none":
        p = phi
    else:
        raise ValueError(f"correction: expected one of {', '.join(map(repr, CORRECTIONS))}, got {correction!r}")
    if p >= 1.0:
        raise ValueError(
            f"phi: {phi!r} is so close to 1 that the per-sensor probability for {n_sensors} sensors "
            "rounds to 1 (unbounded thresholds); use a smaller phi"
        )
    return p


def threshold_bounds(combined, phi: float = 0.95, correction: str = "sidak") -> Thresholds:
    """Threshold bounds from the combined uncertainty of every sensor (Eqs. 5-7).

    Per sensor, the shortest interval of U_c holding the per-sensor probability
    (`sensor_probability`): ``phi**(1/n_m)`` with the Sidak correction (Eq. 5),
    so that the hyper-rectangle of all sensors holds ``phi`` (Eq. 7).

    Parameters
    ----------
    combined : CombinedUncertainty, array_like or frozen distributions
        One of:

        - the result of `combine`;
        - a 2-D array of Monte Carlo samples of U_c, shape (n_samples, n_m):
          the bounds are the shortest interval holding the per-sensor
          probability of each column's samples (computed in Rust, in parallel
          over sensors);
        - a sequence of n_m frozen ``scipy.stats`` continuous distributions,
          or one frozen distribution vectorised over the n_m sensors:
          central intervals through ``ppf`` for symmetric unimodal families
          (Eq. 6), the shortest interval otherwise.
    phi : float, default 0.95
        Target identification probability, in (0, 1).
    correction : {"sidak", "bonferroni", "none"}, default "sidak"
        How the per-sensor probability follows from ``phi``
        (`sensor_probability`).

    Returns
    -------
    Thresholds
        The bounds, with ``phi``, the per-sensor ``probability`` and the
        ``correction`` recorded.

    Raises
    ------
    TypeError
        If ``combined`` is none of the above.
    ValueError
        If ``phi`` is not in (0, 1), the samples are not 2-D with at least one
        sensor, or there are too few samples for the per-sensor probability.

    Examples
    --------
    >>> from scipy import stats
    >>> import edmf_rs
    >>> t = edmf_rs.threshold_bounds([stats.norm(0, 1), stats.norm(0, 2)], phi=0.95)
    >>> round(t.probability, 4), t.high.round(2).tolist()
    (0.9747, [2.24, 4.47])

    From Monte Carlo samples:

    >>> import numpy as np
    >>> samples = np.random.default_rng(0).normal(size=(100_000, 2))
    >>> t = edmf_rs.threshold_bounds(samples, phi=0.95, correction="bonferroni")
    >>> t.correction, t.high.round(1).tolist()
    ('bonferroni', [2.2, 2.2])
    """
    from .uncertainty import CombinedUncertainty

    phi = probability(phi, "phi")
    if isinstance(combined, CombinedUncertainty):
        combined = combined.samples if combined.samples is not None else combined.distribution
    if intervals.is_frozen(combined):
        shape = intervals.batch_shape(combined)
        if len(shape) != 1:
            raise ValueError(
                f"combined: expected a distribution vectorised over the sensors (1-D), got batch shape {shape}"
            )
        combined = intervals.split(combined, shape[0])
    if isinstance(combined, (list, tuple)) and combined and all(map(intervals.is_frozen, combined)):
        for i, d in enumerate(combined):
            if intervals.batch_shape(d) != ():
                raise ValueError(
                    f"combined: expected one scalar distribution per sensor, element {i} is vectorised "
                    f"over shape {intervals.batch_shape(d)}"
                )
        p = sensor_probability(phi, len(combined), correction)
        low, high = intervals.shortest_intervals(combined, p)
    else:
        samples = _samples(combined)
        p = sensor_probability(phi, samples.shape[1], correction)
        low, high = _core.shortest_intervals(samples, p)
    return Thresholds(low, high, phi=phi, probability=p, correction=correction)


def _samples(combined) -> np.ndarray:
    if isinstance(combined, (list, tuple)) and combined and any(map(intervals.is_frozen, combined)):
        raise TypeError("combined: expected every element to be a frozen scipy.stats continuous distribution")
    try:
        samples = np.asarray(combined)
    except (TypeError, ValueError):
        samples = np.asarray(combined, dtype=object)
    if samples.dtype.kind not in "iuf":
        raise TypeError(
            "combined: expected a 2-D array of Monte Carlo samples, frozen scipy.stats distributions "
            f"or the result of combine(), got {type(combined).__name__} (dtype {samples.dtype})"
        )
    if samples.ndim != 2:
        raise ValueError(f"combined: expected samples of shape (n_samples, n_m), got shape {samples.shape}")
    if samples.shape[1] == 0:
        raise ValueError("combined: expected at least one sensor (n_m >= 1), got 0")
    samples = np.require(samples, dtype=np.float64, requirements="A")
    if any(stride < 0 for stride in samples.strides):
        samples = np.ascontiguousarray(samples)  # the core reads non-negative strides in place
    return samples
