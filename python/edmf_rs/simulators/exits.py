"""A model that calls ``os._exit`` fails instead of ending the run as a success."""

from __future__ import annotations

import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager


class ExitCalled(SystemExit):
    """The project's code called ``os._exit`` while edmf_rs was running it."""


_LOCK = threading.Lock()
_refusals = {"depth": 0, "real": os._exit, "pid": 0}


def _refuse(status):
    if os.getpid() != _refusals["pid"]:  # a child forked meanwhile: it must exit
        _refusals["real"](status)
    raise ExitCalled(status)


@contextmanager
def exits_refused() -> Iterator[None]:
    """``os._exit`` raises :class:`ExitCalled` while the project's code runs.

    ``os._exit`` ends the interpreter at once: no exception, no output, and
    status 0 for ``os._exit(0)``, so a run would look like a success. Refused
    in this process only: a child forked meanwhile (multiprocessing's ``fork``
    start method ends its children with ``os._exit``) exits as it should. A
    compiled library calling C ``exit()`` is not caught. Calls may nest and
    overlap in threads: the first one in replaces ``os._exit``, the last one
    out puts it back.
    """
    with _LOCK:
        if _refusals["depth"] == 0:
            _refusals.update(real=os._exit, pid=os.getpid())
            os._exit = _refuse
        _refusals["depth"] += 1
    try:
        yield
    finally:
        with _LOCK:
            _refusals["depth"] -= 1
            if _refusals["depth"] == 0:
                os._exit = _refusals["real"]
