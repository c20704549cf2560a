"""Lights: spectra, photometric → radiometric conversions, beam patterns (wavelengths in nm, SI).

* :mod:`rigsim.light.spectra` — named relative spectra (xenon strobe, CIE LEDs, D65,
  blackbody, user CSV), defined over 360–830 nm.
* :mod:`rigsim.light.photometry` — lumens, flash energy and guide number → on-axis
  spectral radiant intensity (K_m = 683 lm/W, CIE 1924 V(λ), ISO 2720).
* :mod:`rigsim.light.beam` — beam patterns, their solid-angle integral and an exact sampler.
* :mod:`rigsim.light.sources` — build :class:`~rigsim.scene.types.Light` objects from ratings.
"""

from rigsim.light.beam import (
    beam_angle_in_water_deg,
    beam_from_csv,
    beam_pdf,
    beam_solid_angle_sr,
    local_to_world,
    sample_beam_direction,
    soft_cone,
)
from rigsim.light.photometry import (
    ISO2720_INCIDENT_CONSTANT_C,
    K_M_LM_PER_W,
    XENON_FLASH_EFFICACY_LM_S_PER_J,
    axial_intensity_from_lumens,
    axial_luminous_exposure_from_guide_number_ISO2720,
    axial_spectral_intensity,
    guide_number_from_axial_luminous_exposure_ISO2720,
    luminous_energy_from_flash_energy,
    luminous_integral,
    photopic_V_CIE1924,
)
from rigsim.light.sources import strobe_light, video_light
from rigsim.light.spectra import (
    LIGHT_WAVELENGTHS_NM,
    SPECTRUM_METHODS,
    light_spectrum,
    spectrum_blackbody_Planck,
    spectrum_d65_CIE,
    spectrum_from_csv,
    spectrum_led_CIE2018,
    spectrum_names,
    spectrum_xenon_flash_PTB,
    spectrum_xenon_flash_Vivitar283,
)

__all__ = [
    "beam_angle_in_water_deg", "beam_from_csv", "beam_pdf", "beam_solid_angle_sr", "local_to_world",
    "sample_beam_direction", "soft_cone", "ISO2720_INCIDENT_CONSTANT_C", "K_M_LM_PER_W",
    "XENON_FLASH_EFFICACY_LM_S_PER_J", "axial_intensity_from_lumens",
    "axial_luminous_exposure_from_guide_number_ISO2720", "axial_spectral_intensity",
    "guide_number_from_axial_luminous_exposure_ISO2720", "luminous_energy_from_flash_energy",
    "luminous_integral", "photopic_V_CIE1924", "strobe_light", "video_light", "LIGHT_WAVELENGTHS_NM",
    "SPECTRUM_METHODS", "light_spectrum", "spectrum_blackbody_Planck", "spectrum_d65_CIE",
    "spectrum_from_csv", "spectrum_led_CIE2018", "spectrum_names", "spectrum_xenon_flash_PTB",
    "spectrum_xenon_flash_Vivitar283",
]
