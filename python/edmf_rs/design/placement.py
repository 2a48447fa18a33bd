"""Hierarchical (greedy) sensor placement by joint entropy (Papadopoulou et
al. 2014, Sec. 3.2; Bertola, Papadopoulou, Vernay & Smith 2017, Sensors
17(12):2904): each step adds the location that raises the joint entropy most
(per unit cost when locations have costs), until ``k`` sensors, the budget, or a
gain below ``tolerance``. Gains within ``TIE`` bits of the best are ties, won by
the lowest location index.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _core
from . import _checks
from .reference import TIE

__all__ = ["TIE", "SensorDesign", "place_sensors"]


@dataclass(frozen=True, eq=False)
class SensorDesign:
    """Locations chosen by :func:`place_sensors`, in the order they were added.

    Attributes
    ----------
    order : numpy.ndarray of int64
        Chosen location indices (fixed sensors first).
    joint_entropy : numpy.ndarray
        H (bits) of the first 1, 2, ... sensors of ``order``.
    n_instances : int
        N, so that ``joint_entropy <= log2(n_instances)``.
    cost : numpy.ndarray or None
        Cumulative cost after each sensor, when costs were given.
    types : tuple of str or None
        Sensor type of each chosen location, when types were given.
    evaluations : int
        (step, location) pairs evaluated.

    Examples
    --------
    >>> import numpy as np
    >>> d = place_sensors(np.array([[0.0, 0.0], [0.0, 1.0], [1.0, 2.0], [1.0, 3.0]]), [0.5, 0.5], k=2)
    >>> d.order.tolist(), d.gains.tolist()
    ([1, 0], [2.0, 0.0])
    """

    order: np.ndarray
    joint_entropy: np.ndarray
    n_instances: int
    cost: np.ndarray | None = None
    types: tuple | None = None
    evaluations: int = 0

    @property
    def gains(self) -> np.ndarray:
        """Information gain (bits) of each added sensor."""
        return np.diff(self.joint_entropy, prepend=0.0)

    def __len__(self) -> int:
        return int(self.order.size)

    def __repr__(self) -> str:
        h = self.joint_entropy[-1] if len(self) else 0.0
        return f"SensorDesign(n_sensors={len(self)}, joint_entropy={h:.4g} bits, order={self.order.tolist()})"


def place_sensors(predictions, widths, k=None, *, fixed=(), costs=None, types=None, budget=None,
                  tolerance=None, nan_policy: str = "raise", max_per_type=None, lazy: bool = True) -> SensorDesign:
    """Greedy sensor placement maximising the joint entropy of the predictions.

    Parameters
    ----------
    predictions : array of shape (N, L)
        Predictions of N model instances at L candidate locations (several load
        cases are simply more columns). float64 or float32, read in place.
    widths : array of shape (L,)
        Bin width per location (finite, > 0); see :func:`interval_widths`.
    k : int, optional
        Most sensors in the design, fixed ones included (<= L). Defaults to L
        when a ``budget`` is given.
    fixed : sequence of int
        Locations the design starts with (distinct, in range).
    costs : array of shape (L,), optional
        Cost of each location (> 0). The gain of a location is then divided by
        its cost (information per unit cost).
    types : sequence of str, optional
        Sensor type of each location (deflection, strain, ...), reported with
        the design and used by ``max_per_type``.
    budget : float, optional
        Total cost the design may not exceed (needs ``costs``; at least the
        cheapest sensor).
    tolerance : float, optional
        Stop when the best gain falls below this many bits (by more than
        ``TIE``: a location that leaves the partition as it was gains 0).
    nan_policy : {"raise", "bin"}
        Refuse NaN predictions, or give them a bin of their own.
    max_per_type : dict of str to int, optional
        Most sensors of a type (fixed ones included), e.g. ``{"strain": 5}``;
        types not named are not limited. Needs ``types``.
    lazy : bool
        Evaluate gains lazily (joint entropy is submodular: a location whose
        last gain cannot reach the best is not evaluated again). The choice is
        that of plain greedy either way; ``False`` evaluates every remaining
        location at every step (for checking, slower).

    Returns
    -------
    SensorDesign

    Raises
    ------
    ValueError
        Bad widths, NaN predictions, k > L, fixed sensors out of range or
        repeated, costs <= 0, a budget below the cheapest sensor or the cost
        of the fixed sensors, k below the number of fixed sensors, quotas of
        unknown types, below 0 or below the fixed sensors of a type; the
        message names the argument.

    Examples
    --------
    >>> import numpy as np
    >>> g = np.array([[0., 0., 0.], [0., 0., 0.], [0., 1., 1.], [1., 0., 1.]])
    >>> d = place_sensors(g, [0.5, 0.5, 0.5], k=2)
    >>> d.order.tolist(), d.joint_entropy.tolist()
    ([2, 0], [1.0, 1.5])
    >>> place_sensors(g, [0.5] * 3, k=2, types=["a", "b", "b"], max_per_type={"b": 1}).order.tolist()
    [2, 0]
    """
    g = _checks.predictions_array(predictions)
    n, n_loc = g.shape
    w = _checks.widths_vector(widths, n_loc)
    fixed = _checks.locations(fixed, "fixed", n_loc)
    c = None if costs is None else _checks.costs_vector(costs, n_loc)
    if budget is not None:
        if c is None:
            raise ValueError("budget: expected costs to go with it (costs=...)")
        budget = _checks.non_negative(budget, "budget")
        problem = _checks.budget_problem(c, fixed, budget)
        if problem is not None:
            what, cost = problem
            least = "the cheapest sensor" if what == "cheapest" else "the cost of the fixed sensors"
            raise ValueError(f"budget: expected at least {least} ({cost}), got {budget}")
    if k is None:
        if budget is None:
            raise ValueError("k: expected a number of sensors (or a budget)")
        k = n_loc
    k = _checks.count(k, "k", "a number of sensors")
    if not 1 <= k <= n_loc:
        raise ValueError(f"k: expected 1 <= k <= {n_loc} (the candidate locations), got {k}")
    if _checks.too_few_for_fixed(k, fixed):
        raise ValueError(f"k: expected at least the {len(fixed)} fixed sensors, got {k}")
    types = _checks.sensor_types(types, n_loc)
    tol = None if tolerance is None else _checks.non_negative(tolerance, "tolerance")
    type_of, quotas = _checks.quotas(max_per_type, types, fixed, n_loc)
    order, entropy, evaluations = _core.design_place(g, w, k, fixed, c, budget, tol, _checks.nan_bin(nan_policy),
                                                     type_of, quotas, not bool(lazy))
    order = np.asarray(order, dtype=np.int64)
    return SensorDesign(
        order=order,
        joint_entropy=np.asarray(entropy, dtype=np.float64),
        n_instances=n,
        cost=None if c is None else np.cumsum(c[order]),
        types=None if types is None else tuple(types[i] for i in order),
        evaluations=int(evaluations),
    )
