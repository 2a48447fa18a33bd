"""Argument checks shared by the public functions: each error names the
argument and says what was expected."""

from __future__ import annotations

import numbers

import numpy as np


def probability(value, name: str) -> float:
    """A probability strictly inside (0, 1)."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name}: expected a number in (0, 1), got {type(value).__name__}")
    value = float(value)
    if not 0.0 < value < 1.0:
        raise ValueError(f"{name}: expected a value in (0, 1), got {value}")
    return value


def positive_int(value, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name}: expected a positive integer, got {type(value).__name__}")
    if value < 1:
        raise ValueError(f"{name}: expected a positive integer, got {value}")
    return int(value)


def finite_vector(values, name: str, n: int | None = None) -> np.ndarray:
    """A read-only 1-D float64 array of finite values (of length n if given)."""
    try:
        arr = np.asarray(values)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name}: expected a 1-D array of numbers ({exc})") from None
    if arr.dtype.kind not in "iuf" and arr.dtype != bool:
        raise TypeError(f"{name}: expected numbers, got dtype {arr.dtype}")
    arr = np.array(arr, dtype=np.float64, copy=True)
    if arr.ndim != 1:
        raise ValueError(f"{name}: expected a 1-D array, got shape {arr.shape}")
    if n is not None and arr.shape[0] != n:
        raise ValueError(f"{name}: expected {n} values (one per sensor), got {arr.shape[0]}")
    if arr.shape[0] == 0:
        raise ValueError(f"{name}: expected at least one sensor (n_m >= 1), got 0")
    bad = np.flatnonzero(~np.isfinite(arr))
    if bad.size:
        raise ValueError(f"{name}: expected finite values, got {arr[bad[0]]} at sensor {bad[0]}")
    arr.flags.writeable = False
    return arr


def flag(value, name: str) -> bool:
    """A yes/no option: True or False (a NumPy bool too). Strings such as
    "no" are refused rather than read as true."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name}: expected True or False, got {value!r}")
    return bool(value)


def real_array(values, name: str, copy: bool) -> np.ndarray:
    """A float64 array of real numbers (a copy if ``copy``, else converted
    only when it is not float64 already); complex, text or objects are refused."""
    try:
        arr = np.asarray(values)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name}: expected an array of numbers ({exc})") from None
    if arr.dtype.kind not in "iufb":
        raise TypeError(f"{name}: expected real numbers, got dtype {arr.dtype}")
    return np.array(arr, dtype=np.float64, copy=True) if copy else np.asarray(arr, dtype=np.float64)
