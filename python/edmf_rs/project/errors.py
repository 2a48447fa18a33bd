"""Failures of the project's own code, reported as coming from it.

A project file names code (the model, prognosis functions) that edmf_rs runs.
When that code raises, the message says which function failed, on which
batch and instances, and the parameters of the first instance that fails on
its own, so the engineer can reproduce it with one call. ``edmf-rs`` exits
with status 1 for these (the user's code failed) and 2 for a project file or
input that cannot be used (:class:`~edmf_rs.project.ProjectError`).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from ..simulators.exits import exit_call, exits_refused

#: Seconds spent at most looking for the first instance that fails on its own.
SEARCH_SECONDS = 10.0


class UserCodeError(Exception):
    """The project's model or prognosis function raised (or called sys.exit).

    ``original`` is the exception the function raised (also ``__cause__``).
    """

    def __init__(self, message: str, original: BaseException):
        super().__init__(message)
        self.original = original


def read_only_copy(theta: np.ndarray) -> np.ndarray:
    """A copy of theta the called code cannot write to: a model that edits its
    input in place would otherwise corrupt the candidates' parameters."""
    out = np.array(theta, dtype=np.float64, copy=True)
    out.flags.writeable = False
    return out


def _fails(call: Callable, rows: np.ndarray) -> bool:
    try:
        with exits_refused():
            call(read_only_copy(rows))
    except KeyboardInterrupt:
        raise
    except BaseException:  # also sys.exit and the user's own BaseException subclasses
        return True
    return False


def first_failing(call: Callable, theta: np.ndarray, seconds: float = SEARCH_SECONDS) -> int | None:
    """Index of the first row of theta on which ``call`` fails alone (None if
    none does within ``seconds``)."""
    deadline = time.monotonic() + seconds
    for i in range(theta.shape[0]):
        if _fails(call, theta[i:i + 1]):
            return i
        if time.monotonic() > deadline:
            return None
    return None


def call_user_code(call: Callable, theta: np.ndarray, *, what: str, where: str, first: int,
                   describe: Callable[[np.ndarray], str], unit: str = "instance"):
    """``call(theta)`` on a read-only copy; any exception (or sys.exit, os._exit) becomes a
    :class:`UserCodeError` naming ``what``, ``where`` (batch and instances)
    and the first failing row's parameters."""
    try:
        with exits_refused():
            return call(read_only_copy(theta))
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # sys.exit and the user's own BaseException subclasses too
        if getattr(exc, "names_its_instances", False):
            raise  # e.g. stopped external runs: already named, and re-running them would run the solver again
        called = exit_call(exc)
        if called is not None:
            raised = f"called {called}"
        else:
            raised = f"raised {type(exc).__name__}" + (f": {exc}" if str(exc) else "")
        k = first_failing(call, theta) if theta.shape[0] > 1 else 0
        if k is None:
            culprit = f"no single {unit} of these fails on its own (first: {describe(theta[0])})"
        else:
            culprit = f"first failing {unit}: {first + k} ({describe(theta[k])})"
        raise UserCodeError(f"{what} {raised}, on {where}; {culprit}", exc) from exc
