"""A Python model's outputs as the prediction store's columns, matched by name.

The store keeps one column per sensor of the measurements (excluded ones
too, so changing ``exclude`` evaluates nothing again). A model may return a
``pandas.DataFrame``, a mapping of sensor name to column or a structured
array: its columns are matched to the sensors by name, in any order (issue 12
part 1), exactly as when the model is called in process. A bare array is
matched by position to ``[model] sensors`` or to the measurements' order. A
sensor the model does not provide is an error when the identification uses
it; an excluded one is stored as *absent* (no column in the part file), so a
later run that includes it is refused instead of reading NaN as predictions.

Worker processes and Dask workers send back what the model returned, names
and all (:func:`portable`), and the caller matches it here, so every path
gives the same columns.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..engine._validate import real_array
from ..engine.sensors import SensorMapping, SensorMatch, SensorMismatch, named_output


class OutputMismatch(SensorMismatch):
    """The model's outputs do not name the sensors the identification uses.

    The message names the model, the instances and the sensors on both sides;
    it passes through the model's error wrapping unchanged (exit code 2, like
    the same mismatch found in process).

    Examples
    --------
    >>> OutputMismatch("m: provides no prediction for sensor B").names_its_instances
    True
    """

    names_its_instances = True


def portable(out):
    """What a worker sends back: a named output as it is (DataFrame, mapping,
    structured array: they pickle with their names), anything else as float64.

    Parameters
    ----------
    out
        What the model returned for a batch of parameter sets.

    Returns
    -------
    object
        ``out`` itself when it has named columns, else ``np.asarray(out, float)``.

    Examples
    --------
    >>> portable([[1, 2]]).dtype
    dtype('float64')
    >>> portable({"S": [1.0]})
    {'S': [1.0]}
    """
    names, out = named_output(out)
    if names is not None:
        return out
    arr = np.asarray(out)
    return arr if arr.dtype.kind == "c" else np.asarray(arr, dtype=np.float64)  # complex: refused by the caller


class StoreColumns:
    """Turns a model output into the store's columns: every sensor of the
    measurements in their order, NaN (and listed as absent) where the model
    gives none.

    Parameters
    ----------
    sensors
        Every sensor of the measurements, in order (the store's columns).
    required
        The sensors the identification uses (default: all of them).
    positional
        The sensor of each column of a bare array (default: ``sensors``).
    positional_source
        Where ``positional`` comes from, for messages.
    where
        The model, for messages (e.g. ``p.toml: model.function = 'm:f'``).

    Raises
    ------
    OutputMismatch
        (from :meth:`__call__`) when a required sensor is missing, a bare
        array has the wrong width, or columns are named twice.

    Examples
    --------
    >>> cols = StoreColumns(("A", "B", "C"), required=("A", "C"), where="m")
    >>> values, absent = cols({"C": [3.0], "A": [1.0], "X": [9.0]}, 1, first=0)
    >>> values.tolist(), absent, cols.mapping.columns
    ([[1.0, nan, 3.0]], ('B',), ('A', 'C'))
    """

    def __init__(self, sensors: Sequence[str], required: Sequence[str] | None = None,
                 positional: Sequence[str] | None = None, positional_source: str = "the measurements' order",
                 where: str = "model"):
        self.sensors = tuple(sensors)
        self.required = tuple(required) if required is not None else self.sensors
        self.positional = tuple(positional) if positional is not None else self.sensors
        self.where = where
        # The same matching (and messages) as the in-process path, on the sensors the identification uses.
        self.check = SensorMatch(self.required, self.positional, positional_source)
        self.source = positional_source
        self._plans: dict[tuple[str, ...], tuple[SensorMatch, list[int], tuple[str, ...]]] = {}
        self.names: tuple[str, ...] | None = None  # the output names last seen (None: a bare array)

    def replay(self, names: list[str] | None) -> None:
        """Sets :attr:`mapping` from the output names a run stored (None: a bare array), for a run
        served from the store without calling the model."""
        if self.check.mapping is None:
            fake = dict.fromkeys(names, np.zeros(0)) if names is not None else np.zeros((0, len(self.positional)))
            try:
                self.check(fake, 0)
            except SensorMismatch:
                pass  # refused when the rows are read (refuse_absent)

    @property
    def mapping(self) -> SensorMapping | None:
        """How the outputs were matched to the sensors used (None before the first output)."""
        return self.check.mapping

    def __call__(self, out, n_rows: int, first: int) -> tuple[np.ndarray, tuple[str, ...]]:
        """(values of shape (n_rows, len(sensors)), the sensors absent from ``out``)."""
        names, out = named_output(out)
        try:
            self.check(out, n_rows)
            given = names if names is not None else self.positional
            self.names = names
            if given not in self._plans:
                present = [s for s in self.sensors if s in given]
                index = [self.sensors.index(s) for s in present]
                self._plans[given] = (SensorMatch(present, self.positional, self.source), index,
                                      tuple(s for s in self.sensors if s not in given))
            match, index, absent = self._plans[given]
            values = real_array(match(out, n_rows), "model", copy=False)  # complex: refused, not cast
        except SensorMismatch as exc:
            raise OutputMismatch(f"{self.where}: {exc} (instances {first}..{first + n_rows - 1})") from None
        except (TypeError, ValueError):
            kind = f" of dtype {out.dtype}" if hasattr(out, "dtype") else ""
            raise OutputMismatch(f"{self.where}: returned {type(out).__name__}{kind}, expected an array of real "
                                 f"numbers of shape ({n_rows}, {len(self.positional)}) or a DataFrame with a column "
                                 f"per sensor (instances {first}..{first + n_rows - 1})") from None
        if not absent:
            return (values if values.shape[1] == len(self.sensors) and index == list(range(len(index)))
                    else _spread(values, index, n_rows, len(self.sensors))), ()
        return _spread(values, index, n_rows, len(self.sensors)), absent

    def refuse_absent(self, absent, first: int, n_rows: int, store) -> None:
        """Refuses stored rows that lack a sensor the identification now uses."""
        missing = [s for s in self.required if s in set(absent)]
        if missing:
            raise OutputMismatch(
                f"{self.where}: provides no prediction for sensor{'s' if len(missing) > 1 else ''} "
                f"{', '.join(missing)} (instances {first}..{first + n_rows - 1} in the prediction store {store}, "
                "evaluated while it was excluded); the measurements have "
                f"{', '.join(self.required)}")


class NamedColumns(Mapping):
    """An (n, m) array of predictions with the sensor name of each column: what the evaluator of
    an external program returns. Its results are read by sensor name (``results.csv`` rows
    ``sensor,value``), so the identification matches them to the measurements by name (a
    mapping of sensor name to column) and reports so; ``np.asarray`` gives the array.

    Parameters
    ----------
    values : (n, m) array
    names : sequence of str
        The sensor of each column.

    Examples
    --------
    >>> cols = NamedColumns(np.array([[1.0, 2.0]]), ("A", "B"))
    >>> list(cols), cols["B"].tolist(), np.asarray(cols).tolist()
    (['A', 'B'], [2.0], [[1.0, 2.0]])
    """

    def __init__(self, values: np.ndarray, names: Sequence[str]):
        self.values, self.names = np.asarray(values, dtype=np.float64), tuple(names)
        self._index = {name: j for j, name in enumerate(self.names)}

    def __getitem__(self, name: str) -> np.ndarray:
        return self.values[:, self._index[name]]

    def __iter__(self):
        return iter(self.names)

    def __len__(self) -> int:
        return len(self.names)

    @property
    def shape(self) -> tuple[int, ...]:
        return self.values.shape

    def __array__(self, dtype=None, copy=None):
        return self.values if dtype is None else self.values.astype(dtype, copy=False)


def _spread(values: np.ndarray, index: list[int], n_rows: int, width: int) -> np.ndarray:
    full = np.full((n_rows, width), np.nan)
    full[:, index] = values
    return full
