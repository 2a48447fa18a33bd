"""The durability layer around a falsification loop.

``falsify`` and ``falsify_model`` feed chunks to a Rust accumulator; whether
that work is saved to a checkpoint folder as it goes is this module's
business, not theirs. Both loops talk to a run object with the same small
interface, whichever kind it is:

- :class:`Ephemeral` (no ``checkpoint`` folder): every call is free and the
  result is read straight from the accumulator;
- :class:`Durable` (a folder): it resumes where the folder left off after
  checking every instance already done against the digests saved (the
  source hands the skipped rows to ``skipped``), records the digest of every
  chunk done, saves when due, on errors and at the end, and reads the
  finished result back from the folder.

The block checksums of the chunks a run falsifies are computed by the
falsifier in the same pass (``acc.update(chunk, digest=run.digest(first))``:
by the vector kernels as they read them, where the rows are stored back to
back; other rows 128 KiB at a time right after the kernel has read them,
while they are in cache); ``done`` sums in a
separate pass the rows that are not the falsifier's input (the parameter sets
of ``falsify_model``). Rows re-read on resumption are checked by a separate
``_core.RowDigest`` pass (``skipped``): that re-read is only a verification.
"""

from __future__ import annotations

import numpy as np

from ..stream.checkpoint import Checkpoint, save_on_error
from .candidate_set import CandidateSegments
from .result import FalsificationResult
from .thresholds import Thresholds

def from_accumulator(acc, measurements: np.ndarray, thresholds: Thresholds, **more) -> FalsificationResult:
    """Reads a finished ``_core.Falsifier`` into a :class:`FalsificationResult`
    (``more``: further fields, e.g. the candidates' parameters). The
    candidates are moved out as the accumulator keeps them (a bitmap where
    dense); their indices are formed only if ``candidate_indices`` is read."""
    tally = acc.tally()
    violations = acc.take_violations()
    count = int(acc.n_candidates)  # before the candidates are moved out
    return FalsificationResult(
        thresholds=thresholds,
        measurements=measurements,
        n_instances=int(acc.n_instances),
        candidate_indices=CandidateSegments(acc.take_candidate_segments(), count=count),
        per_sensor_falsified=None if tally is None else readonly(tally[0].astype(np.int64)),
        falsified_only_by=None if tally is None else readonly(tally[1].astype(np.int64)),
        n_invalid=None if tally is None else int(tally[2]),
        n_violated=None if violations is None else readonly(violations.view(np.int32)),
        **more,
    )

def saved_fields(ckpt: Checkpoint, n_sensors: int) -> dict:
    """A finished folder's result fields, the candidates left as the parts hold them."""
    fields = ckpt.saved(n_sensors)
    fields["candidate_indices"] = CandidateSegments(fields.pop("candidate_segments"))
    return fields


def readonly(arr: np.ndarray) -> np.ndarray:
    arr.flags.writeable = False
    return arr

class Ephemeral:
    """A run that keeps nothing: starts at instance 0, never finished before."""

    start = 0
    finished = False
    skipped = None

    def __enter__(self) -> Ephemeral:
        return self

    def __exit__(self, *exc) -> None:
        pass

    def digest(self, first: int) -> None:
        """No digest to feed: the falsifier hashes nothing."""
        return None

    def done(self, first: int, rows: np.ndarray) -> None:
        """Instances ``first ..`` (``rows``, the input rows) are in the accumulator."""

    def due(self) -> bool:
        return False

    def save(self, acc, kept=None, **extra) -> None:
        pass

    def save_on_error(self, acc, exc: BaseException, kept=None, **extra) -> None:
        pass

    @property
    def extra(self) -> dict:
        return {}

    def result(self, acc, measurements: np.ndarray, thresholds: Thresholds, kept=None,
               **extra) -> FalsificationResult:
        """The result read from ``acc``; ``kept``: the candidates' parameter and
        prediction rows, batch by batch (``falsify_model``)."""
        if kept is None:
            return from_accumulator(acc, measurements, thresholds)
        p = extra.get("n_parameters", 0)
        params = np.concatenate(kept["parameters"]) if kept["parameters"] else np.empty((0, p))
        preds = (np.concatenate(kept["predictions"]) if kept["predictions"]
                 else np.empty((0, measurements.shape[0])))
        return from_accumulator(acc, measurements, thresholds, candidate_parameters=readonly(params),
                                candidate_predictions=readonly(preds))

