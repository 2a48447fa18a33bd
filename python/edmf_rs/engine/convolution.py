"""Combined uncertainty by numerical convolution, and its threshold bounds (Eqs. 4-6).

U_c = sum(model sources) - sum(measurement sources), the sources independent
at a sensor (Eq. 4), so the density of U_c is the convolution of the
sources' densities (measurement sources mirrored). When every source is a
known continuous distribution this is computed on a fine grid instead of
drawn by Monte Carlo:

- each signed source is discretised on a grid of step h by the *cell masses*
  ``F(x + h/2) - F(x - h/2)`` (cdf differences, so uniform and triangular
  edges are exact to grid resolution; no pdf sample is taken);
- the cell masses of all sources are convolved (``scipy.signal.fftconvolve``);
- the cdf of U_c at the cell edges is their running sum, linear in between;
- Eq. 5's shortest interval of probability p is found over every grid
  window and refined by solving ``f(low) = f(high)`` (the condition for a
  shortest interval of a unimodal density); symmetric U_c takes the central
  interval of Eq. 6.

The bounds' numerical error is measured by halving the step: the grid is
refined until the bounds move by less than ``TOLERANCE`` of the width (or
``MAX_CELLS`` is reached); the last change is reported as the bound's
standard error and each bound is moved outward by it, so the interval holds
at least p. Sensors are computed together, in chunks, as 2-D arrays.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

#: Target numerical error of each bound, as a fraction of the interval's width.
TOLERANCE = 1e-4
#: Grid cells across the support of U_c at the first level (doubled until converged).
START_CELLS = 2048
#: Most grid cells across the support of U_c; past this the error is reported, not reduced.
MAX_CELLS = 2**17
#: Tail mass left out of each source's support.
TAIL = 1e-12
#: Widest support of a source, in interquartile ranges, that a grid can resolve.
MAX_SPAN_IQR = 2000.0
_CHUNK_CELLS = 2**21


@dataclass(frozen=True)
class ConvolutionBounds:
    """Per-sensor bounds of U_c from numerical convolution.

    Attributes
    ----------
    low, high : numpy.ndarray
        The bounds, each moved outward by its numerical error.
    error : numpy.ndarray
        Numerical error of each bound: its change when the grid step was last halved.
    cells : numpy.ndarray of int
        Grid cells across each sensor's support at the finest level used.

    Examples
    --------
    >>> from scipy import stats
    >>> b = shortest_bounds([((1.0, stats.norm(0, 1)), (-1.0, stats.norm(0, 1)))], 0.95)
    >>> round(float(b.high[0]), 4), bool(b.error[0] < 1e-4 * (b.high[0] - b.low[0]))
    (2.7718, True)
    """

    low: np.ndarray
    high: np.ndarray
    error: np.ndarray
    cells: np.ndarray


def _support(sign: float, dist) -> tuple[float, float] | None:
    """Support of ``sign * X`` with TAIL mass left out at each end, or None if unusable."""
    with np.errstate(all="ignore"):
        lo, hi = float(dist.ppf(TAIL)), float(dist.isf(TAIL))
        q1, q3 = float(dist.ppf(0.25)), float(dist.ppf(0.75))
    if not all(np.isfinite([lo, hi, q1, q3])) or not hi > lo or not q3 > q1:
        return None
    if hi - lo > MAX_SPAN_IQR * (q3 - q1):
        return None  # tails too heavy for one grid to resolve both bulk and tail
    return (lo, hi) if sign > 0 else (-hi, -lo)


def _group_supports(g):
    """(supports (sensors, sources, 2), usable (sensors,)) of a group, every source at once."""
    n = len(g["sensors"])
    sup = np.empty((n, len(g["kinds"]), 2))
    ok = np.ones(n, dtype=bool)
    for k, (family, sign) in enumerate(g["kinds"]):
        args = [*g["shapes"][k]]
        with np.errstate(all="ignore"):
            q = family.ppf(np.array([TAIL, 0.25, 0.75])[:, None], *args, loc=g["loc"][k], scale=g["scale"][k])
            hi = family.isf(TAIL, *args, loc=g["loc"][k], scale=g["scale"][k])
        lo, q1, q3 = q
        ok &= np.isfinite(lo) & np.isfinite(hi) & np.isfinite(q1) & np.isfinite(q3) & (hi > lo) & (q3 > q1)
        ok &= hi - lo <= MAX_SPAN_IQR * (q3 - q1)  # tails too heavy for one grid: bulk and tail
        sup[:, k] = np.column_stack([lo, hi] if sign > 0 else [-hi, -lo])
    return sup, ok


def usable(sensor_sources) -> np.ndarray:
    """Per sensor, whether `convolvable` holds, computed a group of sensors at a time.

    Parameters
    ----------
    sensor_sources : sequence
        Per sensor, a non-empty sequence of ``(sign, frozen scalar distribution)``.

    Returns
    -------
    numpy.ndarray of bool
        One entry per sensor.

    Raises
    ------
    ValueError
        If a sensor has no source.

    Examples
    --------
    >>> from scipy import stats
    >>> usable([[(1.0, stats.norm())], [(1.0, stats.cauchy())]]).tolist()
    [True, False]
    """
    out = np.zeros(len(sensor_sources), dtype=bool)
    for g in _groups(sensor_sources):
        out[g["sensors"]] = _group_supports(g)[1]
    return out


def convolvable(sources) -> bool:
    """Whether one sensor's sources ``[(sign, frozen distribution), ...]`` can be convolved:
    every source has a finite support after cutting TAIL off each end, not too wide
    for its interquartile range, and a cdf.

    Parameters
    ----------
    sources : sequence of (float, frozen scipy.stats distribution)
        One sensor's signed sources (Eq. 4).

    Returns
    -------
    bool

    Examples
    --------
    >>> from scipy import stats
    >>> convolvable([(1.0, stats.lognorm(0.5)), (-1.0, stats.uniform(-1, 2))]), convolvable([(1.0, stats.cauchy())])
    (True, False)
    """
    return bool(sources) and all(_support(s, d) is not None for s, d in sources)


def _params(dist):
    """(family, shape args, loc, scale) of a scalar frozen distribution."""
    shapes, loc, scale = dist.dist._parse_args(*dist.args, **dist.kwds)
    return dist.dist, tuple(float(a) for a in shapes), float(loc), float(scale)


def _cell_masses(family, shapes, loc, scale, sign, edges):
    """Mass of ``sign * X`` in each cell between consecutive ``edges`` (rows: sensors)."""
    args = [np.asarray(a)[:, None] for a in shapes]
    x = edges if sign > 0 else -edges[:, ::-1]
    with np.errstate(all="ignore"):
        cdf = family.cdf(x, *args, loc=loc[:, None], scale=scale[:, None])
    mass = np.clip(np.diff(cdf, axis=1), 0.0, None)
    return mass if sign > 0 else mass[:, ::-1]


def _level(group, supports, n_cells: int, p: float, symmetric: np.ndarray):
    """Bounds of a group of sensors (same families and signs) on grids of ``n_cells`` cells."""
    n_m = supports.shape[0]
    lo_total = supports[:, :, 0].sum(axis=1)
    span = supports[:, :, 1].sum(axis=1) - lo_total
    h = span / n_cells
    pmf, start = None, np.zeros(n_m)
    for k, (family, sign) in enumerate(group["kinds"]):
        lo_k = supports[:, k, 0]
        n_k = int(np.ceil(np.max((supports[:, k, 1] - lo_k) / h))) + 1
        edges = lo_k[:, None] + h[:, None] * (np.arange(n_k + 1) - 0.5)[None, :]
        mass = _cell_masses(family, group["shapes"][k], group["loc"][k], group["scale"][k], sign, edges)
        start += lo_k
        pmf = mass if pmf is None else signal.fftconvolve(pmf, mass, axes=1)
    pmf = np.clip(pmf, 0.0, None)
    cdf = np.cumsum(pmf, axis=1)
    cdf /= cdf[:, -1:]
    m = pmf.shape[1]
    # node i sits at start + i h; its cell's right edge at start + (i + 1/2) h
    edges = start[:, None] + h[:, None] * (np.arange(-1, m) + 0.5)[None, :]
    cdf = np.concatenate([np.zeros((n_m, 1)), cdf], axis=1)
    density = pmf / h[:, None]
    nodes = start[:, None] + h[:, None] * np.arange(m)[None, :]
    return _intervals(edges, cdf, nodes, density, p, symmetric)


class _Batch:
    """np.interp over rows at once: each row is offset so the rows form one increasing table."""

    def __init__(self, xp, fp):
        n, m = xp.shape
        self.shift = (np.arange(n) * (np.nanmax(xp[:, -1] - xp[:, 0]) + 1.0) - xp[:, 0])[:, None]
        self.xp, self.fp = (xp + self.shift).ravel(), fp.ravel()

    def __call__(self, x):
        return np.interp(x + self.shift, self.xp, self.fp)


def _intervals(edges, cdf, nodes, density, p, symmetric):
    quantile = _Batch(cdf, edges)
    low, high = np.empty(cdf.shape[0]), np.empty(cdf.shape[0])
    tail = 0.5 * (1.0 - p)
    central = np.flatnonzero(symmetric)
    if central.size:
        low[central] = quantile(np.full((cdf.shape[0], 1), tail))[central, 0]
        high[central] = quantile(np.full((cdf.shape[0], 1), 1.0 - tail))[central, 0]
    rest = np.flatnonzero(~symmetric)
    if rest.size:
        low[rest], high[rest] = _shortest(edges[rest], cdf[rest], nodes[rest], density[rest], p)
    return low, high


def _shortest(edges, cdf, nodes, density, p):
    """Shortest windows: every lower edge with its upper quantile, then f(low) = f(high) refined."""
    quantile = _Batch(cdf, edges)
    pdf = _Batch(nodes, density)
    alpha = np.where(cdf <= 1.0 - p, cdf, np.nan)
    width = quantile(np.minimum(alpha + p, 1.0)) - edges
    width[np.isnan(alpha)] = np.inf
    # A flat-topped U_c (e.g. a narrow source plus a wide uniform) has a whole range of shortest windows:
    # take the most central of them (closest to equal tails), so that the bounds found on successive
    # grids agree and the convergence error measures accuracy, not an arbitrary choice among equals.
    near = width <= np.min(width, axis=1, keepdims=True) * (1.0 + 1e-9)
    best = np.argmin(np.where(near, np.abs(alpha - 0.5 * (1.0 - p)), np.inf), axis=1)
    rows = np.arange(cdf.shape[0])
    last = np.maximum(np.sum(np.isfinite(width), axis=1) - 1, 0)
    a_lo = cdf[rows, np.maximum(best - 2, 0)]
    a_hi = cdf[rows, np.minimum(best + 2, last)]
    a_best = cdf[rows, best]

    def gap(a):  # f(high) - f(low): positive before the shortest window, negative after
        a = a[:, None]
        return (pdf(quantile(a + p)) - pdf(quantile(a)))[:, 0]

    ok = (gap(a_lo) >= 0) & (gap(a_hi) <= 0)
    lo, hi = a_lo.copy(), a_hi.copy()
    for _ in range(60):  # bisection, all sensors at once
        mid = 0.5 * (lo + hi)
        up = gap(mid) > 0
        lo, hi = np.where(up, mid, lo), np.where(up, hi, mid)
    a = np.where(ok, 0.5 * (lo + hi), a_best)[:, None]
    low, high = quantile(a)[:, 0], quantile(a + p)[:, 0]
    # a flat density (f(low) = f(high) over a range) can mislead the refinement: keep the best
    # grid window, exact for the piecewise-linear cdf, where the refined one is clearly wider
    worse = (high - low) > width[rows, best] * (1.0 + TOLERANCE)
    low[worse] = edges[rows, best][worse]
    high[worse] = low[worse] + width[rows, best][worse]
    return low, high


def _groups(sensor_sources):
    """Sensors grouped by their sources' families and signs, parameters stacked per group."""
    groups: dict = {}
    for j, sources in enumerate(sensor_sources):
        if not sources:
            raise ValueError(f"combined: sensor {j} has no source to convolve")
        params = [(s, *_params(d)) for s, d in sources]
        key = tuple((fam.name, s, len(sh)) for s, fam, sh, _, _ in params)
        g = groups.setdefault(key, {"kinds": [(fam, s) for s, fam, *_ in params], "sensors": [], "p": []})
        g["sensors"].append(j)
        g["p"].append(params)
    for g in groups.values():
        k_sources = len(g["kinds"])
        g["shapes"] = [list(zip(*[row[k][2] for row in g["p"]])) for k in range(k_sources)]
        g["shapes"] = [[np.array(a) for a in sh] for sh in g["shapes"]]
        g["loc"] = [np.array([row[k][3] for row in g["p"]]) for k in range(k_sources)]
        g["scale"] = [np.array([row[k][4] for row in g["p"]]) for k in range(k_sources)]
    return list(groups.values())


