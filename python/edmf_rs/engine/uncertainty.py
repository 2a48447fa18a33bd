"""Combined uncertainty U_c (Eq. 4): model sources minus measurement sources.

From Eq. 4, ``g_i(theta*) - y_i = eps_model,i - eps_measure,i``, so the residual
of the right model instance is distributed as U_c = sum(model) - sum(measurement).
Sources are ordinary frozen ``scipy.stats`` distributions.

Distributions named in project files (``"lognorm"``, the shorthands) are made
in :mod:`edmf_rs.engine.distributions`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from scipy import stats

from . import intervals, offsets
from ._validate import check_seed, finite_vector, fits_in_memory, positive_int


@dataclass(frozen=True, eq=False)
class CombinedUncertainty:
    """The combined uncertainty U_c of every sensor (Eq. 4), as made by `combine`.

    Exact when every source is normal or of scale 0, a fixed offset
    (``distribution``, a normal vectorised over the sensors), otherwise Monte
    Carlo ``samples`` for every sensor, with the exact ``marginals`` kept where
    known. Pass it to `threshold_bounds`, which uses the exact marginal where
    there is one and the samples elsewhere.

    Attributes
    ----------
    n_sensors : int
        Number of sensors n_m.
    distribution : scipy.stats frozen distribution or None
        ``scipy.stats.norm`` with one mean and standard deviation per sensor,
        when every source is normal; else None.
    samples : numpy.ndarray or None
        Monte Carlo samples of U_c, shape (n_samples, n_m), when not exact;
        else None.
    marginals : list or None
        Per sensor, ``(sign, frozen distribution)`` when the sensor's sources
        are all normal or it has a single source, else None; sources of scale
        0 are not counted, their offset is in the distribution's location.
    symmetric, gaussian : numpy.ndarray of bool
        Sensors whose every source is symmetric about its mean (so U_c is),
        and those whose every source is normal.
    seed : int or None
        The seed the samples were drawn with (None when a Generator was passed).
    sources : tuple or None
        Per sensor, its sources as ``(sign, frozen scalar distribution)``
        (sign -1 for a measurement source, Eq. 4), when not exact; sources of
        scale 0 are left out, their offset folded into the first one's
        location. `threshold_bounds` convolves them numerically
        (`edmf_rs.engine.convolution`).
    exact : bool
        True when ``distribution`` is given.
    mean, std : numpy.ndarray
        Mean and standard deviation of U_c per sensor (of the samples when
        not exact).

    Examples
    --------
    >>> from scipy import stats
    >>> import edmf_rs
    >>> uc = edmf_rs.combine(model=stats.norm(-1.0, 0.3), measurement=stats.norm(0, 0.4), n_sensors=2)
    >>> uc.exact, uc.n_sensors
    (True, 2)
    >>> uc.mean.tolist(), uc.std.round(3).tolist()
    ([-1.0, -1.0], [0.5, 0.5])
    """

    n_sensors: int
    distribution: object | None = None
    samples: np.ndarray | None = None
    marginals: tuple | None = None
    symmetric: np.ndarray | None = None
    gaussian: np.ndarray | None = None
    seed: object = None
    sensor_names: tuple | None = None
    sources: tuple | None = None

    @property
    def exact(self) -> bool:
        """Every sensor's U_c is known in closed form (normal)."""
        return self.distribution is not None

    @property
    def exact_sensors(self) -> np.ndarray:
        """Per sensor: its thresholds come from a closed form, not from samples."""
        if self.exact:
            return np.ones(self.n_sensors, dtype=bool)
        if self.marginals is None:
            return np.zeros(self.n_sensors, dtype=bool)
        return np.array([m is not None for m in self.marginals], dtype=bool)

    @property
    def all_gaussian(self) -> bool:
        """U_c is normal at every sensor (Sidak's inequality then holds whatever the correlation)."""
        return self.exact or (self.gaussian is not None and bool(np.all(self.gaussian)))

    @property
    def mean(self) -> np.ndarray:
        if self.exact:
            return np.asarray(self.distribution.mean())
        mean = self.samples.mean(axis=0)
        for j, m in enumerate(self.marginals or ()):
            if m is not None:
                mean[j] = m[0] * float(m[1].mean())
        return mean

    @property
    def std(self) -> np.ndarray:
        if self.exact:
            return np.asarray(self.distribution.std())
        std = self.samples.std(axis=0, ddof=1)
        for j, m in enumerate(self.marginals or ()):
            if m is not None:
                std[j] = float(m[1].std())
        return std

    def sensor_name(self, j: int) -> str:
        return str(self.sensor_names[j]) if self.sensor_names is not None else str(j)


