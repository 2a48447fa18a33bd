"""Falsification beyond one machine, with Dask (optional: ``pip install edmf_rs[dask]``).

Each task runs the Rust kernel on one block of rows and returns a small
result (the block's candidates and counts); the blocks' results are merged
exactly by `edmf_rs.concatenate`, so the outcome equals the in-process
call whatever the chunking, the number of workers or their threads. On a
``distributed`` worker the Rust thread pool is sized to the worker's threads.
"""

from __future__ import annotations

import os
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import replace

import numpy as np

try:
    import dask
    import dask.array as da
except ImportError as exc:  # pragma: no cover - exercised in a subprocess test
    raise ImportError(
        "edmf_rs.dask needs Dask: install it with `pip install edmf_rs[dask]` "
        "(or `pip install 'dask[array]' distributed`)"
    ) from exc

from . import _core
from .engine._validate import finite_vector, flag, positive_int, real_array
from .engine.durable import from_accumulator
from .engine.durable import readonly as _readonly
from .engine.model import evaluate, is_parameter_array
from .engine.result import FalsificationResult, concatenate
from .engine.sensors import SensorMatch, sensor_match
from .engine.thresholds import Thresholds
from .stream.chunks import as_chunk
from .stream.progress import bar


def falsify(predictions, measurements, thresholds: Thresholds, *, diagnostics: bool = True,
            keep_violations: bool = False, client=None, progress: bool = True) -> FalsificationResult:
    """`edmf_rs.falsify` over the row blocks of a ``dask.array`` (N, n_m).

    Each task runs the Rust kernel on one block; the blocks' results are
    merged exactly by `edmf_rs.concatenate`, so the result equals the
    in-process call whatever the chunking. Columns are gathered into one
    chunk (rows keep their chunking, unless the columns were split too: then
    rows are rechunked to Dask's default size, except rows of unknown size,
    e.g. after boolean indexing, which keep theirs).

    Parameters
    ----------
    predictions : dask.array.Array or array_like
        Predictions g(theta), (N, n_m), numeric.
    measurements : array_like
        Measured values y, one per sensor.
    thresholds : Thresholds
        The threshold bounds.
    diagnostics : bool, default True
        Count which sensors falsify what.
    keep_violations : bool, default False
        Bring back the number of violated sensors of every instance (N counts).
    client : distributed.Client, optional
        Where to run; default: the current Dask scheduler.
    progress : bool, default True
        Show a progress bar (on a ``distributed`` client).

    Returns
    -------
    FalsificationResult

    Raises
    ------
    TypeError
        If ``thresholds`` is not a `Thresholds`, the predictions are not a
        numeric array (a path or an iterator is refused), or ``client`` is
        not a ``distributed.Client``.
    ValueError
        If the predictions are not 2-D with one column per measurement, or
        ``keep_violations`` is asked without ``diagnostics``.

    Examples
    --------
    >>> import numpy as np
    >>> import dask.array as da
    >>> import edmf_rs, edmf_rs.dask
    >>> t = edmf_rs.Thresholds(low=[-1.0], high=[1.0])
    >>> P = da.from_array(np.array([[0.0], [5.0], [0.5], [-3.0], [1.0]]), chunks=(2, 1))
    >>> edmf_rs.dask.falsify(P, [0.0], t, progress=False).candidate_indices.tolist()
    [0, 2, 4]
    """
    y, thresholds = _checked(measurements, thresholds)
    client = _checked_client(client)
    arr = _dask_array(predictions)
    if arr.ndim != 2 or arr.shape[1] != y.shape[0]:
        raise ValueError(
            f"predictions: expected a 2-D array with {y.shape[0]} columns (one per sensor, as in "
            f"measurements), got shape {arr.shape}"
        )
    if arr.dtype.kind not in "iufb":
        raise TypeError(f"predictions: expected a numeric array of predictions, got dtype {arr.dtype}")
    diagnostics, progress = flag(diagnostics, "diagnostics"), flag(progress, "progress")
    keep_violations = flag(keep_violations, "keep_violations")
    if keep_violations and not diagnostics:
        raise ValueError("keep_violations: expected False when diagnostics=False")
    unknown_rows = any(np.isnan(c) for c in arr.chunks[0])
    if len(arr.chunks[1]) > 1:
        # Rows of unknown size (e.g. after boolean indexing) cannot be rechunked: keep them.
        arr = arr.rechunk({1: -1} if unknown_rows else {0: "auto", 1: -1})
    task = dask.delayed(_falsify_block, pure=True)
    low, high = thresholds.low, thresholds.high
    parts = [task(block, y, low, high, diagnostics, keep_violations)
             for block in arr.to_delayed().ravel()]
    rows = None if unknown_rows else arr.chunks[0]
    return _merged(_compute(parts, client, progress, rows), y, thresholds)


