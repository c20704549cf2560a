"""Photometric ratings of lights → on-axis spectral radiant intensity (SI units, nm).

Makers rate lights photometrically; the renderer needs radiometric, spectral
quantities.  The conversions here are done once, when a rig file is read.

Video lights (continuous)
    A luminous flux Φ_v (lm) with a relative spectrum S(λ) and a beam f(θ):
    ``I_e(λ) = k S(λ)`` on the axis (W/(sr·nm)), with k fixed by
    ``Φ_v = K_m Ω_beam ∫ V(λ) I_e(λ) dλ``, K_m = 683 lm/W, V = CIE 1924 photopic
    V(λ), Ω_beam = ∫ f dω (:func:`rigsim.light.beam.beam_solid_angle_sr`).  So
    ``∫ I dω`` over the beam is the radiant flux and its luminous value is Φ_v.

    *Assumption — lumens in water.*  Makers measure lumens in air (integrating
    sphere).  We take the same luminous flux to leave the light into the water:
    the Fresnel loss at the front glass is in fact a few per cent *lower* against
    water than against air, and absorption in the first millimetres of water is
    part of the rendered water path, so the error is ≲ 4 %.  The beam angle in
    the rig file is the underwater one (flux is conserved by refraction; only
    the pattern changes, which the beam angle already describes).

Strobes (per flash)
    (a) Stored flash energy E (J = W·s) × luminous efficacy of the flash η
    (lm·s per W·s) gives the luminous energy Q_v = η E (lm·s), spread over the
    beam: on-axis luminous intensity·time ``Q_v / Ω_beam`` (cd·s).
    η = 30 lm·s/(W·s) by default: an *assumption* in the middle of the
    15–45 lm·s/W·s that Paul C. Buff Inc. quotes for studio xenon flash systems
    ("Efficiency, Wattseconds, and Units of Measure", paulcbuff.com) and the
    15–50 quoted elsewhere for electronic flash; a rig file may override it.

    (b) Guide number GN (m, at ISO S, in air, on the axis of the strobe's beam)
    gives the on-axis luminous intensity·time directly through the incident-light
    exposure equation of ISO 2720:1974, ``N²/t = E S / C``: for a flash the
    luminous exposure is ``H = E t = (I_v t)/d²`` at distance d, and the guide
    number is defined by ``GN = d N`` for correct exposure, hence

        ``I_v t = C · GN² / S``   (cd·s),

    with C = 250 lx·s the flat-receptor calibration constant (the value Sekonic
    and most meters use; ISO 2720 allows 240–400).  Example: GN 24 m at ISO 100
    → 250 · 24² / 100 = 1440 cd·s.  (The older Kodak relation
    ``GN_ft = √(0.05 · BCPS · ISO)`` corresponds to C ≈ 215 lx·s, 0.2 stop apart.)
    The GN fixes the on-axis intensity only; the flux then follows from the beam.
    Underwater, the same on-axis intensity is assumed (a strobe's dome diffuser
    does not concentrate the beam as a flat port would); the water's attenuation
    is left to the renderer — *not* the "underwater guide number" some makers
    quote, which already includes a path through water.

Then ``I_e(λ) = k S(λ)`` with ``K_m ∫ V(λ) I_e(λ) dλ = I_v t``, in J/(sr·nm) per flash.

All spectral integrals use the trapezoidal rule on the 1 nm grid 360–830 nm of
V(λ) (:data:`rigsim.light.spectra.LIGHT_WAVELENGTHS_NM`); spectra are
interpolated linearly onto it.

References
----------
.. [CIE018] CIE 018:2019 *The basis of physical photometry*, 3rd ed. (K_m = 683 lm/W, V(λ)).
.. [ISO2720] ISO 2720:1974 *General purpose photographic exposure meters (photoelectric
   type) — Guide to product specification* (incident-light constant C).
.. [Conrad] J. Conrad, "Exposure Metering: Relating Subject Lighting to Film Exposure" (2006).
"""

from __future__ import annotations

import numpy as np

from rigsim.errors import ConfigError
from rigsim.light.spectra import LIGHT_WAVELENGTHS_NM

__all__ = [
    "K_M_LM_PER_W",
    "ISO2720_INCIDENT_CONSTANT_C",
    "XENON_FLASH_EFFICACY_LM_S_PER_J",
    "photopic_V_CIE1924",
    "luminous_integral",
    "axial_spectral_intensity",
    "axial_intensity_from_lumens",
    "luminous_energy_from_flash_energy",
    "axial_luminous_exposure_from_guide_number_ISO2720",
    "guide_number_from_axial_luminous_exposure_ISO2720",
]

#: Maximum luminous efficacy of photopic vision, lm/W (CIE; 683 lm/W at 540 THz).
K_M_LM_PER_W = 683.0

#: Incident-light meter calibration constant for a flat receptor, lx·s (ISO 2720:1974, typical).
ISO2720_INCIDENT_CONSTANT_C = 250.0

#: Assumed luminous efficacy of a xenon flash, lm·s of light per W·s (J) of stored energy.
XENON_FLASH_EFFICACY_LM_S_PER_J = 30.0


