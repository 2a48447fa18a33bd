"""Argument checks of the design functions: each error names the argument."""

from __future__ import annotations

import numbers

import numpy as np

NAN_POLICIES = ("raise", "bin")


def predictions_array(predictions) -> np.ndarray:
    """A 2-D float64 or float32 array read in place (memory maps included);
    other real dtypes are converted to float64."""
    try:
        g = predictions if isinstance(predictions, np.ndarray) else np.asarray(predictions)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"predictions: expected a 2-D array of numbers ({exc})") from None
    if g.dtype.kind not in "iuf":
        raise TypeError(f"predictions: expected real numbers, got dtype {g.dtype}")
    if g.ndim != 2:
        raise ValueError(f"predictions: expected shape (instances, locations), got shape {g.shape}")
    if g.shape[0] < 1 or g.shape[1] < 1:
        raise ValueError(f"predictions: expected at least one instance and one location, got shape {g.shape}")
    if g.dtype not in (np.float64, np.float32):
        g = g.astype(np.float64)
    if any(s < 0 for s in g.strides) or not g.flags.aligned:
        g = np.ascontiguousarray(g)
    return g


#: Rows of the predictions checked for non-finite values at a time (a memory map is never copied whole).
CHECK_ROWS = 65_536


def first_non_finite(g: np.ndarray) -> tuple[int, int] | None:
    """(instance, location) of the first NaN or infinite prediction of ``g``, or None; read
    ``CHECK_ROWS`` rows at a time."""
    for first in range(0, g.shape[0], CHECK_ROWS):
        bad = ~np.isfinite(g[first:first + CHECK_ROWS])
        if bad.any():
            i, j = np.argwhere(bad)[0]
            return first + int(i), int(j)
    return None


def finite_predictions(g: np.ndarray, why: str = "") -> np.ndarray:
    """``g`` (from :func:`predictions_array`) when every prediction is finite;
    else a ValueError naming the first non-finite one (instance and location),
    then ``why`` (e.g. what to do about it)."""
    bad = first_non_finite(g)
    if bad is not None:
        i, j = bad
        raise ValueError(f"predictions: expected finite values, got {g[i, j]} at instance {i}, location {j}"
                         + (f"; {why}" if why else ""))
    return g


def widths_vector(widths, n_locations: int) -> np.ndarray:
    return _positive_vector(widths, "widths", n_locations)


def costs_vector(costs, n_locations: int) -> np.ndarray:
    return _positive_vector(costs, "costs", n_locations)


def _positive_vector(values, name: str, n: int) -> np.ndarray:
    """One finite value > 0 per location; ``name`` (plural) names the argument and the values."""
    v = _vector(values, name, n)
    bad = np.flatnonzero(~(np.isfinite(v) & (v > 0)))
    if bad.size:
        raise ValueError(f"{name}: expected finite {name} > 0, got {v[bad[0]]} at location {bad[0]}")
    return v


def _vector(values, name: str, n: int) -> np.ndarray:
    try:
        v = np.asarray(values)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name}: expected a 1-D array of numbers ({exc})") from None
    if v.dtype.kind not in "iuf":
        raise TypeError(f"{name}: expected numbers, got dtype {v.dtype}")
    if v.ndim == 0:
        raise ValueError(f"{name}: expected one value per location ({n}), got the single number {v.item()!r} "
                         f"(for the same value everywhere: [{v.item()!r}] * {n})")
    if v.shape != (n,):
        raise ValueError(f"{name}: expected one value per location ({n}), got shape {v.shape}")
    return np.ascontiguousarray(v, dtype=np.float64)


