"""The Kd shortcut: ambient light at depth from Kd(λ) and an irradiance reflectance, no transport.

``Ed(z) = Ed(0−) exp(−Kd z)`` with ``Kd`` from :meth:`Water.kd_per_m`
(Lee et al. 2005 by default) and ``Ed(0−)`` the Fresnel-transmitted sun and sky.
The other quantities follow from documented closures:

* ``Eu(z) = R(z) Ed(z)``, with the deep-water irradiance reflectance of Gordon et
  al. (1975), ``R∞ = 0.0001 + 0.3244 X + 0.1425 X² + 0.1308 X³``, ``X = b_b/(a + b_b)``,
  and a bottom of reflectance A at depth H by Maritorena et al. (1994):
  ``R(z) = R∞ + (A − R∞) exp(−2 Kd (H − z))`` (A = 0 for a black bottom).
* ``Eo`` from Gershun's law ``a Eo = −d(Ed − Eu)/dz`` with both streams decaying as
  ``exp(−Kd z)``: ``Eo = Kd (Ed − Eu)/a`` (never less than ``Ed + Eu``).
* The upwelling radiance is taken as isotropic: ``Eou = 2 Eu``, ``Lu = Eu/π``
  (Q = π; natural waters have Q ≈ 3–5, so Lu is over-estimated by up to ~40 %).
  ``Eod = Eo − Eou``.

Typical accuracy against the Monte Carlo meter: Ed 5–15 % in the top tens of
metres (the Lee model's own accuracy; Kd changes with depth as the light field
becomes diffuse, the shortcut keeps the layer value), Eu and Lu 20–50 %.

References
----------
.. [Le05] Z.-P. Lee, K.-P. Du, R. Arnone, J. Geophys. Res. 110, C02016 (2005).
.. [Go75] H.R. Gordon, O.B. Brown, M.M. Jacobs, "Computed relationships between the
   inherent and apparent optical properties of a flat homogeneous ocean",
   Appl. Opt. 14(2):417–427 (1975).
.. [Ma94] S. Maritorena, A. Morel, B. Gentili, "Diffuse reflectance of oceanic
   shallow waters: influence of water depth and bottom albedo",
   Limnol. Oceanogr. 39(7):1689–1703 (1994).
.. [Mo94] C.D. Mobley, *Light and Water* (1994), §5.10 (Gershun's law).
"""

from __future__ import annotations

import numpy as np

from rigsim.daylight.meter import QUANTITIES, AmbientResult, Bottom, check_depths
from rigsim.daylight.sky import BlackSky, SkyModel, sky_model
from rigsim.daylight.solar import SurfaceIrradiance, surface_irradiance
from rigsim.daylight.surface import Surface, fresnel_reflectance_unpolarised
from rigsim.spectrum import as_wavelengths
from rigsim.water.model import Water
from rigsim.water.refraction import WATER_INDEX

__all__ = [
    "irradiance_reflectance_Gordon1975",
    "irradiance_reflectance_shallow_Maritorena1994",
    "sky_fresnel_reflectance",
    "transmitted_plane_irradiance",
    "ambient_light_kd",
    "compare_ambient",
]


def irradiance_reflectance_Gordon1975(a_per_m, bb_per_m) -> np.ndarray:
    """Deep-water irradiance reflectance R = Eu/Ed just below the surface [Go75].

    Examples
    --------
    >>> round(float(irradiance_reflectance_Gordon1975(0.1, 0.01)), 4)
    0.0309
    """
    a, bb = np.asarray(a_per_m, float), np.asarray(bb_per_m, float)
    x = np.divide(bb, a + bb, out=np.zeros(np.broadcast(a, bb).shape), where=(a + bb) > 0)
    return 0.0001 + 0.3244 * x + 0.1425 * x * x + 0.1308 * x ** 3


def irradiance_reflectance_shallow_Maritorena1994(r_deep, kd_per_m, height_above_bottom_m,
                                                  bottom_reflectance) -> np.ndarray:
    """R(z) = R∞ + (A − R∞) exp(−2 Kd (H − z)) [Ma94]."""
    return r_deep + (bottom_reflectance - r_deep) * np.exp(-2.0 * np.asarray(kd_per_m) *
                                                             np.asarray(height_above_bottom_m))


def sky_fresnel_reflectance(sky: SkyModel, n_water: float = WATER_INDEX, n_mu: int = 400) -> float:
    """Share of the sky's plane irradiance a flat surface reflects: ``∫ ℓ cos θ R(θ) dΩ`` (0.066 for a uniform sky)."""
    if not sky.emits:
        return 0.0
    mu = (np.arange(n_mu) + 0.5) / n_mu
    phi = (np.arange(180) + 0.5) / 180 * 2 * np.pi - np.pi
    ell = sky.radiance(mu[:, None], phi[None, :])
    r = fresnel_reflectance_unpolarised(mu, 1.0, n_water)[:, None]
    dmu, dphi = 1.0 / n_mu, 2 * np.pi / 180
    tot = np.sum(ell * mu[:, None]) * dmu * dphi
    return float(np.sum(ell * mu[:, None] * r) * dmu * dphi / tot)


