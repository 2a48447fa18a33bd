"""Falsification of model instances (Eq. 8) by the Rust core, in memory or streaming."""

from __future__ import annotations

import os

import numpy as np

from . import _core
from ._validate import finite_vector, flag, positive_int
from .checkpoint import Checkpoint, digest, every_seconds, fingerprint, save_on_error
from .chunks import FileSource, close, open_source
from .npy import CHUNK_BYTES
from .progress import bar
from .result import FalsificationResult
from .thresholds import Thresholds


def falsify(predictions, measurements, thresholds: Thresholds, *, diagnostics: bool = True,
            keep_violations: bool | None = None, chunk_rows: int | None = None, progress: bool = True,
            checkpoint: str | os.PathLike | None = None, checkpoint_every: float = 60.0) -> FalsificationResult:
    """Falsify every model instance whose residual leaves the thresholds at any sensor.

    An instance (row of ``predictions``) is a candidate iff for every sensor i,
    ``low_i <= g_i(theta) - y_i <= high_i`` (Eq. 8, inclusive).

    Parameters
    ----------
    predictions
        Model predictions g(theta), one row per instance and one column per
        sensor: a 2-D float64/float32 array (C, Fortran or strided, read in
        place), a path to a ``.npy`` file of any size (read in chunks by a
        background thread while the previous chunk is falsified: memory does
        not grow with N; any byte order, integers allowed), or an iterable of
        2-D chunks (each used before the next is asked for, so a generator
        may refill one buffer). The result does not depend on the chunking
        nor on the thread count.
    measurements
        Measured values y, one per sensor.
    thresholds
        A :class:`Thresholds`, e.g. from :func:`threshold_bounds`.
    diagnostics
        Visit every sensor of every instance to count which sensors falsify
        what (default). ``False`` stops at the first violated sensor: fastest,
        candidates only.
    keep_violations
        Keep the number of violated sensors of every instance (``n_violated``).
        Default: yes for arrays and iterables, no for files and memory maps.
    chunk_rows
        Rows per chunk when splitting an array or reading a file.
    progress
        Show a progress bar once the run lasts a few seconds.
    checkpoint
        A folder where the run saves its candidates and position as it goes
        (every ``checkpoint_every`` seconds, on Ctrl-C and at the end). Calling
        again with the same folder and inputs resumes after the last saved
        chunk (or returns the finished result); other inputs are refused
        (checked by their measurements, thresholds, options, length and
        first and last rows done; a finished run over an iterable returns its
        saved result after checking only the iterable's first chunk). A folder
        serves one run at a time: a second run on it meanwhile is refused.
    """
    if not isinstance(thresholds, Thresholds):
        raise TypeError(f"thresholds: expected edmf_rs.Thresholds, got {type(thresholds).__name__}")
    y = finite_vector(measurements, "measurements")
    if y.shape[0] != thresholds.n_sensors:
        raise ValueError(
            f"measurements: expected {thresholds.n_sensors} values (one per threshold), got {y.shape[0]}"
        )
    if chunk_rows is not None:
        chunk_rows = positive_int(chunk_rows, "chunk_rows")
    diagnostics, progress = flag(diagnostics, "diagnostics"), flag(progress, "progress")
    every = every_seconds(checkpoint_every)
    if keep_violations is None:
        keep_violations = diagnostics and not isinstance(predictions, (str, bytes, os.PathLike, np.memmap))
    keep_violations = flag(keep_violations, "keep_violations")
    if keep_violations and not diagnostics:
        raise ValueError("keep_violations: expected False when diagnostics=False")
    if checkpoint is not None and chunk_rows is None:
        chunk_rows = max(1024, CHUNK_BYTES // (8 * y.shape[0]))  # so an array is checkpointed in steps too
    source = open_source(predictions, y.shape[0], chunk_rows)
    ckpt = None
    try:
        if checkpoint is not None:
            fp = fingerprint("falsify", y, thresholds, diagnostics=diagnostics,
                             keep_violations=keep_violations, n_instances=source.n_instances)
            ckpt = Checkpoint(checkpoint, fp, every,
                              ("n_violated",) if keep_violations else ())
            if ckpt.complete:
                if source.n_instances is not None:  # arrays and files: two rows read to confirm
                    ckpt.confirm_finished(source.chunks(ckpt.n_done, ckpt.verify_row))
                else:  # an iterable is not drained again: its first chunk is checked
                    ckpt.confirm_first_row(source.chunks())
                return ckpt.result(thresholds, y)
        start = ckpt.n_done if ckpt else 0

        acc = _core.Falsifier(y, thresholds.low, thresholds.high, diagnostics=diagnostics,
                              keep_violations=keep_violations)
        chunks = source.chunks(start, ckpt.verify_row if ckpt else None)
        tail = None  # (index, row) of the last instance falsified, for the checkpoint
        with bar(source.n_instances, progress and _streams(source, chunk_rows), initial=start) as progress_bar:
            try:
                for chunk in chunks:
                    first = start + int(acc.n_instances)
                    acc.update(chunk)
                    if ckpt is None:
                        progress_bar.update(chunk.shape[0])
                        continue
                    if chunk.shape[0]:
                        if first == 0:
                            ckpt.first_row = digest(chunk[0])
                        tail = (first + chunk.shape[0] - 1, chunk[-1].copy())
                    progress_bar.update(chunk.shape[0])
                    if ckpt.due():
                        ckpt.flush(acc, tail)
            except BaseException as exc:
                save_on_error(ckpt, acc, tail, exc)
                raise
            finally:
                close(chunks)
        if ckpt is None:
            return from_accumulator(acc, y, thresholds)
        ckpt.flush(acc, tail, final=True)
        return ckpt.result(thresholds, y)
    finally:
        if ckpt is not None:
            ckpt.close()  # frees the folder for the next run, even after an error


def _streams(source, chunk_rows) -> bool:
    """A bar is worth it for files, iterables and arrays cut into chunks."""
    return isinstance(source, FileSource) or source.n_instances is None or chunk_rows is not None


def from_accumulator(acc, measurements: np.ndarray, thresholds: Thresholds) -> FalsificationResult:
    """Reads a finished ``_core.Falsifier`` into a :class:`FalsificationResult`."""
    tally = acc.tally()
    violations = acc.take_violations()
    return FalsificationResult(
        thresholds=thresholds,
        measurements=measurements,
        n_instances=int(acc.n_instances),
        candidate_indices=_readonly(acc.take_candidates().view(np.int64)),  # moved, indices < 2**63: no copy
        per_sensor_falsified=None if tally is None else _readonly(tally[0].astype(np.int64)),
        falsified_only_by=None if tally is None else _readonly(tally[1].astype(np.int64)),
        n_invalid=None if tally is None else int(tally[2]),
        n_violated=None if violations is None else _readonly(violations.view(np.int32)),
    )


def _readonly(arr: np.ndarray) -> np.ndarray:
    arr.flags.writeable = False
    return arr
