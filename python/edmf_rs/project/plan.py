"""The plan of a run, checked and estimated before any instance is evaluated.

``Project.check()`` calls the model and every prognosis function on two
instances (so shape and type errors surface in seconds, not after the first
batch) and returns a :class:`Plan`: the number of instances, the sampling,
and the model time per instance measured on those two. A run of more than
:data:`MAX_INSTANCES` instances, or estimated to last more than
:data:`MAX_SECONDS` once the first batch has been timed, needs an explicit
go-ahead (``edmf-rs run --yes``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .format import number, plural
from .schema import ProjectError

#: Instances above which a run needs ``--yes``.
MAX_INSTANCES = 10**10
#: Estimated seconds above which a run needs ``--yes`` (one day).
MAX_SECONDS = 86_400.0


class RunTooLarge(ProjectError):
    """A run over the limits, started without the go-ahead (``--yes``)."""


def duration(seconds: float) -> str:
    """``3.2 s``, ``4.5 min``, ``2.1 h``, ``3.4 days``.

    Examples
    --------
    >>> duration(7200.0)
    '2.0 h'
    """
    if not math.isfinite(seconds):
        return "unknown"
    for limit, unit, scale in ((120.0, "s", 1.0), (7200.0, "min", 60.0), (172_800.0, "h", 3600.0)):
        if seconds < limit:
            return f"{seconds / scale:.1f} {unit}"
    return f"{seconds / 86_400.0:.1f} days"


@dataclass(frozen=True)
class Plan:
    """What a run will do, and how long the model may take.

    ``seconds_per_instance`` comes from the two-instance check (an upper bound
    for a vectorised model, whose cost per instance falls in full batches);
    None without a model function (precomputed instances).
    """

    project: str
    n_instances: int
    n_sensors: int
    n_parameters: int
    instances: str
    model: str
    batch_size: int
    prognoses: tuple[str, ...]
    seconds_per_instance: float | None

    @property
    def estimated_seconds(self) -> float | None:
        if self.seconds_per_instance is None:
            return None
        return self.seconds_per_instance * self.n_instances

    def describe(self) -> str:
        """The plan in a few lines, as ``edmf-rs run --dry-run`` prints it."""
        lines = [f"{self.project}: {plural(self.n_instances, 'model instance')} ({self.instances}), "
                 f"{plural(self.n_parameters, 'parameter')}, {plural(self.n_sensors, 'sensor')}",
                 f"model: {self.model}, in batches of {self.batch_size:,}"]
        if self.seconds_per_instance is not None:
            lines.append(f"model checked on 2 instances: {number(self.seconds_per_instance * 1e3, 3)} ms per instance; "
                         f"estimated model time at most {duration(self.estimated_seconds)} "
                         "(a vectorised model is faster per instance in full batches; the first batch refines this)")
        if self.prognoses:
            lines.append(f"prognosis functions checked on 2 instances: {', '.join(self.prognoses)}")
        return "\n".join(lines)


def check_instances(n: int, yes: bool, where: str = "") -> None:
    """Refuses a run of more than :data:`MAX_INSTANCES` instances without ``yes``
    (``where``: the project file and key, for the message)."""
    if n > MAX_INSTANCES and not yes:
        raise RunTooLarge(f"{where + ': ' if where else ''}the run has {n:,} model instances, more than {MAX_INSTANCES:,}; "
                          "rerun with --yes to go ahead (or reduce [sampling])")


def check_estimate(seconds: float, n_done: int, elapsed: float, n: int, limit: float = MAX_SECONDS) -> None:
    """Refuses a run estimated (from its first batch) at more than ``limit`` seconds."""
    if seconds > limit:
        raise RunTooLarge(f"the run is estimated at {duration(seconds)} ({n:,} instances; the first "
                          f"{n_done:,} took {elapsed:.2f} s), more than {duration(limit)}; "
                          "rerun with --yes to go ahead (or reduce [sampling])")
