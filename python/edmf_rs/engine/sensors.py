"""Model outputs matched to sensors by name.

A model may return its predictions with names (a ``pandas.DataFrame``, a
mapping of sensor name to column, or a NumPy structured array): the columns are
then matched to the sensors by name, in any order, and outputs no sensor uses
are ignored (and reported). A bare array carries no names, so its columns are
matched by position to a list of names given for that purpose. Matching by
name is what keeps a model whose columns come in another order than the
measurements from being compared with the wrong readings (Eq. 8 compares
``g_i(theta)`` with ``y_i`` sensor by sensor).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["SensorMapping", "SensorMatch", "SensorMismatch", "named_output", "sensor_match"]


class SensorMismatch(ValueError):
    """The model's outputs and the measured sensors do not name the same sensors."""


def named_output(out) -> tuple[tuple[str, ...] | None, object]:
    """The output's column names (None for a bare array) and the output itself.

    Parameters
    ----------
    out
        What a model returned: a ``pandas.DataFrame``, a mapping of name to
        column, a structured array, or anything ``np.asarray`` reads.

    Returns
    -------
    tuple
        ``(names, out)``: ``names`` is a tuple of str, or None when the
        output carries no names.

    Examples
    --------
    >>> named_output({"D1": [1.0], "D2": [2.0]})[0]
    ('D1', 'D2')
    >>> named_output(np.zeros((1, 2)))[0] is None
    True
    """
    if hasattr(out, "columns") and hasattr(out, "iloc"):  # a pandas DataFrame, duck-typed
        return tuple(str(c) for c in out.columns), out
    if isinstance(out, Mapping):
        return tuple(str(k) for k in out.keys()), out
    if isinstance(out, np.ndarray) and out.dtype.names is not None:
        return tuple(out.dtype.names), out
    return None, out


def _columns(out, names: tuple[str, ...], index: Sequence[int]) -> np.ndarray:
    """The columns at ``index`` of a named output, as a 2-D float64 array."""
    if hasattr(out, "columns") and hasattr(out, "iloc"):
        return np.asarray(out.iloc[:, list(index)].to_numpy(dtype=np.float64))
    if isinstance(out, Mapping):
        keys = list(out.keys())
        cols = [np.asarray(out[keys[i]], dtype=np.float64).reshape(-1) for i in index]
    else:
        cols = [np.asarray(out[names[i]], dtype=np.float64).reshape(-1) for i in index]
    lengths = [c.shape[0] for c in cols]
    if len(set(lengths)) > 1:
        each = ", ".join(f"{names[i]} has {n}" for i, n in zip(index, lengths))
        raise SensorMismatch(f"returned columns of different lengths for the sensors ({each} rows); "
                             "expected one row per parameter set in every column")
    return np.column_stack(cols)


@dataclass(frozen=True)
class SensorMapping:
    """How the model's outputs were matched: ``how`` in words, the output
    column (name or position) giving each sensor, and the outputs ignored."""

    how: str
    columns: tuple[str, ...]
    ignored: tuple[str, ...]


