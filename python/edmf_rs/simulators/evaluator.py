"""The model as the falsification sees it: a callable on batches of parameter
sets that reuses stored instances, evaluates the rest (in parallel), stores
them as they arrive and turns failed runs into data.

``Evaluator(theta)`` has the call signature of a Python model: an (n, p)
batch in, (n, n_columns) predictions out, with NaN rows for failed instances
(so the falsification counts them as invalid: neither candidates nor
falsified). Batches must arrive in instance order, as ``falsify_model`` sends them.
"""

from __future__ import annotations

import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from .columns import NamedColumns, StoreColumns
from .command import CommandModel, _source_digest
from .failures import Failure, FailurePolicy, SimulationError, write_failures
from .pool import FunctionPool, ordered
from .store import PredictionStore, StoredRows

#: Seconds between flushes of an external program's results to the store.
FLUSH_SECONDS = 1.0


def store_fingerprint(command: CommandModel | None, function, ref: str, options: dict, sampling) -> dict:
    """What a prediction store is keyed by: the model (the command and its templates, or the
    function's reference, source and options) and the sampling."""
    if command is not None:
        model_key = command.fingerprint()
    else:
        model_key = {"kind": "function", "ref": ref, "source": _source_digest(function), "options": dict(options)}
    return {"model": model_key, "sampling": sampling}