def photopic_V_CIE1924(wavelength_nm) -> np.ndarray:
    """CIE 1924 photopic luminous efficiency V(λ) (dimensionless); 0 outside 360–830 nm.

    The table is colour-science's
    ``colour.colorimetry.SDS_LEFS_PHOTOPIC["CIE 1924 Photopic Standard Observer"]``
    (CIE 018:2019, 360–830 nm every 1 nm), interpolated linearly.
    """
    from colour.colorimetry import SDS_LEFS_PHOTOPIC

    v = SDS_LEFS_PHOTOPIC["CIE 1924 Photopic Standard Observer"]
    wl = np.asarray(wavelength_nm, float)
    return np.interp(wl, v.wavelengths, v.values, left=0.0, right=0.0)


def _positive(value: float, name: str, unit: str) -> float:
    v = float(value)
    if not (np.isfinite(v) and v > 0):
        raise ConfigError(f"must be > 0 {unit}, got {v:g}", field=name, allowed=f"> 0 {unit}")
    return v


def luminous_integral(wavelength_nm, spectral) -> float:
    """``∫ V(λ) X(λ) dλ`` over 360–830 nm (trapezoid on the 1 nm V grid), X interpolated linearly.

    Parameters
    ----------
    wavelength_nm, spectral
        A sampled spectral quantity X (any units per nm); it must cover 360–830 nm
        or be zero where it does not (values outside its range are taken as 0).

    Returns
    -------
    float
        The integral, in the units of X·nm (multiply by K_m for lumens).
    """
    wl = np.asarray(wavelength_nm, float)
    x = np.interp(LIGHT_WAVELENGTHS_NM, wl, np.asarray(spectral, float), left=0.0, right=0.0)
    return float(np.trapezoid(photopic_V_CIE1924(LIGHT_WAVELENGTHS_NM) * x, LIGHT_WAVELENGTHS_NM))


def axial_spectral_intensity(luminous_axial: float, wavelength_nm, relative_spectrum) -> np.ndarray:
    """Scale a relative spectrum to a given on-axis luminous intensity (or intensity·time).

    Parameters
    ----------
    luminous_axial
        On-axis luminous intensity (cd = lm/sr) or luminous intensity·time (cd·s).
    wavelength_nm, relative_spectrum
        The spectrum's shape S(λ) (relative).

    Returns
    -------
    numpy.ndarray
        ``I_e(λ) = k S(λ)`` in W/(sr·nm) (or J/(sr·nm)), with ``K_m ∫ V I_e dλ = luminous_axial``.
    """
    s = np.asarray(relative_spectrum, float)
    lum = luminous_integral(wavelength_nm, s)
    if not lum > 0:
        raise ConfigError("the spectrum has no visible (V(λ)-weighted) power", field="spectrum",
                          allowed="a spectrum with power inside 380–780 nm")
    return s * (float(luminous_axial) / (K_M_LM_PER_W * lum))


def axial_intensity_from_lumens(lumens: float, beam_solid_angle_sr: float, wavelength_nm,
                                relative_spectrum) -> np.ndarray:
    """On-axis spectral radiant intensity (W/(sr·nm)) of a video light of ``lumens`` lm.

    Examples
    --------
    >>> from rigsim.light.spectra import light_spectrum, LIGHT_WAVELENGTHS_NM as wl
    >>> s = light_spectrum("daylight-led")
    >>> i = axial_intensity_from_lumens(3000.0, 2.0, wl, s)
    >>> round(K_M_LM_PER_W * 2.0 * luminous_integral(wl, i), 6)
    3000.0
    """
    lm = _positive(lumens, "lumens", "lm")
    om = _positive(beam_solid_angle_sr, "beam", "sr")
    return axial_spectral_intensity(lm / om, wavelength_nm, relative_spectrum)


def luminous_energy_from_flash_energy(flash_energy_J: float,
                                      efficacy_lm_s_per_J: float = XENON_FLASH_EFFICACY_LM_S_PER_J) -> float:
    """Luminous energy of one flash (lm·s) from its stored electrical energy (J = W·s)."""
    return _positive(flash_energy_J, "flash_energy_J", "J") * _positive(
        efficacy_lm_s_per_J, "luminous_efficacy_lm_s_per_J", "lm·s/J")


def axial_luminous_exposure_from_guide_number_ISO2720(guide_number_m: float, iso: float = 100.0,
                                                      c_lx_s: float = ISO2720_INCIDENT_CONSTANT_C) -> float:
    """On-axis luminous intensity·time of a flash (cd·s) from its guide number.

    ``I_v t = C GN² / S`` (see the module notes).

    Parameters
    ----------
    guide_number_m
        Guide number (m) at ISO ``iso``, in air.
    iso
        The ISO speed the guide number is quoted for (usually 100).
    c_lx_s
        Incident-light calibration constant C (lx·s), 250 by default.

    Examples
    --------
    >>> axial_luminous_exposure_from_guide_number_ISO2720(24.0)
    1440.0
    """
    gn = _positive(guide_number_m, "guide_number_m", "m")
    s = _positive(iso, "guide_number_iso", "")
    return float(c_lx_s) * gn * gn / s


def guide_number_from_axial_luminous_exposure_ISO2720(intensity_time_cd_s: float, iso: float = 100.0,
                                                      c_lx_s: float = ISO2720_INCIDENT_CONSTANT_C) -> float:
    """Inverse of :func:`axial_luminous_exposure_from_guide_number_ISO2720` (m)."""
    return float(np.sqrt(float(intensity_time_cd_s) * float(iso) / float(c_lx_s)))
