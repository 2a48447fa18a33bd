"""Precomputed predictions of a design project: ``[design] predictions =``
a ``.npy`` file (read as a memory map, never copied) or a ``.csv`` file
(a header of location names, one row per model instance).

The columns are matched to the candidate locations by name: a CSV's header,
or for a ``.npy`` the ``[design] columns`` key (a list of names, or a text
file of one name per line; without it the columns are the candidates in the
order of the candidates file). The candidates are then taken in the order of
the columns, so a memory map is passed on as it is, whatever its order.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ..project.inputs import regular_file
from ..project.table import ProjectError
from ._checks import first_non_finite


def files(predictions: Path | None, columns) -> tuple[Path, ...]:
    """The files the predictions are read from (inputs an output must never replace)."""
    if predictions is None:
        return ()
    return (predictions, predictions.parent / columns) if isinstance(columns, str) else (predictions,)


def read_text(file: Path, label: str, key: str, first_line: bool = False) -> str:
    """The UTF-8 text of a regular file, ``key`` of the project file ``label`` (its first line only
    with ``first_line``: a CSV's numbers may be large); a byte that is not UTF-8 is named with its line."""
    regular_file(file, label, key)
    try:
        with open(file, "rb") as fh:
            data = fh.readline() if first_line else fh.read()
    except OSError as exc:
        raise ProjectError(f"{label}: {key}: cannot read '{file}': {exc.strerror}") from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise ProjectError(f"{label}: {key}: {file}: line {line}: expected UTF-8 text, got byte "
                           f"0x{data[exc.start]:02x}; save the file as UTF-8") from None


def column_names(file: Path, columns, label: str) -> tuple[str, ...] | None:
    """Names of the columns of ``file`` (None: a .npy in candidate order)."""
    suffix = file.suffix.lower()
    if suffix not in (".npy", ".csv"):
        raise ProjectError(f"{label}: design.predictions: expected a .npy or .csv file, got '{file.name}'")
    regular_file(file, label, "design.predictions")
    if suffix == ".csv":
        if columns is not None:
            raise ProjectError(f"{label}: design.columns: expected no columns for a CSV file (its header names them)")
        header = next(csv.reader([read_text(file, label, "design.predictions", first_line=True)]), None)
        if not header:
            raise ProjectError(f"{file}: expected a header of candidate location names")
        return tuple(h.strip() for h in header)
    if columns is None:
        return None
    if isinstance(columns, str):
        text = read_text(file.parent / columns, label, "design.columns")
        return tuple(line.strip() for line in text.splitlines() if line.strip())
    if isinstance(columns, list) and all(isinstance(c, str) for c in columns):
        return tuple(columns)
    raise ProjectError(f"{label}: design.columns: expected a list of location names or a text file of them, "
                       f"got {columns!r}")


def in_column_order(candidates: tuple, names: tuple[str, ...] | None, label: str) -> tuple:
    """The candidates in the order of the prediction columns; an error names
    the locations that have no column and the columns that are no location."""
    if names is None:
        return candidates
    have = {c.name: c for c in candidates}
    twice = sorted({n for n in names if names.count(n) > 1}) if len(set(names)) != len(names) else []
    if twice:
        raise ProjectError(f"{label}: design.predictions: column {twice[0]!r} appears more than once")
    missing = [c.name for c in candidates if c.name not in set(names)]
    extra = [n for n in names if n not in have]
    if missing or extra:
        parts = []
        if missing:
            parts.append(f"no prediction column for location(s) {', '.join(missing[:5])}"
                         + (f" and {len(missing) - 5} more" if len(missing) > 5 else ""))
        if extra:
            parts.append(f"prediction column(s) {', '.join(extra[:5])} are not candidate locations"
                         + (f" ({len(extra) - 5} more)" if len(extra) > 5 else ""))
        raise ProjectError(f"{label}: the candidate locations and the prediction columns disagree: " + "; ".join(parts))
    return tuple(have[n] for n in names)


def load_predictions(file: Path, names, label: str) -> np.ndarray:
    """(N, L) predictions: a read-only memory map of a .npy (float32 or
    float64, not copied) or the numbers of a CSV as float64; ``names`` are the
    candidate locations of the columns. A NaN or infinite prediction is
    refused, naming the file, the instance and the location."""
    n_locations = len(names)
    if file.suffix.lower() == ".npy":
        try:
            g = np.load(file, mmap_mode="r")
        except (ValueError, OSError) as exc:
            raise ProjectError(f"{label}: design.predictions: cannot read '{file}' as .npy ({exc})") from None
    else:
        try:
            g = np.loadtxt(file, delimiter=",", skiprows=1, dtype=np.float64, ndmin=2)
        except ValueError as exc:
            raise ProjectError(f"{file}: expected numbers below the header ({exc})") from None
    if g.ndim != 2 or g.shape[1] != n_locations or g.shape[0] < 1:
        raise ProjectError(f"{label}: design.predictions: expected shape (instances, {n_locations}), one column per "
                           f"candidate location, got shape {g.shape}")
    bad = first_non_finite(g)
    if bad is not None:
        i, j = bad
        row = f"row {i}" + (" below the header" if file.suffix.lower() == ".csv" else "")
        raise ProjectError(f"{label}: design.predictions: {file.name}: expected finite predictions, got {g[i, j]} "
                           f"at instance {i} ({row}), location '{names[j]}'; leave out the instances whose model "
                           "run failed, or run them again")
    return g
