"""Water optics: absorption, scattering, phase functions, presets and Kd (wavelengths in nm, 1/m).

Plain functions of wavelength arrays, named after their source (see each module):

* :mod:`rigsim.water.absorption` — pure water (Smith & Baker 1981, Pope & Fry 1997,
  Buiteveld 1994), detritus, CDOM, phytoplankton.
* :mod:`rigsim.water.scattering` — Kopelevich (1983) VSF and scattering coefficients.
* :mod:`rigsim.water.phase` — normalised phase functions with exact samplers.
* :mod:`rigsim.water.kd` — diffuse attenuation Kd from IOPs.
* :mod:`rigsim.water.model` — :class:`Water` objects; :mod:`rigsim.water.presets` — named waters.
"""

from rigsim.water.absorption import (
    PURE_WATER_ABSORPTION_METHODS,
    absorption_cdom_Bricaud1981,
    absorption_detritus_Bricaud1998,
    absorption_phytoplankton_Bricaud1995,
    absorption_pure_water,
)
from rigsim.water.kd import KD_METHODS, kd
from rigsim.water.model import ConstituentWater, Spectrum1D, TabulatedWater, Water
from rigsim.water.phase import (
    FournierForand,
    HenyeyGreenstein,
    MixturePhase,
    PhaseFunction,
    RayleighWater,
    TabulatedPhase,
    petzold_average_particle,
)
from rigsim.water.presets import JERLOV_TYPES, ORIGINAL_PRESETS, jerlov_water, preset, preset_names
from rigsim.water.scattering import vsf_Kopelevich1983

__all__ = [
    "PURE_WATER_ABSORPTION_METHODS", "absorption_cdom_Bricaud1981", "absorption_detritus_Bricaud1998",
    "absorption_phytoplankton_Bricaud1995", "absorption_pure_water", "KD_METHODS", "kd",
    "ConstituentWater", "Spectrum1D", "TabulatedWater", "Water", "FournierForand", "HenyeyGreenstein",
    "MixturePhase", "PhaseFunction", "RayleighWater", "TabulatedPhase", "petzold_average_particle",
    "JERLOV_TYPES", "ORIGINAL_PRESETS", "jerlov_water", "preset", "preset_names", "vsf_Kopelevich1983",
]
