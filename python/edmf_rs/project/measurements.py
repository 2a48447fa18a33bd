"""The measurements CSV, read strictly: every field of every row is used or refused.

Columns are ``sensor,value`` and optionally ``type,location,unit``, in any
order. A row with more fields than the header (a decimal comma in a
comma-separated file: ``0,167689``), a number written with a decimal comma,
an unknown column or text in another encoding is refused with the file and
line, never read as something else. Files with decimal commas are read with
``[measurements] decimal = ","`` (fields then separated by ``;``).
"""

from __future__ import annotations

import codecs
import csv
import io
import re
from pathlib import Path

from .inputs import cell_number, regular_file
from .schema import ProjectError, Sensor

COLUMNS = ("sensor", "value", "type", "location", "unit")
COMMA_HINT = ("; a decimal comma (as in 0,167689)? write 0.167689, or set decimal = \",\" under [measurements] "
              "with the fields separated by ;")


def _text(file: Path, encoding: str) -> str:
    data = file.read_bytes()
    try:
        return data.decode("utf-8-sig" if codecs.lookup(encoding).name == "utf-8" else encoding)
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        raise ProjectError(f"{file}: line {line}: expected {encoding} text, got byte 0x{data[exc.start]:02x}; save "
                           "the file as UTF-8, or give its encoding under [measurements] "
                           "(e.g. encoding = \"latin-1\")") from None


def read_measurements(file: Path, key: str = "measurements.file", label: str | None = None, *,
                      decimal: str = ".", encoding: str = "utf-8") -> tuple[Sensor, ...]:
    """Sensors of a CSV with columns ``sensor,value`` and optionally ``type,location,unit``.

    Parameters
    ----------
    file, key, label
        The CSV, its key in the project file and the project file (for messages).
    decimal
        ``"."`` (fields separated by ``,``) or ``","`` (fields separated by ``;``).
    encoding
        The file's text encoding.

    Raises
    ------
    ProjectError
        Naming the file and line of the first field that cannot be used.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "m.csv"; _ = f.write_text("sensor;value\\nD1;0,5\\n")
    >>> read_measurements(f, decimal=",")[0].value
    0.5
    """
    regular_file(file, label or str(file), key)
    if decimal not in (".", ","):
        raise ValueError(f"decimal: expected '.' or ',', got {decimal!r}")
    try:
        text = _text(file, encoding)
    except OSError as exc:
        raise ProjectError(f"{file}: cannot read the measurements ({key}): {exc.strerror}") from None
    delimiter = ";" if decimal == "," else ","
    reader = csv.reader(io.StringIO(text, newline=""), delimiter=delimiter)
    header = [c.strip() for c in next(reader, [])]
    missing = [c for c in ("sensor", "value") if c not in header]
    if missing:
        raise ProjectError(f"{file}: line 1: expected a header with columns sensor{delimiter}value "
                           f"(optional: type, location, unit), missing {', '.join(missing)}{_hint(header)}")
    unknown = [c for c in header if c not in COLUMNS]
    twice = sorted({c for c in header if header.count(c) > 1})
    if unknown or twice:
        what = f"unknown column '{unknown[0]}'" if unknown else f"column '{twice[0]}' twice"
        raise ProjectError(f"{file}: line 1: {what}; expected the columns {', '.join(COLUMNS)} (each at most once)")
    sensors = []
    for row in reader:
        line = reader.line_num
        if not any(cell.strip() for cell in row):
            continue  # a blank line
        if len(row) != len(header):
            hint = COMMA_HINT if len(row) > len(header) and decimal == "." else ""
            raise ProjectError(f"{file}: line {line}: expected {len(header)} fields ({delimiter.join(header)}), "
                               f"got {len(row)}{hint}")
        cells = dict(zip(header, (c.strip() for c in row)))
        if not cells["sensor"]:
            raise ProjectError(f"{file}: line {line}: sensor: expected a sensor name, got an empty cell")
        value = _number(cells["value"], file, line, "value", True, decimal)
        location = _number(cells.get("location"), file, line, "location", False, decimal)
        sensors.append(Sensor(cells["sensor"], value, type=cells.get("type", ""), location=location,
                              unit=cells.get("unit", "")))
    if not sensors:
        raise ProjectError(f"{file}: expected at least one sensor row after the header")
    return tuple(sensors)


def _number(text, file: Path, line: int, column: str, required: bool, decimal: str) -> float | None:
    text = (text or "").strip()
    if not text:
        if required:
            raise ProjectError(f"{file}: line {line}: {column}: expected a number, got an empty cell")
        return None
    if decimal == ",":
        if "." in text:
            raise ProjectError(f"{file}: line {line}: {column}: expected a number with a decimal comma "
                               f"(decimal = \",\"), got {text!r}")
        text = text.replace(",", ".")
    return cell_number(text, file, line, column, COMMA_HINT)


def _hint(header: list[str]) -> str:
    """Why a header lacks sensor and value, where the cause is plain: another
    separator (``decimal = ","`` reads ``;``-separated files) or capitals."""
    cells = [c.strip().lower() for line in header for c in re.split(r"[;,\t]", line)]
    if {"sensor", "value"} <= set(cells):
        if len(header) == 1:
            return (f" (read as one column '{header[0]}': separate the columns with ',', or with ';' and "
                    "decimal = \",\" in [measurements])")
        return " (the column names are lower case: sensor, value)"
    return ""