def _source_dists(source, name: str) -> tuple[list | None, object | None, int | None]:
    """(per-sensor list, or None), (vectorised/scalar dist, or None), its n_m."""
    if intervals.is_frozen(source):
        shape = intervals.batch_shape(source)
        if len(shape) > 1:
            raise ValueError(f"{name}: expected a distribution over at most one axis (sensors), got {shape}")
        return None, source, (shape[0] if shape else None)
    if isinstance(source, (list, tuple)) and source and all(map(intervals.is_frozen, source)):
        for d in source:
            if intervals.batch_shape(d) != ():
                raise ValueError(f"{name}: a per-sensor list must hold scalar distributions")
        return list(source), None, len(source)
    raise TypeError(
        f"{name}: expected frozen scipy.stats continuous distributions (e.g. scipy.stats.norm(0, 1)), "
        f"or a list of them with one per sensor; got {type(source).__name__}"
    )


def combine(model=(), measurement=(), *, n_samples: int = 200_000, seed=0,
            n_sensors: int | None = None) -> CombinedUncertainty:
    """Combine uncertainty sources into U_c per sensor (Eq. 4).

    From Eq. 4, the residual of the right model instance is
    ``g_i(theta*) - y_i = eps_model,i - eps_measure,i``, so
    U_c,i = sum(model sources) - sum(measurement sources). A model error is
    prediction minus true value, a measurement error reading minus true value.
    Sources are independent of each other at a sensor; how sensors depend on
    each other does not matter to the thresholds, which use each sensor's
    marginal only (Eq. 7).

    A sensor whose sources are all normal keeps its exact normal U_c, and a
    sensor with a single source keeps that source's distribution, even when
    other sensors need Monte Carlo samples.

    A source of scale 0, of any family (e.g. ``scipy.stats.uniform(c, 0)``),
    is the constant c: it shifts U_c by +c (model) or -c (measurement), and
    U_c is otherwise combined as if it were absent, so normal sources plus
    fixed offsets stay exact. A sensor whose every source has scale 0 is
    refused.

    Parameters
    ----------
    model, measurement : source or list of sources
        Each source is a frozen ``scipy.stats`` continuous distribution
        (scalar: the same at every sensor; or vectorised over the n_m
        sensors, e.g. from `relative_to_measured`), or a list of n_m scalar
        frozen distributions, one per sensor.
    n_samples : int, default 200_000
        Monte Carlo samples of U_c when some source is neither normal nor of
        scale 0.
    seed : int >= 0, numpy.random.Generator or None, default 0
        Seed of those samples (fixed by default, so two identical calls give
        identical samples and bounds); recorded on the result.
    n_sensors : int, optional
        Number of sensors n_m; needed when every source is scalar.

    Returns
    -------
    CombinedUncertainty
        Exact (a normal per sensor) when every source is normal or of scale
        0, otherwise ``n_samples`` Monte Carlo samples of U_c per sensor, with
        the sources kept, so that `threshold_bounds` can convolve them instead.

    Raises
    ------
    TypeError
        If a source is not a frozen ``scipy.stats`` distribution or a list of
        them, or ``seed`` is none of the above.
    ValueError
        If there is no source, the sources disagree on the number of sensors,
        every source is scalar and ``n_sensors`` is missing, a source has a
        non-finite location, a negative scale or shape parameters outside
        its family's domain, the combined standard deviation is zero at a
        sensor, the samples would not fit in half this machine's memory,
        ``seed`` is negative, or a distribution gives non-finite samples.

    Examples
    --------
    The paper's cantilever: a model error of mean -10 %, sd 15 % of the
    measured values, and sensor noise of 0.02 mm.

    >>> import numpy as np
    >>> from scipy import stats
    >>> import edmf_rs
    >>> y = np.array([2.0, 4.0])
    >>> uc = edmf_rs.combine(model=edmf_rs.relative_to_measured(stats.norm(-0.10, 0.15), y),
    ...                      measurement=stats.norm(0, 0.02))
    >>> uc.exact
    True
    >>> uc.mean.tolist()
    [-0.2, -0.4]

    A uniform source makes U_c samples (seeded by default); `threshold_bounds`
    then convolves the sources' densities where it can, and uses the samples
    only where it cannot:

    >>> uc = edmf_rs.combine(model=stats.uniform(-0.5, 1.0), measurement=stats.norm(0, 0.1),
    ...                      n_sensors=3, n_samples=10_000)
    >>> uc.exact, uc.seed, uc.samples.shape, bool(uc.symmetric.all())
    (False, 0, (10000, 3), True)

    A uniform of zero width is a fixed offset: U_c stays an exact normal.

    >>> uc = edmf_rs.combine(model=[stats.norm(0, 0.3), stats.uniform(0.5, 0)], measurement=stats.norm(0, 0.4),
    ...                      n_sensors=3)
    >>> uc.exact, uc.mean.tolist(), uc.std.round(3).tolist()
    (True, [0.5, 0.5, 0.5], [0.5, 0.5, 0.5])
    """
    seed = check_seed(seed, generator=True)
    sources = []
    for sign, group, name in ((1.0, model, "model"), (-1.0, measurement, "measurement")):
        if intervals.is_frozen(group):
            group = [group]
        elif isinstance(group, (list, tuple)):
            group = list(group)
        else:
            raise TypeError(
                f"{name}: expected a frozen scipy.stats continuous distribution or a list of sources, "
                f"got {type(group).__name__}"
            )
        for k, src in enumerate(group):
            per_sensor, dist, n = _source_dists(src, f"{name}[{k}]")
            sources.append((sign, per_sensor, dist, n, f"{name}[{k}]"))
    if not sources:
        raise ValueError("model, measurement: expected at least one uncertainty source")
    sizes = {n for *_, n, _ in sources if n is not None}
    if n_sensors is not None:
        sizes.add(positive_int(n_sensors, "n_sensors"))
    if len(sizes) > 1:
        detail = ", ".join(f"{nm}: {n}" for *_, n, nm in sources if n is not None)
        raise ValueError(f"model, measurement: sources disagree on the number of sensors ({detail})")
    if not sizes:
        raise ValueError("n_sensors: every source is scalar, so give n_sensors")
    n_m = sizes.pop()
    n_samples = _check_sources(sources, n_m, n_samples, "n_sensors" if n_sensors is not None else "n_samples")
    for group in ("model", "measurement"):
        scalar = [nm for _, per, _, n, nm in sources if nm.startswith(group + "[") and per is None and n is None]
        if len(scalar) >= 2 and len(scalar) == n_m:
            warnings.warn(
                f"{group}: {len(scalar)} scalar sources, each applied to every sensor and summed; a list "
                f"with one distribution per sensor must be nested, e.g. {group}=[[d1, d2, ...]]",
                stacklevel=2,
            )

    # Sources of scale 0 are fixed offsets, and choose no method (see `offsets`).
    offset, spread_sources = offsets.whole_offsets(sources, n_m)

    if all(s[2] is not None and s[2].dist.name == "norm" for s in spread_sources):
        # Every source a (vectorised) normal: sum the moments as arrays, no per-sensor objects.
        mean, var = offset.copy(), np.zeros(n_m)
        for sign, _, dist, _, name in spread_sources:
            loc, scale = _normal_parameters(dist, n_m)
            mean += sign * loc
            var += scale**2
        if not np.all(var > 0):
            i = int(np.flatnonzero(~(var > 0))[0])
            raise ValueError(f"model, measurement: the combined standard deviation is zero at sensor {i}")
        return CombinedUncertainty(n_m, distribution=stats.norm(loc=mean, scale=np.sqrt(var)),
                                   seed=_seed_record(seed), gaussian=np.ones(n_m, dtype=bool),
                                   symmetric=np.ones(n_m, dtype=bool))
    shift, active = offsets.per_sensor(spread_sources, offset, n_m)
    normal = [all(d.dist.name == "norm" for _, d in a) for a in active]
    if all(normal):
        mean, sd = _normal_sum(active, shift, range(n_m))
        return CombinedUncertainty(n_m, distribution=stats.norm(loc=mean, scale=sd), seed=_seed_record(seed),
                                   gaussian=np.ones(n_m, dtype=bool), symmetric=np.ones(n_m, dtype=bool))

    marginals = []
    for j in range(n_m):
        if normal[j]:
            mean, sd = _normal_sum(active, shift, [j])
            marginals.append((1.0, stats.norm(mean[0], sd[0])))
        elif len(active[j]) == 1:
            marginals.append(offsets.fold(active[j], shift[j])[0])
        else:
            marginals.append(None)
    symmetric = np.array([all(intervals.is_symmetric(d) for _, d in a) for a in active])
    rng = np.random.default_rng(seed)
    samples = np.zeros((n_samples, n_m))
    for sign, group, dist, _, name in spread_sources:
        if dist is not None:
            draws = dist.rvs(size=(n_samples, n_m), random_state=rng)
        else:
            draws = np.column_stack([d.rvs(size=n_samples, random_state=rng) for d in group])
        if not np.all(np.isfinite(draws)):
            raise ValueError(f"{name}: its distribution gave non-finite samples (check its parameters)")
        if sign > 0:  # in place: no third array of n_samples x n_m
            samples += draws
        else:
            samples -= draws
    samples += offset  # entries of scale 0 inside the sources drawn were drawn as their loc
    per_sensor_sources = tuple(offsets.fold(a, shift[j]) for j, a in enumerate(active))
    return CombinedUncertainty(n_m, samples=samples, marginals=tuple(marginals), symmetric=symmetric,
                               gaussian=np.array(normal), seed=_seed_record(seed), sources=per_sensor_sources)


