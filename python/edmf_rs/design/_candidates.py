"""The candidate locations CSV of a design project, read strictly like the
measurements CSV (:mod:`edmf_rs.project.measurements`): an unknown column
(``cots`` for ``cost``), a row with more or fewer fields than the header (a
decimal comma: ``D1,deflection,1000,5,3``) or text that is not UTF-8 is
refused with the file and line, never read as something else.

Columns: ``name,type`` and optionally ``location,cost,load_case,unit``, in any order.
"""

from __future__ import annotations

import csv
import difflib
import io
from dataclasses import dataclass
from pathlib import Path

from ..project.inputs import cell_number
from ..project.schema import ProjectError
from ._precomputed import read_text

COLUMNS = ("name", "type", "location", "cost", "load_case", "unit")
COMMA_HINT = "; a decimal comma (as in 2,5)? write 2.5"


@dataclass(frozen=True)
class Candidate:
    """One candidate sensor location."""

    name: str
    type: str
    location: float | None
    cost: float
    load_case: str = ""
    unit: str = ""


def _header(row: list[str], file: Path) -> list[str]:
    header = [c.strip() for c in row]
    missing = [c for c in ("name", "type") if c not in header]
    unknown = [c for c in header if c not in COLUMNS]
    twice = sorted({c for c in header if header.count(c) > 1})
    if missing and not unknown:
        raise ProjectError(f"{file}: line 1: expected a header with columns name,type (optional: location, cost, "
                           f"load_case, unit), missing {', '.join(missing)}")
    if unknown or twice:
        close = difflib.get_close_matches(unknown[0], COLUMNS, n=1) if unknown else []
        what = f"unknown column '{unknown[0]}'" if unknown else f"column '{twice[0]}' twice"
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        raise ProjectError(f"{file}: line 1: {what}{hint}; expected the columns {', '.join(COLUMNS)} "
                           "(name and type required, each at most once)")
    return header


def read_candidates(file: Path, label: str, key: str = "design.candidates") -> tuple[Candidate, ...]:
    """The candidate locations of ``file`` (``key`` of the project file ``label``).

    Raises
    ------
    ProjectError
        Naming the file and line (and the project file and key for a file
        that cannot be read) of the first field that cannot be used.
    """
    reader = csv.reader(io.StringIO(read_text(file, label, key), newline=""))
    first = next(reader, None)
    if not first:
        raise ProjectError(f"{file}: expected a header (name,type,location,cost) and at least one location")
    header = _header(first, file)
    result, seen = [], set()
    for row in reader:
        line = reader.line_num
        if not any(cell.strip() for cell in row):
            continue  # a blank line
        if len(row) != len(header):
            hint = COMMA_HINT if len(row) > len(header) else ""
            raise ProjectError(f"{file}: line {line}: expected {len(header)} fields ({','.join(header)}), "
                               f"got {len(row)}{hint}")
        r = dict(zip(header, (c.strip() for c in row)))
        name = r["name"]
        if not name or name in seen:
            raise ProjectError(f"{file}: line {line}: expected a unique location name, got {name!r}")
        seen.add(name)
        cost = _number(r.get("cost"), 1.0, file, line, "cost")
        if not cost > 0:
            raise ProjectError(f"{file}: line {line}: cost: expected a cost > 0, got {cost}")
        location = _number(r.get("location"), None, file, line, "location")
        result.append(Candidate(name, r["type"], location, cost, r.get("load_case", ""), r.get("unit", "")))
    if not result:
        raise ProjectError(f"{file}: expected at least one location after the header")
    return tuple(result)


def _number(text, default, file, line, column):
    return cell_number(text, file, line, column, COMMA_HINT) if text else default
