"""A TOML table that knows where it came from, so every check names the file
and the dotted key (``parameters.E.low``) with what was expected."""

from __future__ import annotations

import difflib
import math
import numbers

_MISSING = object()


class ProjectError(ValueError):
    """A project file, or a file it names, that cannot be used as it is.

    The message names the file, the key or line, and what was expected;
    ``edmf-rs run`` prints it and exits with status 2. A ``ValueError``.

    Attributes
    ----------
    args : tuple of str
        The message, e.g. ``"bridge.toml: identification.phi: expected a
        probability between 0.5 and 1 - 1e-9, got 1.5"``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> import edmf_rs
    >>> path = pathlib.Path(tempfile.mkdtemp()) / "bad.toml"
    >>> _ = path.write_text("[identification]\\nphi = 1.5\\n")
    >>> try:
    ...     edmf_rs.Project.from_toml(path)
    ... except edmf_rs.ProjectError as exc:
    ...     print(str(exc).split(": ", 1)[1])  # doctest: +ELLIPSIS
    identification.phi: expected ...got 1.5
    """


class Table:
    """A TOML table with where it came from, so errors can name the key."""

    def __init__(self, file: str, key: str, data):
        self.file, self.key = file, key
        if not isinstance(data, dict):
            raise self.error("", f"a table (e.g. [{key}])", data)
        self.data = data

    def path(self, key: str) -> str:
        return f"{self.key}.{key}" if self.key and key else (self.key or key)

    def error(self, key: str, expected: str, got=_MISSING) -> ProjectError:
        where = self.path(key)
        what = "missing" if got is _MISSING else f"got {got!r}"
        return ProjectError(f"{self.file}: {where}: expected {expected}, {what}")

    def check_keys(self, allowed) -> None:
        for key in self.data:
            if key not in allowed:
                close = difflib.get_close_matches(key, list(allowed), n=1)
                hint = f"; did you mean '{close[0]}'?" if close else ""
                raise ProjectError(
                    f"{self.file}: unknown key '{self.path(key)}' "
                    f"(expected one of: {', '.join(allowed)}){hint}"
                )

    def get(self, key: str, kind: str, default=_MISSING, *, choices=(), what: str = ""):
        """The value of ``key`` checked against ``kind``: number, positive, int, seed (an integer >= 0, as
        numpy's generators take), str, choice, table, list."""
        value = self.data.get(key, _MISSING)
        expected = what or {
            "number": "a number", "positive": "a positive number", "int": "an integer", "str": "a string",
            "seed": "a random seed, an integer >= 0",
            "table": "a table", "list": "a list", "bool": "true or false",
            "choice": "one of " + ", ".join(map(repr, choices)),
        }[kind]
        if value is _MISSING:
            if default is _MISSING:
                raise self.error(key, expected)
            return default
        ok = {
            "number": lambda v: _is_number(v),
            "positive": lambda v: _is_number(v) and v > 0,
            "int": lambda v: isinstance(v, int) and not isinstance(v, bool),
            "seed": lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= 0,
            "str": lambda v: isinstance(v, str),
            "choice": lambda v: v in choices,
            "table": lambda v: isinstance(v, dict),
            "list": lambda v: isinstance(v, list),
            "bool": lambda v: isinstance(v, bool),
        }[kind](value)
        if not ok:
            raise self.error(key, expected, value)
        return float(value) if kind in ("number", "positive") else value

    def table(self, key: str, default=_MISSING) -> Table:
        value = self.data.get(key, _MISSING)
        if value is _MISSING:
            if default is _MISSING:
                raise self.error(key, f"a table [{self.path(key)}]")
            value = default
        return Table(self.file, self.path(key), value)

    def tables(self, key: str) -> list[Table]:
        """An array of tables ([[key]]), possibly empty."""
        value = self.data.get(key, [])
        if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
            raise self.error(key, f"an array of tables ([[{self.path(key)}]])", value)
        return [Table(self.file, f"{self.path(key)}[{i}]", v) for i, v in enumerate(value)]


def _is_number(v) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, bool) and math.isfinite(v)
