"""The Examples in the daylight modules' docstrings run."""

from __future__ import annotations

import doctest
import importlib

import pytest


@pytest.mark.parametrize("mod", ["solar", "sky", "surface", "shortcut"])
def test_doctests(mod):
    m = importlib.import_module(f"rigsim.daylight.{mod}")
    res = doctest.testmod(m, optionflags=doctest.ELLIPSIS)
    assert res.failed == 0 and res.attempted > 0