def _check_sources(sources, n_m: int, n_samples, size_name: str):
    """Refuses, up front, parameters scipy would turn into NaN, a sensor whose
    every source has scale 0, and sizes past this machine's memory
    (n_sensors = 10**12 once swapped for hours). Returns n_samples, checked
    when Monte Carlo samples are drawn (some source not normal and not of scale 0, a fixed offset)."""
    sampled = any(d.dist.name != "norm" and np.any(offsets.loc_scale(d)[1] != 0)
                  for _, per, dist, _, _ in sources for d in (per or [dist]))
    if sampled:
        n_samples = positive_int(n_samples, "n_samples")
        fits_in_memory(16 * n_samples * n_m, size_name, f"{n_samples:,} Monte Carlo samples at {n_m:,} sensors "
                       f"are drawn as 2 x {n_samples:,} x {n_m:,} values", "fewer sensors or a smaller n_samples")
    else:
        fits_in_memory(64 * n_m, size_name, f"U_c at {n_m:,} sensors takes 8 x {n_m:,} values", "fewer sensors")
    spread = np.zeros(n_m, dtype=bool)
    for _, per_sensor, dist, _, name in sources:  # a scale of 0 is a fixed offset
        for j, d in enumerate(per_sensor or ()):
            spread[j] |= intervals.check_parameters(d, name, sensor=j, zero_scale=True)[0] > 0
        if dist is not None:
            spread |= intervals.check_parameters(dist, name, n_m, zero_scale=True) > 0
    if not spread.all():  # U_c constant there: zero-width thresholds would falsify every instance
        i = int(np.flatnonzero(~spread)[0])
        raise ValueError(f"model, measurement: the combined standard deviation is zero at sensor {i}")
    return n_samples


