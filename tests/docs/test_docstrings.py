"""Every public function and class has a numpy-style docstring: what it takes,
what it gives, what it raises, and a short example."""

import inspect
import re

import edmf_rs
import pytest
from api_pages import documented_objects

OBJECTS = documented_objects()


def sections(doc: str) -> set[str]:
    """Numpy-style section titles: a line followed by a line of dashes as long."""
    lines = [line.strip() for line in inspect.cleandoc(doc).splitlines()]
    return {a for a, b in zip(lines, lines[1:]) if a and b == "-" * len(a)}


def takes_arguments(obj) -> bool:
    try:
        params = inspect.signature(obj).parameters
    except (TypeError, ValueError):
        return True
    return any(p for p in params if p not in ("self", "cls"))


PUBLIC = [n for n in edmf_rs.__all__ if inspect.isclass(getattr(edmf_rs, n)) or callable(getattr(edmf_rs, n))
          and not inspect.ismodule(getattr(edmf_rs, n))]


def test_public_names_are_found():
    assert {"combine", "threshold_bounds", "falsify", "Thresholds", "get_num_threads"} <= set(PUBLIC)


def assert_full_docstring(name: str, obj, function_sections: set[str]) -> None:
    """An Examples section with a doctest; Parameters or Attributes for a class; for a
    function, Parameters when it takes arguments and ``function_sections``."""
    doc = obj.__doc__ or ""
    found = sections(doc)
    assert "Examples" in found and ">>>" in doc, f"{name}: no Examples section with a doctest"
    if inspect.isclass(obj):
        assert found & {"Parameters", "Attributes"}, f"{name}: no Parameters or Attributes section"
    else:
        if takes_arguments(obj):
            assert "Parameters" in found, f"{name}: no Parameters section"
        assert function_sections <= found, f"{name}: expected {sorted(function_sections)} sections, found {found}"


@pytest.mark.parametrize("name", PUBLIC)
def test_every_public_name_has_a_full_docstring(name):
    assert_full_docstring(name, getattr(edmf_rs, name), {"Returns", "Raises"})


@pytest.mark.parametrize("name", sorted(OBJECTS))
def test_everything_in_the_api_reference_is_documented(name):
    obj = OBJECTS[name]
    doc = obj.__doc__ or ""
    found = sections(doc)
    if inspect.isclass(obj):
        assert found & {"Parameters", "Attributes"}, f"{name}: no Parameters or Attributes section"
        methods = [m for m, v in vars(obj).items() if not m.startswith("_") and inspect.isfunction(v)]
        for m in methods:
            if getattr(obj, m).__doc__:
                assert "Returns" in sections(getattr(obj, m).__doc__), f"{name}.{m}: no Returns section"
    else:
        if takes_arguments(obj):
            assert "Parameters" in found, f"{name}: no Parameters section"
        assert "Returns" in found, f"{name}: no Returns section"
    # An example here, or a pointer to the one object whose example covers it.
    assert ("Examples" in found and (">>>" in doc or re.search(r"See `\w+`", doc))) or \
        re.search(r"Examples: see `\w+`", doc), f"{name}: no example"


def test_stub_docstrings_match_the_extension():
    # The site reads the Rust functions' docstrings from _core.pyi; Python reads them from the extension.
    import ast
    from pathlib import Path

    stub = Path(edmf_rs.__file__).with_name("_core.pyi")
    if not stub.exists():  # an installed wheel may not ship the stub: read the source tree's
        stub = Path(__file__).resolve().parents[2] / "python" / "edmf_rs" / "_core.pyi"
    tree = ast.parse(stub.read_text(encoding="utf-8"))
    documented = {f.name: ast.get_docstring(f) for f in tree.body if isinstance(f, ast.FunctionDef)
                  and ast.get_docstring(f)}
    assert {"get_num_threads", "set_num_threads"} <= set(documented)
    for name, text in documented.items():
        assert inspect.cleandoc(getattr(edmf_rs._core, name).__doc__) == text, name


ROOMS = ("edmf_rs.adaptive", "edmf_rs.design", "edmf_rs.simulators")
ROOM_OBJECTS = {f"{room}.{name}": getattr(__import__(room, fromlist=["_"]), name)
                for room in ROOMS for name in __import__(room, fromlist=["_"]).__all__}


@pytest.mark.parametrize("name", sorted(n for n, o in ROOM_OBJECTS.items() if inspect.isclass(o) or inspect.isfunction(o)))
def test_every_public_name_of_the_rooms_has_a_full_docstring(name):
    """The rooms' public functions and classes (their ``__all__``) follow the same rule."""
    assert_full_docstring(name, ROOM_OBJECTS[name], {"Returns"})