def falsify_model(model: Callable, parameters, measurements, thresholds: Thresholds, *, client=None,
                  batch_size: int = 10_000, diagnostics: bool = True, keep_violations: bool = False,
                  nan: str = "raise", progress: bool = True, window: int | None = None,
                  sensors: Sequence[str] | None = None) -> FalsificationResult:
    """`edmf_rs.falsify_model` with the model evaluated on Dask workers,
    one task per batch of parameter sets.

    Parameters
    ----------
    model : callable
        Vectorised: (n, p) parameters -> (n, n_m) predictions. Must be
        picklable (cloudpickle: lambdas and closures are fine) and importable
        on the workers.
    parameters : array_like, dask.array.Array or iterable of arrays
        An (N, p) NumPy or Dask array (cut into ``batch_size`` rows; a Dask
        array's parameters are generated where they are used), or an iterable
        of (n, p) batches, sent ``window`` batches at a time so the caller
        never holds them all.
    measurements : array_like
        Measured values y, one per sensor.
    thresholds : Thresholds
        The threshold bounds.
    client : distributed.Client, optional
        Where to run; default: the current Dask scheduler.
    batch_size : int, default 10_000
        Rows per task for array parameters.
    diagnostics, keep_violations, nan, progress
        As in `edmf_rs.falsify_model`.
    window : int, optional
        Batches of an iterable in flight at once; default four per worker thread.
    sensors : sequence of str, optional
        The names of the sensors of ``measurements``, in order: the model may
        then return a ``pandas.DataFrame``, a mapping of sensor name to column
        or a structured array, matched to the sensors by name on the workers
        (outputs no sensor uses are ignored, with a warning), as in
        `edmf_rs.falsify_model`. Without it, a named output is refused.

    Returns
    -------
    FalsificationResult
        With ``candidate_parameters`` and ``candidate_predictions``; equal to
        the in-process call.

    Raises
    ------
    TypeError
        If ``model`` is not callable, ``thresholds`` is not a `Thresholds`,
        ``parameters`` is neither an array nor an iterable of batches, or
        ``client`` is not a ``distributed.Client``.
    ValueError
        If an argument is out of range, a Dask array of parameters has
        chunks of unknown size, batches differ in width, ``sensors``
        does not name each measurement once, the model returns the wrong
        shape or NaN (with ``nan="raise"``), or its named outputs lack a
        sensor (naming the sensors on both sides).

    Examples
    --------
    >>> import numpy as np
    >>> import edmf_rs, edmf_rs.dask
    >>> def model(theta):
    ...     return np.column_stack([theta[:, 0], 2 * theta[:, 0]])
    >>> t = edmf_rs.Thresholds(low=[-1.5, -1.5], high=[1.5, 1.5])
    >>> r = edmf_rs.dask.falsify_model(model, np.arange(10.0), [4.0, 8.0], t, batch_size=3, progress=False)
    >>> r.candidate_parameters.tolist()
    [[4.0]]
    """
    if not callable(model):
        raise TypeError(f"model: expected a callable, got {type(model).__name__}")
    if nan not in ("raise", "falsify"):
        raise ValueError(f"nan: expected 'raise' or 'falsify', got {nan!r}")
    diagnostics, progress = flag(diagnostics, "diagnostics"), flag(progress, "progress")
    keep_violations = flag(keep_violations, "keep_violations")
    if keep_violations and not diagnostics:
        raise ValueError("keep_violations: expected False when diagnostics=False")
    y, thresholds = _checked(measurements, thresholds)
    client = _checked_client(client)
    batch_size = positive_int(batch_size, "batch_size")
    names = tuple(sensor_match(sensors, y.shape[0]).sensors) if sensors is not None else None
    task = dask.delayed(_model_block, pure=True)
    args = (model, y, thresholds.low, thresholds.high, diagnostics, keep_violations, nan, names)

    if isinstance(parameters, da.Array) or is_parameter_array(parameters):
        arr = parameters if isinstance(parameters, da.Array) else da.from_array(
            real_array(parameters, "parameters", copy=False))
        arr = arr[:, None] if arr.ndim == 1 else arr
        if arr.ndim != 2:
            raise ValueError(f"parameters: expected an (N, p) array, got shape {arr.shape}")
        if any(np.isnan(n) for n in arr.shape):  # each batch's first instance must be known
            raise ValueError(f"parameters: expected a dask array of known chunk sizes, got shape {arr.shape} "
                             "(e.g. after boolean indexing); call parameters.compute_chunk_sizes() first")
        arr = arr.rechunk({0: batch_size, 1: -1})
        offsets = np.concatenate([[0], np.cumsum(arr.chunks[0])[:-1]]).astype(int)
        blocks = arr.to_delayed().ravel()
        parts = [task(block, int(off), k, *args) for k, (block, off) in enumerate(zip(blocks, offsets))]
        return _merged_blocks(_compute(parts, client, progress, arr.chunks[0]), y, thresholds)
    if isinstance(parameters, (str, bytes)) or not isinstance(parameters, Iterable):
        raise TypeError(
            f"parameters: expected an (N, p) array or an iterable of (n, p) batches, got {type(parameters).__name__}"
        )
    window = positive_int(window, "window") if window is not None else 4 * max(_total_threads(client), 1)
    results: list[FalsificationResult] = []
    offset, width, pending, sizes = 0, None, [], []
    with bar(None, progress) as progress_bar:
        for k, batch in enumerate(parameters):
            # A copy: batches wait in the window, and a generator may refill one buffer.
            arr = real_array(batch, f"parameters (batch {k})", copy=True)
            arr = arr[:, None] if arr.ndim == 1 else arr
            if arr.ndim != 2 or (width is not None and arr.shape[1] != width):
                raise ValueError(f"parameters: batch {k} has shape {arr.shape}, expected (n, {width or 'p'})")
            width = arr.shape[1]
            pending.append(task(arr, offset, k, *args))
            sizes.append(arr.shape[0])
            offset += arr.shape[0]
            if len(pending) == window:
                results += _compute(pending, client, False)
                progress_bar.update(sum(sizes))
                pending, sizes = [], []
        results += _compute(pending, client, False)
        progress_bar.update(sum(sizes))
    if not results:
        return _merged_blocks([_model_block(np.empty((0, width or 0)), 0, 0, *args)], y, thresholds)
    return _merged_blocks(results, y, thresholds)


