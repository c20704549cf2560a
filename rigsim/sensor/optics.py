"""Lens and camera equation: entrance-pupil radiance → photo-electrons per pixel.

The focal-plane irradiance of an object of radiance L seen through a lens of
f-number N and transmittance T is (camera equation, on axis, object at
infinity)

    E(λ) = π · T · L(λ) / (4 N²)          [W m⁻² nm⁻¹]

optionally times cos⁴θ off axis (natural vignetting).  A pixel of area A
exposed for t seconds collects

    n_p = Σ_bands E(λ_b) · A · t · λ_b / (h c) · Δλ_b      photons,

and produces n_e = Σ_b n_p,b · η_c(λ_b) photo-electrons in CFA channel c.

The render's pixel grid need not match the sensor's: the SpectralImage is a
resampled view of the scene, and the photon count of each of its pixels is that
of *one sensor pixel* (area = pitch²) seeing that radiance.  Resampling to
another grid (``shape=`` in :func:`rigsim.sensor.pipeline.capture`) keeps
radiance, hence electrons per pixel, unchanged.

References
----------
Slater, P. N. (1980). *Remote Sensing: Optics and Optical Systems*, §7 (camera equation).
EMVA Standard 1288, Release 4.0 (2021), §2 (photons per pixel, μ_p = A E t λ / (h c)).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.constants import c as SPEED_OF_LIGHT, h as PLANCK

from rigsim.errors import ConfigError


@dataclass(frozen=True)
class Lens:
    """A camera lens for the camera equation.

    Attributes
    ----------
    f_number
        Working f-number N (> 0.5).
    transmittance
        Lens transmittance T (0–1), spectrally flat.
    vignetting
        If True, apply natural cos⁴θ fall-off using the render's field of view
        (``meta['fov_deg']``, horizontal, degrees); ignored if the render has none.
    """

    f_number: float = 4.0
    transmittance: float = 0.9
    vignetting: bool = False

    def __post_init__(self):
        if not (np.isfinite(self.f_number) and self.f_number >= 0.5):
            raise ConfigError(f"f-number must be >= 0.5, got {self.f_number}", field="f_number",
                              allowed="0.5 … 64")
        if not (0 < self.transmittance <= 1):
            raise ConfigError(f"lens transmittance must be in (0, 1], got {self.transmittance}",
                              field="transmittance", allowed="(0, 1]")


def irradiance_factor(lens: Lens) -> float:
    """π·T/(4N²): focal-plane irradiance per unit scene radiance (sr)."""
    return np.pi * lens.transmittance / (4.0 * lens.f_number ** 2)


def cos4_map(shape: tuple[int, int], fov_deg: float) -> np.ndarray:
    """cos⁴θ natural vignetting over an image of ``shape`` with horizontal FOV ``fov_deg``.

    Parameters
    ----------
    shape
        (rows, cols).
    fov_deg
        Horizontal field of view (degrees, 0–179).

    Returns
    -------
    ndarray
        (rows, cols) float32, 1 on axis.
    """
    rows, cols = shape
    f_px = (cols / 2.0) / np.tan(np.radians(fov_deg) / 2.0)
    y = (np.arange(rows) - (rows - 1) / 2.0)[:, None]
    x = (np.arange(cols) - (cols - 1) / 2.0)[None, :]
    cos2 = f_px ** 2 / (f_px ** 2 + x ** 2 + y ** 2)
    return (cos2 * cos2).astype(np.float32)


def electrons_per_radiance(wavelength_nm, bandwidth_nm, qe, *, lens: Lens, pixel_area_m2: float,
                           exposure_time_s: float) -> np.ndarray:
    """Matrix turning band radiance into mean photo-electrons per pixel.

    Parameters
    ----------
    wavelength_nm, bandwidth_nm
        Band centres and widths (nm), shape (bands,).
    qe
        Absolute quantum efficiency at the band centres, shape (bands, channels).
    lens
        The lens (f-number, transmittance).
    pixel_area_m2
        Pixel area (m²).
    exposure_time_s
        Exposure time (s).

    Returns
    -------
    ndarray
        (bands, channels): electrons = radiance[..., bands] @ M, radiance in
        W·m⁻²·sr⁻¹·nm⁻¹.
    """
    wl = np.asarray(wavelength_nm, float)
    bw = np.asarray(bandwidth_nm, float)
    photon_energy_j = PLANCK * SPEED_OF_LIGHT / (wl * 1e-9)
    photons_per_radiance = irradiance_factor(lens) * pixel_area_m2 * exposure_time_s * bw / photon_energy_j
    return photons_per_radiance[:, None] * np.asarray(qe, float)


def port_radiance_factor(meta: dict | None) -> float:
    """Factor from the in-water radiance a render reports to the radiance in air behind the port.

    The basic radiance L/n² is conserved along a ray through lossless interfaces
    (radiance theorem; e.g. Mobley, *Light and Water* 1994, §4.3), so the housing's air
    side sees ``L_air = T_port · L_water / n_water²`` — for a dome or a flat port alike
    (the dome changes where the image forms, not its radiance).  T_port is the Fresnel
    transmittance at normal incidence of the water→glass and glass→air surfaces,
    ``(1 − R₁)(1 − R₂)`` with ``R = ((n₁ − n₂)/(n₁ + n₂))²``; glass absorption is neglected.

    Renders whose ``meta['radiance_reference']`` says the radiance is in water and that
    have water (``meta['water']``) get this factor; anything else (renders without water,
    real photographs) gets 1.
    """
    meta = meta or {}
    if not str(meta.get("radiance_reference", "")).startswith("in-water") or not meta.get("water"):
        return 1.0
    from rigsim.water.kd import WATER_INDEX

    port = (meta.get("camera") or {}).get("port") or {}
    ng = float(port.get("glass_index", 1.49))
    nw = WATER_INDEX
    r1 = ((nw - ng) / (nw + ng)) ** 2
    r2 = ((ng - 1.0) / (ng + 1.0)) ** 2
    return (1 - r1) * (1 - r2) / nw**2
