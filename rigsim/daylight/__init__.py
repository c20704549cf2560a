"""Daylight at depth: sun and sky above the sea, the air–water surface, and light in the water column.

* :mod:`~rigsim.daylight.solar` — spectral sun and sky plane irradiance above the
  surface (ASTM G173 clear-sky model, CIE daylight).
* :mod:`~rigsim.daylight.sky` — sky radiance shapes: black, uniform, CIE Standard
  General Sky (S 011/E:2003).
* :mod:`~rigsim.daylight.surface` — Fresnel, Snell, Cox–Munk rough surface.
* :mod:`~rigsim.daylight.meter` — the Monte Carlo ambient light meter (Ed, Eu, Eo,
  Eod, Eou, Lu, Kd with standard errors).
* :mod:`~rigsim.daylight.shortcut` — the fast Kd approximation and a comparison.
* :mod:`~rigsim.daylight.underwater` — what the renderer needs: the sun beam and
  sky radiance below the surface, the light field at a depth.
* :mod:`~rigsim.daylight.waves` — wavy surfaces (sum of sines, Pierson–Moskowitz)
  and caustic patterns.
"""

from rigsim.daylight.meter import (
    DEFAULT_PHOTONS,
    QUANTITIES,
    UNITS,
    AmbientResult,
    Bottom,
    ambient_light_monte_carlo,
)
from rigsim.daylight.shortcut import ambient_light_kd, compare_ambient
from rigsim.daylight.sky import SKY_MODELS, CIEGeneralSky, SkyModel, UniformSky, sky_model
from rigsim.daylight.solar import SurfaceIrradiance, surface_irradiance
from rigsim.daylight.surface import (
    Surface,
    cox_munk_surface,
    flat_surface,
    fresnel_reflectance_unpolarised,
    slope_variance_CoxMunk1954,
)
from rigsim.daylight.underwater import (
    AmbientLightField,
    SunBeam,
    ambient_light_field_at_depth,
    daylight_above_surface,
    sky_radiance_below_surface,
    sun_beam_below_surface,
)
from rigsim.daylight.waves import WaveField, caustic_pattern, sine_waves, waves_PiersonMoskowitz1964

__all__ = [
    "DEFAULT_PHOTONS", "QUANTITIES", "UNITS", "AmbientResult", "Bottom", "ambient_light_monte_carlo",
    "ambient_light_kd", "compare_ambient",
    "SKY_MODELS", "CIEGeneralSky", "SkyModel", "UniformSky", "sky_model",
    "SurfaceIrradiance", "surface_irradiance",
    "Surface", "cox_munk_surface", "flat_surface", "fresnel_reflectance_unpolarised", "slope_variance_CoxMunk1954",
    "AmbientLightField", "SunBeam", "ambient_light_field_at_depth", "daylight_above_surface",
    "sky_radiance_below_surface", "sun_beam_below_surface",
    "WaveField", "caustic_pattern", "sine_waves", "waves_PiersonMoskowitz1964",
]
