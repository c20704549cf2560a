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
        If True, apply natural cos⁴θ fall-off of the image's camera (:func:`vignetting_map`);
        ignored, with a warning, for an image without a typed scene.
    f_number_source
        Where the f-number came from, for the capture record: ``"camera"`` (the image's own
        camera, :func:`lens_for`), ``"override"`` (stated over the camera's), ``"stated"``
        (given for an image without a camera, or built directly), ``"default …"`` (an image
        without a camera and no f-number given).
    """

    f_number: float = 4.0
    transmittance: float = 0.9
    vignetting: bool = False
    f_number_source: str = "stated"

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


def port_factor_map(spectral_image) -> np.ndarray | float:
    """Radiance in air behind the port per unit in-water radiance the image reports, per pixel.

    ``T_port / n_w²`` at each pixel centre (:func:`rigsim.scene.optics.air_radiance_factor`:
    the n² law of radiance and the port's Fresnel transmittance at the ray's angles) for an
    image whose typed scene (:attr:`~rigsim.spectral_image.SpectralImage.scene`) has water;
    1 for anything else (the clear ground truth without water, real photographs, synthetic
    images without a scene).

    Returns
    -------
    ndarray or float
        (rows, cols) factors, or the scalar 1.
    """
    scene = getattr(spectral_image, "scene", None)
    if scene is None or scene.water is None:
        return 1.0
    from rigsim.scene.optics import air_radiance_factor, outside_index

    rows, cols = np.shape(spectral_image.radiance)[:2]
    px, py = np.meshgrid((np.arange(cols) + 0.5) / cols, (np.arange(rows) + 0.5) / rows)
    return air_radiance_factor(scene.camera, px, py, n_outside=outside_index(scene))


def vignetting_map(spectral_image) -> np.ndarray | None:
    """cos⁴θ natural vignetting (rows, cols) of the image's camera, θ the chief ray's angle in air
    behind the port (from the sensor size and focal length); None without a typed scene."""
    scene = getattr(spectral_image, "scene", None)
    if scene is None:
        return None
    from rigsim.scene.optics import tan_half_fov

    rows, cols = np.shape(spectral_image.radiance)[:2]
    tx, ty = tan_half_fov(scene.camera)
    x = (2.0 * (np.arange(cols) + 0.5) / cols - 1.0)[None, :] * tx
    y = (1.0 - 2.0 * (np.arange(rows) + 0.5) / rows)[:, None] * ty
    cos2 = 1.0 / (1.0 + x * x + y * y)
    return (cos2 * cos2).astype(np.float32)


def lens_for(spectral_image, *, f_number: float | None = None, transmittance: float = 0.9,
             vignetting: bool = False) -> Lens:
    """The lens that took ``spectral_image``: its camera's f-number unless ``f_number`` overrides it.

    An image without a typed scene (a synthetic or foreign image) gets ``f_number`` or, if that
    is None too, the :class:`Lens` default (f/4), and says so in ``f_number_source``.
    """
    scene = getattr(spectral_image, "scene", None)
    if f_number is None:
        if scene is None:
            return Lens(transmittance=transmittance, vignetting=vignetting,
                        f_number_source="default (the image has no camera of its own)")
        return Lens(f_number=float(scene.camera.f_number), transmittance=transmittance, vignetting=vignetting,
                    f_number_source="camera")
    return Lens(f_number=float(f_number), transmittance=transmittance, vignetting=vignetting,
                f_number_source="override" if scene is not None else "stated")
