"""A project's falsification pass with memory bounded whatever N and the number of candidates.

Like :func:`edmf_rs.falsify_model` (Python evaluates the model on batch k+1
while the Rust core falsifies batch k on its own threads, the GIL released),
but the candidates are not kept: after each batch the accumulator hands its
candidates over (``take_candidate_segments``) and they go, with their
parameters and predictions, to a ``sink`` (the
:class:`~edmf_rs.project.candidates.CandidateWriter` and the prognoses), on
the main thread while the Rust core falsifies the next batch. What stays in
memory is the per-sensor tally (Eq. 8 counts) and whatever the sink keeps.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace

import numpy as np

from .. import _core
from ..engine.candidate_set import CandidateSegments
from ..engine.durable import from_accumulator, readonly
from ..engine.model import evaluate
from ..engine.result import FalsificationResult
from ..engine.thresholds import Thresholds


def falsify_streaming(model: Callable, batches: Iterable[np.ndarray], measured: np.ndarray, thresholds: Thresholds,
                      *, sink: Callable[[np.ndarray, np.ndarray, np.ndarray], None],
                      candidate_indices: Callable[[], np.ndarray],
                      on_batch: Callable[[int, np.ndarray, np.ndarray], None] | None = None,
                      nan: str = "raise") -> FalsificationResult:
    """Evaluates ``model`` on every batch and falsifies it (Eq. 8), handing each batch's candidates to ``sink``.

    Parameters
    ----------
    model : callable
        (n, p) parameter sets -> (n, n_m) predictions, batch by batch in instance order.
    batches : iterable of numpy.ndarray
        The parameter sets, (n, p) per batch.
    measured : numpy.ndarray
        y, one value per sensor.
    thresholds : Thresholds
        The bounds on the residuals.
    sink : callable
        ``sink(indices, parameters, predictions)`` with each batch's candidates
        (instance indices int64, their rows), in instance order.
    candidate_indices : callable
        Returns every candidate index the sink has seen (e.g. memory-mapped):
        the result's ``candidate_indices``.
    on_batch : callable, optional
        ``on_batch(offset, parameters, predictions)`` for every batch, before
        it is falsified (diagnostics, plot sample, progress).
    nan : {"raise", "falsify"}
        What a NaN prediction is: an error, or an invalid instance.

    Returns
    -------
    FalsificationResult
        With the per-sensor counts; ``candidate_parameters`` and
        ``candidate_predictions`` are None (they went to the sink).

    Raises
    ------
    ValueError, TypeError
        When the model returns the wrong shape or NaN with ``nan="raise"``.
    Exception
        Whatever the model, ``on_batch`` or ``sink`` raises.

    Examples
    --------
    >>> import numpy as np, edmf_rs
    >>> found = []
    >>> r = falsify_streaming(lambda t: 2 * t, [np.array([[0.0], [1.0], [5.0]])], np.array([2.0]),
    ...                       edmf_rs.Thresholds(low=[-1.0], high=[1.0]),
    ...                       sink=lambda i, p, q: found.append(i), candidate_indices=lambda: np.concatenate(found))
    >>> r.candidate_indices.tolist(), r.per_sensor_falsified.tolist()
    ([1], [2])
    """
    y = np.asarray(measured, dtype=np.float64)
    acc = _core.Falsifier(y, thresholds.low, thresholds.high, diagnostics=True, keep_violations=False)

    def falsify_batch(offset: int, params: np.ndarray, preds: np.ndarray):
        # The worker thread: falsify, then move this batch's candidates out of the accumulator.
        acc.update(preds)
        found = CandidateSegments(acc.take_candidate_segments()).indices()
        local = found - offset
        return found, params[local], preds[local]

    with ThreadPoolExecutor(max_workers=1, thread_name_prefix="edmf-rs-falsify") as pool:
        pending = None
        offset = 0
        try:
            for k, params in enumerate(batches):
                if params.shape[0] == 0:
                    continue
                # The model runs here while the worker falsifies the previous batch.
                preds = evaluate(model, params, offset, y.shape[0], nan, k)
                if on_batch is not None:
                    on_batch(offset, params, preds)
                if pending is not None:
                    done, pending = pending, None
                    sink(*done.result())
                pending = pool.submit(falsify_batch, offset, params, preds)
                offset += params.shape[0]
            if pending is not None:
                done, pending = pending, None
                sink(*done.result())
        except BaseException:
            if pending is not None:
                try:
                    pending.result()  # never leave the worker running on a batch
                except BaseException:
                    pass
            raise
    result = from_accumulator(acc, y, thresholds)
    return replace(result, candidate_indices=readonly(candidate_indices()))
