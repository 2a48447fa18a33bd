"""How numbers are shown to engineers in summaries and reports (and written to summary.json)."""

from __future__ import annotations

import math

import numpy as np


def number(v, digits: int = 4) -> str:
    """A readable number: digits significant, thousands separated, exponent only if large or small."""
    v = float(v)
    if not math.isfinite(v) or v == 0.0:
        return f"{v:g}"
    e = math.floor(math.log10(abs(v)))
    if -3 <= e < 6:
        decimals = max(digits - 1 - e, 0)
        return f"{round(v, decimals):,.{decimals}f}"
    return f"{v:.{digits}g}"


def in_domain(v, low: float, high: float, digits: int = 4) -> str:
    """A value of a parameter whose domain is [low, high]: `number` with enough
    digits to show three significant digits of the domain's width, so that
    the ends of a narrow domain (1000.0 .. 1000.4) and values in it differ.

    Examples
    --------
    >>> in_domain(1000.2, 1000.0, 1000.4), in_domain(1000.0, 1000.0, 1000.4)
    ('1,000.200', '1,000.000')
    >>> in_domain(35000.0, 20e3, 50e3), in_domain(0.25, 0.0, 1.0)
    ('35,000', '0.2500')
    """
    v, width = float(v), float(high) - float(low)
    if math.isfinite(v) and v != 0.0 and math.isfinite(width) and width > 0:
        needed = 3 + math.floor(math.log10(abs(v))) - math.floor(math.log10(width))
        digits = min(max(digits, needed), 17)
    return number(v, digits)


def plural(count: int, word: str) -> str:
    """``count`` and ``word``, with an s unless count is 1: plural(1, "candidate") -> '1 candidate'.

    Examples
    --------
    >>> plural(1, "candidate"), plural(12000, "instance")
    ('1 candidate', '12,000 instances')
    """
    return f"{int(count):,} {word}{'' if int(count) == 1 else 's'}"


def json_safe(obj):
    """JSON-safe: NumPy scalars to Python, non-finite floats to null."""
    if isinstance(obj, dict):
        return {str(k): json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_safe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return json_safe(obj.tolist())
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None
    return obj
