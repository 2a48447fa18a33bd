"""Files and code a project names: the measurements CSV, the model function,
precomputed predictions. Every problem is a :class:`ProjectError` naming the
file, the key or line, and what was expected."""

from __future__ import annotations

import importlib
import math
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..simulators.exits import exit_call, exits_refused
from .identification import non_regular
from .schema import ProjectError, Sensor

TABLE_SUFFIXES = (".npy", ".csv", ".parquet")


def regular_file(file: Path, label: str, key: str) -> Path:
    """``file`` when it is a regular file; else a :class:`ProjectError` naming the
    project file, the key and the folder searched (see :func:`non_regular`)."""
    try:
        kind = non_regular(file)
    except FileNotFoundError:
        raise ProjectError(f"{label}: {key}: no such file '{file.name}' (looked in {file.parent.resolve()})") from None
    except OSError as exc:
        raise ProjectError(f"{label}: {key}: cannot read '{file}': {exc.strerror}") from None
    if kind:
        raise ProjectError(f"{label}: {key}: expected a regular file, '{file}' is {kind}")
    return file


def check_sensors(sensors: tuple[Sensor, ...], exclude: tuple[str, ...], where: str, label: str) -> tuple[int, ...]:
    """Indices of the sensors kept for the identification, after checking names.

    ``where`` names the measurements (file or table), ``label`` the project file.
    """
    seen = set()
    for s in sensors:
        if s.name in seen:
            raise ProjectError(f"{where}: sensor '{s.name}' appears twice; expected unique sensor names")
        seen.add(s.name)
    unknown = [name for name in exclude if name not in seen]
    if unknown:
        raise ProjectError(f"{label}: measurements.exclude: unknown sensor '{unknown[0]}' "
                           f"(the sensors are: {', '.join(s.name for s in sensors)})")
    kept = tuple(i for i, s in enumerate(sensors) if s.name not in exclude)
    if not kept:
        raise ProjectError(f"{label}: measurements.exclude: expected at least one sensor left, all are excluded")
    return kept


def import_function(ref: str, path: Path, label: str, key: str) -> Callable:
    """The callable ``module:function``, importing with ``path`` on sys.path.

    ``path`` stays on sys.path so the model can import its own helpers lazily.
    A module of the same name cached from another project's folder is
    imported afresh from this project's folder, never silently reused.
    """
    module_name, _, attr = ref.partition(":")
    if not path.is_dir():
        raise ProjectError(f"{label}: {key.rsplit('.', 1)[0]}.path: expected a folder, got '{path}' "
                           f"(relative to the project file's folder {Path(label).parent.resolve()})")
    folder = str(path.resolve())
    if folder not in sys.path:
        sys.path.insert(0, folder)
    _forget_if_from_elsewhere(module_name, Path(folder))
    try:
        with exits_refused():
            module = importlib.import_module(module_name)
    except SystemExit as exc:  # sys.exit or os._exit at the module's top level: not a run that passed
        raise ProjectError(f"{label}: {key}: importing '{module_name}' called {exit_call(exc)}") from None
    except ImportError as exc:
        if isinstance(exc, ModuleNotFoundError) and exc.name and module_name.startswith(exc.name):
            raise ProjectError(f"{label}: {key}: cannot import module '{module_name}' "
                               f"(looked in {path.resolve()} and the installed packages)") from None
        raise ProjectError(f"{label}: {key}: importing '{module_name}' failed: {exc}") from None
    try:
        func = module
        for part in attr.split("."):
            func = getattr(func, part)
    except AttributeError:
        raise ProjectError(f"{label}: {key}: module '{module_name}' has no '{attr}'") from None
    if not callable(func):
        raise ProjectError(f"{label}: {key}: '{ref}' is not callable (got {type(func).__name__})")
    return func


