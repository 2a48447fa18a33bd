"""Falsification of model instances (Eq. 8) by the Rust core, in memory or streaming."""

from __future__ import annotations

import os

import numpy as np

from . import _core
from ._validate import finite_vector, positive_int
from .chunks import iter_chunks
from .result import FalsificationResult
from .thresholds import Thresholds


def falsify(predictions, measurements, thresholds: Thresholds, *, diagnostics: bool = True,
            keep_violations: bool | None = None, chunk_rows: int | None = None) -> FalsificationResult:
    """Falsify every model instance whose residual leaves the thresholds at any sensor.

    An instance (row of ``predictions``) is a candidate iff for every sensor i,
    ``low_i <= g_i(theta) - y_i <= high_i`` (Eq. 8, inclusive).

    Parameters
    ----------
    predictions
        Model predictions g(theta), one row per instance and one column per
        sensor: a 2-D float64/float32 array (C, Fortran or strided, read in
        place), a path to a ``.npy`` file (read in chunks: memory does not grow
        with N), or an iterable of 2-D chunks. The result does not depend on
        the chunking nor on the thread count.
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
        Default: yes for arrays and iterables, no for files.
    chunk_rows
        Rows per chunk when splitting an array or reading a file.
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
    if keep_violations is None:
        keep_violations = diagnostics and not isinstance(predictions, (str, os.PathLike))
    if keep_violations and not diagnostics:
        raise ValueError("keep_violations: expected False when diagnostics=False")

    acc = _core.Falsifier(y, thresholds.low, thresholds.high, diagnostics=diagnostics,
                          keep_violations=bool(keep_violations))
    for chunk in iter_chunks(predictions, y.shape[0], chunk_rows):
        acc.update(chunk)
    return from_accumulator(acc, y, thresholds)


def from_accumulator(acc, measurements: np.ndarray, thresholds: Thresholds) -> FalsificationResult:
    """Reads a finished ``_core.Falsifier`` into a :class:`FalsificationResult`."""
    tally = acc.tally()
    violations = acc.take_violations()
    return FalsificationResult(
        thresholds=thresholds,
        measurements=measurements,
        n_instances=int(acc.n_instances),
        candidate_indices=_readonly(acc.candidates().astype(np.int64)),
        per_sensor_falsified=None if tally is None else _readonly(tally[0].astype(np.int64)),
        falsified_only_by=None if tally is None else _readonly(tally[1].astype(np.int64)),
        n_invalid=None if tally is None else int(tally[2]),
        n_violated=None if violations is None else _readonly(violations.view(np.int32)),
    )


def _readonly(arr: np.ndarray) -> np.ndarray:
    arr.flags.writeable = False
    return arr
