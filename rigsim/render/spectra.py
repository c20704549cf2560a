"""Spectra as Mitsuba sees them: defined over its whole 360–830 nm sampling range.

A Mitsuba spectrum given by samples is zero outside them, and an ``irregular``
spectrum that is zero everywhere cannot even be built; these helpers hold the end
values out to 360–830 nm and use a ``uniform`` spectrum for constants and zeros.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from rigsim.errors import ConfigError
from rigsim.spectrum import MITSUBA_WAVELENGTH_RANGE_NM, extend_to_range

__all__ = ["REGULAR_STEP_NM", "regular_dict", "spectrum_dict"]

#: Spacing of spectra resampled from functions of wavelength (nm).
REGULAR_STEP_NM = 1.0


def _fmt(a) -> str:
    return ", ".join(f"{x:.9g}" for x in np.asarray(a, float))


def spectrum_dict(wavelength_nm, values, lo_nm: float = MITSUBA_WAVELENGTH_RANGE_NM[0],
                  hi_nm: float = MITSUBA_WAVELENGTH_RANGE_NM[1], *, name: str = "spectrum") -> dict:
    """Mitsuba dict of a piecewise-linear spectrum through (wavelength, value) samples.

    Exact at and between the samples; ends held to ``[lo_nm, hi_nm]``.
    """
    wl = np.atleast_1d(np.asarray(wavelength_nm, float))
    v = np.atleast_1d(np.asarray(values, float))
    if wl.shape != v.shape or wl.size == 0:
        raise ConfigError(f"{name}: wavelengths and values must be non-empty and of equal length")
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(wl))):
        raise ConfigError(f"{name}: values must be finite")
    if np.any(v < 0):
        raise ConfigError(f"{name}: values must be >= 0", allowed=">= 0")
    if wl.size > 1 and np.any(np.diff(wl) <= 0):
        raise ConfigError(f"{name}: wavelengths must increase strictly")
    if np.all(v == v[0]):
        return {"type": "uniform", "value": float(v[0])}
    wl, v = extend_to_range(wl, v, lo_nm, hi_nm)
    return {"type": "irregular", "wavelengths": _fmt(wl), "values": _fmt(v)}


def regular_dict(fn: Callable[[np.ndarray], np.ndarray], valid_range_nm: tuple[float, float],
                 *, floor: float = 0.0) -> tuple[dict, np.ndarray, np.ndarray]:
    """Mitsuba ``regular`` spectrum sampling ``fn`` every 1 nm over 360–830 nm.

    ``fn`` is evaluated only inside ``valid_range_nm`` (end values held outside) and
    floored at ``floor``.  Returns the dict and the (wavelengths, values) it holds.
    """
    lo, hi = MITSUBA_WAVELENGTH_RANGE_NM
    wl = np.linspace(lo, hi, int(round((hi - lo) / REGULAR_STEP_NM)) + 1)
    vlo, vhi = max(valid_range_nm[0], lo), min(valid_range_nm[1], hi)
    vals = np.maximum(np.asarray(fn(np.clip(wl, vlo, vhi)), float), floor)
    if np.all(vals == vals[0]):
        return {"type": "uniform", "value": float(vals[0])}, wl, vals
    return ({"type": "regular", "wavelength_min": float(lo), "wavelength_max": float(hi),
             "values": _fmt(vals)}, wl, vals)