def index(value, name: str, what: str = "location indices (integers)") -> int:
    """``value`` as an int; a TypeError naming ``name`` and saying ``what`` was expected otherwise."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name}: expected {what}, got {value!r}")
    return int(value)


def count(value, name: str, what: str) -> int:
    """An integer count (``what`` says of what, e.g. "a number of sensors"); a TypeError otherwise."""
    return index(value, name, f"{what} (an integer)")


def sensor_types(types, n_locations: int) -> tuple[str, ...] | None:
    """One sensor type per location, as strings (how designs report them and
    ``max_per_type`` names them: :func:`quotas` takes its keys as strings too)."""
    if types is None:
        return None
    if isinstance(types, (str, bytes)) or not hasattr(types, "__iter__"):
        raise TypeError(f"types: expected a sequence of sensor types, one per location, got {types!r}")
    types = tuple(str(t) for t in types)
    if len(types) != n_locations:
        raise ValueError(f"types: expected one type per location ({n_locations}), got {len(types)}")
    return types


def locations(values, name: str, n_locations: int, *, distinct: bool = True) -> list[int]:
    """Location indices in range (and distinct)."""
    if isinstance(values, np.ndarray):
        values = values.tolist()
    if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
        raise TypeError(f"{name}: expected a sequence of location indices, got {values!r}")
    out = [index(v, name) for v in values]
    for i in out:
        if not 0 <= i < n_locations:
            raise ValueError(f"{name}: expected location indices in [0, {n_locations}), got {i}")
    if distinct:
        seen: set[int] = set()
        for i in out:
            if i in seen:
                raise ValueError(f"{name}: expected distinct locations, got {i} more than once")
            seen.add(i)
    return out


def seed(value):
    """``value`` when numpy.random.default_rng accepts it (an integer >= 0, a
    sequence of them, None, a Generator, BitGenerator or SeedSequence)."""
    what = "an integer >= 0, a sequence of them, None or a numpy Generator/SeedSequence"
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"seed: expected {what}, got {value!r}")
    try:
        np.random.default_rng(value)
    except TypeError:
        raise TypeError(f"seed: expected {what}, got {value!r}") from None
    except ValueError:
        raise ValueError(f"seed: expected {what}, got {value!r}") from None
    return value


def nan_bin(policy: str) -> bool:
    if policy not in NAN_POLICIES:
        raise ValueError(f"nan_policy: expected one of {NAN_POLICIES}, got {policy!r}")
    return policy == "bin"


def non_negative(value, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real) or not np.isfinite(value) or value < 0:
        raise ValueError(f"{name}: expected a finite number >= 0, got {value!r}")
    return float(value)


def fixed_cost(costs, fixed) -> float:
    """Total cost of the ``fixed`` locations."""
    return float(np.asarray(costs, dtype=np.float64)[np.asarray(fixed, dtype=np.int64)].sum())


def budget_problem(costs, fixed, budget: float):
    """Why ``budget`` cannot pay for a design: ``("cheapest", cost)`` when it is
    below the cheapest location, ``("fixed", cost)`` when below the cost of the
    ``fixed`` locations; None when it can. The rule of :func:`place_sensors`
    and of a design project's ``budget``."""
    cheapest = float(np.min(costs))
    if budget < cheapest:
        return "cheapest", cheapest
    total = fixed_cost(costs, fixed)
    if total > budget:
        return "fixed", total
    return None


def too_few_for_fixed(k: int, fixed) -> bool:
    """``k`` sensors cannot hold the ``fixed`` ones."""
    return k < len(fixed)


def quota_below_fixed(max_per_type: dict, types, fixed):
    """(type, fixed sensors of that type, its quota) of the first type (in
    sorted order) whose quota is below its fixed sensors; None when none is."""
    for t in sorted(set(types)):
        if t not in max_per_type:
            continue
        used = sum(1 for i in fixed if types[i] == t)
        if used > max_per_type[t]:
            return t, used, max_per_type[t]
    return None


def quotas(max_per_type, types, fixed, n_locations: int):
    """(type index of each location, most sensors per type index) for the
    core, or (None, None) without quotas."""
    if max_per_type is None:
        return None, None
    if not isinstance(max_per_type, dict):
        raise TypeError(f"max_per_type: expected a dict of sensor type to a number of sensors, got {max_per_type!r}")
    if types is None:
        raise ValueError("max_per_type: expected types=... (one sensor type per location) to go with it")
    # Types are compared as strings, as `sensor_types` gives them: {2: 1} limits the locations of type 2.
    keyed: dict[str, object] = {}
    given: dict[str, object] = {}  # the keys as given, for messages
    for key, value in max_per_type.items():
        if str(key) in keyed:
            raise ValueError(f"max_per_type: expected each sensor type once, got {given[str(key)]!r} and {key!r}")
        keyed[str(key)], given[str(key)] = value, key
    max_per_type = keyed
    names = sorted(set(types))
    unknown = [t for t in max_per_type if t not in names]
    if unknown:
        raise ValueError(f"max_per_type: expected sensor types of the locations ({', '.join(names)}), "
                         f"got {given[unknown[0]]!r}")
    limit = []
    for t in names:
        q = max_per_type.get(t, n_locations)
        if isinstance(q, bool) or not isinstance(q, numbers.Integral) or q < 0:
            raise ValueError(f"max_per_type: expected a number of sensors >= 0 for {t!r}, got {q!r}")
        limit.append(min(int(q), n_locations))
    index = {t: j for j, t in enumerate(names)}
    type_of = [index[t] for t in types]
    below = quota_below_fixed(max_per_type, types, fixed)
    if below is not None:
        t, used, q = below
        raise ValueError(f"max_per_type: expected at least the {used} fixed sensors of type {t!r}, got {q}")
    return type_of, limit
