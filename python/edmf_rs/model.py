"""Falsification straight from a Python model: parameters in, candidates out.

Batches are pipelined: while the Rust core falsifies batch k on its own
threads (the GIL released), Python evaluates the model on batch k+1. Only the
candidates' parameters and predictions are kept, so memory follows the size
of the candidate model set, not the number of instances.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from . import _core
from ._validate import finite_vector, positive_int
from .chunks import as_chunk
from .falsify import from_accumulator
from .progress import bar
from .result import FalsificationResult
from .thresholds import Thresholds


def parameter_batches(parameters, batch_size: int) -> tuple[Iterator[np.ndarray], int | None]:
    """Batches of parameter sets (rows) and the total count when known."""
    if isinstance(parameters, np.ndarray) or (isinstance(parameters, (list, tuple)) and parameters
                                              and np.ndim(parameters[0]) < 2):
        arr = np.asarray(parameters, dtype=np.float64)
        if arr.ndim == 1:
            arr = arr[:, None]
        if arr.ndim != 2:
            raise ValueError(f"parameters: expected an (N, p) array, got shape {arr.shape}")
        return (arr[i:i + batch_size] for i in range(0, arr.shape[0], batch_size)), arr.shape[0]
    if not isinstance(parameters, Iterable):
        raise TypeError(f"parameters: expected an (N, p) array or an iterable of batches, got {type(parameters).__name__}")

    def checked() -> Iterator[np.ndarray]:
        width = None
        for k, batch in enumerate(parameters):
            arr = np.asarray(batch, dtype=np.float64)
            arr = arr[:, None] if arr.ndim == 1 else arr
            if arr.ndim != 2 or (width is not None and arr.shape[1] != width):
                raise ValueError(f"parameters: batch {k} has shape {arr.shape}, expected (n, {width or 'p'})")
            width = arr.shape[1]
            yield arr
    return checked(), None


def evaluate(model: Callable, batch: np.ndarray, offset: int, n_sensors: int, nan: str) -> np.ndarray:
    """Runs the model on one batch and checks what it returns."""
    try:
        predictions = model(batch)
    except Exception as exc:
        exc.add_note(f"edmf_rs: raised by the model on instances {offset}..{offset + len(batch) - 1}")
        raise
    try:
        predictions = np.asarray(predictions)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"model: expected an array of predictions, got {type(predictions).__name__}") from exc
    if predictions.shape != (batch.shape[0], n_sensors):
        raise ValueError(
            f"model: returned shape {predictions.shape} for {batch.shape[0]} parameter sets, "
            f"expected ({batch.shape[0]}, {n_sensors}) (one prediction per sensor)"
        )
    chunk = as_chunk(predictions, n_sensors, name="model")
    if nan == "raise":
        bad = np.flatnonzero(np.isnan(chunk).any(axis=1))
        if bad.size:
            raise ValueError(
                f"model: returned NaN for instance {offset + bad[0]} (parameters {batch[bad[0]].tolist()}); "
                "pass nan='falsify' to count such instances as invalid instead"
            )
    return chunk


def falsify_model(model: Callable, parameters, measurements, thresholds: Thresholds, *,
                  batch_size: int = 10_000, diagnostics: bool = True, keep_violations: bool = False,
                  nan: str = "raise", progress: bool = True,
                  on_batch: Callable[[int, np.ndarray, np.ndarray], None] | None = None) -> FalsificationResult:
    """Evaluate ``model`` on every parameter set and falsify as it goes (Eq. 8).

    Parameters
    ----------
    model
        Vectorised callable: ``model(batch)`` with ``batch`` of shape (n, p)
        returns predictions of shape (n, n_m), one column per sensor.
    parameters
        An (N, p) array, or an iterable of (n, p) batches (e.g. from
        ``scipy.stats.qmc``) consumed once.
    nan
        ``"raise"`` (default): a NaN prediction is an error naming the
        instance; ``"falsify"``: such instances are counted invalid.
    on_batch
        Called as ``on_batch(offset, parameters, predictions)`` for every batch,
        e.g. to compute extra diagnostics.

    Returns a :class:`FalsificationResult` whose ``candidate_parameters`` and
    ``candidate_predictions`` hold the candidates' rows.
    """
    if not callable(model):
        raise TypeError(f"model: expected a callable, got {type(model).__name__}")
    if not isinstance(thresholds, Thresholds):
        raise TypeError(f"thresholds: expected edmf_rs.Thresholds, got {type(thresholds).__name__}")
    if nan not in ("raise", "falsify"):
        raise ValueError(f"nan: expected 'raise' or 'falsify', got {nan!r}")
    y = finite_vector(measurements, "measurements", n=thresholds.n_sensors)
    batches, total = parameter_batches(parameters, positive_int(batch_size, "batch_size"))
    acc = _core.Falsifier(y, thresholds.low, thresholds.high, diagnostics=diagnostics,
                          keep_violations=keep_violations)
    kept_parameters: list[np.ndarray] = []
    kept_predictions: list[np.ndarray] = []
    n_params = None

    def falsify_batch(params: np.ndarray, preds: np.ndarray, offset: int) -> None:
        seen = acc.n_candidates
        acc.update(preds)
        local = acc.candidates(seen).astype(np.int64) - offset
        kept_parameters.append(params[local])
        kept_predictions.append(preds[local])

    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="edmf-rs-falsify") as pool, \
            bar(total, progress) as progress_bar:
        pending = None
        offset = 0
        for params in batches:
            n_params = params.shape[1]
            preds = evaluate(model, params, offset, y.shape[0], nan)
            if on_batch is not None:
                on_batch(offset, params, preds)
            if pending is not None:
                pending.result()
            pending = pool.submit(falsify_batch, params, preds, offset)
            offset += params.shape[0]
            progress_bar.update(params.shape[0])
        if pending is not None:
            pending.result()

    result = from_accumulator(acc, y, thresholds)
    p = n_params if n_params is not None else 0
    return _with_candidates(result,
                            np.concatenate(kept_parameters) if kept_parameters else np.empty((0, p)),
                            np.concatenate(kept_predictions) if kept_predictions else np.empty((0, y.shape[0])))


def _with_candidates(result: FalsificationResult, params: np.ndarray, preds: np.ndarray) -> FalsificationResult:
    from dataclasses import replace

    return replace(result, candidate_parameters=params, candidate_predictions=preds)
