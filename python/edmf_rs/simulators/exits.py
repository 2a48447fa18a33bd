"""A model that calls ``os._exit`` fails instead of ending the run as a success."""

from __future__ import annotations

import os
import threading
from collections.abc import Iterator
from contextlib import contextmanager


class ExitCalled(SystemExit):
    """The project's code called ``os._exit`` while edmf_rs was running it."""


class ModelExited(Exception):
    """A model in a worker process (or on a Dask worker) called ``os._exit`` or
    ``sys.exit``: sent back as an ordinary exception, since a pool (Dask) takes
    a SystemExit from a task as an order to shut the worker down."""

    def __init__(self, code, hard: bool):
        super().__init__(code, hard)
        self.code, self.hard = code, hard


def exit_call(exc: BaseException) -> str | None:
    """How the code asked to exit, as it wrote it (``"os._exit(0)"``,
    ``"sys.exit(2)"``), or None if ``exc`` is no exit."""
    if isinstance(exc, ModelExited):
        hard, code = exc.hard, exc.code
    elif isinstance(exc, SystemExit):
        hard, code = isinstance(exc, ExitCalled), exc.code
    else:
        return None
    return f"{'os._exit' if hard else 'sys.exit'}({code!r})"


_LOCK = threading.Lock()
#: Threads running the project's code now (ident: depth), the real os._exit, and the process they are in.
_refusals = {"threads": {}, "real": os._exit, "pid": 0}


def _refuse(status):
    # Only the guarded threads of this process: a child forked meanwhile, or another thread
    # (a watchdog, a Dask worker's event loop), must exit as it asked.
    if os.getpid() != _refusals["pid"] or threading.get_ident() not in _refusals["threads"]:
        _refusals["real"](status)
    raise ExitCalled(status)


@contextmanager
def exits_refused() -> Iterator[None]:
    """``os._exit`` raises :class:`ExitCalled` in this thread while the project's code runs.

    ``os._exit`` ends the interpreter at once: no exception, no output, and
    status 0 for ``os._exit(0)``, so a run would look like a success. Refused
    only in the threads inside this block, in this process: other threads (a
    watchdog, a Dask worker's event loop) and children forked meanwhile
    (multiprocessing's ``fork`` start method ends them with ``os._exit``) exit
    as they ask. A compiled library calling C ``exit()`` is not caught. Blocks
    may nest and overlap in threads: the first one in replaces ``os._exit``,
    the last one out puts it back.
    """
    me = threading.get_ident()
    with _LOCK:
        threads = _refusals["threads"]
        if not threads or _refusals["pid"] != os.getpid():  # first in (or first in a forked child)
            if os._exit is not _refuse:
                _refusals["real"] = os._exit
            threads.clear()
            _refusals["pid"] = os.getpid()
            os._exit = _refuse
        threads[me] = threads.get(me, 0) + 1
    try:
        yield
    finally:
        with _LOCK:
            threads = _refusals["threads"]
            threads[me] -= 1
            if not threads[me]:
                del threads[me]
            if not threads:
                os._exit = _refusals["real"]
