"""Shortest intervals of frozen ``scipy.stats`` distributions (Eqs. 5 and 6).

Symmetric unimodal distributions use the central interval of Eq. 6 through
``ppf``. Any other continuous distribution gets its shortest interval by
minimising ``ppf(a + p) - ppf(a)`` over the lower tail mass ``a``.
"""

from __future__ import annotations

import numpy as np
from scipy import optimize, stats

#: Families whose every member is symmetric and unimodal, so Eq. 6 is exact.
SYMMETRIC_UNIMODAL = frozenset(
    {"norm", "t", "cauchy", "logistic", "laplace", "uniform", "hypsecant",
     "cosine", "gennorm", "semicircular"}
)


def is_frozen(obj) -> bool:
    """True for a frozen continuous scipy.stats distribution."""
    return isinstance(getattr(obj, "dist", None), stats.rv_continuous) and hasattr(obj, "ppf")


def batch_shape(dist) -> tuple[int, ...]:
    """Shape a frozen distribution is vectorised over (() for a scalar one)."""
    return np.broadcast(*dist.args, *dist.kwds.values()).shape if (dist.args or dist.kwds) else ()


def split(dist, n: int) -> list:
    """Per-sensor frozen distributions of a scalar or vectorised one."""
    args = [np.broadcast_to(a, (n,)) for a in dist.args]
    kwds = {k: np.broadcast_to(v, (n,)) for k, v in dist.kwds.items()}
    return [dist.dist(*(a[i] for a in args), **{k: v[i] for k, v in kwds.items()}) for i in range(n)]


def check_parameters(dist, name: str, n: int | None = None, *, sensor: int = 0,
                     zero_scale: bool = False) -> np.ndarray:
    """Refuses, naming ``name`` and the sensor, parameters scipy would turn
    into NaN quantiles without a word: a non-finite location or scale, a
    scale <= 0 (a normal's sd, a uniform's width; 0 allowed with
    ``zero_scale``, a fixed offset when drawing samples) or shape parameters
    outside the family's domain. ``dist`` is vectorised over ``n`` sensors,
    or scalar and at ``sensor``. Returns the scale per sensor (n, or 1)."""
    family = dist.dist.name
    shapes, loc, scale = dist.dist._parse_args(*dist.args, **dist.kwds)
    size = (n or 1,)
    loc, scale = (np.broadcast_to(np.asarray(v, dtype=float), size) for v in (loc, scale))
    shapes = [np.broadcast_to(np.asarray(a, dtype=float), size) for a in shapes]
    spread = (scale >= 0) if zero_scale else (scale > 0)
    checks = [("a finite location", ~np.isfinite(loc), lambda i: f"loc={loc[i]}"),
              (f"a finite scale {'>=' if zero_scale else '>'} 0", ~(np.isfinite(scale) & spread),
               lambda i: f"scale={scale[i]}")]
    if shapes:
        checks.append((f"shape parameters valid for scipy.stats.{family}",
                       ~np.broadcast_to(dist.dist._argcheck(*shapes), size),
                       lambda i: "shape parameters " + ", ".join(str(a[i]) for a in shapes)))
    for expected, bad, got in checks:
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(f"{name}: expected {expected}, got {got(i)} at sensor {i if n else sensor} ({family})")
    return scale


def is_symmetric(dist) -> bool:
    """True when a scalar frozen distribution is symmetric about its median:
    every member of a symmetric family, else ``ppf(q) + ppf(1 - q) = 2 median``
    checked at several q (e.g. a triangular with its mode midway, a normal
    truncated symmetrically about its mean).

    Examples
    --------
    >>> is_symmetric(stats.triang(0.5)), is_symmetric(stats.triang(0.2)), is_symmetric(stats.lognorm(0.3))
    (True, False, False)
    """
    if dist.dist.name in SYMMETRIC_UNIMODAL:
        return True
    q = np.array([1e-4, 1e-3, 0.01, 0.05, 0.1, 0.2, 0.3, 0.4])
    lo, hi, mid = dist.ppf(q), dist.ppf(1.0 - q), dist.ppf(0.5)
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.isfinite(mid)):
        return False
    return bool(np.all(np.abs(lo + hi - 2.0 * mid) <= 1e-9 * np.maximum(hi - lo, 1e-300)))


def shortest_interval(dist, probability: float) -> tuple[float, float]:
    """Shortest interval holding ``probability`` of a scalar frozen distribution."""
    if dist.dist.name in SYMMETRIC_UNIMODAL:
        tail = 0.5 * (1.0 - probability)  # Eq. 6
        return float(dist.ppf(tail)), float(dist.isf(tail))  # isf: 1 - tail would round a small tail

    # The upper bound through isf of the upper tail mass 1 - p - a (1 - p is exact for p >= 1/2):
    # ppf(a + p) loses the digits of a small upper tail when p is close to 1.
    span = 1.0 - probability

    def width(a: float) -> float:
        w = dist.isf(span - a) - dist.ppf(a)
        return float(w) if np.isfinite(w) else np.inf

    # A coarse scan guards against local minima; Brent's method then refines.
    grid = np.linspace(0.0, span, 201)[1:-1]
    widths = np.array([width(a) for a in grid])
    k = int(np.argmin(widths))
    lo = grid[k - 1] if k > 0 else 0.0
    hi = grid[k + 1] if k + 1 < grid.size else span
    best = optimize.minimize_scalar(width, bounds=(lo, hi), method="bounded",
                                    options={"xatol": 1e-12 * max(span, 1e-300)})  # relative to the tail mass
    a = best.x if best.fun <= widths[k] else grid[k]
    return float(dist.ppf(a)), float(dist.isf(span - a))


def shortest_intervals(dists, probability: float) -> tuple[np.ndarray, np.ndarray]:
    """Bounds for a list of scalar frozen distributions, one per sensor."""
    bounds = np.array([shortest_interval(d, probability) for d in dists], dtype=np.float64)
    return bounds[:, 0].copy(), bounds[:, 1].copy()