# -- on the workers --------------------------------------------------------

def _falsify_block(block, y, low, high, diagnostics, keep_violations) -> FalsificationResult:
    _match_worker_threads()
    y, low, high = _aligned(y, low, high)
    acc = _core.Falsifier(y, low, high, diagnostics=diagnostics, keep_violations=keep_violations)
    acc.update(as_chunk(block, y.shape[0]))
    return from_accumulator(acc, y, Thresholds(low, high))


def _model_block(params, offset, index, model, y, low, high, diagnostics, keep_violations, nan, sensors=None):
    """One batch: (its falsification result, the model outputs no sensor uses)."""
    _match_worker_threads()
    y, low, high = _aligned(y, low, high)
    params = np.asarray(params, dtype=np.float64)
    acc = _core.Falsifier(y, low, high, diagnostics=diagnostics, keep_violations=keep_violations)
    match = SensorMatch(sensors) if sensors is not None else None
    if params.shape[0]:
        preds = evaluate(model, params, offset, y.shape[0], nan, index, match)
        acc.update(preds)
    else:
        preds = np.empty((0, y.shape[0]))
    result = from_accumulator(acc, y, Thresholds(low, high))
    local = result.candidate_indices
    ignored = match.mapping.ignored if match is not None and match.mapping is not None else ()
    return replace(result, candidate_parameters=params[local], candidate_predictions=preds[local]), ignored


def _aligned(*vectors: np.ndarray) -> list[np.ndarray]:
    # Arrays unpickled from out-of-band buffers may be misaligned; the core
    # constructor wants contiguous, aligned float64.
    return [np.require(v, dtype=np.float64, requirements=["C", "A"]) for v in vectors]


