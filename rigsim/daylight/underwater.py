"""Daylight for the renderer: the sun beam and sky radiance just below the surface, and the light field at depth.

These are the functions the renderer's ambient lighting uses, so that rendered
daylight and the ambient meter are the same physics.

Scene frame (as :mod:`rigsim.scene`): x right, **y up**, z forward (the default
camera looks along +z).  The sun's azimuth φ is measured in the horizontal x–z
plane from +z towards +x: the horizontal direction *towards* the sun is
``(sin φ, 0, cos φ)``.  A direction of propagation of light going down at zenith
angle θ (from the vertical) away from the sun is therefore
``(−sin θ sin φ, −cos θ, −sin θ cos φ)``.

Units: plane and beam irradiance W·m⁻²·nm⁻¹, radiance W·m⁻²·sr⁻¹·nm⁻¹.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigsim.daylight.meter import Bottom, ambient_light_monte_carlo
from rigsim.daylight.shortcut import ambient_light_kd
from rigsim.daylight.sky import BlackSky, SkyModel, sky_model
from rigsim.daylight.solar import SurfaceIrradiance, surface_irradiance
from rigsim.water.refraction import WATER_INDEX, fresnel_reflectance_unpolarised, snell_cos_transmitted
from rigsim.errors import ConfigError
from rigsim.scene.types import Daylight
from rigsim.spectrum import as_wavelengths
from rigsim.water.model import Water

__all__ = [
    "daylight_above_surface",
    "SunBeam",
    "sun_beam_below_surface",
    "sky_radiance_below_surface",
    "AmbientLightField",
    "ambient_light_field_at_depth",
    "direction_down_scene",
]


def direction_down_scene(zenith_deg, azimuth_deg) -> np.ndarray:
    """Propagation direction (scene frame, unit) of light going down at ``zenith_deg`` from a source at ``azimuth_deg``."""
    t, p = np.radians(np.asarray(zenith_deg, float)), np.radians(np.asarray(azimuth_deg, float))
    return np.stack(np.broadcast_arrays(-np.sin(t) * np.sin(p), -np.cos(t), -np.sin(t) * np.cos(p)), axis=-1)


def daylight_above_surface(daylight: Daylight, wavelength_nm, sky: str | SkyModel = "cie") -> SurfaceIrradiance:
    """Sun and sky plane irradiance just above the surface for a :class:`Daylight`.

    If the daylight carries a surface irradiance spectrum it is interpolated and
    split between sun and sky with the ASTM G173 clear-sky model's sky share (none
    for a black sky); otherwise the clear-sky model itself is used.
    """
    wl = np.atleast_1d(as_wavelengths(wavelength_nm))
    sky_m = sky_model(sky, daylight.sun_zenith_deg) if isinstance(sky, str) else sky
    black = isinstance(sky_m, BlackSky)
    model = surface_irradiance(wl, daylight.sun_zenith_deg, black_sky=black)
    if not daylight.surface_irradiance:
        return model
    tw = np.asarray(daylight.surface_irradiance_wavelength_nm, float)
    tv = np.asarray(daylight.surface_irradiance, float)
    if tw.size != tv.size or tw.size == 0:
        raise ConfigError("surface irradiance table needs as many values as wavelengths",
                          field="daylight.surface_irradiance")
    total = np.interp(wl, tw, tv) if tw.size > 1 else np.full(wl.shape, float(tv[0]))
    f = model.sky_fraction
    return SurfaceIrradiance(wl, total * (1 - f), total * f, "daylight.surface_irradiance")


@dataclass(frozen=True, eq=False)
class SunBeam:
    """The direct sun beam just below a flat surface.

    Attributes
    ----------
    direction
        Unit propagation direction in the scene frame (going down).
    zenith_water_deg
        Zenith angle of the refracted beam, deg (Snell, n = 1.34).
    wavelength_nm
        Band centres, nm.
    irradiance_normal
        Spectral irradiance on a plane normal to the beam, W·m⁻²·nm⁻¹:
        ``E_sun(0+) (1 − R(θ_s)) / cos θ_w`` (the plane irradiance through the
        surface is conserved apart from Fresnel reflection).
    fresnel_transmittance
        ``1 − R(θ_s)``.
    """

    direction: np.ndarray
    zenith_water_deg: float
    wavelength_nm: np.ndarray
    irradiance_normal: np.ndarray
    fresnel_transmittance: float

    def at_depth(self, depth_m: float, c_per_m: np.ndarray) -> np.ndarray:
        """Unscattered beam irradiance (normal to the beam) at ``depth_m``: ``E e^{−c z / cos θ_w}``."""
        mu = np.cos(np.radians(self.zenith_water_deg))
        return self.irradiance_normal * np.exp(-np.asarray(c_per_m, float) * float(depth_m) / mu)


def sun_beam_below_surface(daylight: Daylight, wavelength_nm, *, sky: str | SkyModel = "cie",
                           above: SurfaceIrradiance | None = None, n_water: float = WATER_INDEX) -> SunBeam:
    """The sun's refracted, Fresnel-transmitted beam just below a flat surface (see :class:`SunBeam`)."""
    wl = np.atleast_1d(as_wavelengths(wavelength_nm))
    above = above or daylight_above_surface(daylight, wl, sky)
    cos_s = np.cos(np.radians(daylight.sun_zenith_deg))
    t = 1.0 - float(fresnel_reflectance_unpolarised(cos_s, 1.0, n_water))
    cos_w = float(snell_cos_transmitted(cos_s, 1.0, n_water))
    zw = float(np.degrees(np.arccos(cos_w)))
    return SunBeam(direction_down_scene(zw, daylight.sun_azimuth_deg), zw, wl, above.sun * t / cos_w, t)


