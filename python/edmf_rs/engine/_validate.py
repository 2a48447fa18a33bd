"""Argument checks shared by the public functions: each error names the
argument and says what was expected."""

from __future__ import annotations

import numbers
import os

import numpy as np

#: What a ``seed`` may be besides a non-negative integer, where a Generator is accepted.
_GENERATORS = (np.random.Generator, np.random.BitGenerator, np.random.SeedSequence)


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


def check_seed(seed, name: str = "seed", *, generator: bool = False):
    """A random seed: an integer >= 0 (NumPy's SeedSequence refuses negatives
    without naming the argument). With ``generator``, None or a NumPy
    Generator (BitGenerator, SeedSequence) passes through unchanged."""
    if generator and (seed is None or isinstance(seed, _GENERATORS)):
        return seed
    expected = "an integer >= 0" + (", a numpy.random.Generator or None" if generator else "")
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, numbers.Integral):
        raise TypeError(f"{name}: expected {expected}, got {type(seed).__name__}")
    if seed < 0:
        raise ValueError(f"{name}: expected {expected}, got {seed}")
    return int(seed)


def memory_bytes() -> int | None:
    """Physical memory of this machine (None where it cannot be read)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return None


def fits_in_memory(n_bytes: int, name: str, what: str, instead: str) -> None:
    """Refuses up front, with the number, an array of more than half this
    machine's memory: allocating it would swap for hours or be killed.
    ``what`` describes the array, ``instead`` what to give instead."""
    have = memory_bytes()
    if have is not None and n_bytes > have // 2:
        raise ValueError(f"{name}: {what} ({n_bytes / 2**30:,.1f} GiB), more than half this machine's memory "
                         f"({have / 2**30:,.1f} GiB); expected {instead}")


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
