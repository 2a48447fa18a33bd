"""Falsification straight from a Python model: parameters in, candidates out.

Batches are pipelined: while the Rust core falsifies batch k on its own
threads (the GIL released), Python evaluates the model on batch k+1. Only the
candidates' parameters and predictions are kept, so memory follows the size
of the candidate model set, not the number of instances.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from .. import _core
from ..stream.checkpoint import every_seconds
from ..stream.chunks import Skipped, as_chunk, skip_rows
from ..stream.identity import fingerprint, model_fingerprint
from ..stream.progress import bar
from ._validate import finite_vector, flag, positive_int, real_array
from .durable import open_run
from .result import FalsificationResult
from .sensors import SensorMatch, SensorMismatch, named_output, sensor_match
from .thresholds import Thresholds


def parameter_batches(parameters, batch_size: int, start: int = 0,
                      skipped: Skipped | None = None) -> tuple[Iterator[np.ndarray], int | None]:
    """Batches of parameter sets (float64 rows) from row ``start`` on, and the
    total count when known. When resuming, ``skipped`` sees every row before
    ``start``, in blocks (for an array, when the batches are drawn)."""
    if is_parameter_array(parameters):
        arr = real_array(parameters, "parameters", copy=False)  # a memmap stays on disk
        if arr.ndim == 1:
            arr = arr[:, None]
        if arr.ndim != 2:
            raise ValueError(f"parameters: expected an (N, p) array, got shape {arr.shape}")
        def sliced() -> Iterator[np.ndarray]:
            if skipped is not None:
                for i in range(0, min(start, arr.shape[0]), batch_size):
                    skipped(i, arr[i:min(i + batch_size, start)])
            for i in range(start, arr.shape[0], batch_size):
                yield arr[i:i + batch_size]
        return sliced(), arr.shape[0]
    if isinstance(parameters, (str, bytes)) or not isinstance(parameters, Iterable):
        raise TypeError(
            f"parameters: expected an (N, p) array or an iterable of (n, p) batches, got {type(parameters).__name__}"
        )

    def checked() -> Iterator[np.ndarray]:
        width = None
        for k, batch in enumerate(parameters):
            # A copy: batch k is still being falsified while the source
            # produces batch k+1, perhaps into the same buffer.
            arr = real_array(batch, f"parameters (batch {k})", copy=True)
            arr = arr[:, None] if arr.ndim == 1 else arr
            if arr.ndim != 2 or (width is not None and arr.shape[1] != width):
                raise ValueError(
                    f"parameters: batch {k} has shape {arr.shape}, expected (n, {width or 'p'})"
                    + (" like the batches before it" if width is not None else "")
                )
            width = arr.shape[1]
            yield arr
    return skip_rows(checked(), start, skipped, "parameters"), None


def evaluate(model: Callable, batch: np.ndarray, offset: int, n_sensors: int, nan: str,
             index: int | None = None, match: SensorMatch | None = None) -> np.ndarray:
    """Runs the model on one batch and checks what it returns.

    With ``match``, named outputs (DataFrame, mapping, structured array) are
    matched to the sensors by name; without it, a named output is refused
    rather than read by position.
    """
    where = (f"batch {index}, " if index is not None else "") + f"instances {offset}..{offset + len(batch) - 1}"
    # A read-only copy: a model that edits its input in place would otherwise
    # change the caller's array and the candidates' reported parameters.
    theta = batch.copy()
    theta.flags.writeable = False
    try:
        predictions = model(theta)
    except Exception as exc:
        exc.add_note(f"edmf_rs: raised by the model on {where}")
        raise
    names, _ = named_output(predictions)
    if match is not None:
        try:
            predictions = match(predictions, batch.shape[0])
        except SensorMismatch as exc:
            raise ValueError(f"model: {exc} ({where})") from None
    elif names is not None:
        shown = ", ".join(names[:8]) + (", ..." if len(names) > 8 else "")
        raise TypeError(
            f"model: returned {type(predictions).__name__} with named columns ({shown}) on {where}; pass "
            "sensors=[...] (the measurements' sensor names, in order) so they are matched by name")
    try:
        predictions = np.asarray(predictions)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"model: expected an array of predictions, got {type(predictions).__name__} "
                        f"on {where}") from exc
    if predictions.shape != (batch.shape[0], n_sensors):
        raise ValueError(
            f"model: returned shape {predictions.shape} for {batch.shape[0]} parameter sets ({where}), "
            f"expected ({batch.shape[0]}, {n_sensors}) (one prediction per sensor)"
        )
    chunk = as_chunk(predictions, n_sensors, name=f"model ({where})")
    if np.may_share_memory(chunk, predictions):
        # Rust reads this batch while the model computes the next one: a model
        # that reuses its output buffer would overwrite it under the reader.
        chunk = chunk.copy()
    if nan == "raise":  # an infinite prediction is a failed model run too (an overflow, a diverged solver)
        bad = np.flatnonzero(~np.isfinite(chunk).all(axis=1))
        if bad.size:
            raise ValueError(
                f"model: returned {non_finite(chunk[bad[0]])} for instance {offset + bad[0]} ({where}; parameters "
                f"{batch[bad[0]].tolist()}); pass nan='falsify' to count instances with NaN as invalid and "
                "falsify those with infinite predictions instead"
            )
    return chunk


def non_finite(row: np.ndarray) -> str:
    """What a row of predictions holds that is not finite: "NaN", "inf" or "-inf" (the first such value)."""
    value = row[~np.isfinite(row)][0]
    return "NaN" if np.isnan(value) else ("inf" if value > 0 else "-inf")


def falsify_model(model: Callable, parameters, measurements, thresholds: Thresholds, *,
                  batch_size: int = 10_000, diagnostics: bool = True, keep_violations: bool = False,
                  nan: str = "raise", progress: bool = True,
                  on_batch: Callable[[int, np.ndarray, np.ndarray], None] | None = None,
                  checkpoint: str | os.PathLike | None = None,
                  checkpoint_every: float = 60.0, trust_iterable: bool = False,
                  sensors: Sequence[str] | None = None) -> FalsificationResult:
    """Evaluate ``model`` on every parameter set and falsify as it goes (Eq. 8).

    Python evaluates the model on batch k+1 while the Rust core falsifies
    batch k with the GIL released; only the candidates' parameters and
    predictions are kept, so memory follows the candidate set, not N.

    Parameters
    ----------
    model : callable
        Vectorised callable: ``model(batch)`` with ``batch`` of shape (n, p)
        returns predictions of shape (n, n_m), one column per sensor. The
        batch it gets is a read-only copy (editing it in place raises).
    parameters : array_like or iterable of arrays
        An (N, p) array, or an iterable of (n, p) batches consumed once (e.g.
        a generator of ``scipy.stats.qmc.Sobol(d).random(n)`` draws).
    measurements : array_like
        Measured values y, one per sensor.
    thresholds : Thresholds
        The threshold bounds, e.g. from `threshold_bounds`.
    batch_size : int, default 10_000
        Parameter sets per call of ``model`` when ``parameters`` is an array.
    diagnostics : bool, default True
        Count which sensors falsify what (see `falsify`).
    keep_violations : bool, default False
        Keep the number of violated sensors of every instance.
    nan : {"raise", "falsify"}, default "raise"
        ``"raise"`` (default): a NaN or infinite prediction is an error
        naming the instance; ``"falsify"``: instances with NaN are counted
        invalid, and infinite predictions are falsified by their residual.
    on_batch : callable, optional
        Called as ``on_batch(offset, parameters, predictions)`` for every batch,
        e.g. to compute extra diagnostics.
    progress : bool, default True
        Show a progress bar once the run lasts a few seconds.
    checkpoint : str or os.PathLike, optional
        A folder where the run saves its candidates and position as it goes
        (every ``checkpoint_every`` seconds, on Ctrl-C or a model error, and at
        the end). Calling again with the same folder and inputs resumes after
        the last saved batch without evaluating the model on the parameter
        sets already done (an iterable is still drawn from, to skip them; an
        array is sliced; every parameter set already done is checked against
        the digests saved); other inputs (including another model, see
        :func:`edmf_rs.stream.identity.model_fingerprint`) are refused, and
        so is a second run on the folder while this one holds it.
    checkpoint_every : float, default 60.0
        Seconds between saves of the checkpoint, at least: a save also waits
        until the run has worked 19 times as long as the last save took (a
        save rewrites a state listing every save before it), so saves take
        at most about 5 % of the run. With 0, the run saves as soon as that
        much work is done (after every chunk, where chunks take that long).
    trust_iterable : bool, default False
        When the folder holds a finished run and ``parameters`` is a one-pass
        iterator, return the saved result without drawing it again to check
        it (else ValueError). Arrays and lists of batches are always checked.
    sensors : sequence of str, optional
        The names of the sensors of ``measurements``, in order. The model may
        then return a ``pandas.DataFrame``, a mapping of sensor name to column
        or a structured array: columns are matched to the sensors by name, in
        any order, and outputs no sensor uses are ignored (with a warning). A
        bare array is read by position, one column per sensor in this order.
        Without ``sensors``, a model output with named columns is refused.

    Returns
    -------
    FalsificationResult
        Its ``candidate_parameters`` and ``candidate_predictions`` hold the
        candidates' rows.

    Raises
    ------
    TypeError
        If ``model`` or ``on_batch`` is not callable, ``thresholds`` is not a
        `Thresholds`, ``parameters`` is neither an array nor an iterable of
        batches, or the model returns something that is not an array.
    ValueError
        If the model returns the wrong shape, or NaN with ``nan="raise"``;
        if batches differ in width; if an argument is out of range; or if
        ``checkpoint`` holds a run made with other inputs or is in use.
    CheckpointError
        If saving the checkpoint fails during the run (e.g. a full disk).
    Exception
        Whatever the model raises, with a note naming the batch and instances.

    Examples
    --------
    A one-parameter model at two sensors, ten parameter values:

    >>> import numpy as np
    >>> import edmf_rs
    >>> def model(theta):                       # (n, 1) -> (n, 2)
    ...     return np.column_stack([theta[:, 0], 2 * theta[:, 0]])
    >>> thresholds = edmf_rs.Thresholds(low=[-1.5, -1.5], high=[1.5, 1.5])
    >>> result = edmf_rs.falsify_model(model, np.arange(10.0), [4.0, 8.0], thresholds, progress=False)
    >>> result.candidate_indices.tolist()
    [4]
    >>> result.candidate_parameters.tolist(), result.candidate_predictions.tolist()
    ([[4.0]], [[4.0, 8.0]])
    """
    if not callable(model):
        raise TypeError(f"model: expected a callable, got {type(model).__name__}")
    if not isinstance(thresholds, Thresholds):
        raise TypeError(f"thresholds: expected edmf_rs.Thresholds, got {type(thresholds).__name__}")
    if nan not in ("raise", "falsify"):
        raise ValueError(f"nan: expected 'raise' or 'falsify', got {nan!r}")
    if on_batch is not None and not callable(on_batch):
        raise TypeError(f"on_batch: expected a callable or None, got {type(on_batch).__name__}")
    diagnostics, progress = flag(diagnostics, "diagnostics"), flag(progress, "progress")
    keep_violations = flag(keep_violations, "keep_violations")
    trust_iterable = flag(trust_iterable, "trust_iterable")
    if keep_violations and not diagnostics:
        raise ValueError("keep_violations: expected False when diagnostics=False")
    y = finite_vector(measurements, "measurements", n=thresholds.n_sensors)
    batch_size = positive_int(batch_size, "batch_size")
    every = every_seconds(checkpoint_every)
    match = sensor_match(sensors, y.shape[0])
    n_total = _known_length(parameters)
    named = {"sensors": list(sensors)} if sensors is not None else {}
    fp = fingerprint("falsify_model", y, thresholds, diagnostics=diagnostics, keep_violations=keep_violations,
                     nan=nan, model=model_fingerprint(model), n_instances=n_total, **named)
    fields = ("n_violated",) if keep_violations else ()
    rereadable = n_total is not None or not isinstance(parameters, Iterator)
    with open_run(checkpoint, fp, every, fields + ("parameters", "predictions"), input_name="parameters",
                  rereadable=rereadable) as run:
        if run.finished:  # the rows done are checked as they are skipped, unless a one-pass iterator is trusted
            rest = parameter_batches(parameters, batch_size, run.start, run.skipped)[0] if rereadable else None
            return run.saved_result(rest, y, thresholds, trusted=trust_iterable)
        start = run.start
        batches, total = parameter_batches(parameters, batch_size, start, run.skipped)
        acc = _core.Falsifier(y, thresholds.low, thresholds.high, diagnostics=diagnostics,
                              keep_violations=keep_violations)
        kept: dict[str, list[np.ndarray]] = {"parameters": [], "predictions": []}
        n_params = run.extra.get("n_parameters")
        if n_params is None and isinstance(parameters, np.ndarray) and parameters.ndim in (1, 2):
            n_params = parameters.shape[1] if parameters.ndim == 2 else 1  # known even when there are no rows

        def falsify_batch(params: np.ndarray, preds: np.ndarray, offset: int) -> None:
            # Runs on the worker thread, which signals never interrupt: the
            # accumulator, the kept rows and the run's record move together.
            acc.update(preds)
            local = acc.candidates_since(offset).astype(np.int64) - offset
            kept["parameters"].append(params[local])
            kept["predictions"].append(preds[local])
            run.done(start + offset, params)

        with ThreadPoolExecutor(max_workers=1, thread_name_prefix="edmf-rs-falsify") as pool, \
                bar(total, progress, initial=start) as progress_bar:
            pending = None
            offset = 0  # instances of this session (after `start`)
            try:
                for k, params in enumerate(batches):
                    if n_params is not None and params.shape[1] != n_params:
                        raise ValueError(f"parameters: batch {k} has {params.shape[1]} columns, expected {n_params}"
                                         " like the batches before it")
                    n_params = params.shape[1]
                    if params.shape[0] == 0:
                        continue
                    # The model runs here while the worker falsifies the previous batch.
                    preds = evaluate(model, params, start + offset, y.shape[0], nan, k if start == 0 else None,
                                     match)
                    if match is not None and offset == 0 and match.mapping.ignored:
                        warnings.warn(f"model outputs not among the sensors, ignored: "
                                      f"{', '.join(match.mapping.ignored)}", UserWarning, stacklevel=2)
                    if on_batch is not None:
                        on_batch(start + offset, params, preds)
                    if pending is not None:
                        pending.result()
                        pending = None
                        if run.due():
                            run.save(acc, kept, n_parameters=n_params)
                    pending = pool.submit(falsify_batch, params, preds, offset)
                    offset += params.shape[0]
                    progress_bar.update(params.shape[0])
                if pending is not None:
                    pending.result()
            except BaseException as exc:
                try:
                    if pending is not None:
                        pending.result()  # the worker's batch completes or leaves no trace
                except BaseException:
                    pass
                if pending is None or pending.done():  # never save while the worker runs
                    run.save_on_error(acc, exc, kept, n_parameters=n_params)
                raise

        return run.result(acc, y, thresholds, kept, n_parameters=n_params if n_params is not None else 0)


def is_parameter_array(parameters) -> bool:
    """An (N, p) array, or a list of parameter rows (a list of 2-D blocks is
    an iterable of batches)."""
    return isinstance(parameters, np.ndarray) or (isinstance(parameters, (list, tuple)) and bool(parameters)
                                                  and np.ndim(parameters[0]) < 2)


def _known_length(parameters) -> int | None:
    return int(np.shape(parameters)[0]) if is_parameter_array(parameters) else None