def _seed_record(seed):
    """The seed as recorded on the result: an int, None for a Generator."""
    if seed is None or isinstance(seed, (np.random.Generator, np.random.BitGenerator, np.random.SeedSequence)):
        return None
    return seed


def _normal_sum(active, shift, sensors) -> tuple[np.ndarray, np.ndarray]:
    """Mean and sd of ``shift`` + sum(model) - sum(measurement) at ``sensors``, every
    source in ``active`` (per sensor, its ``(sign, normal)`` sources) normal."""
    sensors = list(sensors)
    mean = np.array([shift[j] for j in sensors], dtype=float)
    var = np.zeros(len(sensors))
    for k, j in enumerate(sensors):
        for sign, d in active[j]:
            loc, scale = _normal_parameters(d)
            mean[k] += sign * loc
            var[k] += scale**2
    if not np.all(var > 0):
        i = sensors[int(np.flatnonzero(~(var > 0))[0])]
        raise ValueError(f"model, measurement: the combined standard deviation is zero at sensor {i}")
    return mean, np.sqrt(var)


def _normal_parameters(dist, n: int | None = None):
    """(loc, scale) of a frozen normal, as floats, or as arrays of length n for one
    vectorised over the sensors; scale 0 (a fixed offset) is allowed, which
    scipy's own mean()/var() report as NaN."""
    args = dict(zip(("loc", "scale"), dist.args))
    args.update(dist.kwds)
    loc, scale = np.asarray(args.get("loc", 0.0), dtype=float), np.asarray(args.get("scale", 1.0), dtype=float)
    if not (np.all(np.isfinite(loc)) and np.all(np.isfinite(scale)) and np.all(scale >= 0)):
        raise ValueError(f"model, measurement: a normal source needs a finite mean and sd >= 0, got {loc}, {scale}")
    if n is None:
        return float(loc), float(scale)
    return np.broadcast_to(loc, (n,)), np.broadcast_to(scale, (n,))


