"""The ``[identification]`` table and the project file it stands in, shared by
the identification's project (:mod:`edmf_rs.project.schema`) and the design
project (:mod:`edmf_rs.design.project`): one reader, one set of messages."""

from __future__ import annotations

import os
import stat
import tomllib
from dataclasses import dataclass, fields
from pathlib import Path

from ..engine.thresholds import CORRECTIONS
from .table import ProjectError, Table

#: The target identification probabilities a project may ask for: below 0.5 the
#: true model is more likely falsified than not; above 1 - 1e-9 the thresholds
#: rest on tails no uncertainty model describes.
PHI_LOW, PHI_HIGH = 0.5, 1.0 - 1e-9
PHI_RANGE = "a target identification probability between 0.5 and 0.999999999 (typically 0.95)"


@dataclass(frozen=True, eq=False)
class IdentificationTable:
    """The ``[identification]`` settings with the file they come from: the first
    fields of a project, of its spec and of a design project."""

    file: Path
    name: str
    description: str
    phi: float
    correction: str
    n_samples: int
    seed: int


def identification_fields(record: IdentificationTable) -> dict:
    """The :class:`IdentificationTable` fields of ``record`` by name, for another record of the same identification."""
    return {f.name: getattr(record, f.name) for f in fields(IdentificationTable)}


def non_regular(path: Path) -> str | None:
    """What ``path`` is when it is not a regular file ("a directory", "a FIFO
    (named pipe)", "a device or other special file"), None when it is one.
    FIFOs and devices are refused by the callers: reading a FIFO blocks until
    something writes to it. ``os.stat``'s OSError (e.g. FileNotFoundError) passes."""
    mode = os.stat(path).st_mode
    if stat.S_ISREG(mode):
        return None
    return "a directory" if stat.S_ISDIR(mode) else "a FIFO (named pipe)" if stat.S_ISFIFO(mode) else \
        "a device or other special file"


def load_toml(path: Path) -> Table:
    """The project file's top-level table; a missing file, a directory, a FIFO,
    invalid TOML or text that is not UTF-8 is a :class:`ProjectError` naming the file."""
    label = str(path)
    try:
        kind = non_regular(path)
    except FileNotFoundError:
        raise ProjectError(f"{label}: no such project file (looked in {path.parent.resolve()})") from None
    except OSError as exc:
        raise ProjectError(f"{label}: cannot read the project file: {exc.strerror}") from None
    if kind:
        raise ProjectError(f"{label}: expected a project file (TOML), got {kind}")
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except tomllib.TOMLDecodeError as exc:
        raise ProjectError(f"{label}: invalid TOML: {exc}") from None
    except UnicodeDecodeError as exc:
        raise ProjectError(f"{label}: expected UTF-8 text (TOML), got byte 0x{exc.object[exc.start]:02x} "
                           f"at offset {exc.start}") from None
    except FileNotFoundError:
        raise ProjectError(f"{label}: no such project file") from None
    except IsADirectoryError:
        raise ProjectError(f"{label}: expected a project file (TOML), got a directory") from None
    return Table(label, "", data)


def identification(root: Table, path: Path, *, phi_ok=lambda phi: PHI_LOW <= phi <= PHI_HIGH,
                   phi_what: str = PHI_RANGE) -> dict:
    """The ``[identification]`` table checked, as the fields of an :class:`IdentificationTable`;
    ``phi_ok`` and ``phi_what`` say which phi is accepted (a design takes any probability)."""
    ident = root.table("identification", {})
    ident.check_keys(("name", "description", "phi", "correction", "n_samples", "seed"))
    phi = ident.get("phi", "number", 0.95, what=phi_what)
    if not phi_ok(phi):
        raise ident.error("phi", phi_what, phi)
    n_samples = ident.get("n_samples", "int", 200_000, what="a number of Monte Carlo samples >= 1000")
    if n_samples < 1000:
        raise ident.error("n_samples", "a number of Monte Carlo samples >= 1000", n_samples)
    return dict(file=path, name=ident.get("name", "str", path.stem), description=ident.get("description", "str", ""),
                phi=phi, correction=ident.get("correction", "choice", "sidak", choices=CORRECTIONS),
                n_samples=n_samples, seed=ident.get("seed", "seed", 0))
