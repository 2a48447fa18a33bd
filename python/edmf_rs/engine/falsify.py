"""Falsification of model instances (Eq. 8) by the Rust core, in memory or streaming."""

from __future__ import annotations

import os

import numpy as np

from .. import _core
from ..stream.checkpoint import every_seconds
from ..stream.identity import fingerprint
from ..stream.chunks import FileSource, close, open_source
from ..stream.npy import CHUNK_BYTES
from ..stream.progress import bar
from ._validate import finite_vector, flag, positive_int
from .durable import open_run
from .result import FalsificationResult
from .thresholds import Thresholds


def falsify(predictions, measurements, thresholds: Thresholds, *, diagnostics: bool = True,
            keep_violations: bool | None = None, chunk_rows: int | None = None, progress: bool = True,
            checkpoint: str | os.PathLike | None = None, checkpoint_every: float = 60.0,
            trust_iterable: bool = False) -> FalsificationResult:
    """Falsify every model instance whose residual leaves the thresholds at any sensor.

    An instance (row of ``predictions``) is a candidate iff for every sensor i,
    ``low_i <= g_i(theta) - y_i <= high_i`` (Eq. 8, inclusive).

    Parameters
    ----------
    predictions : array_like, str, os.PathLike or iterable of arrays
        Model predictions g(theta), one row per instance and one column per
        sensor: a 2-D float64/float32 array (C, Fortran or strided, read in
        place), a path to a ``.npy`` file of any size (read in chunks by a
        background thread while the previous chunk is falsified: memory does
        not grow with N; any byte order, integers allowed), or an iterable of
        2-D chunks (each used before the next is asked for, so a generator
        may refill one buffer). The result does not depend on the chunking
        nor on the thread count.
    measurements : array_like
        Measured values y, one per sensor.
    thresholds : Thresholds
        The threshold bounds, e.g. from `threshold_bounds`.
    diagnostics : bool, default True
        Visit every sensor of every instance to count which sensors falsify
        what (default). ``False`` gives the candidates only (no per-sensor
        counts, no per-instance values): fastest.
    keep_violations : bool, optional
        Keep the number of violated sensors of every instance (``n_violated``).
        Default: yes for arrays and iterables, no for files and memory maps.
    chunk_rows : int, optional
        Rows per chunk when splitting an array or reading a file.
    progress : bool, default True
        Show a progress bar once the run lasts a few seconds.
    checkpoint : str or os.PathLike, optional
        A folder where the run saves its candidates and position as it goes
        (every ``checkpoint_every`` seconds, on Ctrl-C and at the end). Calling
        again with the same folder and inputs resumes after the last saved
        chunk (or returns the finished result); other inputs are refused,
        checked by their measurements, thresholds, options, length and a
        checksum of every block of instances already done (a guard against
        accidental change, not tampering), re-read on resumption
        (the error names the first block of instances that differs). A
        folder serves one run at a time: a second run on it meanwhile is
        refused.
    checkpoint_every : float, default 60.0
        Seconds between saves of the checkpoint, at least: a save also waits
        until the run has worked 19 times as long as the last save took (a
        save rewrites a state listing every save before it), so saves take
        at most about 5 % of the run. With 0, the run saves as soon as that
        much work is done (after every chunk, where chunks take that long).
    trust_iterable : bool, default False
        When the folder holds a finished run and ``predictions`` is a
        one-pass iterator (e.g. a generator), return the saved result without
        drawing it again to check it; without this, that case is refused
        (ValueError), since checking would mean producing every chunk again.
        Arrays, files and lists of chunks are always checked.

    Returns
    -------
    FalsificationResult
        The candidate model set (``candidate_indices``) and, with
        ``diagnostics``, how many instances each sensor falsifies.

    Raises
    ------
    TypeError
        If ``thresholds`` is not a `Thresholds`, or ``predictions`` is not an
        array, a path or an iterable of numeric 2-D chunks.
    ValueError
        If ``measurements`` is not a finite vector with one value per
        threshold, the predictions do not have one column per sensor,
        ``keep_violations`` is asked without ``diagnostics``, or
        ``checkpoint`` holds a run made with other inputs (or its files were
        changed since), is in use by another run, or cannot be written.
    CheckpointError
        If saving the checkpoint fails during the run (e.g. a full disk); the
        folder keeps its last saved state.

    Examples
    --------
    Three model instances (rows) at two sensors (columns):

    >>> import numpy as np
    >>> import edmf_rs
    >>> thresholds = edmf_rs.Thresholds(low=[-1.0, -1.0], high=[1.0, 1.0])
    >>> predictions = np.array([[10.5, 20.0], [12.0, 20.0], [10.0, 18.5]])
    >>> result = edmf_rs.falsify(predictions, [10.0, 20.0], thresholds, progress=False)
    >>> result.candidate_indices.tolist(), result.per_sensor_falsified.tolist()
    ([0], [1, 1])
    >>> result.model_class_falsified
    False
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
    trust_iterable = flag(trust_iterable, "trust_iterable")
    every = every_seconds(checkpoint_every)
    if keep_violations is None:
        keep_violations = diagnostics and not isinstance(predictions, (str, bytes, os.PathLike, np.memmap))
    keep_violations = flag(keep_violations, "keep_violations")
    if keep_violations and not diagnostics:
        raise ValueError("keep_violations: expected False when diagnostics=False")
    if checkpoint is not None and chunk_rows is None and not isinstance(predictions, (str, bytes, os.PathLike)):
        # So an array is checkpointed in steps too, of the reader's chunk size
        # (a file is read in those already): float32 rows are read as they are.
        item = 4 if getattr(predictions, "dtype", None) == np.float32 else 8
        chunk_rows = max(1024, CHUNK_BYTES // (item * y.shape[0]))
    source = open_source(predictions, y.shape[0], chunk_rows)
    fields = ("n_violated",) if keep_violations else ()
    fp = fingerprint("falsify", y, thresholds, diagnostics=diagnostics, keep_violations=keep_violations,
                     n_instances=source.n_instances)
    with open_run(checkpoint, fp, every, fields, rereadable=source.rereadable) as run:
        if run.finished:  # every instance is re-read and checked, unless a one-pass iterator is trusted
            rest = source.chunks(run.start, run.skipped) if source.rereadable else None
            return run.saved_result(rest, y, thresholds, trusted=trust_iterable)
        acc = _core.Falsifier(y, thresholds.low, thresholds.high, diagnostics=diagnostics,
                              keep_violations=keep_violations)
        chunks = source.chunks(run.start, run.skipped)
        with bar(source.n_instances, progress and _streams(source, chunk_rows), initial=run.start) as progress_bar:
            try:
                for chunk in chunks:  # Eq. 8, chunk after chunk, in Rust with the GIL released
                    first = run.start + int(acc.n_instances)
                    digest = run.digest(first)  # summed by the falsifier while the rows are in cache
                    acc.update(chunk, digest=digest)
                    if digest is None:
                        run.done(first, chunk)
                    progress_bar.update(chunk.shape[0])
                    if run.due():
                        run.save(acc)
            except BaseException as exc:
                run.save_on_error(acc, exc)
                raise
            finally:
                close(chunks)
        return run.result(acc, y, thresholds)


def _streams(source, chunk_rows) -> bool:
    """A bar is worth it for files, iterables and arrays cut into chunks."""
    return isinstance(source, FileSource) or source.n_instances is None or chunk_rows is not None
