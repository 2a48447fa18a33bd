"""Emulator screening (issue 16, step 3): which points could still be candidates.

A point x is kept while, at every sensor i,
``T_low,i - c sigma_i(x) <= mu_i(x) - y_i <= T_high,i + c sigma_i(x)``:
Eq. 8 on the emulator's mean, with the thresholds widened by ``c`` of its
standard deviations. With sigma = 0 this is Eq. 8 itself, bit for bit.
The Rust core does it in parallel with the GIL released; :func:`screen_reference`
is the NumPy oracle it is tested against.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from .. import _core
from ..engine._validate import finite_vector
from ..engine.thresholds import Thresholds


def _matrix(values, name: str) -> np.ndarray:
    try:
        arr = np.asarray(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name}: expected an (N, n_m) array of numbers ({exc})") from None
    if arr.ndim != 2:
        raise ValueError(f"{name}: expected an (N, n_m) array, got shape {arr.shape}")
    if any(s < 0 for s in arr.strides) or not arr.flags.aligned:
        arr = np.ascontiguousarray(arr)
    return arr


def _margin(c) -> float:
    if isinstance(c, bool) or not isinstance(c, numbers.Real) or not math.isfinite(c) or c < 0:
        raise ValueError(f"c: expected a finite number >= 0 (standard deviations of margin), got {c!r}")
    return float(c)


def screen(mu, sigma, measurements, thresholds: Thresholds, c: float = 3.0) -> tuple[np.ndarray, list[int]]:
    """Indices of the points the emulator cannot yet falsify, and the sensor order used.

    Parameters
    ----------
    mu, sigma
        Emulator mean and standard deviation, shape (N, n_m): one row per
        point, one column per sensor. ``sigma >= 0``; a NaN keeps no point.
    measurements
        Measured values y (n_m).
    thresholds
        Threshold bounds on the residual (:class:`edmf_rs.Thresholds`).
    c
        Margin in standard deviations (3 by default).

    Returns
    -------
    kept : ndarray of int64
        Ascending indices of the kept rows.
    order : list of int
        The sensors in the order visited (most rejecting first); it never
        changes the verdict.

    Raises
    ------
    ValueError
        Shapes that differ, a negative sigma, a negative or non-finite c.

    Examples
    --------
    >>> import numpy as np, edmf_rs
    >>> from edmf_rs.adaptive.screen import screen
    >>> t = edmf_rs.Thresholds([-1.0], [1.0])
    >>> screen(np.array([[0.5], [2.5], [4.0]]), np.array([[0.0], [0.5], [0.5]]), [0.0], t)[0]
    array([0, 1])
    """
    if not isinstance(thresholds, Thresholds):
        raise TypeError(f"thresholds: expected edmf_rs.Thresholds, got {type(thresholds).__name__}")
    y = finite_vector(measurements, "measurements", n=thresholds.n_sensors)
    mu, sigma = _matrix(mu, "mu"), _matrix(sigma, "sigma")
    if mu.shape[1] != thresholds.n_sensors:
        raise ValueError(f"mu: expected {thresholds.n_sensors} columns (one per sensor), got {mu.shape[1]}")
    if sigma.shape != mu.shape:
        raise ValueError(f"sigma: expected the shape of mu {mu.shape}, got {sigma.shape}")
    kept, order = _core.screen_emulator(mu, sigma, np.ascontiguousarray(y), thresholds.low, thresholds.high,
                                        _margin(c))
    return kept.view(np.int64), list(order)


def screen_reference(mu, sigma, measurements, thresholds: Thresholds, c: float = 3.0) -> np.ndarray:
    """The screening rule in plain NumPy, every sensor of every point (the oracle).

    A point is kept when, at every sensor, ``T_low - c sigma <= mu - y <= T_high + c sigma``.

    Parameters
    ----------
    mu, sigma : array_like, shape (N, n_m)
        The emulators' predictive means and standard deviations.
    measurements : array_like, shape (n_m,)
        y.
    thresholds : Thresholds
        The threshold bounds (Eqs. 5-6).
    c : float, default 3.0
        Margin in predictive standard deviations.

    Returns
    -------
    numpy.ndarray of int64
        Indices of the points kept.

    Raises
    ------
    ValueError
        If the shapes do not broadcast.

    Examples
    --------
    >>> import numpy as np, edmf_rs
    >>> t = edmf_rs.Thresholds([-1.0], [1.0])
    >>> screen_reference(np.array([[0.5], [2.5]]), np.array([[0.0], [0.4]]), [0.0], t)
    array([0])
    """
    mu, sigma = np.asarray(mu, dtype=np.float64), np.asarray(sigma, dtype=np.float64)
    y = np.asarray(measurements, dtype=np.float64)
    r = mu - y  # Eq. 14
    margin = c * sigma
    inside = (r >= thresholds.low - margin) & (r <= thresholds.high + margin)
    return np.flatnonzero(inside.all(axis=1)).astype(np.int64)


def required_margin(mu: np.ndarray, sigma: np.ndarray, measurements: np.ndarray,
                    thresholds: Thresholds) -> np.ndarray:
    """Per point, the smallest c that would keep it: how far the emulator
    places it outside the thresholds, in its own standard deviations (0 when
    its mean passes Eq. 8; inf when it fails with sigma = 0)."""
    r = mu - measurements
    excess = np.maximum(thresholds.low - r, r - thresholds.high)
    with np.errstate(divide="ignore", invalid="ignore"):
        need = np.where(excess <= 0, 0.0, excess / sigma)
    need = np.where(np.isnan(need), np.inf, need)
    return need.max(axis=1)
