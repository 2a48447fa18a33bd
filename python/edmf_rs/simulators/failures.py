"""Failed model instances are data: why each failed, kept beside the results.

A failed instance (non-zero exit, timeout, killed by a signal, output missing
or unreadable, sensors missing or unknown) is neither a candidate nor
falsified: it is counted apart, listed in ``failures.csv`` with its reason,
the last lines of its stderr and its work folder, and the run goes on, unless
the failures say the setup itself is wrong (:class:`FailurePolicy`).
"""

from __future__ import annotations

import csv
import io
from dataclasses import dataclass

from ..stream.atomic import write_text

#: Lines of a failed run's stderr kept in failures.csv and in messages.
STDERR_LINES = 5


class SimulationError(RuntimeError):
    """The model's runs failed in a way that stops the identification (exit code 1).

    Attributes
    ----------
    args : tuple of str
        The message: the instances, the command and the work folders.

    Examples
    --------
    >>> SimulationError("the first 5 instances all failed").names_its_instances
    True
    """

    #: The message already names the instances, the command and the work folders.
    names_its_instances = True


@dataclass(frozen=True)
class Failure:
    """One failed model instance: its index, parameters, reason, stderr tail and work folder.

    Attributes
    ----------
    instance : int
        Index of the model instance.
    parameters : tuple of float
        Its parameters.
    reason : str
        Exit code, signal, timeout or why the output could not be read.
    stderr, work : str
        The last lines of the program's stderr, and its (kept) work folder.
    timeout : float or None
        The timeout the run exceeded (None unless it timed out): a run with
        a longer timeout evaluates it again.

    Examples
    --------
    >>> Failure(3, (1.5,), "exit code 2").describe(["E"])
    'instance 3 (E=1.5): exit code 2'
    """

    instance: int
    parameters: tuple[float, ...]
    reason: str
    stderr: str = ""
    work: str = ""
    timeout: float | None = None

    def describe(self, names) -> str:
        values = ", ".join(f"{n}={_number(v)}" for n, v in zip(names, self.parameters))
        text = f"instance {self.instance} ({values}): {self.reason}"
        if self.work:
            text += f"; work folder {self.work}"
        if self.stderr:
            text += "; stderr: " + " | ".join(self.stderr.splitlines()[-STDERR_LINES:])
        return text


@dataclass(frozen=True)
class FailurePolicy:
    """When failures stop the run.

    Parameters
    ----------
    first : int, default 5
        If the first ``first`` instances all fail, the setup is wrong (a
        command, a template or a parser) and the run stops with their reasons.
    max_rate : float or None
        The run stops as soon as more than this fraction of all planned
        instances has failed (so a stop is never premature: the limit can no
        longer be met). None: no limit.

    Examples
    --------
    >>> FailurePolicy(first=2).check(n_done=2, first_failed=2, n_failed=2, n_planned=10)
    'the first 2 instances all failed'
    >>> FailurePolicy(max_rate=0.1).check(n_done=5, first_failed=1, n_failed=2, n_planned=10)
    '2 of 10 instances failed already, more than max_failure_rate = 0.1 allows'
    """

    first: int = 5
    max_rate: float | None = None

    def check(self, n_done: int, first_failed: int, n_failed: int, n_planned: int) -> str | None:
        """Why the run must stop now, or None (``first_failed``: failures among the first ``first``)."""
        if self.first and n_done >= self.first and first_failed >= self.first:
            return f"the first {self.first} instances all failed"
        if self.max_rate is not None and n_failed > self.max_rate * n_planned:
            return (f"{n_failed} of {n_planned} instances failed already, more than max_failure_rate = "
                    f"{self.max_rate:g} allows")
        return None


def failures_csv(failures, names) -> str:
    """failures.csv: instance, the parameters, reason, stderr (last lines), work folder."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["instance", *names, "reason", "stderr", "work_folder"])
    for f in sorted(failures, key=lambda f: f.instance):
        tail = "\n".join(f.stderr.splitlines()[-STDERR_LINES:])
        writer.writerow([f.instance, *map(_number, f.parameters), f.reason, tail, f.work])
    return buf.getvalue()


def _number(value) -> str:
    """A parameter as failures.csv and messages show it: ``60000.0`` (repr of a Python float, exact),
    never ``np.float64(60000.0)``."""
    try:
        return repr(float(value))
    except (TypeError, ValueError):
        return str(value)


def write_failures(path, failures, names) -> None:
    """Writes failures.csv atomically (whole, so a reader never sees half a row)."""
    write_text(path, failures_csv(failures, names))
