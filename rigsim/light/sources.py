"""Build :class:`~rigsim.scene.types.Light` objects from makers' ratings (done once, at config time).

``video_light`` takes lumens, ``strobe_light`` a flash energy (J) or a guide
number (m); both take a beam pattern and a spectrum name and tabulate the
on-axis spectral radiant intensity on the 360–830 nm, 1 nm grid
(:data:`rigsim.light.spectra.LIGHT_WAVELENGTHS_NM`).  See
:mod:`rigsim.light.photometry` for the conversions and their assumptions.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rigsim.errors import ConfigError
from rigsim.light.beam import beam_solid_angle_sr
from rigsim.light.photometry import (
    ISO2720_INCIDENT_CONSTANT_C,
    XENON_FLASH_EFFICACY_LM_S_PER_J,
    axial_intensity_from_lumens,
    axial_luminous_exposure_from_guide_number_ISO2720,
    axial_spectral_intensity,
    luminous_energy_from_flash_energy,
)
from rigsim.light.spectra import LIGHT_WAVELENGTHS_NM, light_spectrum
from rigsim.scene.types import BeamPattern, Light

__all__ = ["video_light", "strobe_light"]


def _tuple3(v) -> tuple[float, float, float]:
    a = tuple(float(x) for x in v)
    if len(a) != 3:
        raise ValueError("expected 3 components")
    return a  # type: ignore[return-value]


def video_light(name: str, position_m, aim, beam: BeamPattern, *, lumens: float,
                spectrum: str = "daylight-led", base_dir: str | Path | None = None) -> Light:
    """A continuous light rated at ``lumens`` lm; axial intensity in W/(sr·nm).

    Examples
    --------
    >>> from rigsim.light.beam import soft_cone
    >>> lt = video_light("v", (0.2, 0, 0), (0, 0, 1), soft_cone(100.0), lumens=3000.0)
    >>> lt.kind, len(lt.wavelength_nm)
    ('continuous', 471)
    """
    s = light_spectrum(spectrum, LIGHT_WAVELENGTHS_NM, base_dir=base_dir)
    inten = axial_intensity_from_lumens(lumens, beam_solid_angle_sr(beam), LIGHT_WAVELENGTHS_NM, s)
    return Light(name=name, kind="continuous", position_m=_tuple3(position_m), aim=_tuple3(aim),
                 beam=beam, wavelength_nm=tuple(LIGHT_WAVELENGTHS_NM.tolist()),
                 axial_intensity=tuple(inten.tolist()), spectrum_name=spectrum)


def strobe_light(name: str, position_m, aim, beam: BeamPattern, *,
                 flash_energy_J: float | None = None, guide_number_m: float | None = None,
                 guide_number_iso: float = 100.0,
                 luminous_efficacy_lm_s_per_J: float = XENON_FLASH_EFFICACY_LM_S_PER_J,
                 power_fraction: float = 1.0, spectrum: str = "xenon-strobe",
                 base_dir: str | Path | None = None) -> Light:
    """A strobe; axial intensity in J/(sr·nm) per flash.

    Parameters
    ----------
    flash_energy_J, guide_number_m
        Exactly one: stored flash energy (J = W·s) or guide number (m, in air, at
        ``guide_number_iso``), both at full power.
    luminous_efficacy_lm_s_per_J
        Light per stored energy (lm·s/J), used with ``flash_energy_J``.
    power_fraction
        Power setting as a fraction of full power, 0 < p ≤ 1 (1/4 power = 0.25):
        scales the flash energy (and the guide number by √p).
    """
    if (flash_energy_J is None) == (guide_number_m is None):
        raise ConfigError("a strobe needs exactly one of flash_energy_J and guide_number_m",
                          field="flash_energy_J", allowed="flash_energy_J (J) or guide_number_m (m)")
    p = float(power_fraction)
    if not (0.0 < p <= 1.0):
        raise ConfigError(f"must be > 0 and <= 1, got {p:g}", field="power_fraction", allowed="0 < p <= 1")
    s = light_spectrum(spectrum, LIGHT_WAVELENGTHS_NM, base_dir=base_dir)
    if flash_energy_J is not None:
        q_v = luminous_energy_from_flash_energy(flash_energy_J, luminous_efficacy_lm_s_per_J)
        axial_cd_s = q_v / beam_solid_angle_sr(beam)
    else:
        axial_cd_s = axial_luminous_exposure_from_guide_number_ISO2720(
            guide_number_m, guide_number_iso, ISO2720_INCIDENT_CONSTANT_C)
    inten = axial_spectral_intensity(axial_cd_s * p, LIGHT_WAVELENGTHS_NM, s)
    return Light(name=name, kind="strobe", position_m=_tuple3(position_m), aim=_tuple3(aim),
                 beam=beam, wavelength_nm=tuple(LIGHT_WAVELENGTHS_NM.tolist()),
                 axial_intensity=tuple(np.asarray(inten).tolist()), spectrum_name=spectrum)