class SensorMatch:
    """Selects, from each model output, the columns of ``sensors`` in order.

    Parameters
    ----------
    sensors
        The names of the sensors whose predictions are wanted, in the order
        of the measurements used.
    positional
        The sensor each column of a bare array holds (e.g. the project's
        ``[model] sensors`` list, or every sensor of the measurements). None:
        a bare array must have exactly one column per sensor, in order.
    positional_source
        Where ``positional`` comes from, for messages and the report.

    Raises
    ------
    SensorMismatch
        (from :meth:`__call__`) when a wanted sensor is missing from the
        output, naming the sensors on both sides.

    Examples
    --------
    >>> match = SensorMatch(["D1", "D2"])
    >>> match({"D2": [2.0], "D1": [1.0], "T": [9.0]}, 1)
    array([[1., 2.]])
    >>> match.mapping.ignored
    ('T',)
    """

    def __init__(self, sensors: Sequence[str], positional: Sequence[str] | None = None,
                 positional_source: str | None = None):
        self.sensors = tuple(str(s) for s in sensors)
        if len(set(self.sensors)) != len(self.sensors):
            raise ValueError(f"sensors: expected distinct names, got {list(self.sensors)}")
        self.positional = tuple(positional) if positional is not None else None
        self.positional_source = positional_source or (
            "the measurements' order" if positional is not None else "the sensors' order")
        self._cache: tuple[tuple, list[int], SensorMapping] | None = None

    @property
    def mapping(self) -> SensorMapping | None:
        """The matching used for the last output (None before the first)."""
        return None if self._cache is None else self._cache[2]

    def _plan(self, names: tuple[str, ...] | None, width: int, n_rows: int) -> tuple[list[int], SensorMapping]:
        if names is None:
            source = self.positional if self.positional is not None else self.sensors
            how = f"by position, columns in {self.positional_source}"
            if width != len(source):
                raise SensorMismatch(
                    f"returned shape ({n_rows}, {width}) for {n_rows} parameter sets, expected ({n_rows}, "
                    f"{len(source)}): one column per sensor, in {self.positional_source} ({', '.join(source)}); "
                    "or return a DataFrame or a mapping of sensor name to column, matched by name")
        else:
            source, how = names, "by name"
            if len(set(names)) != len(names):
                twice = sorted({n for n in names if names.count(n) > 1})
                raise SensorMismatch(f"returned columns named twice: {', '.join(twice)}")
        position = {name: i for i, name in enumerate(source)}
        missing = [s for s in self.sensors if s not in position]
        if missing:
            raise SensorMismatch(
                f"provides no prediction for sensor{'s' if len(missing) > 1 else ''} {', '.join(missing)}: "
                f"the measurements have {', '.join(self.sensors)}; the model's outputs ({how}) are "
                f"{', '.join(source)}")
        index = [position[s] for s in self.sensors]
        wanted = set(self.sensors)
        ignored = tuple(n for n in source if n not in wanted)
        return index, SensorMapping(how, tuple(source[i] for i in index), ignored)

    def __call__(self, out, n_rows: int) -> np.ndarray:
        """The (n_rows, n_sensors) predictions of ``out``, columns in the sensors' order."""
        names, out = named_output(out)
        if names is None:
            arr = np.asarray(out)
            width = arr.shape[1] if arr.ndim == 2 else -1
            if arr.ndim != 2 or arr.shape[0] != n_rows:
                raise SensorMismatch(
                    f"returned shape {arr.shape} for {n_rows} parameter sets, expected ({n_rows}, "
                    f"{len(self.positional or self.sensors)}): one column per sensor, in {self.positional_source}")
        else:
            arr, width = out, len(names)
        key = (names, width)
        if self._cache is None or self._cache[0] != key:
            index, mapping = self._plan(names, width, n_rows)
            self._cache = (key, index, mapping)
        index = self._cache[1]
        if names is None:
            if index == list(range(width)):
                return arr
            return arr[:, index]
        cols = _columns(out, names, index)
        if cols.shape != (n_rows, len(self.sensors)):
            raise SensorMismatch(f"returned columns of {cols.shape[0]} rows for {n_rows} parameter sets")
        return cols


def sensor_match(sensors, n_measurements: int) -> SensorMatch | None:
    """The ``sensors=`` argument of `falsify_model` checked: a :class:`SensorMatch`, or None when not given.

    Parameters
    ----------
    sensors : sequence of str or None
        The names of the measurements' sensors, in order.
    n_measurements : int
        How many measurements there are.

    Returns
    -------
    SensorMatch or None

    Raises
    ------
    TypeError
        If ``sensors`` is not a sequence of str.
    ValueError
        If it does not hold one distinct name per measurement.

    Examples
    --------
    >>> sensor_match(["D1", "D2"], 2).sensors
    ('D1', 'D2')
    >>> sensor_match(["D1"], 2)
    Traceback (most recent call last):
    ...
    ValueError: sensors: expected 2 names (one per measurement), got 1
    """
    if sensors is None:
        return None
    if isinstance(sensors, str) or not all(isinstance(s, str) for s in sensors):
        raise TypeError("sensors: expected a sequence of sensor names (str)")
    if len(sensors) != n_measurements:
        raise ValueError(f"sensors: expected {n_measurements} names (one per measurement), got {len(sensors)}")
    return SensorMatch(sensors)
