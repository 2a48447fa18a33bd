"""Uncertainty sources by name, as project files give them: the shorthands
(``normal``, ``uniform``, ``triangular``, ``truncated_normal``) with engineering
parameters, and any continuous ``scipy.stats`` distribution with its own
parameter names, checked against the distribution's signature."""

from __future__ import annotations

import difflib

import numpy as np
from scipy import stats

SHORTHANDS = {
    "normal": ("mean", "sd"),
    "uniform": ("low", "high"),
    "triangular": ("low", "mode", "high"),
    "truncated_normal": ("mean", "sd", "low", "high"),
}


def accepted_parameters(name: str) -> tuple[str, ...]:
    """Parameter names of a shorthand or of a continuous scipy.stats distribution.

    Examples
    --------
    >>> accepted_parameters("lognorm"), accepted_parameters("triangular")
    (('s', 'loc', 'scale'), ('low', 'mode', 'high'))
    """
    if name in SHORTHANDS:
        return SHORTHANDS[name]
    family = getattr(stats, name, None)
    if not isinstance(family, stats.rv_continuous):
        close = difflib.get_close_matches(name, [*SHORTHANDS, *_scipy_names()], n=1)
        hint = f"; did you mean '{close[0]}'?" if close else ""
        raise ValueError(
            f"distribution: expected {', '.join(map(repr, SHORTHANDS))} or the name of a continuous "
            f"scipy.stats distribution (e.g. 'lognorm', 't', 'gamma'), got {name!r}{hint}"
        )
    shapes = tuple(x.strip() for x in family.shapes.split(",")) if family.shapes else ()
    return (*shapes, "loc", "scale")


def _scipy_names() -> list[str]:
    return [n for n in dir(stats) if isinstance(getattr(stats, n, None), stats.rv_continuous)]


def distribution(name: str, params: dict):
    """A scalar frozen distribution from its name and parameters, checked.

    ``name`` is a shorthand (``normal``: mean, sd; ``uniform``: low, high;
    ``triangular``: low, mode, high; ``truncated_normal``: mean, sd, low, high,
    the normal's mean and sd before truncation to [low, high]) or any
    continuous ``scipy.stats`` distribution with its own parameter names
    (``lognorm``: s, loc, scale). Every shape parameter must be given; loc
    (default 0) and scale (default 1) are optional, as in scipy; normal's mean
    defaults to 0.

    Parameters
    ----------
    name : str
    params : dict of parameter name -> number

    Returns
    -------
    A frozen ``scipy.stats`` distribution.

    Raises
    ------
    ValueError
        Unknown name, unknown or missing parameter (the message lists the
        accepted names), or values the family does not accept.

    Examples
    --------
    >>> float(distribution("lognorm", {"s": 0.25, "scale": 1.0}).median())
    1.0
    >>> round(float(distribution("triangular", {"low": -1, "mode": 0, "high": 1}).var()) * 6, 9)  # (a²+b²+c²-ab-ac-bc)/18
    1.0
    """
    if not isinstance(name, str):
        raise TypeError(f"name: expected the name of a distribution (a string), got {type(name).__name__}")
    if not isinstance(params, dict):
        raise TypeError(f"params: expected a dict of parameter name -> number, got {type(params).__name__}")
    accepted = accepted_parameters(name)
    listed = ", ".join(accepted)
    for key, value in params.items():
        if key not in accepted:
            raise ValueError(f"params: unknown parameter {key!r} for {name} (accepted: {listed})")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or value != value:
            raise ValueError(f"params: {key} of {name}: expected a number, got {value!r}")
    optional = {"loc", "scale"} | ({"mean"} if name in ("normal", "truncated_normal") else set())
    missing = [k for k in accepted if k not in params and k not in optional]
    if missing:
        raise ValueError(f"params: {name} needs {', '.join(missing)} (accepted: {listed})")
    v = {k: float(x) for k, x in params.items()}
    if name == "normal":
        dist, ok = stats.norm(v.get("mean", 0.0), v["sd"]), v["sd"] > 0
    elif name == "uniform":
        dist, ok = stats.uniform(v["low"], v["high"] - v["low"]), v["low"] < v["high"]
    elif name == "triangular":
        lo, mode, hi = v["low"], v["mode"], v["high"]
        ok = lo < hi and lo <= mode <= hi
        dist = stats.triang((mode - lo) / (hi - lo) if ok else 0.5, loc=lo, scale=hi - lo)
    elif name == "truncated_normal":
        mean, sd, lo, hi = v.get("mean", 0.0), v["sd"], v["low"], v["high"]
        ok = sd > 0 and lo < hi
        dist = stats.truncnorm((lo - mean) / sd if ok else -1, (hi - mean) / sd if ok else 1, loc=mean, scale=sd)
    else:
        family = getattr(stats, name)
        dist = family(**v)
        shapes = [v[k] for k in accepted[:-2]]
        ok = v.get("scale", 1.0) > 0 and bool(np.all(family._argcheck(*shapes))) if shapes else v.get("scale", 1.0) > 0
    if ok:
        with np.errstate(all="ignore"):
            q = dist.ppf([1e-6, 0.5, 1 - 1e-6])
        ok = bool(np.all(np.isfinite(q))) and q[2] > q[0]
    if not ok:
        given = ", ".join(f"{k} = {x:g}" for k, x in v.items())
        raise ValueError(f"params: {name} does not accept {given} (check the ranges of {listed}; "
                         "a proper distribution with finite quantiles is needed)")
    return dist
