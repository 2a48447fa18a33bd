"""Joint entropy of sensor locations (Papadopoulou, Raphael, Smith & Sekhar
2014, Entropy 16(9):5078, Eq. 3), computed by the Rust core.

The predictions of N model instances at a location are binned into intervals
of width ``w_i`` starting at their minimum: ``b[k, i] = floor((G[k, i] - min_k
G[k, i]) / w_i)``. The joint entropy of a set S of locations is
``H(S) = -sum_t p_t log2 p_t`` over the distinct tuples of bins of S: the bits a
measurement at S can tell apart, at the resolution the uncertainty allows.
"""

from __future__ import annotations

import numpy as np

from .. import _core
from ..engine.thresholds import sensor_probability, threshold_bounds
from . import _checks


def joint_entropy(predictions, widths, sensors=None, *, nan_policy: str = "raise") -> float:
    """Joint entropy H(S), in bits, of the binned predictions at ``sensors``.

    Parameters
    ----------
    predictions : array of shape (N, L)
        Predictions of N model instances at L candidate locations (float64 or
        float32, any layout, a ``np.load(..., mmap_mode="r")`` memory map too;
        read in place).
    widths : array of shape (L,)
        Interval (bin) width per location, finite and > 0; see
        :func:`interval_widths`.
    sensors : sequence of int, optional
        Location indices of S (all locations when None; empty gives 0).
    nan_policy : {"raise", "bin"}
        NaN predictions are refused, or form a bin of their own.

    Returns
    -------
    float
        H(S) in bits, between 0 and log2 N.

    Raises
    ------
    ValueError
        Widths <= 0 or non-finite, NaN predictions with ``nan_policy="raise"``,
        locations out of range.

    Examples
    --------
    >>> import numpy as np
    >>> g = np.array([[0.0], [0.0], [1.0], [1.0]])
    >>> joint_entropy(g, [0.5])
    1.0
    """
    g = _checks.predictions_array(predictions)
    w = _checks.widths_vector(widths, g.shape[1])
    s = list(range(g.shape[1])) if sensors is None else _checks.locations(sensors, "sensors", g.shape[1],
                                                                          distinct=False)
    return float(_core.design_joint_entropy(g, w, s, _checks.nan_bin(nan_policy)))


def interval_widths(combined, n_sensors: int, phi: float = 0.95, correction: str = "sidak") -> np.ndarray:
    """Default bin widths: the width of each location's threshold bounds.

    Each location gets the shortest interval of its combined uncertainty U_c
    holding the per-sensor probability of a design of ``n_sensors`` sensors
    (Eq. 5 of Goulet & Smith 2013: ``phi**(1/n_sensors)`` with Šidák), i.e. the
    width of the bounds it would have once chosen. Predictions closer than that
    cannot be told apart by a measurement.

    Parameters
    ----------
    combined : CombinedUncertainty
        U_c of all L locations (:func:`edmf_rs.combine`).
    n_sensors : int
        Sensors of the design (the Šidák correction's n_m).
    phi, correction
        As in :func:`edmf_rs.threshold_bounds`.

    Returns
    -------
    numpy.ndarray
        One width per location.

    Examples
    --------
    >>> import edmf_rs, scipy.stats as st
    >>> u = edmf_rs.combine(measurement=[st.norm(0, 1)], n_sensors=3)
    >>> interval_widths(u, n_sensors=1).round(2)
    array([3.92, 3.92, 3.92])
    """
    p = sensor_probability(phi, n_sensors, correction)
    return threshold_bounds(combined, phi=p, correction="none").width
