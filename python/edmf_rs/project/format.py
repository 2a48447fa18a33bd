"""How numbers are shown to engineers in summaries and reports."""

from __future__ import annotations

import math


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
