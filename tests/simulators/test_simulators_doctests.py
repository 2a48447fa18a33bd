"""The Examples sections of the simulators package run as written (the KeyedEvaluator example
had drifted: two lambdas on two lines are two models to the store's key)."""

import doctest
import importlib

import pytest


@pytest.mark.parametrize("name", ["cluster", "columns", "command", "evaluator", "failures", "keyed", "parsers",
                                  "pool", "store", "template"])
def test_examples_run(name):
    module = importlib.import_module(f"edmf_rs.simulators.{name}")
    failures, tried = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert tried > 0 and failures == 0