class Durable:
    """A run saved in a checkpoint folder (see :mod:`edmf_rs.stream.checkpoint`).

    ``start`` is the first instance still to do, ``skipped`` the check a
    resumed source applies to every row it skips (all rows before
    ``start``), ``finished`` whether the folder already holds the whole run.
    """

    def __init__(self, folder, fingerprint: dict, every: float, fields: tuple[str, ...] = (),
                 input_name: str = "predictions", rereadable: bool = True):
        self._ckpt = Checkpoint(folder, fingerprint, every, fields, input_name=input_name,
                                rereadable=rereadable)
        self.start = self._ckpt.n_done
        self.finished = self._ckpt.complete
        self.skipped = self._ckpt.verify_skipped

    def __enter__(self) -> Durable:
        return self

    def __exit__(self, *exc) -> None:
        self._ckpt.close()  # frees the folder for the next run, even after an error

    @property
    def extra(self) -> dict:
        """Small facts saved with the state (e.g. the number of parameters)."""
        return self._ckpt.extra

    def saved_result(self, rest, measurements: np.ndarray, thresholds: Thresholds,
                     trusted: bool = False) -> FalsificationResult:
        """The finished run's result, once the input is confirmed to be the
        same: ``rest`` is the input from instance ``start`` on, whose skipped
        rows are checked as it is drained. ``trusted``: ``rest`` is None, a
        one-pass iterator the caller vouches for (``trust_iterable=True``)."""
        if rest is None and not trusted:
            self._ckpt.refuse_unchecked()
        if rest is not None:
            self._ckpt.confirm_finished(rest)
        return FalsificationResult(thresholds=thresholds, measurements=measurements,
                                   **saved_fields(self._ckpt, thresholds.n_sensors))

    #: Whether ``digest`` hands the falsifier the run's digest (True), or leaves
    #: the hashing to ``done`` in a second pass (False: the older way, kept
    #: so tests and benchmarks can check both give the same folder).
    in_pass = True

    def digest(self, first: int):
        """The ``_core.RowDigest`` the falsifier feeds instances ``first ..``
        to in its own pass (None when ``in_pass`` is off: call ``done``)."""
        if not self.in_pass:
            return None
        return self._ckpt.digest_from(first)

    def done(self, first: int, rows: np.ndarray) -> None:
        if len(rows):
            self._ckpt.record(first, rows)  # the digest a resumption checks this chunk against

    def due(self) -> bool:
        return self._ckpt.due()

    def save(self, acc, kept=None, **extra) -> None:
        self._ckpt.extra.update(extra)
        self._ckpt.flush(acc, kept)

    def save_on_error(self, acc, exc: BaseException, kept=None, **extra) -> None:
        """Keeps the work done before ``exc`` (the failing chunk left no trace in ``acc``)."""
        self._ckpt.extra.update(extra)
        save_on_error(self._ckpt, acc, exc, kept)

    def result(self, acc, measurements: np.ndarray, thresholds: Thresholds, kept=None,
               **extra) -> FalsificationResult:
        """Saves the final state and reads the whole run back from the folder."""
        self._ckpt.extra.update(extra)
        self._ckpt.flush(acc, kept, final=True)
        return FalsificationResult(thresholds=thresholds, measurements=measurements,
                                   **saved_fields(self._ckpt, thresholds.n_sensors))

def open_run(folder, fingerprint: dict, every: float, fields: tuple[str, ...] = (),
             input_name: str = "predictions", rereadable: bool = True) -> Ephemeral | Durable:
    """A :class:`Durable` run in ``folder``, or an :class:`Ephemeral` one when it is None."""
    if folder is None:
        return Ephemeral()
    return Durable(folder, fingerprint, every, fields, input_name, rereadable)

__all__ = ["Durable", "Ephemeral", "from_accumulator", "open_run", "readonly"]
