"""Scattering by sea water and its particles (Kopelevich model), 1/m and 1/(m·sr); wavelengths in nm.

``β(ψ; λ) = β_w(ψ; λ) + ν_s β_s*(ψ) (550/λ)^1.7 + ν_l β_l*(ψ) (550/λ)^0.3``

with ν_s, ν_l the volume concentrations of small and large particles in ppm, and
β_s*, β_l* Kopelevich's specific VSFs at 550 nm (``data/water/
kopelevich_vsf_small_large_particles.csv``), interpolated in log-log space
(PCHIP) so that the forward peak is integrated correctly.  The scattering
coefficient is ``b = 2π ∫ β sin ψ dψ``; integrating the 19-angle tables this way
gives b_s* = 1.300 and b_l* = 0.3156 1/(m·ppm), within 3 % and 1.2 % of the
published model coefficients 1.34 and 0.312 (Mobley 1994 p. 119).

The pure-water term is ``β_w = b_w(λ) · p_w(ψ)`` with ``p_w ∝ 1 + 0.835 cos²ψ`` and
``b_w(λ) = 0.0017 (550/λ)^4.3`` 1/m — the pure-water term of Kopelevich's published
scattering model (Mobley 1994 p. 119).  The original code's fresh-water form
``β_w(ψ) = 0.93e-4 (1 + 0.835 cos²ψ)(550/λ)^4.32`` (Morel 1974, b_w(550) = 0.00149 1/m) is
available as ``pure_water="morel-1974-fresh"``.

References
----------
.. [Ko83] O.V. Kopelevich (1983), see :mod:`rigsim.water.phase`.
.. [Mo94] C.D. Mobley, *Light and Water* (1994), §3.8, eqs. 3.28, 3.38, p. 119.
"""

from __future__ import annotations

import numpy as np

from rigsim.errors import ConfigError, unknown_name_error
from rigsim.spectrum import as_wavelengths
from rigsim.water.phase import RayleighWater, kopelevich_large_particle, kopelevich_small_particle

__all__ = [
    "PURE_WATER_SCATTERING_METHODS",
    "scattering_pure_water",
    "scattering_small_particles_Kopelevich1983",
    "scattering_large_particles_Kopelevich1983",
    "vsf_pure_water",
    "vsf_Kopelevich1983",
    "KOPELEVICH_PUBLISHED",
]

#: The published coefficients of the Kopelevich scattering model (1/m; 1/(m·ppm)):
#: b = 0.0017(550/λ)^4.3 + 1.34 ν_s (550/λ)^1.7 + 0.312 ν_l (550/λ)^0.3 (Mobley 1994, p. 119).
KOPELEVICH_PUBLISHED = {"b_w550": 0.0017, "exp_w": 4.3, "b_s550": 1.34, "exp_s": 1.7,
                        "b_l550": 0.312, "exp_l": 0.3}

#: Pure-water scattering laws: name → (b_w at 550 nm in 1/m, exponent of 550/λ, source).
PURE_WATER_SCATTERING_METHODS = {
    "kopelevich-1983": (0.0017, 4.3, "Kopelevich model pure-water term, Mobley 1994 p.119"),
    # 0.93e-4 1/(m sr) at 90 deg times 4π(1 + 0.835/3) = 1.494e-3 1/m
    "morel-1974-fresh": (0.93e-4 * 4 * np.pi * (1 + 0.835 / 3), 4.32,
                         "Morel 1974 pure fresh water, beta(90)=0.93e-4 1/(m sr) at 550 nm (original code)"),
}

_RAYLEIGH = RayleighWater()


def _conc(value: float, field: str) -> float:
    v = float(value)
    if not np.isfinite(v) or v < 0:
        raise ConfigError(f"must be a finite concentration >= 0, got {value!r}", field=field, allowed=">= 0 ppm")
    return v


def scattering_pure_water(wavelength_nm, method: str = "kopelevich-1983") -> np.ndarray:
    """Pure-water scattering coefficient b_w(λ) in 1/m by law name."""
    wl = as_wavelengths(wavelength_nm)
    try:
        b550, n, _ = PURE_WATER_SCATTERING_METHODS[method]
    except KeyError:
        raise unknown_name_error("pure-water scattering law", method, PURE_WATER_SCATTERING_METHODS,
                                 field="pure_water_scattering") from None
    return b550 * (550.0 / wl) ** n


def scattering_small_particles_Kopelevich1983(wavelength_nm, small_ppm: float) -> np.ndarray:
    """Small-particle scattering ``ν_s b_s* (550/λ)^1.7`` in 1/m (b_s* from the tabulated VSF)."""
    wl = as_wavelengths(wavelength_nm)
    return _conc(small_ppm, "small_particles_ppm") * kopelevich_small_particle().norm * (550.0 / wl) ** 1.7


def scattering_large_particles_Kopelevich1983(wavelength_nm, large_ppm: float) -> np.ndarray:
    """Large-particle scattering ``ν_l b_l* (550/λ)^0.3`` in 1/m (b_l* from the tabulated VSF)."""
    wl = as_wavelengths(wavelength_nm)
    return _conc(large_ppm, "large_particles_ppm") * kopelevich_large_particle().norm * (550.0 / wl) ** 0.3


def vsf_pure_water(psi_rad, wavelength_nm, method: str = "kopelevich-1983") -> np.ndarray:
    """Pure-water VSF β_w(ψ; λ) in 1/(m·sr) (broadcast ψ against λ)."""
    b = scattering_pure_water(wavelength_nm, method)
    return b * _RAYLEIGH.eval(np.cos(np.asarray(psi_rad, float)))


def vsf_Kopelevich1983(psi_rad, wavelength_nm, small_ppm: float, large_ppm: float, *,
                       pure_water: str = "kopelevich-1983") -> np.ndarray:
    """Kopelevich (1983) VSF of sea water β(ψ; λ) in 1/(m·sr).

    Parameters
    ----------
    psi_rad
        Scattering angle in rad (0 … π).
    wavelength_nm
        Wavelength(s) in nm, broadcast against ``psi_rad``.
    small_ppm, large_ppm
        Volume concentrations of small and large particles (ppm, >= 0).
    """
    mu = np.cos(np.asarray(psi_rad, float))
    wl = as_wavelengths(wavelength_nm)
    s, l = kopelevich_small_particle(), kopelevich_large_particle()
    return (vsf_pure_water(psi_rad, wl, pure_water)
            + scattering_small_particles_Kopelevich1983(wl, small_ppm) * s.eval(mu)
            + scattering_large_particles_Kopelevich1983(wl, large_ppm) * l.eval(mu))
