"""Instances whose verdict rests on the Monte Carlo noise of the threshold bounds.

A bound estimated from samples is known to within its standard error (SE).
An instance is *borderline* when it is a candidate with every bound widened
by ``k`` SE but falsified with every bound narrowed by ``k`` SE (the narrowed
candidates are a subset of the widened ones, so this is their symmetric
difference): another seed, or more samples, could change its verdict.
Exact bounds (SE 0) make no instance borderline.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from ._validate import finite_vector, real_array
from .thresholds import Thresholds


def _checked_k(k) -> float:
    """``k``: a finite number of standard errors >= 0."""
    if isinstance(k, (bool, np.bool_)) or not isinstance(k, numbers.Real):
        raise TypeError(f"k: expected a number of standard errors >= 0, got {type(k).__name__}")
    k = float(k)
    if not (math.isfinite(k) and k >= 0):
        raise ValueError(f"k: expected a finite number of standard errors >= 0, got {k}")
    return k


def _checked_thresholds(thresholds) -> Thresholds:
    if not isinstance(thresholds, Thresholds):
        raise TypeError(f"thresholds: expected edmf_rs.Thresholds, got {type(thresholds).__name__}")
    return thresholds


def _bands(thresholds: Thresholds, k: float):
    se_low = thresholds.se_low if thresholds.se_low is not None else np.zeros(thresholds.n_sensors)
    se_high = thresholds.se_high if thresholds.se_high is not None else np.zeros(thresholds.n_sensors)
    se_low, se_high = np.nan_to_num(se_low, posinf=0.0), np.nan_to_num(se_high, posinf=0.0)
    wide = (thresholds.low - k * se_low, thresholds.high + k * se_high)
    narrow = (thresholds.low + k * se_low, thresholds.high - k * se_high)
    return wide, narrow


def borderline_mask(predictions, measurements, thresholds: Thresholds, k: float = 2.0) -> np.ndarray:
    """Boolean mask over the rows of ``predictions`` (N, n_m) of borderline instances.

    Parameters
    ----------
    predictions : array (N, n_m) of g(theta)
    measurements : array (n_m,) of y
    thresholds : Thresholds, with ``se_low``/``se_high`` for Monte Carlo bounds
    k : how many standard errors to widen and narrow the bounds by (a finite number >= 0)

    Returns
    -------
    numpy bool array of shape (N,)

    Raises
    ------
    TypeError
        ``thresholds`` not a `Thresholds`, ``predictions`` not numeric, or
        ``k`` not a number.
    ValueError
        Shapes that do not match the thresholds, or ``k`` negative or not finite.

    Examples
    --------
    >>> t = Thresholds([-1.0], [1.0], se_low=[0.01], se_high=[0.01])
    >>> borderline_mask(np.array([[0.0], [0.99], [1.5]]), [0.0], t).tolist()
    [False, True, False]
    """
    thresholds = _checked_thresholds(thresholds)
    k = _checked_k(k)
    y = finite_vector(measurements, "measurements", n=thresholds.n_sensors)
    p = real_array(predictions, "predictions", copy=False)
    if p.ndim != 2 or p.shape[1] != thresholds.n_sensors:
        raise ValueError(f"predictions: expected shape (N, {thresholds.n_sensors}), got {p.shape}")
    (wl, wh), (nl, nh) = _bands(thresholds, k)
    r = p - y
    wide = np.all((r >= wl) & (r <= wh), axis=1)
    narrow = np.all((r >= nl) & (r <= nh), axis=1)
    return wide & ~narrow


def borderline_instances(predictions, measurements, thresholds: Thresholds, k: float = 2.0) -> np.ndarray:
    """Indices of the borderline instances (see :func:`borderline_mask`).

    Examples
    --------
    >>> t = Thresholds([-1.0], [1.0], se_low=[0.01], se_high=[0.01])
    >>> borderline_instances(np.array([[0.0], [-1.01], [1.5]]), [0.0], t).tolist()
    [1]
    """
    return np.flatnonzero(borderline_mask(predictions, measurements, thresholds, k))


class BorderlineCounter:
    """Counts borderline instances batch by batch: an ``on_batch(offset, theta, predictions)`` hook."""

    def __init__(self, thresholds: Thresholds, measurements, k: float = 2.0):
        thresholds = _checked_thresholds(thresholds)
        self.thresholds, self.measurements, self.k = thresholds, measurements, _checked_k(k)
        # Only Monte Carlo bounds have sampling noise to speak of; exact and convolved bounds
        # (whose SE is a numerical error below 1e-4 of the width) skip the extra pass per batch.
        self.active = bool(thresholds.monte_carlo) and thresholds.se_low is not None and bool(
            np.any(np.nan_to_num(thresholds.se_low) > 0) or np.any(np.nan_to_num(thresholds.se_high) > 0))
        self.count = 0

    def __call__(self, offset, theta, predictions) -> None:
        if self.active and len(predictions):
            self.count += int(np.count_nonzero(borderline_mask(predictions, self.measurements, self.thresholds,
                                                               self.k)))
