"""Model instances: parameter sets theta spread over the parameter domain (Sec. 3.3).

A :class:`Sampling` is a plan of N parameter sets produced in batches, so the
instances stream through the model and the falsification without ever being
held all at once (except for Latin hypercube samples, which are stratified as a
whole). Every sampler maps the unit hypercube onto the domain per parameter:
linearly, or uniformly in log space for ``scale = "log"`` (stiffnesses spanning
decades), where the grid uses ``geomspace``.
"""

from __future__ import annotations

import math
import numbers
import warnings
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import qmc

from ..engine._validate import check_seed, fits_in_memory, positive_int

SCALES = ("linear", "log")
METHODS = ("grid", "lhs", "sobol")
#: Instances a plan can count (the instance index is an int64).
MAX_COUNT = 2**63 - 1


@dataclass(frozen=True)
class Parameter:
    """One parameter of the model class and its domain ``[low, high]``."""

    name: str
    low: float
    high: float
    unit: str = ""
    scale: str = "linear"

    def __post_init__(self):
        for key in ("low", "high"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
                raise ValueError(f"{self.name}.{key}: expected a finite number, got {value!r}")
            object.__setattr__(self, key, float(value))
        if self.scale not in SCALES:
            raise ValueError(f"{self.name}.scale: expected 'linear' or 'log', got {self.scale!r}")
        if not self.low < self.high:
            raise ValueError(f"{self.name}.low: expected low < high, got low={self.low:g} >= high={self.high:g}")
        if self.scale == "log" and self.low <= 0:
            raise ValueError(f"{self.name}.low: expected low > 0 for scale = 'log', got {self.low:g}")

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """Maps u in [0, 1] onto the domain (uniformly in log space for a log scale)."""
        if self.scale == "log":
            return np.exp(math.log(self.low) + u * (math.log(self.high) - math.log(self.low)))
        return self.low + u * (self.high - self.low)

    def to_unit(self, x: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`from_unit`: the position of x in the domain, 0 at low and 1 at high."""
        x = np.asarray(x, dtype=np.float64)
        if self.scale == "log":
            return (np.log(x) - math.log(self.low)) / (math.log(self.high) - math.log(self.low))
        return (x - self.low) / (self.high - self.low)

    def grid(self, count: int) -> np.ndarray:
        """``count`` values from low to high inclusive (one value: the domain's centre)."""
        count = positive_int(count, f"{self.name} points")
        if count == 1:
            return self.from_unit(np.array([0.5]))
        space = np.geomspace if self.scale == "log" else np.linspace
        return space(self.low, self.high, count)


@dataclass(frozen=True)
class Sampling:
    """N parameter sets over ``parameters``: a grid, a Latin hypercube or a Sobol' sequence.

    Build one with :func:`grid`, :func:`latin_hypercube` or :func:`sobol`.
    Columns follow the order of ``parameters``.
    """

    parameters: tuple[Parameter, ...]
    method: str
    n: int
    seed: int | None = None
    points: tuple[int, ...] | None = None

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    def batches(self, batch_size: int = 10_000) -> Iterator[np.ndarray]:
        """The parameter sets in order, as (n, p) batches of at most ``batch_size`` rows."""
        batch_size = positive_int(batch_size, "batch_size")
        if self.method == "grid":
            axes = [p.grid(k) for p, k in zip(self.parameters, self.points)]
            for first in range(0, self.n, batch_size):
                # First parameter varies slowest (C order), like nested loops.
                index = np.unravel_index(np.arange(first, min(first + batch_size, self.n)), self.points)
                yield np.column_stack([axis[i] for axis, i in zip(axes, index)])
        elif self.method == "lhs":
            # A Latin hypercube is stratified as a whole: draw it once, then slice.
            unit = _qmc(qmc.LatinHypercube, len(self.parameters), self.seed).random(self.n)
            for first in range(0, self.n, batch_size):
                yield self._from_unit(unit[first:first + batch_size])
        else:
            engine = _qmc(qmc.Sobol, len(self.parameters), self.seed)
            for first in range(0, self.n, batch_size):
                with warnings.catch_warnings():
                    # Balance holds for the whole sequence when n is a power of 2;
                    # intermediate batch totals need not be.
                    warnings.filterwarnings("ignore", message=".*balance properties.*")
                    unit = engine.random(min(batch_size, self.n - first))
                yield self._from_unit(unit)

    def head(self, k: int = 2) -> np.ndarray:
        """Up to ``k`` parameter sets in the domain, cheaply, to check the model on
        before a run: the first k of the grid or the Sobol' sequence; for a Latin
        hypercube (drawn whole in a run) a small hypercube of its own."""
        k = min(positive_int(k, "k"), self.n)
        if self.method == "lhs":
            return self._from_unit(_qmc(qmc.LatinHypercube, len(self.parameters), self.seed).random(k))
        return next(iter(self.batches(k)))

    def all(self) -> np.ndarray:
        """Every parameter set at once, shape (N, p)."""
        parts = list(self.batches(max(self.n, 1)))
        return np.concatenate(parts) if parts else np.empty((0, len(self.parameters)))

    def _from_unit(self, unit: np.ndarray) -> np.ndarray:
        return np.column_stack([p.from_unit(unit[:, j]) for j, p in enumerate(self.parameters)])

    def describe(self) -> str:
        if self.method == "grid":
            return f"grid {' x '.join(map(str, self.points))} = {self.n:,} instance{'s' * (self.n != 1)}"
        kind = "Latin hypercube" if self.method == "lhs" else "Sobol' sequence"
        return f"{kind}, {self.n:,} instance{'s' * (self.n != 1)}, seed {self.seed}"


def _parameters(parameters: Sequence[Parameter]) -> tuple[Parameter, ...]:
    parameters = tuple(parameters)
    if not parameters or not all(isinstance(p, Parameter) for p in parameters):
        raise TypeError("parameters: expected a non-empty sequence of edmf_rs.sampling.Parameter")
    names = [p.name for p in parameters]
    if len(set(names)) != len(names):
        raise ValueError(f"parameters: expected distinct names, got {names}")
    return parameters


def _qmc(engine, d: int, seed):
    try:
        return engine(d, rng=seed)
    except TypeError:  # SciPy < 1.15 names it seed
        return engine(d, seed=seed)


def grid(parameters: Sequence[Parameter], points: Mapping[str, int] | Sequence[int]) -> Sampling:
    """Full factorial grid: ``points[name]`` values per parameter, bounds included."""
    parameters = _parameters(parameters)
    if isinstance(points, Mapping):
        missing = [p.name for p in parameters if p.name not in points]
        if missing:
            raise ValueError(f"points: expected a count for every parameter, missing {', '.join(missing)}")
        unknown = sorted(set(points) - {p.name for p in parameters})
        if unknown:
            raise ValueError(f"points: unknown parameter {', '.join(unknown)}")
        counts = [points[p.name] for p in parameters]
    else:
        counts = list(points)
        if len(counts) != len(parameters):
            raise ValueError(f"points: expected {len(parameters)} counts (one per parameter), got {len(counts)}")
    counts = tuple(positive_int(k, f"points.{p.name}") for k, p in zip(counts, parameters))
    n = math.prod(counts)
    if n > MAX_COUNT:
        raise ValueError(f"points: the grid {' x '.join(f'{k:,}' for k in counts)} has {n:,} instances, more than "
                         f"can be counted ({MAX_COUNT:,}); expected fewer points")
    return Sampling(parameters, "grid", n, points=counts)


def latin_hypercube(parameters: Sequence[Parameter], n: int, seed: int | None = None) -> Sampling:
    """``n`` Latin hypercube samples (``scipy.stats.qmc.LatinHypercube``).

    A Latin hypercube is stratified as a whole, so it is drawn whole: n that
    would not fit in this machine's memory is refused (use :func:`sobol`).
    """
    parameters = _parameters(parameters)
    n = positive_int(n, "n")
    fits_in_memory(8 * n * len(parameters), "n", f"a Latin hypercube of {n:,} instances is drawn whole "
                   f"as {n:,} x {len(parameters)} values", "a smaller n, or method = 'sobol', which is streamed")
    return Sampling(parameters, "lhs", n, seed=check_seed(seed, generator=True))


def sobol(parameters: Sequence[Parameter], n: int, seed: int | None = None) -> Sampling:
    """The first ``n`` points of a scrambled Sobol' sequence (``scipy.stats.qmc.Sobol``).

    A power of two keeps the sequence's balance properties.
    """
    n = positive_int(n, "n")
    if n > MAX_COUNT:
        raise ValueError(f"n: {n:,} instances is more than can be counted ({MAX_COUNT:,})")
    return Sampling(_parameters(parameters), "sobol", n, seed=check_seed(seed, generator=True))
