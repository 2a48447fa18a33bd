"""What the API reference (docs/api.md) documents, read from its ``::: name``
directives, so adding an object to the page puts it under the docs tests."""

from __future__ import annotations

import importlib
import inspect
import re
import sys
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[2]
API_PAGE = ROOT / "docs" / "api.md"


def directives() -> list[tuple[str, list[str] | None]]:
    """(dotted name, members listed in its options or None) for every ``:::`` block."""
    found = []
    lines = API_PAGE.read_text(encoding="utf-8").splitlines()
    for k, line in enumerate(lines):
        m = re.match(r"^::: (\S+)\s*$", line)
        if not m:
            continue
        members = None
        for option in lines[k + 1:]:
            if not option.startswith("    "):
                break
            listed = re.match(r"\s+members:\s*\[(.*)\]\s*$", option)
            if listed:
                members = [s.strip() for s in listed.group(1).split(",") if s.strip()]
        found.append((m.group(1), members))
    return found


def resolve(name: str):
    """The object a dotted name stands for (a module, or an attribute of one)."""
    parts = name.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for attr in parts[cut:]:
            obj = getattr(obj, attr)
        return obj
    raise ImportError(name)


def defining_module(obj) -> ModuleType:
    return obj if inspect.ismodule(obj) else sys.modules[obj.__module__]


def documented_objects() -> dict[str, object]:
    """Every public function and class the page shows: named ones, and the
    public members of the modules it shows (or the members it lists)."""
    objects = {}
    for name, members in directives():
        obj = resolve(name)
        if not inspect.ismodule(obj):
            objects[name] = obj
            continue
        names = members if members is not None else [
            n for n, v in vars(obj).items()
            if not n.startswith("_") and (inspect.isfunction(v) or inspect.isclass(v))
            and getattr(v, "__module__", None) == obj.__name__]
        for member in names:
            objects[f"{name}.{member}"] = getattr(obj, member)
    return objects


def documented_modules() -> list[str]:
    """The modules where the documented objects are defined (their doctests live there)."""
    return sorted({defining_module(obj).__name__ for obj in documented_objects().values()})
