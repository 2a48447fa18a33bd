"""The prediction store keyed by parameters, for runs whose instances are not a
fixed sample (adaptive sampling, issue 16).

:class:`~edmf_rs.simulators.store.PredictionStore` numbers rows by their index
in the sampling (instance i of a Sobol' sample is row i), which is what lets a
run reuse a prefix and extend it. Adaptive sampling places its runs where the
emulator says, and where that is depends on the thresholds: after a change of
phi or of an uncertainty source the same run may come at another position, or
not at all. So here a row is found by its parameters (the exact float64 bits:
``repr`` round-trips in decks, Parquet stores them as they are), and the
``instance`` column is only the row's number in the store, in the order rows
were evaluated. Same files, same atomic parts, same columns; the manifest says
``schema = "edmf_rs.prediction-store/2"`` and the fingerprint holds
``"rows": "keyed by parameters"``, so a store of one kind is never opened as
the other (their keys differ).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .columns import NamedColumns
from .command import _source_digest
from .evaluator import Evaluator
from .failures import Failure
from .store import PredictionStore

#: Format of a store whose rows are found by their parameters.
KEYED_SCHEMA = "edmf_rs.prediction-store/2"


class KeyedPredictionStore(PredictionStore):
    """A :class:`PredictionStore` whose rows are looked up by their parameters.

    Parameters
    ----------
    root, fingerprint, parameters, sensors
        As for :class:`PredictionStore`; ``"rows": "keyed by parameters"`` is
        added to the fingerprint.

    Examples
    --------
    >>> import tempfile, numpy as np
    >>> s = KeyedPredictionStore(tempfile.mkdtemp(), {"model": "f"}, ("a",), ("S",))
    >>> s.append(s.next_instance(), np.array([[0.5], [2.0]]), np.array([[1.0], [4.0]]), np.zeros(2, bool),
    ...          ["", ""], ["", ""], ["", ""])
    >>> again = KeyedPredictionStore(s.root, {"model": "f"}, ("a",), ("S",))
    >>> again.lookup(np.array([[2.0], [3.0]])).tolist(), again.next_instance()
    ([1, -1], 2)
    """

    schema = KEYED_SCHEMA

    def __init__(self, root, fingerprint: dict, parameters, sensors):
        super().__init__(root, {**fingerprint, "rows": "keyed by parameters"}, parameters, sensors)
        self._index: dict[bytes, int] = {}
        self._rows: dict[int, tuple] = {}
        self._indexed: set[Path] = set()

    def next_instance(self) -> int:
        """The number the next evaluated row gets (one past the last stored row)."""
        return max((first + n for first, n, _ in self.parts), default=0)

    def _refresh(self) -> None:
        for start, _, path in self.parts:
            if path in self._indexed:
                continue
            rows = self._load(start, path)
            for i, row in enumerate(np.ascontiguousarray(rows.parameters, dtype=np.float64)):
                key = row.tobytes()
                if key not in self._index:  # the first copy of a row wins, as in PredictionStore.read
                    self._index[key] = start + i
                    self._rows[start + i] = (rows.predictions[i], bool(rows.failed[i]), rows.reason[i],
                                             rows.stderr[i], rows.work[i])
            self._indexed.add(path)

    def lookup(self, theta: np.ndarray) -> np.ndarray:
        """Per row of ``theta``, the stored row with exactly these parameters, or -1.

        Parameters
        ----------
        theta : (n, p) array

        Returns
        -------
        numpy.ndarray of int64
            Stored row numbers (``instance``), -1 where not stored.

        Raises
        ------
        ValueError
            If ``theta`` does not have one column per parameter.
        """
        theta = np.ascontiguousarray(theta, dtype=np.float64)
        if theta.ndim != 2 or theta.shape[1] != len(self.parameters):
            raise ValueError(f"theta: expected an (n, {len(self.parameters)}) array, got shape {theta.shape}")
        self._refresh()
        return np.array([self._index.get(row.tobytes(), -1) for row in theta], dtype=np.int64)

    def row(self, instance: int) -> tuple:
        """(predictions, failed, reason, stderr, work) of stored row ``instance``."""
        return self._rows[instance]


class KeyedEvaluator(Evaluator):
    """An :class:`Evaluator` for runs placed anywhere (adaptive sampling): each
    batch's rows already in the store (same model, same parameters) are
    reused, whatever their order or the run that stored them; the rest are
    evaluated like any instance (workers, external program, failures) and
    stored as they arrive.

    Parameters
    ----------
    parameters, sensors, n_planned
        As for :class:`Evaluator` (``n_planned``: the budget of real runs).
    **kwargs
        The keyword arguments of :class:`Evaluator`; ``sampling`` should name
        the parameters and sensors only (where the runs go does not change
        what the model gives there).

    Examples
    --------
    >>> import numpy as np, tempfile
    >>> out = tempfile.mkdtemp()
    >>> double = lambda t: 2 * t  # one function: the store is keyed by the model's code
    >>> ev = KeyedEvaluator(("a",), ("S",), 4, function=double, ref="", path=".", out=out)
    >>> ev(np.array([[1.0], [2.0]])).ravel().tolist()
    [2.0, 4.0]
    >>> ev = KeyedEvaluator(("a",), ("S",), 4, function=double, ref="", path=".", out=out)
    >>> ev(np.array([[3.0], [1.0]])).ravel().tolist(), ev.model_evaluations, ev.reused_evaluations
    ([6.0, 2.0], 1, 1)
    """

    def __init__(self, parameters, sensors, n_planned: int, *, out=None, sampling: dict | None = None,
                 store: bool = True, **kwargs):
        super().__init__(parameters, sensors, n_planned, out=out, sampling=sampling, store=False, **kwargs)
        if self.command is not None:
            model_key = self.command.fingerprint()
        else:
            model_key = {"kind": "function", "ref": kwargs.get("ref", ""), "source": _source_digest(self.function),
                         "options": self.options}
        self.store = (KeyedPredictionStore(self.out / "store", {"model": model_key, "sampling": sampling},
                                           self.parameters, self.sensors)
                      if self.out is not None and store else None)

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        theta = np.asarray(theta, dtype=np.float64)
        n = theta.shape[0]
        out = np.full((n, len(self.sensors)), np.nan)
        stored = self.store.lookup(theta) if self.store is not None else np.full(n, -1, np.int64)
        for i in np.flatnonzero(stored >= 0):
            predictions, failed, reason, stderr, work = self.store.row(int(stored[i]))
            out[i] = predictions
            if failed:  # a failed run stays failed: counted again (and against the policy), not rerun
                self._count_reused(Failure(int(stored[i]), tuple(float(v) for v in theta[i]), reason, stderr, work))
        self.reused_evaluations += int((stored >= 0).sum())
        new = np.flatnonzero(stored < 0)
        if new.size:
            first = self.store.next_instance() if self.store is not None else self.offset
            out[new] = self._evaluate(first, theta[new])
        self.offset += n
        return NamedColumns(out, self.sensors) if self.command is not None else out  # matched by name