def shortest_bounds(sensor_sources, probability: float, symmetric=None) -> ConvolutionBounds:
    """Threshold bounds of U_c per sensor by numerical convolution of its sources (Eqs. 4-6).

    Parameters
    ----------
    sensor_sources : sequence
        Per sensor, a sequence of ``(sign, frozen scalar scipy.stats distribution)``:
        sign +1 for a model source, -1 for a measurement source (Eq. 4).
        Every sensor must pass `convolvable`.
    probability : float
        Per-sensor probability p in (0, 1).
    symmetric : array_like of bool, optional
        Sensors whose U_c is symmetric about its mean: the central interval
        (Eq. 6) instead of the shortest (default: none).

    Returns
    -------
    ConvolutionBounds

    Raises
    ------
    ValueError
        If a sensor's sources cannot be convolved (see `convolvable`).

    Examples
    --------
    >>> from scipy import stats
    >>> b = shortest_bounds([((1.0, stats.norm(0, 1)), (-1.0, stats.uniform(-2, 4)))], 0.99, symmetric=[True])
    >>> round(float(b.low[0]), 3), round(float(b.high[0]), 3)
    (-3.663, 3.663)
    """
    n_m = len(sensor_sources)
    symmetric = np.zeros(n_m, dtype=bool) if symmetric is None else np.asarray(symmetric, dtype=bool)
    low, high, error = np.empty(n_m), np.empty(n_m), np.empty(n_m)
    cells = np.zeros(n_m, dtype=np.int64)
    for g in _groups(sensor_sources):
        idx = np.array(g["sensors"])
        sup, ok = _group_supports(g)  # (sensors, sources, 2)
        if not ok.all():
            raise ValueError(f"combined: the sources at sensor {idx[~ok][0]} cannot be convolved on a grid "
                             "(a source without finite quantiles, or with tails too heavy)")
        lo, hi, err, n = _converge(g, sup, probability, symmetric[idx])
        low[idx], high[idx], error[idx], cells[idx] = lo, hi, err, n
    return ConvolutionBounds(low - error, high + error, error, cells)