def _match_worker_threads() -> None:
    """Sizes the Rust pool to this ``distributed`` worker's threads."""
    try:
        from distributed import get_worker

        worker = get_worker()
    except (ImportError, ValueError):
        return  # not on a distributed worker: keep the process's own setting
    _size_pool(worker)


def _size_pool(dask_worker) -> None:
    n = dask_worker.state.nthreads
    if _core.get_num_threads() != n:
        _core.set_num_threads(n)


# -- on the caller ----------------------------------------------------------

def _checked(measurements, thresholds) -> tuple[np.ndarray, Thresholds]:
    if not isinstance(thresholds, Thresholds):
        raise TypeError(f"thresholds: expected edmf_rs.Thresholds, got {type(thresholds).__name__}")
    return finite_vector(measurements, "measurements", n=thresholds.n_sensors), thresholds


def _dask_array(predictions) -> da.Array:
    """``predictions`` as a Dask array; a path, an iterator or ragged rows are refused by name."""
    if isinstance(predictions, da.Array):
        return predictions
    if isinstance(predictions, (str, bytes, os.PathLike)):
        raise TypeError("predictions: expected a dask array or an array of shape (instances, sensors), got a path; "
                        "stream a .npy file with edmf_rs.falsify, or pass da.from_array(np.load(path, mmap_mode='r'))")
    if not (hasattr(predictions, "__array__") or isinstance(predictions, (list, tuple))):
        raise TypeError("predictions: expected a dask array or an array of shape (instances, sensors), "
                        f"got {type(predictions).__name__}")
    try:
        return da.asarray(predictions)
    except (TypeError, ValueError) as exc:  # e.g. a list of blocks of different lengths
        raise TypeError(f"predictions: expected a 2-D array of numbers ({exc})") from None


def _checked_client(client):
    """``client`` if it can run tasks like a ``distributed.Client`` (or None)."""
    if client is not None and not all(callable(getattr(client, m, None)) for m in ("compute", "gather", "nthreads")):
        raise TypeError("client: expected a distributed.Client (e.g. distributed.Client(\"tcp://scheduler:8786\")) "
                        f"or None for the current scheduler, got {type(client).__name__}")
    return client


def _client(client):
    if client is not None:
        return client
    try:
        from distributed import default_client

        return default_client()
    except (ImportError, ValueError):
        return None


def _compute(tasks: list, client, progress: bool, rows=None) -> list:
    """Results of ``tasks`` in order, on ``client`` (or the default one)."""
    if not tasks:
        return []
    client = _client(client)
    if client is None:
        return list(dask.compute(*tasks))
    from distributed import as_completed

    # No broadcast to the workers first (a worker lost meanwhile failed the
    # whole call): each task sizes its worker's pool itself, and a task whose
    # worker dies is rescheduled by Dask like any other.
    futures = client.compute(tasks)
    counts = [int(r) for r in rows] if rows is not None else [1] * len(futures)
    size = {f.key: c for f, c in zip(futures, counts)}
    with bar(int(sum(size.values())), progress) as progress_bar:
        for future in as_completed(futures):
            progress_bar.update(size[future.key])
    return client.gather(futures)


def _total_threads(client) -> int:
    client = _client(client)
    if client is None:
        return os.cpu_count() or 1
    return sum(client.nthreads().values())


def _merged_blocks(blocks: list, y: np.ndarray, thresholds: Thresholds) -> FalsificationResult:
    """The model blocks' results merged; outputs no sensor uses are reported once, as in process."""
    ignored = next((names for _, names in blocks if names), ())
    if ignored:
        warnings.warn(f"model outputs not among the sensors, ignored: {', '.join(ignored)}", UserWarning,
                      stacklevel=3)
    return _merged([result for result, _ in blocks], y, thresholds)


def _merged(parts: list[FalsificationResult], y: np.ndarray, thresholds: Thresholds) -> FalsificationResult:
    result = concatenate(parts)
    arrays = {name: _readonly(getattr(result, name)) for name in
              ("candidate_indices", "per_sensor_falsified", "falsified_only_by", "n_violated",
               "candidate_parameters", "candidate_predictions") if getattr(result, name) is not None}
    return replace(result, thresholds=thresholds, measurements=y, **arrays)
