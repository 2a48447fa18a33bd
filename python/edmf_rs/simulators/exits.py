"""A model that calls ``os._exit`` fails instead of ending the run as a success."""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager


class ExitCalled(SystemExit):
    """The project's code called ``os._exit`` while edmf_rs was running it."""


@contextmanager
def exits_refused() -> Iterator[None]:
    """``os._exit`` raises :class:`ExitCalled` while the project's code runs.

    ``os._exit`` ends the interpreter at once: no exception, no output, and
    status 0 for ``os._exit(0)``, so a run would look like a success. Refused
    in this process only: a child forked meanwhile (multiprocessing's ``fork``
    start method ends its children with ``os._exit``) exits as it should. A
    compiled library calling C ``exit()`` is not caught.
    """
    real, pid = os._exit, os.getpid()

    def refuse(status):
        if os.getpid() != pid:
            real(status)
        raise ExitCalled(status)

    os._exit = refuse
    try:
        yield
    finally:
        os._exit = real
