"""Parallel evaluation: processes for Python models, threads for external programs.

A Python model holds the GIL, so ``workers > 1`` runs it in a pool of
processes started with ``spawn`` (safe with threads, the Rust pool and any
OS; the model is imported by name in each worker, so it need not pickle). An
external program runs in its own process anyway, so a thread per worker only
waits for it. Results always come back in instance order.
"""

from __future__ import annotations

import importlib
import multiprocessing
import signal
import sys
from collections.abc import Iterator
from concurrent.futures import Future, ProcessPoolExecutor, ThreadPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import numpy as np

from .columns import portable
from .exits import ExitCalled, ModelExited, exits_refused
from .failures import SimulationError

_FUNCTIONS: dict[tuple[str, str], object] = {}


def _function(ref: str, path: str):
    """``module:function`` imported once per worker process, with ``path`` on sys.path."""
    key = (ref, path)
    if key not in _FUNCTIONS:
        if path not in sys.path:
            sys.path.insert(0, path)
        module_name, _, attr = ref.partition(":")
        func = importlib.import_module(module_name)
        for part in attr.split("."):
            func = getattr(func, part)
        _FUNCTIONS[key] = func
    return _FUNCTIONS[key]


def _leave_interrupts_to_the_parent() -> None:
    """Worker set-up: Ctrl-C reaches every process of the terminal's group; the
    parent stops the workers (`FunctionPool.terminate`), so a worker prints no
    traceback of its own."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _call(ref: str, path: str, options: dict, theta: np.ndarray):
    """The model on one piece of a batch; a named output (DataFrame, mapping,
    structured array) comes back with its names, to be matched by name."""
    try:
        with exits_refused():  # the model's os._exit is its failure, not a dead worker
            return portable(_function(ref, path)(theta, **options))
    except SystemExit as exc:  # os._exit or sys.exit: Dask would shut the worker down on a SystemExit
        raise ModelExited(exc.code, isinstance(exc, ExitCalled)) from None


class FunctionPool:
    """``function(theta, **options)`` evaluated by ``workers`` spawned processes,
    each batch cut into one contiguous slice per worker.

    Parameters
    ----------
    ref
        ``module:function`` (importable in a fresh interpreter with ``path`` on sys.path).
    path
        Folder of the model's module.
    options
        Keyword arguments of every call.
    workers
        Number of processes (>= 1).

    Examples
    --------
    >>> import numpy as np
    >>> with FunctionPool("numpy:cumsum", ".", {"axis": 1}, workers=2) as pool:
    ...     pool(np.ones((3, 2)), first=0).tolist()
    [[1.0, 2.0], [1.0, 2.0], [1.0, 2.0]]
    """

    def __init__(self, ref: str, path: str | Path, options: dict, workers: int):
        self.ref, self.path, self.options, self.workers = ref, str(Path(path).resolve()), dict(options), workers
        self.pool = ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"),
                                        initializer=_leave_interrupts_to_the_parent)
        self._terminated = False

    def __call__(self, theta: np.ndarray, first: int) -> np.ndarray:
        return np.concatenate([np.asarray(out, dtype=np.float64) for _, out in self.pieces(theta, first)])

    def pieces(self, theta: np.ndarray, first: int) -> list[tuple[int, object]]:
        """(rows, what the model returned) for each contiguous piece of the batch, in order."""
        pieces = [p for p in np.array_split(theta, self.workers) if len(p)]
        futures = [self.pool.submit(_call, self.ref, self.path, self.options, p) for p in pieces]
        try:
            return [(len(p), f.result()) for p, f in zip(pieces, futures)]
        except BrokenProcessPool:
            raise SimulationError(
                f"a worker process evaluating model.function = '{self.ref}' on instances {first}.."
                f"{first + len(theta) - 1} died (killed, out of memory or crashed); the instances before "
                "them are kept in the prediction store") from None
        except KeyboardInterrupt:  # waiting for a slow model would hang; the model's own errors keep the
            self.terminate()       # workers, which then find the first failing instance
            raise

    def terminate(self) -> None:
        """Stops the workers now; the calls they were running are lost."""
        stop = getattr(self.pool, "terminate_workers", None)  # Python 3.14
        if stop is not None:
            stop()
        else:
            for process in list((getattr(self.pool, "_processes", None) or {}).values()):
                process.terminate()
            self.pool.shutdown(wait=False, cancel_futures=True)
        self._terminated = True

    def close(self) -> None:
        if not self._terminated:
            self.pool.shutdown(wait=True, cancel_futures=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def ordered(pool: ThreadPoolExecutor, func, jobs) -> Iterator:
    """``func(*job)`` for every job on ``pool``, yielded in job order; pending jobs
    are cancelled when the consumer stops early (or raises)."""
    futures: list[Future] = [pool.submit(func, *job) for job in jobs]
    try:
        for fut in futures:
            yield fut.result()
    finally:
        for fut in futures:
            fut.cancel()
