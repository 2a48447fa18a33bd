"""The package layout is part of the design: rooms with one job, dependencies
pointing one way, every module importable on its own, ``__all__`` exact."""

import ast
import pkgutil
import subprocess
import sys
from pathlib import Path

import edmf_rs

PACKAGE = Path(edmf_rs.__file__).parent
MODULES = sorted(m.name for m in pkgutil.walk_packages([str(PACKAGE)], "edmf_rs.")
                 if not m.name.startswith("edmf_rs.examples.projects"))

#: Which rooms each room may import (besides itself and the Rust core ``_core``).
#: project -> adaptive, simulators -> engine -> stream; paper -> engine; nothing imports project or paper
#: but the command line, the top-level API and the examples that use them.
ALLOWED = {
    "stream": set(),
    "engine": {"stream"},
    "reference": {"engine", "design"},
    "dask": {"engine", "stream"},
    "paper": {"engine", "stream", "examples"},
    "examples": {"paper", "stream"},
    "project": {"engine", "stream", "adaptive", "simulators", "__init__"},
    "design": {"engine", "stream", "project", "reference"},
    "adaptive": {"engine", "stream", "reference"},
    "cli": {"paper", "project", "design", "examples", "simulators"},
    "simulators": {"stream", "engine"},  # engine.sensors: model outputs matched by name
}


def room(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def imported_rooms(path: Path, module: str) -> set[str]:
    """The edmf_rs rooms that ``path`` imports (relative imports resolved)."""
    package = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text("utf-8"))):
        targets = []
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                full = base + (node.module.split(".") if node.module else [])
                targets = [full] if node.module else [base + [a.name] for a in node.names]
            elif node.module and node.module.startswith("edmf_rs"):
                targets = [node.module.split(".")]
        elif isinstance(node, ast.Import):
            targets = [a.name.split(".") for a in node.names if a.name.startswith("edmf_rs")]
        for t in targets:
            if t[0] == "edmf_rs":
                found.add(t[1] if len(t) > 1 else "__init__")
    return found - {"_core", "__version__"}


ISOLATED = """
import importlib, sys
failed = []
for name in sys.argv[1:]:
    for m in [m for m in sys.modules if m.startswith("edmf_rs") and m != "edmf_rs._core"]:
        del sys.modules[m]  # each module is imported first, as if alone (the Rust core loads once)
    try:
        importlib.import_module(name)
    except Exception as exc:
        failed.append(f"{name}: {type(exc).__name__}: {exc}")
print("\\n".join(failed))
sys.exit(1 if failed else 0)
"""


def test_every_module_imports_on_its_own():
    # An import cycle shows as an ImportError when the module is the first one imported.
    modules = [m for m in MODULES if m != "edmf_rs.__main__"]  # __main__ runs the command line
    out = subprocess.run([sys.executable, "-c", ISOLATED, *modules], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout + out.stderr


def test_rooms_depend_one_way():
    wrong = []
    for module in MODULES:
        spec = __import__("importlib").util.find_spec(module)
        r = room(module)
        if r not in ALLOWED:
            continue
        for other in imported_rooms(Path(spec.origin), module) - {r}:
            if other not in ALLOWED[r]:
                wrong.append(f"{module} imports edmf_rs.{other}")
    assert not wrong, wrong


def test_top_level_shows_rooms_not_files():
    entries = sorted(p.name for p in PACKAGE.iterdir() if p.name != "__pycache__" and not p.name.endswith(".so"))
    assert len(entries) <= 16, entries
    for name in ("engine", "stream", "project", "paper", "examples"):
        assert (PACKAGE / name / "__init__.py").is_file()


def test_all_lists_exactly_the_public_names():
    for name in edmf_rs.__all__:
        assert hasattr(edmf_rs, name), name
    assert len(set(edmf_rs.__all__)) == len(edmf_rs.__all__)
    public = {n for n in vars(edmf_rs) if not n.startswith("_")}
    rooms = {"engine", "stream", "project", "paper", "examples", "reference", "design", "adaptive", "dask", "cli",
             "simulators"}
    assert public - rooms == set(edmf_rs.__all__) - rooms


def test_no_module_is_long_without_a_reason():
    long = []
    for path in PACKAGE.rglob("*.py"):
        text = path.read_text("utf-8")
        if text.count("\n") > 450 and "Longer than" not in text[:2000]:
            long.append(f"{path.relative_to(PACKAGE)}: {text.count(chr(10))} lines")
    assert not long, long
