"""The Examples sections of the adaptive package run as written."""

import doctest
import importlib

import pytest


@pytest.mark.parametrize("name", ["screen", "design", "edges", "emulator", "waves"])
def test_examples_run(name):
    module = importlib.import_module(f"edmf_rs.adaptive.{name}")
    failures, tried = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert tried > 0 and failures == 0
