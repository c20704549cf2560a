"""Helpers for the daylight tests: single-wavelength waters with explicit IOPs."""

from __future__ import annotations

import pytest

from rigsim.water.model import Spectrum1D, TabulatedWater
from rigsim.water.phase import HenyeyGreenstein


def iop_water(a: float, b: float, g: float = 0.9) -> TabulatedWater:
    """A textbook water: constant a, b (1/m) and a Henyey–Greenstein phase function."""
    return TabulatedWater(f"a={a},b={b},hg={g}", Spectrum1D.constant(a), Spectrum1D.constant(b),
                          HenyeyGreenstein(g))


@pytest.fixture()
def water_factory():
    return iop_water
