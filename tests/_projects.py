"""Project folders for tests and benches: the project file rendered from keyword
arguments, written beside its measurements CSV and model module.

One renderer instead of a hand-written TOML template in every test file, so that a
change to the project-file format is made once. Every table is written as
``\\n[header]\\n`` and one ``key = value`` line a key, in the order given; tests
edit the text with ``str.replace`` on those lines.

Tests import it as ``_projects``: pytest puts ``tests/`` on ``sys.path`` when it
imports ``tests/conftest.py`` (rootdir-relative "prepend" import mode, no
``__init__.py`` in tests/). Benches put ``tests/`` on ``sys.path`` themselves.
"""

from __future__ import annotations

import json
from pathlib import Path

# The linear model g(a, b) = [a, b] @ A of four sensors S1..S4; the truth a = b = 1 gives Y.
A_ROWS = "[[1.0, 2.0, 0.5, -1.0], [0.3, -0.2, 1.5, 0.8]]"
LINEAR_MODEL = f"""
import numpy as np
A = np.array({A_ROWS})
def predict(theta, scale=1.0):
    return scale * theta @ A
def three_columns(theta):
    return theta @ A[:, :3]
"""
LINEAR_CSV = "sensor,type,value\nS1,deflection,1.3\nS2,deflection,1.8\nS3,strain,2.0\nS4,strain,-0.2\n"


def toml_value(value) -> str:
    """``value`` as a TOML literal: strings quoted, lists as arrays, dicts as inline tables."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)  # JSON string escapes are TOML basic-string escapes
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(map(toml_value, value)) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"toml_value: expected a string, number, list or dict, got {value!r}")


def table(header: str, keys: dict | str = "", /) -> str:
    """``[header]`` and its keys (``header`` "[name]" gives an array-of-tables entry
    ``[[name]]``); ``keys`` a dict, or TOML lines written as they are."""
    if isinstance(keys, dict):
        keys = "".join(f"{k} = {toml_value(v)}\n" for k, v in keys.items())
    elif keys and not keys.endswith("\n"):
        keys += "\n"
    return f"\n[{header}]\n{keys}"


def uncertainty(**keys) -> str:
    """One ``[[uncertainty]]`` source."""
    return table("[uncertainty]", keys)


def project_text(*, identification: dict | None = None, parameters: dict, sampling: dict | str | None,
                 model: dict | str, measurements: dict | str | None = None, sensors: tuple = (),
                 uncertainty: tuple = ()) -> str:
    """A project file, its tables in the usual order.

    ``parameters`` maps a name to ``(low, high)`` or to the keys of its table;
    ``sensors`` (dicts) become ``[[measurements.sensors]]``, ``uncertainty`` (dicts)
    ``[[uncertainty]]``; a None table is left out; a str table body is written as it is.
    """
    parts = [] if identification is None else [table("identification", identification)]
    for name, bounds in parameters.items():
        parts.append(table(f"parameters.{name}", bounds if isinstance(bounds, dict)
                           else {"low": bounds[0], "high": bounds[1]}))
    if sampling is not None:
        parts.append(table("sampling", sampling))
    parts.append(table("model", model))
    if measurements is not None:
        parts.append(table("measurements", measurements))
    parts += [table("[measurements.sensors]", s) for s in sensors]
    parts += [table("[uncertainty]", u) for u in uncertainty]
    return "".join(parts)


def write_project(folder: Path, text: str, *, modules: dict | None = None, csv: str | bytes | None = None,
                  name: str = "p.toml") -> Path:
    """``folder`` (created) with the project file ``name`` holding ``text``, each
    ``modules`` {module name: source} as a .py file and ``csv`` as meas.csv; its path."""
    folder.mkdir(parents=True, exist_ok=True)
    for module, source in (modules or {}).items():
        (folder / f"{module}.py").write_text(source)
    if csv is not None:
        (folder / "meas.csv").write_bytes(csv if isinstance(csv, bytes) else csv.encode())
    path = folder / name
    path.write_text(text)
    return path