class Evaluator:
    """Evaluates model instances batch by batch, with a prediction store.

    Parameters
    ----------
    parameters, sensors
        Names of the parameter columns and of every prediction column (all
        sensors of the measurements, excluded ones too).
    n_planned
        Number of instances the run will ask for (for ``max_failure_rate``).
    command
        An external program (:class:`CommandModel`), or None for a Python function.
    function, ref, path, options
        The Python model, its ``module:function`` and folder (for worker
        processes) and its keyword arguments.
    workers
        Parallel runs (processes for a function, threads for a command).
    out
        The output folder: the store goes to ``out/store``, work folders to
        ``out/work`` and failures to ``out/failures.csv``. None: no store,
        work folders in a temporary folder.
    sampling
        A description of the sampling (part of the store's key).
    columns
        How a Python model's outputs become the store's columns (matched by
        name, see :class:`~edmf_rs.simulators.columns.StoreColumns`);
        default: a bare array in the order of ``sensors``.
    scheduler
        A Dask scheduler's address: evaluate a Python function on that
        cluster (:class:`~edmf_rs.simulators.cluster.ClusterPool`) instead
        of local processes.
    retry_failures
        Run again every failed instance the store holds. Without it, only
        those that timed out under a shorter timeout than the command's
        are run again.
    store_root
        The store's folder (default ``out/store``), e.g. another run's store.
    reuse_only
        Evaluate nothing and write nothing into the store: every instance
        must be in it (``edmf-rs falsify``). A stored failure a run would
        retry (timed out under a shorter timeout) stays failed, counted in
        ``stats()["failures_not_retried"]``.

    Examples
    --------
    >>> import numpy as np, tempfile
    >>> ev = Evaluator(("a",), ("S",), 4, function=lambda t: 2 * t, ref="", path=".",
    ...                out=tempfile.mkdtemp(), sampling={"n": 4})
    >>> ev(np.array([[1.0], [2.0]])).ravel().tolist(), ev.model_evaluations
    ([2.0, 4.0], 2)
    """

    def __init__(self, parameters, sensors, n_planned: int, *, command: CommandModel | None = None,
                 function=None, ref: str = "", path=".", options: dict | None = None, workers: int = 1,
                 out=None, sampling: dict | None = None, store: bool = True, policy: FailurePolicy = FailurePolicy(),
                 columns: StoreColumns | None = None, scheduler: str | None = None, retry_failures: bool = False,
                 store_root=None, reuse_only: bool = False):
        self.parameters, self.sensors, self.n_planned = tuple(parameters), tuple(sensors), n_planned
        self.columns = columns if columns is not None else StoreColumns(self.sensors)
        self.retry_failures = retry_failures
        self._outputs_saved = False
        self.command, self.function, self.options = command, function, dict(options or {})
        self.workers, self.policy = workers, policy
        self.out = Path(out) if out is not None else None
        self.offset = self.model_evaluations = self.reused_evaluations = self.failures_not_retried = 0
        self.failures: list[Failure] = []
        self._first_failed = 0
        root = Path(store_root) if store_root is not None else self.out / "store" if self.out is not None else None
        self.store = (PredictionStore(root, store_fingerprint(command, function, ref, self.options, sampling),
                                      self.parameters, self.sensors)
                      if root is not None and store else None)
        self.reuse_only = reuse_only
        self._temp = None
        if command is not None:
            if reuse_only:  # runs nothing: no work folders
                self.work_root = None
            elif self.out is not None:
                self.work_root = self.out / "work"
                self.work_root.mkdir(parents=True, exist_ok=True)
            else:
                self._temp = self.work_root = Path(tempfile.mkdtemp(prefix="edmf-rs-work-"))
            self._write_failures()
        self.pool = None
        if command is None and scheduler is not None:
            from .cluster import ClusterPool

            self.pool = ClusterPool(scheduler, ref, path, self.options)
        elif command is None and workers > 1:
            self.pool = FunctionPool(ref, path, self.options, workers)

    @property
    def mapping(self):
        """How a Python model's outputs were matched to the sensors used (None until it is called)."""
        return self.columns.mapping

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        theta = np.asarray(theta, dtype=np.float64)
        first, n = self.offset, theta.shape[0]
        # The rows the store holds (a prefix of the batch: it holds instances 0..covered-1) are reused.
        k = min(max(self.store.covered() - first, 0), n) if self.store is not None else 0
        parts = [self._reuse(first, theta[:k])] if k else []
        if k < n and self.reuse_only:
            raise SimulationError(f"the prediction store {self.store.folder if self.store else None} holds no "
                                  f"instance {first + k}; this run evaluates no model (reuse only)")
        if k < n:
            parts.append(self._evaluate(first + k, theta[k:]))
        self.offset += n
        out = parts[0] if len(parts) == 1 else np.concatenate(parts)
        # An external program's results are read by sensor name (results.csv rows sensor,value):
        # handed on with their names, so they are matched (and reported) by name.
        return NamedColumns(out, self.sensors) if self.command is not None else out

    def _reuse(self, first: int, theta: np.ndarray) -> np.ndarray:
        n = theta.shape[0]
        stored = self.store.read(first, n)
        if stored is None or not np.array_equal(stored.parameters, theta):
            raise SimulationError(f"the prediction store {self.store.folder} holds other parameters for instances "
                                  f"{first}..{first + n - 1} than this run's sampling; remove that folder")
        if self.command is None:
            self.columns.refuse_absent(stored.absent, first, n, self.store.folder)
            if self.columns.mapping is None and (saved := self.store.outputs()) is not False:
                self.columns.replay(saved)
        again = self._to_retry(stored)
        if self.reuse_only:  # evaluates nothing: a failure a run would retry stays failed, as stored
            self.failures_not_retried += again.size
            again = again[:0]
        self.reused_evaluations += n - again.size
        for i in np.flatnonzero(stored.failed):
            if i not in again:
                self._count_reused(Failure(first + int(i), _values(theta[i]), stored.reason[i], stored.stderr[i],
                                           stored.work[i], _finite(stored.timeout[i])))
        if not again.size:
            return stored.predictions
        out = stored.predictions.copy()
        out[again] = self._run_commands(first + again, theta[again], retry=True)
        return out

    def _to_retry(self, stored: StoredRows) -> np.ndarray:
        """Stored failures to run again: all with ``retry_failures``, else those that timed out
        under a shorter timeout than this run's (a run that exits non-zero or writes no
        readable output would fail the same way again)."""
        if self.command is None or not stored.failed.any():
            return np.empty(0, dtype=np.int64)
        if self.retry_failures:
            return np.flatnonzero(stored.failed)
        limit = self.command.spec.timeout
        longer = ~np.isnan(stored.timeout) & (True if limit is None else stored.timeout < limit)
        return np.flatnonzero(stored.failed & longer)

    def _evaluate(self, first: int, theta: np.ndarray) -> np.ndarray:
        n = theta.shape[0]
        if self.command is not None:
            return self._run_commands(np.arange(first, first + n), theta)
        pieces = self.pool.pieces(theta, first) if self.pool is not None else [
            (n, self.function(theta, **self.options))]
        matched, at, absent = [], first, set()
        for rows, piece in pieces:  # each piece matched by name on its own: the same columns on every path
            values, missing = self.columns(piece, rows, at)
            matched.append(values)
            absent.update(missing)
            at += rows
        out = matched[0] if len(matched) == 1 else np.concatenate(matched)
        self.model_evaluations += n
        if self.store is not None:
            if not self._outputs_saved:  # how the outputs were named, for the report of a rerun
                self.store.save_outputs(self.columns.names)
                self._outputs_saved = True
            self.store.append(first, theta, out, np.zeros(n, bool), [""] * n, [""] * n, [""] * n,
                              absent=tuple(absent))
        return out

    def _run_commands(self, index: np.ndarray, theta: np.ndarray, retry: bool = False) -> np.ndarray:
        """Runs instances ``index`` (consecutive, or stored failures run again with ``retry``)."""
        n, m = theta.shape[0], len(self.sensors)
        out = np.full((n, m), np.nan)
        failed, reason, stderr, work = np.zeros(n, bool), [""] * n, [""] * n, [""] * n
        timeout = np.full(n, np.nan)
        flushed, last = 0, time.monotonic()

        def flush(upto: int) -> None:
            nonlocal flushed, last
            if self.store is not None and upto > flushed:
                s = slice(flushed, upto)
                self.store.append(int(index[flushed]), theta[s], out[s], failed[s], reason[s], stderr[s], work[s],
                                  timeout=timeout[s], instances=index[s] if retry else None)
            if failed[flushed:upto].any():
                self._write_failures()
            flushed, last = upto, time.monotonic()

        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(self.workers, thread_name_prefix="edmf-rs-run") as pool:
            results = ordered(pool, self.command.run, ((int(index[i]), theta[i], self.work_root) for i in range(n)))
            done = 0
            try:
                for i, result in enumerate(results):
                    done = i + 1
                    self.model_evaluations += 1
                    if isinstance(result, Failure):
                        failed[i], reason[i], stderr[i], work[i] = True, result.reason, result.stderr, result.work
                        timeout[i] = np.nan if result.timeout is None else result.timeout
                        self._count(result)
                    else:
                        out[i] = result
                    why = self.policy.check(int(index[i]) + 1, self._first_failed, len(self.failures),
                                            self.n_planned)
                    if why is not None:
                        flush(i + 1)
                        raise SimulationError(self._stop_message(why))
                    if time.monotonic() - last > FLUSH_SECONDS:
                        flush(i + 1)
            except BaseException:  # a stop, Ctrl-C: keep what finished, do not wait for long runs
                results.close()
                self.command.kill_running()
                flush(done)
                raise
            finally:
                results.close()  # cancels the runs not started (after Ctrl-C or a stop)
        flush(n)
        return out

    def _count(self, failure: Failure) -> None:
        self.failures.append(failure)
        if failure.instance < self.policy.first:
            self._first_failed += 1

    def _count_reused(self, failure: Failure) -> None:
        """Counts a failure read from the store, against stop_after_failures and max_failure_rate as a
        new one is (else a rerun into the store would pass where a fresh folder stops)."""
        self._count(failure)
        why = self.policy.check(failure.instance + 1, self._first_failed, len(self.failures), self.n_planned)
        if why is not None:
            self._write_failures()
            raise SimulationError(self._stop_message(why))

    def _stop_message(self, why: str) -> str:
        shown = self.failures[: self.policy.first]
        lines = [f"model runs stopped: {why}" + (f" (see {self.out / 'failures.csv'})" if self.out else "") + ":"]
        lines += [f"  {f.describe(self.parameters)}" for f in shown]
        return "\n".join(lines)

    def _write_failures(self) -> None:
        if self.out is not None:
            write_failures(self.out / "failures.csv", self.failures, self.parameters)

    def stats(self) -> dict:
        """Counts for summary.json: instances evaluated now, reused from the store, failed (and, reading
        the store only, the failures a run would have retried)."""
        stats = {"model_evaluations": self.model_evaluations, "reused_evaluations": self.reused_evaluations,
                 "failed_instances": len(self.failures),
                 "prediction_store": str(self.store.folder) if self.store is not None else None}
        if self.reuse_only:
            stats["failures_not_retried"] = self.failures_not_retried
        return stats

    def close(self) -> None:
        if self.pool is not None:
            self.pool.close()
        if self.command is not None:
            self.command.wait_for_cleanup()
            self._write_failures()
        if self._temp is not None and not any(self._temp.iterdir()):
            shutil.rmtree(self._temp, ignore_errors=True)


def _values(row) -> tuple[float, ...]:
    """A parameter row as plain floats (failures.csv and messages show ``60000.0``, not ``np.float64(60000.0)``)."""
    return tuple(float(v) for v in row)


def _finite(value: float) -> float | None:
    return None if np.isnan(value) else float(value)
