"""The examples in the docstrings of everything the API reference shows run
as doctests, in the modules that define those objects."""

import doctest
import importlib

import pytest
from api_pages import documented_modules

MODULES = documented_modules()
FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def test_the_api_reference_covers_the_rooms():
    for module in ("edmf_rs.engine.uncertainty", "edmf_rs.engine.thresholds", "edmf_rs.engine.falsify",
                   "edmf_rs.engine.model", "edmf_rs.engine.result", "edmf_rs.reference", "edmf_rs.dask",
                   "edmf_rs.project.run", "edmf_rs.paper.cantilever", "edmf_rs._core"):
        assert module in MODULES


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples_run(name, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # an example that writes a file writes it here
    module = importlib.import_module(name)
    finder = doctest.DocTestFinder(exclude_empty=True)
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    for test in finder.find(module, name):
        runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.attempted > 0, f"{name}: no docstring example ran"
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} docstring examples failed"