def _subgroup(g, rows):
    return {"kinds": g["kinds"], "shapes": [[a[rows] for a in sh] for sh in g["shapes"]],
            "loc": [x[rows] for x in g["loc"]], "scale": [x[rows] for x in g["scale"]]}


def _converge(group, supports, p, symmetric):
    """Halve the step until each bound moves by less than TOLERANCE of the width."""
    n_m = supports.shape[0]
    n = START_CELLS
    low, high = _chunked(group, supports, np.arange(n_m), n, p, symmetric)
    error = np.full(n_m, np.inf)
    cells = np.full(n_m, n)
    todo = np.arange(n_m)
    while todo.size and n < MAX_CELLS:
        n *= 2
        lo, hi = _chunked(group, supports, todo, n, p, symmetric)
        err = np.maximum(np.abs(lo - low[todo]), np.abs(hi - high[todo]))
        low[todo], high[todo], error[todo], cells[todo] = lo, hi, err, n
        todo = todo[err > TOLERANCE * (hi - lo)]
    return low, high, error, cells


def _chunked(group, supports, rows, n, p, symmetric):
    """_level over ``rows`` in chunks of about _CHUNK_CELLS grid cells (bounded memory)."""
    low, high = np.empty(rows.size), np.empty(rows.size)
    step = max(1, _CHUNK_CELLS // (2 * n))
    for s in range(0, rows.size, step):
        r = rows[s:s + step]
        low[s:s + step], high[s:s + step] = _level(_subgroup(group, r), supports[r], n, p, symmetric[r])
    return low, high