#: Shorthand families and their parameters (besides any scipy.stats name with its own parameters).
def relative_to_measured(fraction, measured):
    """A source expressed as a fraction of each sensor's measured value.

    The error at sensor i is ``fraction * y_i``, with the sign of ``y_i``: for
    a negative reading the distribution is mirrored, so a model error of mean
    -10 % is an underestimated magnitude for readings of either sign. This
    keeps the family only when it is symmetric, so asymmetric families need
    positive measurements. Pass ``numpy.abs(y)`` for fractions of the
    magnitude instead (see the documentation's porting page).

    Parameters
    ----------
    fraction : scipy.stats frozen distribution
        A scalar frozen distribution of the fraction, e.g.
        ``scipy.stats.norm(-0.10, 0.15)`` for the paper's model uncertainty
        "mean -10 % of the measured value, 15 % standard deviation".
    measured : array_like
        The measured values y, one per sensor, finite.

    Returns
    -------
    scipy.stats frozen distribution
        The distribution of ``fraction * y``, of the same family, vectorised
        over the sensors; a source for `combine`.

    Raises
    ------
    TypeError
        If ``fraction`` is not a scalar frozen ``scipy.stats`` distribution.
    ValueError
        If ``measured`` is not a finite 1-D vector, or a measured value is
        <= 0 while the family is not symmetric (e.g. lognormal).

    Examples
    --------
    >>> from scipy import stats
    >>> import edmf_rs
    >>> d = edmf_rs.relative_to_measured(stats.norm(-0.10, 0.15), [4.0, -5.0])
    >>> d.mean().round(6).tolist(), d.std().round(6).tolist()
    ([-0.4, 0.5], [0.6, 0.75])
    """
    if not intervals.is_frozen(fraction) or intervals.batch_shape(fraction) != ():
        raise TypeError("fraction: expected a scalar frozen scipy.stats distribution")
    y = finite_vector(measured, "measured")
    family = fraction.dist
    shapes = fraction.args[: family.numargs]
    rest = fraction.args[family.numargs:]
    loc = fraction.kwds.get("loc", rest[0] if len(rest) > 0 else 0.0)
    scale = fraction.kwds.get("scale", rest[1] if len(rest) > 1 else 1.0)
    shape_kwds = {k: v for k, v in fraction.kwds.items() if k not in ("loc", "scale")}
    if not intervals.is_symmetric(fraction):
        if np.any(y <= 0):
            raise ValueError(
                f"measured: a {family.name} fraction needs positive measured values "
                "(only symmetric families stay in their family when y < 0)"
            )
        return family(*shapes, loc=loc * y, scale=scale * y, **shape_kwds)
    # y*X for X symmetric about c: y*c + |y|*(X - c); the standard form's centre is c0.
    c0 = float(family(*shapes, **shape_kwds).median())
    centre = loc + scale * c0
    return family(*shapes, loc=y * centre - np.abs(y) * scale * c0, scale=np.abs(y) * scale, **shape_kwds)