def transmitted_plane_irradiance(above: SurfaceIrradiance, sun_zenith_deg: float, sky: SkyModel,
                                 n_water: float = WATER_INDEX) -> tuple[np.ndarray, np.ndarray]:
    """Ed(0−) of the sun and of the sky through a flat surface (no internal reflection of upwelling light)."""
    t_sun = 1.0 - float(fresnel_reflectance_unpolarised(np.cos(np.radians(sun_zenith_deg)), 1.0, n_water))
    t_sky = 1.0 - sky_fresnel_reflectance(sky, n_water)
    return above.sun * t_sun, above.sky * t_sky


def ambient_light_kd(water: Water, wavelength_nm, depth_m, *, sun_zenith_deg: float = 30.0,
                     sky: str | SkyModel = "cie", above: SurfaceIrradiance | None = None,
                     surface: Surface | None = None, bottom: Bottom | None = None,
                     kd_method: str = "lee-2005") -> AmbientResult:
    """Ambient light at depth by the Kd shortcut (see module docstring); same result type as the meter.

    ``surface`` is accepted for a uniform interface; the shortcut always uses the
    flat-surface Fresnel transmittance.  Standard errors are zero (the error is the
    model's, see the module docstring).
    """
    wl = np.atleast_1d(water.check_range(as_wavelengths(wavelength_nm)))
    bottom = bottom or Bottom()
    surface = surface or Surface()
    z = check_depths(depth_m, bottom)
    if isinstance(sky, str):
        sky = sky_model(sky, sun_zenith_deg)
    if above is None:
        above = surface_irradiance(wl, sun_zenith_deg, black_sky=isinstance(sky, BlackSky))
    e_sun, e_sky = transmitted_plane_irradiance(above, sun_zenith_deg, sky, surface.n_water)
    ed0 = e_sun + e_sky
    a, bb = water.a_per_m(wl), water.bb_per_m(wl)
    kd = water.kd_per_m(wl, sun_zenith_deg, kd_method)
    ed = ed0[None, :] * np.exp(-kd[None, :] * z[:, None])
    r_inf = irradiance_reflectance_Gordon1975(a, bb)
    if bottom.depth_m is None:
        r = np.broadcast_to(r_inf, ed.shape)
    else:
        r = irradiance_reflectance_shallow_Maritorena1994(r_inf[None, :], kd[None, :],
                                                          float(bottom.depth_m) - z[:, None], bottom.reflectance)
    eu = r * ed
    with np.errstate(divide="ignore", invalid="ignore"):
        eo = np.where(a[None, :] > 0, kd[None, :] * (ed - eu) / a[None, :], np.inf)
    eo = np.maximum(eo, ed + 2.0 * eu)
    eou = 2.0 * eu
    values = {"Ed": ed, "Eu": eu, "Eo": eo, "Eod": eo - eou, "Eou": eou, "Lu": eu / np.pi,
              "Kd": np.broadcast_to(kd, ed.shape).copy()}
    stderr = {q: np.zeros_like(values[q]) for q in QUANTITIES}
    meta = {"model": "kd", "kd_method": kd_method, "water": water.describe(),
            "sun_zenith_deg": float(sun_zenith_deg), "sky": sky.describe(), "surface": "flat (Fresnel)",
            "bottom": bottom.describe(), "above_surface_spectrum": above.spectrum,
            "closures": "R: Gordon 1975 + Maritorena 1994; Eo: Gershun; Eou = 2 Eu; Lu = Eu/pi"}
    return AmbientResult(wl, z, values, stderr, above, {}, meta)


def compare_ambient(reference: AmbientResult, other: AmbientResult) -> dict[str, np.ndarray]:
    """Relative difference ``other/reference − 1`` per quantity (n_depth, n_wavelength).

    Typically ``reference`` is the Monte Carlo meter and ``other`` the Kd shortcut.
    """
    if reference.depth_m.shape != other.depth_m.shape or not np.allclose(reference.depth_m, other.depth_m) \
            or not np.allclose(reference.wavelength_nm, other.wavelength_nm):
        raise ValueError("results are on different depth or wavelength grids")
    out = {}
    for q in QUANTITIES:
        with np.errstate(divide="ignore", invalid="ignore"):
            out[q] = other.values[q] / reference.values[q] - 1.0
    return out
