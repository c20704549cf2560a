"""Doctests of the modules that wrap colour-science, colour-demosaicing and PyVista."""

import doctest
import importlib

import pytest


@pytest.mark.parametrize("mod", ["rigsim.colorimetry", "rigsim.scene.meshes", "rigsim.sensor.cfa",
                                 "rigsim.light.spectra", "rigsim.light.photometry"])
def test_doctests(mod):
    m = importlib.import_module(mod)
    res = doctest.testmod(m, optionflags=doctest.ELLIPSIS)
    assert res.failed == 0 and res.attempted > 0
