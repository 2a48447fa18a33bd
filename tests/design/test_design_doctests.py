"""The Examples sections of edmf_rs.design run as written."""

import doctest
import importlib

import pytest

MODULES = ["entropy", "placement", "identifiability"]


@pytest.mark.parametrize("name", MODULES)
def test_examples_run(name):
    module = importlib.import_module(f"edmf_rs.design.{name}")
    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0
