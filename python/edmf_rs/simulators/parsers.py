"""Reading a run's output file into ``{sensor: prediction}``.

Built in: ``results.csv`` (a header ``sensor,value``, one row per sensor) and
``results.json`` (an object ``{"sensor": value}``); anything else through a
``module:function`` parser called as ``parser(path) -> {sensor: value}``.
"""

from __future__ import annotations

import csv
import importlib
import json
import math
import sys
from collections.abc import Callable, Mapping
from pathlib import Path

from .exits import exit_call, exits_refused


class OutputError(ValueError):
    """An output file that cannot be read as predictions (the instance fails)."""


def read_csv(path: Path) -> dict[str, float]:
    """``sensor,value`` rows (header required).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "results.csv"
    >>> _ = p.write_text("sensor,value\\nD1,1.5\\nD2,-2e-3\\n")
    >>> read_csv(p)
    {'D1': 1.5, 'D2': -0.002}
    """
    with open(path, newline="", encoding="utf-8-sig") as fh:
        reader = csv.DictReader(fh)
        if [c.strip() for c in reader.fieldnames or []][:2] != ["sensor", "value"]:
            raise OutputError(f"{path.name}: expected a header sensor,value, got {reader.fieldnames}")
        out = {}
        for row in reader:
            name, value = (row.get("sensor") or "").strip(), (row.get("value") or "").strip()
            if name in out:
                raise OutputError(f"{path.name}: line {reader.line_num}: sensor {name!r} appears twice")
            out[name] = _number(value, f"{path.name}: line {reader.line_num}")
    return out


def read_json(path: Path) -> dict[str, float]:
    """An object ``{"sensor": value}``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "results.json"
    >>> _ = p.write_text('{"D1": 1.5, "D2": 2}')
    >>> read_json(p)
    {'D1': 1.5, 'D2': 2.0}
    """
    try:
        data = json.loads(path.read_text("utf-8"))
    except json.JSONDecodeError as exc:
        raise OutputError(f"{path.name}: not valid JSON: {exc}") from None
    if not isinstance(data, dict):
        raise OutputError(f"{path.name}: expected an object {{sensor: value}}, got {type(data).__name__}")
    return {str(k): _number(v, f"{path.name}: {k}") for k, v in data.items()}


def _number(value, where: str) -> float:
    if isinstance(value, bool):
        raise OutputError(f"{where}: expected a number, got {value!r}")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise OutputError(f"{where}: expected a number, got {value!r}") from None
    return x


BUILT_IN = {".csv": read_csv, ".json": read_json}


def resolve(ref: str | None, file: str, path: Path) -> Callable[[Path], Mapping[str, float]]:
    """The parser for ``file``: ``ref`` (``module:function``, imported with
    ``path`` on sys.path) or the built-in one for its suffix.

    Raises
    ------
    ValueError
        No parser given and the suffix is neither .csv nor .json, or ``ref``
        cannot be imported.
    """
    if ref is None:
        parser = BUILT_IN.get(Path(file).suffix.lower())
        if parser is None:
            raise ValueError(f"no built-in parser for '{file}' (only .csv with sensor,value and .json "
                             "{sensor: value}); give parser = 'module:function'")
        return parser
    module_name, _, attr = ref.partition(":")
    folder = str(path.resolve())
    if folder not in sys.path:
        sys.path.insert(0, folder)
    try:
        with exits_refused():
            module = importlib.import_module(module_name)
    except SystemExit as exc:  # sys.exit or os._exit at the module's top level
        raise ValueError(f"parser '{ref}': importing module '{module_name}' called {exit_call(exc)}") from None
    except ImportError as exc:
        raise ValueError(f"parser '{ref}': cannot import module '{module_name}' ({exc})") from None
    func = getattr(module, attr, None)
    if not callable(func):
        raise ValueError(f"parser '{ref}': module '{module_name}' has no function '{attr}'")
    return func


def predictions(values, sensors: tuple[str, ...], where: str) -> list[float]:
    """The parsed values in the order of ``sensors``; unknown or missing sensors raise OutputError.

    Examples
    --------
    >>> predictions({"b": 2.0, "a": 1.0}, ("a", "b"), "out.csv")
    [1.0, 2.0]
    """
    if not isinstance(values, Mapping):
        raise OutputError(f"{where}: the parser returned {type(values).__name__}, expected a dict {{sensor: value}}")
    unknown = [k for k in values if k not in sensors]
    if unknown:
        raise OutputError(f"{where}: unknown sensor(s) {', '.join(map(str, unknown[:5]))} "
                          f"(the measurements have: {', '.join(sensors)})")
    missing = [s for s in sensors if s not in values]
    if missing:
        raise OutputError(f"{where}: missing sensor(s) {', '.join(missing[:5])}")
    out = [_number(values[s], f"{where}: {s}") for s in sensors]
    bad = [s for s, v in zip(sensors, out) if not math.isfinite(v)]
    if bad:
        raise OutputError(f"{where}: non-finite prediction for {', '.join(bad[:5])}")
    return out
