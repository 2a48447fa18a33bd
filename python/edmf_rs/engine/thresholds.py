"""Threshold bounds (Goulet & Smith 2013, Sec. 3.1).

Per sensor, the shortest interval of the combined uncertainty U_c holding the
per-sensor probability (Eq. 5). With the Sidak correction that probability is
``phi**(1/n_m)``. What the hyper-rectangle of all sensors then holds (Eq. 7)
depends on U_c: for Gaussian U_c, Sidak's inequality (Sidak 1967) gives at
least ``phi`` whatever the correlations; for other U_c only Bonferroni's
inequality holds for every dependence, ``1 - n_m (1 - p)`` (0.9487 for
phi = 0.95, n_m = 50), and ``correction="bonferroni"`` restores ``phi``.
:attr:`Thresholds.guaranteed_probability` gives the figure for a result.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _core
from . import convolution, intervals, mc_intervals
from ._validate import check_seed, finite_vector, positive_int, probability, real_array

CORRECTIONS = ("sidak", "bonferroni", "none")
METHODS = ("convolution", "monte-carlo")
#: Per-sensor estimators whose bounds are not drawn from Monte Carlo samples.
NUMERICAL = ("exact", "convolution")


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
    gaussian : bool or None
        Whether U_c is normal at every sensor; it decides what the correction
        guarantees (`guaranteed_probability`).
    se_low, se_high : numpy.ndarray or None
        Standard error of each bound: Monte Carlo, or the numerical error of
        a convolution bound (0 where the bound is exact; +inf where it could
        not be estimated). One per sensor, >= 0.
    method : tuple of str or None
        The estimator per sensor: "exact" (closed form), "convolution"
        (numerical convolution of the sources), or the Monte Carlo
        "central", "shortest" or "shortest-plain".
    confidence : float or None
        Confidence with which each Monte Carlo interval holds at least
        ``probability``; ``n_samples`` and ``seed`` record the draws.

    Raises
    ------
    ValueError
        If ``low`` or ``high`` is not a finite 1-D vector, they differ in
        length, or ``low > high`` at some sensor; if ``se_low`` or
        ``se_high`` is not one value per sensor, or holds NaN or a negative value.
    TypeError
        If ``se_low`` or ``se_high`` is not numeric.

    Examples
    --------
    >>> import edmf_rs
    >>> t = edmf_rs.Thresholds(low=[-1.0, -2.0], high=[1.0, 0.5])
    >>> t.n_sensors, t.width.tolist(), t.guaranteed_probability
    (2, [2.0, 2.5], None)
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
    gaussian: bool | None = None
    se_low: np.ndarray | None = None
    se_high: np.ndarray | None = None
    method: tuple | None = None
    confidence: float | None = None
    n_samples: int | None = None
    seed: object = None

    def __post_init__(self):
        low = finite_vector(self.low, "low")
        high = finite_vector(self.high, "high", n=low.shape[0])
        bad = np.flatnonzero(low > high)
        if bad.size:
            i = bad[0]
            raise ValueError(f"low: expected low <= high, got low={low[i]} > high={high[i]} at sensor {i}")
        object.__setattr__(self, "low", low)
        object.__setattr__(self, "high", high)
        for name in ("se_low", "se_high"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, self._standard_errors(value, name, low.shape[0]))

    @staticmethod
    def _standard_errors(values, name: str, n: int) -> np.ndarray:
        """``se_low``/``se_high``: n standard errors, each >= 0; +inf (an SE that
        could not be estimated, as the bootstrap reports with too few samples) is kept."""
        arr = real_array(values, name, copy=True)
        if arr.ndim != 1 or arr.shape[0] != n:
            raise ValueError(f"{name}: expected {n} standard errors (one per sensor), got shape {arr.shape}")
        bad = np.flatnonzero(np.isnan(arr) | (arr < 0))
        if bad.size:
            raise ValueError(f"{name}: expected standard errors >= 0, got {arr[bad[0]]} at sensor {bad[0]}")
        return arr

    @property
    def n_sensors(self) -> int:
        return int(self.low.shape[0])

    @property
    def width(self) -> np.ndarray:
        return self.high - self.low

    @property
    def monte_carlo(self) -> bool:
        """Some bound was estimated from Monte Carlo samples."""
        return self.method is not None and any(m not in NUMERICAL for m in self.method)

    @property
    def guaranteed_probability(self) -> float | None:
        """Joint probability that the right instance's residuals all lie within
        the bounds, guaranteed whatever the dependence between sensors.

        Gaussian U_c: Sidak's inequality gives ``p ** n_m`` (= phi with the Sidak
        correction, Eq. 7). Otherwise only Bonferroni's inequality holds for
        every dependence: ``1 - n_m (1 - p)`` (0.9487 for phi = 0.95 with the
        Sidak correction at n_m = 50; phi with ``correction="bonferroni"``).
        """
        if self.probability is None:
            return None
        n, p = self.n_sensors, self.probability
        if self.gaussian:
            return p**n
        return max(0.0, 1.0 - n * (1.0 - p))

    def guarantee(self) -> str:
        """One line saying what the bounds guarantee (printed with project results).

        Returns
        -------
        str
            The guaranteed joint probability and the inequality it rests on.
        """
        if self.probability is None:
            return "bounds given by hand: no probability is attached to them"
        g = self.guaranteed_probability
        if self.gaussian:
            text = (f"joint probability >= {g:.4f} whatever the correlation (Sidak's inequality, exact for "
                    "Gaussian combined uncertainty)")
        else:
            text = (f"joint probability >= {g:.4f} whatever the dependence (Bonferroni bound "
                    f"1 - n_m (1 - p), non-Gaussian combined uncertainty)")
            if self.correction == "sidak":
                text += f"; {self.probability ** self.n_sensors:.4f} if the sensors' errors are independent"
        if self.monte_carlo:
            text += (f"; each Monte Carlo interval holds at least p = {self.probability:.6g} "
                     f"with confidence {self.confidence:g} ({self.n_samples:,} samples, seed {self.seed})")
        return text

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


def threshold_bounds(combined, phi: float = 0.95, correction: str = "sidak", *,
                     confidence: float = mc_intervals.DEFAULT_CONFIDENCE, estimator: str = "conservative",
                     seed=None, method: str = "convolution") -> Thresholds:
    """Threshold bounds from the combined uncertainty of every sensor (Eqs. 5-7).

    Per sensor, an interval of U_c holding the per-sensor probability
    (`sensor_probability`): ``phi**(1/n_m)`` with the Sidak correction (Eq. 5),
    so that the hyper-rectangle of all sensors holds ``phi`` (Eq. 7) when U_c
    is Gaussian; whatever the dependence, the guaranteed joint probability is
    the Bonferroni bound (`Thresholds.guaranteed_probability`).

    Parameters
    ----------
    combined : CombinedUncertainty, array_like or frozen distributions
        One of:

        - the result of `combine`: exact bounds where a sensor's U_c is known
          in closed form, numerical convolution of the sources elsewhere
          (Monte Carlo where a source cannot be convolved, e.g. heavy tails);
        - a 2-D array of Monte Carlo samples of U_c, shape (n_samples, n_m);
        - a sequence of n_m frozen ``scipy.stats`` continuous distributions,
          or one frozen distribution vectorised over the n_m sensors (exact).
    phi : float, default 0.95
        Target identification probability, in (0, 1).
    correction : {"sidak", "bonferroni", "none"}, default "sidak"
        How the per-sensor probability follows from ``phi``
        (`sensor_probability`); "bonferroni" holds ``phi`` for any dependence.
    confidence : float, optional
        Probability that each Monte Carlo interval holds at least the
        per-sensor probability (see `edmf_rs.engine.mc_intervals`).
    estimator : {"conservative", "shortest"}, default "conservative"
        Monte Carlo estimator. "shortest" is the plain shortest window of
        ceil(pN) samples, computed in Rust, which holds p only on average;
        asking for it uses the samples at every sensor (no convolution).
    seed : int, optional
        Seed of the bootstrap standard errors (default: the samples' seed, else 0).
    method : {"convolution", "monte-carlo"}, default "convolution"
        For a `combine` result: "convolution" computes U_c's density by
        numerical convolution of the sources (`edmf_rs.engine.convolution`;
        numerical error below 1e-4 of the width, reported as the bound's
        SE); "monte-carlo" uses its samples with ``estimator``. Raw samples
        always use Monte Carlo.

    Returns
    -------
    Thresholds
        The bounds, with ``phi``, the per-sensor ``probability``, the
        ``correction`` and the Monte Carlo standard errors recorded.

    Raises
    ------
    TypeError
        If ``combined`` is none of the above.
    ValueError
        If ``phi``, ``correction``, ``method`` or ``seed`` is invalid, a
        distribution has a non-finite location, a scale <= 0 or shape
        parameters outside its family's domain (the message names the
        sensor), or there are too few samples (the message says how many
        are needed).

    Warns
    -----
    UserWarning
        Monte Carlo sensors with fewer than ~100 samples per tail.

    Examples
    --------
    >>> from scipy import stats
    >>> import edmf_rs
    >>> t = edmf_rs.threshold_bounds([stats.norm(0, 1), stats.norm(0, 2)], phi=0.95)
    >>> round(t.probability, 4), t.high.round(2).tolist(), round(t.guaranteed_probability, 4)
    (0.9747, [2.24, 4.47], 0.95)
    """
    from .uncertainty import CombinedUncertainty

    phi = probability(phi, "phi")
    confidence = probability(confidence, "confidence")
    seed = None if seed is None else check_seed(seed)
    if estimator not in ("conservative", "shortest"):
        raise ValueError(f"estimator: expected 'conservative' or 'shortest', got {estimator!r}")
    if method not in METHODS:
        raise ValueError(f"method: expected one of {', '.join(map(repr, METHODS))}, got {method!r}")
    if isinstance(combined, CombinedUncertainty):
        if combined.exact:
            combined = combined.distribution
        else:
            return _monte_carlo_bounds(combined, phi, correction, confidence, estimator, seed,
                                       convolve=method == "convolution" and estimator == "conservative")
    if intervals.is_frozen(combined):
        shape = intervals.batch_shape(combined)
        if len(shape) != 1:
            raise ValueError(
                f"combined: expected a distribution vectorised over the sensors (1-D), got batch shape {shape}"
            )
        intervals.check_parameters(combined, "combined", shape[0])
        p = sensor_probability(phi, shape[0], correction)
        if combined.dist.name in intervals.SYMMETRIC_UNIMODAL:
            # Eq. 6 for every sensor at once; elementwise the same ppf as the per-sensor call.
            tail = 0.5 * (1.0 - p)
            # The upper bound through isf(tail), not ppf(1 - tail): 1 - tail rounds away digits of a
            # small tail (p close to 1 at many sensors), which moved the bound by ~1e-10 of the width.
            low = np.broadcast_to(combined.ppf(tail), shape).astype(np.float64)
            high = np.broadcast_to(combined.isf(tail), shape).astype(np.float64)
            return Thresholds(low, high, phi=phi, probability=p, correction=correction,
                              gaussian=combined.dist.name == "norm", method=("exact",) * shape[0])
        combined = intervals.split(combined, shape[0])
    if isinstance(combined, (list, tuple)) and combined and all(map(intervals.is_frozen, combined)):
        for i, d in enumerate(combined):
            if intervals.batch_shape(d) != ():
                raise ValueError(
                    f"combined: expected one scalar distribution per sensor, element {i} is vectorised "
                    f"over shape {intervals.batch_shape(d)}"
                )
            intervals.check_parameters(d, "combined", sensor=i)
        p = sensor_probability(phi, len(combined), correction)
        low, high = intervals.shortest_intervals(combined, p)
        return Thresholds(low, high, phi=phi, probability=p, correction=correction,
                          gaussian=all(d.dist.name == "norm" for d in combined), method=("exact",) * len(combined))
    samples = _samples(combined)
    n, n_m = samples.shape
    p = sensor_probability(phi, n_m, correction)
    if estimator == "shortest":
        mc_intervals.warn_thin_tails(range(n_m), p, n, confidence)  # as for combine() samples
        low, high = _core.shortest_intervals(samples, p)
        return Thresholds(low, high, phi=phi, probability=p, correction=correction, gaussian=False,
                          method=("shortest-plain",) * n_m, n_samples=n)
    bad = ~np.isfinite(samples)
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise ValueError(f"combined: finite samples, got {samples[i, j]} in sensor column {j}")
    from .uncertainty import CombinedUncertainty as _C

    return _monte_carlo_bounds(_C(n_m, samples=samples, symmetric=np.zeros(n_m, dtype=bool),
                                  gaussian=np.zeros(n_m, dtype=bool)),
                               phi, correction, confidence, estimator, seed)


def _monte_carlo_bounds(combined, phi, correction, confidence, estimator, seed, convolve=False) -> Thresholds:
    """Exact bounds at the sensors with a closed-form marginal, then (``convolve``) numerical
    convolution where every source is convolvable, Monte Carlo bounds elsewhere."""
    samples = combined.samples
    n, n_m = samples.shape
    p = sensor_probability(phi, n_m, correction)
    marginals = combined.marginals or (None,) * n_m
    symmetric = combined.symmetric if combined.symmetric is not None else np.zeros(n_m, dtype=bool)
    low, high = np.empty(n_m), np.empty(n_m)
    se_low, se_high = np.zeros(n_m), np.zeros(n_m)
    method = [None] * n_m
    conv = []
    if convolve and combined.sources is not None:
        conv = [j for j in range(n_m) if marginals[j] is None]
        conv = [j for j, ok in zip(conv, convolution.usable([combined.sources[j] for j in conv])) if ok]
    if conv:
        b = convolution.shortest_bounds([combined.sources[j] for j in conv], p, symmetric=symmetric[conv])
        low[conv], high[conv], se_low[conv], se_high[conv] = b.low, b.high, b.error, b.error
        for j in conv:
            method[j] = "convolution"
    mc = [j for j in range(n_m) if marginals[j] is None and method[j] is None]
    mc_intervals.warn_thin_tails([combined.sensor_name(j) for j in mc], p, n, confidence, stacklevel=4)
    if estimator == "shortest" and mc:
        sub = np.ascontiguousarray(samples[:, mc])
        low[mc], high[mc] = _core.shortest_intervals(sub, p)
    root = seed if seed is not None else (combined.seed if isinstance(combined.seed, int) else 0)
    for j in range(n_m):
        if marginals[j] is not None:
            sign, dist = marginals[j]
            a, b = intervals.shortest_interval(dist, p)
            low[j], high[j] = (a, b) if sign > 0 else (-b, -a)
            method[j] = "exact"
        elif method[j] is not None:
            continue
        elif estimator == "shortest":
            method[j] = "shortest-plain"
        else:
            column = np.sort(samples[:, j])
            b = mc_intervals.sample_interval(column, p, symmetric=bool(symmetric[j]), confidence=confidence,
                                             rng=np.random.default_rng([int(root), j]))
            low[j], high[j], se_low[j], se_high[j] = b.low, b.high, b.se_low, b.se_high
            method[j] = b.method
    gaussian = combined.gaussian is not None and bool(np.all(combined.gaussian))
    return Thresholds(low, high, phi=phi, probability=p, correction=correction, gaussian=gaussian,
                      se_low=se_low, se_high=se_high, method=tuple(method),
                      confidence=confidence if estimator == "conservative" and mc else None,
                      n_samples=n, seed=combined.seed)


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
