"""The Examples in the preview's docstrings run."""

from __future__ import annotations

import doctest
import importlib


def test_doctests():
    m = importlib.import_module("rigsim.preview.model")
    res = doctest.testmod(m, optionflags=doctest.ELLIPSIS)
    assert res.failed == 0 and res.attempted > 0