def sky_radiance_below_surface(daylight: Daylight, wavelength_nm, cos_zenith_water, rel_azimuth_rad, *,
                               sky: str | SkyModel = "cie", above: SurfaceIrradiance | None = None,
                               n_water: float = WATER_INDEX) -> np.ndarray:
    """Transmitted sky radiance just below a flat surface, W·m⁻²·sr⁻¹·nm⁻¹, shape ``dirs.shape + (n_wl,)``.

    For a downward direction at zenith angle θ_w (``cos_zenith_water`` = cos θ_w
    of the direction *looking up* at the sky, i.e. light arriving from there) and
    azimuth φ relative to the sun, the light came from the sky at θ_a with
    ``sin θ_a = n sin θ_w``: ``L_w = n² (1 − R(θ_a)) E_sky ℓ(θ_a, φ)`` (the n²
    radiance law).  Beyond the critical angle (θ_w > 48.3°) the sky contributes
    nothing; the radiance there (internally reflected upwelling light, a few % of
    the sky's) is not included.
    """
    wl = np.atleast_1d(as_wavelengths(wavelength_nm))
    sky_m = sky_model(sky, daylight.sun_zenith_deg) if isinstance(sky, str) else sky
    above = above or daylight_above_surface(daylight, wl, sky_m)
    mu_w = np.clip(np.asarray(cos_zenith_water, float), 0.0, 1.0)
    cos_a = snell_cos_transmitted(mu_w, n_water, 1.0)
    ok = np.isfinite(cos_a)
    cos_a = np.where(ok, cos_a, 0.0)
    ell = np.where(ok, sky_m.radiance(cos_a, rel_azimuth_rad), 0.0)
    t = 1.0 - fresnel_reflectance_unpolarised(cos_a, 1.0, n_water)
    return (n_water ** 2 * t * ell)[..., None] * above.sky


@dataclass(frozen=True, eq=False)
class AmbientLightField:
    """A compact description of daylight at one depth, for the renderer's ambient lighting.

    Attributes
    ----------
    depth_m, wavelength_nm
        Where and at which bands.
    sun
        The unscattered sun beam at this depth (direction, ``irradiance_normal`` already
        attenuated by ``exp(−c z / cos θ_w)``).
    diffuse_down_radiance
        Scattered downwelling light as a uniform hemisphere of this radiance:
        ``(Ed − E_beam,plane)/π``.
    up_radiance
        Upwelling light as a uniform hemisphere of the nadir radiance Lu.
    Ed, Eu, Lu
        The plane irradiances and nadir radiance they were made from.
    model
        ``"kd"`` or ``"monte-carlo"``.
    """

    depth_m: float
    wavelength_nm: np.ndarray
    sun: SunBeam
    diffuse_down_radiance: np.ndarray
    up_radiance: np.ndarray
    Ed: np.ndarray
    Eu: np.ndarray
    Lu: np.ndarray
    model: str


def ambient_light_field_at_depth(daylight: Daylight, water: Water, wavelength_nm, *, sky: str | SkyModel = "cie",
                                 bottom: Bottom | None = None, photons: int = 20_000,
                                 seed: int = 0) -> AmbientLightField:
    """Daylight at ``daylight.depth_m`` from the Kd shortcut or the Monte Carlo meter (``daylight.model``).

    The unscattered sun beam is attenuated by the beam attenuation c; whatever Ed
    remains is scattered light, represented as a uniform downwelling hemisphere;
    upwelling light is a uniform hemisphere of radiance Lu (so Eu is reproduced up
    to the Q-factor, Eu = Q Lu with Q = π here).
    """
    wl = np.atleast_1d(water.check_range(as_wavelengths(wavelength_nm)))
    sky_m = sky_model(sky, daylight.sun_zenith_deg) if isinstance(sky, str) else sky
    above = daylight_above_surface(daylight, wl, sky_m)
    z = float(daylight.depth_m)
    kw = dict(sun_zenith_deg=daylight.sun_zenith_deg, sky=sky_m, above=above, bottom=bottom)
    if daylight.model == "monte-carlo":
        res = ambient_light_monte_carlo(water, wl, [z], photons=photons, seed=seed, **kw)
    elif daylight.model == "kd":
        res = ambient_light_kd(water, wl, [z], **kw)
    else:
        raise ConfigError(f"unknown daylight model {daylight.model!r}", field="daylight.model",
                          allowed="kd, monte-carlo")
    beam0 = sun_beam_below_surface(daylight, wl, sky=sky_m, above=above)
    c = water.c_per_m(wl)
    e_beam = beam0.at_depth(z, c)
    mu_w = np.cos(np.radians(beam0.zenith_water_deg))
    sun = SunBeam(beam0.direction, beam0.zenith_water_deg, wl, e_beam, beam0.fresnel_transmittance)
    ed, eu, lu = res["Ed"][0], res["Eu"][0], res["Lu"][0]
    diffuse = np.maximum(ed - e_beam * mu_w, 0.0) / np.pi
    return AmbientLightField(z, wl, sun, diffuse, lu.copy(), ed, eu, lu, daylight.model)