def _forget_if_from_elsewhere(module_name: str, folder: Path) -> None:
    """Drops a cached module (and its submodules) when this project's folder
    holds a module of that name but the cached one was loaded from elsewhere."""
    top = module_name.split(".")[0]
    local = folder / f"{top}.py" if (folder / f"{top}.py").is_file() else folder / top / "__init__.py"
    cached = sys.modules.get(top)
    if not local.is_file() or cached is None:
        return
    cached_file = getattr(cached, "__file__", None)
    if cached_file is None or Path(cached_file).resolve() != local.resolve():
        for name in [n for n in sys.modules if n == top or n.startswith(top + ".")]:
            del sys.modules[name]


def cell_number(text: str, file: Path, line: int, column: str, comma_hint: str) -> float:
    """The finite number in a (non-empty) CSV cell, or a ProjectError naming the file, line and
    column, with ``comma_hint`` when the cell holds a comma."""
    try:
        value = float(text)
    except ValueError:
        hint = comma_hint if "," in text else ""
        raise ProjectError(f"{file}: line {line}: {column}: expected a number, got {text!r}{hint}") from None
    if not math.isfinite(value):
        raise ProjectError(f"{file}: line {line}: {column}: expected a finite number, got {text!r}")
    return value


def table_columns(file: Path, key: str, label: str) -> list[str] | int:
    """Column names of a CSV/Parquet file, or the width of a 2-D .npy array."""
    regular_file(file, label, key)
    suffix = file.suffix.lower()
    try:
        if suffix == ".npy":
            shape = np.load(file, mmap_mode="r").shape
            if len(shape) != 2:
                raise ProjectError(f"{file}: expected a 2-D array (instances, columns), got shape {shape}")
            return shape[1]
        if suffix == ".csv":
            import pandas as pd

            return [str(c) for c in pd.read_csv(file, nrows=0).columns]
        import pyarrow.parquet as pq

        return list(pq.read_schema(file).names)
    except ProjectError:
        raise
    except Exception as exc:  # a corrupt file: say which, without a traceback
        raise ProjectError(f"{file}: cannot read it as {suffix[1:]} ({key}): {exc}") from None


def read_table(file: Path, columns: list[str] | None, key: str) -> np.ndarray:
    """The (N, k) float64 array of ``columns`` (in that order) of a CSV/Parquet file, or a .npy array."""
    suffix = file.suffix.lower()
    try:
        if suffix == ".npy":
            return np.asarray(np.load(file), dtype=np.float64)
        import pandas as pd

        frame = pd.read_csv(file) if suffix == ".csv" else pd.read_parquet(file)
        frame.columns = [str(c) for c in frame.columns]
        return frame[columns].to_numpy(dtype=np.float64)
    except (ValueError, TypeError) as exc:
        raise ProjectError(f"{file}: expected numbers in every column used ({key}): {exc}") from None


def match_columns(found: list[str] | int, wanted: list[str], allowed: set[str] | None, file: Path, what: str) -> None:
    """Checks a file's columns against the names it must hold (``allowed`` may also
    appear; None: any other column may appear, and is ignored)."""
    if isinstance(found, int):
        expected = len(wanted) if allowed is None else len(allowed)
        if found != expected:
            raise ProjectError(f"{file}: expected {expected} columns ({what}, in order), got {found}")
        return
    missing = [c for c in wanted if c not in found]
    unexpected = [c for c in found if allowed is not None and c not in allowed]
    if missing or unexpected:
        detail = "; ".join(part for part in (
            f"missing {', '.join(missing)}" if missing else "",
            f"unexpected {', '.join(unexpected)}" if unexpected else "") if part)
        extra = [c for c in found if c not in wanted]
        also = f" (the file also has {', '.join(extra)})" if extra and not unexpected else ""
        raise ProjectError(f"{file}: expected columns named after the {what} ({', '.join(wanted)}), {detail}{also}")


def check_model_sensors(listed: tuple[str, ...] | None, sensors: tuple[Sensor, ...], label: str) -> None:
    """Every sensor used is among the columns ``[model] sensors`` names."""
    if listed is None:
        return
    missing = [s.name for s in sensors if s.name not in listed]
    if missing:
        raise ProjectError(f"{label}: model.sensors: expected every sensor of the measurements, missing "
                           f"{', '.join(missing)} (the measurements have {', '.join(s.name for s in sensors)}; "
                           f"model.sensors lists {', '.join(listed)})")
