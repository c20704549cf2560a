"""Shared fixtures: synthetic SpectralImages (ColorChecker under D65, flat fields)."""

from __future__ import annotations

import numpy as np
import pytest

from rigsim.spectral_image import SpectralImage

WL = np.arange(400.0, 701.0, 10.0)
BW = np.full_like(WL, 10.0)
PATCH = 16  # pixels per ColorChecker patch side


def d65(wl=WL) -> np.ndarray:
    import colour

    sd = colour.SDS_ILLUMINANTS["D65"]
    return np.interp(wl, sd.wavelengths, sd.values)


def chart_image(irradiance_scale: float = 0.01, illuminant=None, patch: int = PATCH) -> SpectralImage:
    """ColorChecker N Ohta, 4×6 patches of ``patch`` px, radiance = ρ·E/π (W m⁻² sr⁻¹ nm⁻¹)."""
    from rigsim.sensor.ccm import colorchecker_reflectances

    e = (d65() if illuminant is None else illuminant) * irradiance_scale
    refl = colorchecker_reflectances(WL)
    rad = np.zeros((4 * patch, 6 * patch, len(WL)))
    for i in range(24):
        r, c = divmod(i, 6)
        rad[r * patch:(r + 1) * patch, c * patch:(c + 1) * patch] = refl[i] * e / np.pi
    return SpectralImage(rad, WL, BW, meta={"fov_deg": 50.0})


def patch_means(img: np.ndarray, patch: int = PATCH, margin: int = 4) -> np.ndarray:
    """(24, 3) mean of each patch's centre."""
    return np.array([img[r * patch + margin:(r + 1) * patch - margin,
                         c * patch + margin:(c + 1) * patch - margin].reshape(-1, 3).mean(axis=0)
                     for r in range(4) for c in range(6)])


def flat_image(level: float, shape=(8, 8)) -> SpectralImage:
    """Spectrally flat radiance ``level`` W m⁻² sr⁻¹ nm⁻¹."""
    return SpectralImage(np.full((*shape, len(WL)), level), WL, BW)


@pytest.fixture(scope="session")
def chart():
    return chart_image()
