"""Sources of scale 0: fixed offsets of the combined uncertainty.

A frozen distribution with scale 0, of any family, is the constant loc
(X = loc + scale Z; scipy reports its mean and quantiles as NaN). In Eq. 4,
U_c = sum(model) - sum(measurement), it shifts U_c by +loc (model) or -loc
(measurement), and the sensor is combined as if it were absent: so a fixed
offset never forces Monte Carlo on its own (`combine` takes the method from
the sources with spread).
"""

from __future__ import annotations

import numpy as np

from . import intervals


def loc_scale(dist) -> tuple[np.ndarray, np.ndarray]:
    """(loc, scale) of a frozen distribution as scipy parses them (positional or keyword),
    not broadcast over the sensors: with scale 0 the distribution is the constant loc."""
    _, loc, scale = dist.dist._parse_args(*dist.args, **dist.kwds)
    return np.asarray(loc, dtype=float), np.asarray(scale, dtype=float)


def whole_offsets(sources, n_m: int) -> tuple[np.ndarray, list]:
    """The offset at every sensor of the sources (``(sign, per-sensor list, dist,
    n, name)``, as `combine` reads them) given as one distribution of scale 0 at
    every sensor, and the other sources."""
    offset = np.zeros(n_m)
    spread = []
    for src in sources:
        sign, _, dist, _, _ = src
        if dist is not None:
            loc, scale = loc_scale(dist)
            if np.all(scale == 0):
                offset += sign * loc
                continue
        spread.append(src)
    return offset, spread


def per_sensor(sources, offset: np.ndarray, n_m: int) -> tuple[np.ndarray, list[list]]:
    """Per sensor, the shift (``offset`` plus the entries of scale 0 of a per-sensor
    list, or of a source vectorised over the sensors) and its ``(sign, dist)``
    sources with spread there."""
    shift = offset.copy()
    active: list[list] = [[] for _ in range(n_m)]
    for sign, group, dist, _, _ in sources:
        for j, d in enumerate(group or intervals.split(dist, n_m)):
            loc, scale = loc_scale(d)
            if scale == 0:
                shift[j] += sign * loc
            else:
                active[j].append((sign, d))
    return shift, active


def fold(active, shift: float) -> tuple:
    """One sensor's ``(sign, distribution)`` sources with the constant ``shift`` folded into
    the first one's location (sign * (X + sign * c) = sign * X + c), so that its marginal or
    convolution is that of the sources with spread, moved by the fixed offsets."""
    if shift == 0:
        return tuple(active)
    (sign, d), *rest = active
    shapes, loc, scale = d.dist._parse_args(*d.args, **d.kwds)
    return ((sign, d.dist(*shapes, loc=loc + sign * shift, scale=scale)), *rest)
