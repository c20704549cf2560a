"""Doctests of the optimiser's modules and of the rig conventions it relies on."""

import doctest
import importlib

import pytest


@pytest.mark.parametrize("mod", ["rigsim.optimise.diagram", "rigsim.config.rig"])
def test_doctests(mod):
    res = doctest.testmod(importlib.import_module(mod), optionflags=doctest.ELLIPSIS)
    assert res.failed == 0 and res.attempted > 0
