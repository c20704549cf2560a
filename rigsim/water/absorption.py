"""Absorption coefficients of natural water and its constituents (1/m, wavelengths in nm).

Total absorption in rigsim's constituent model:
``a = a_pw + a_det + a_y (+ a_ph)``.

References
----------
.. [SB81] R.C. Smith, K.S. Baker, "Optical properties of the clearest natural waters
   (200–800 nm)", Appl. Opt. 20(2):177–184 (1981).
.. [PF97] R.M. Pope, E.S. Fry, "Absorption spectrum (380–700 nm) of pure water. II.
   Integrating cavity measurements", Appl. Opt. 36(33):8710–8723 (1997).
.. [Bu94] H. Buiteveld, J.H.M. Hakvoort, M. Donze, "The optical properties of pure
   water", Proc. SPIE 2258:174–183 (1994).
.. [Br81] A. Bricaud, A. Morel, L. Prieur, "Absorption by dissolved organic matter of
   the sea (yellow substance) in the UV and visible domains", Limnol. Oceanogr.
   26(1):43–53 (1981).
.. [Br95] A. Bricaud, M. Babin, A. Morel, H. Claustre, "Variability in the chlorophyll-
   specific absorption coefficients of natural phytoplankton", J. Geophys. Res.
   100(C7):13321–13332 (1995).
.. [Br98] A. Bricaud, A. Morel, M. Babin, K. Allali, H. Claustre, "Variations of light
   absorption by suspended particles with chlorophyll a concentration in oceanic
   (case 1) waters", J. Geophys. Res. 103(C13):31033–31044 (1998).
"""

from __future__ import annotations

import numpy as np

from rigsim.data import load_table
from rigsim.errors import ConfigError, unknown_name_error
from rigsim.spectrum import as_wavelengths, interp_table

__all__ = [
    "absorption_pure_water_SmithBaker1981",
    "absorption_pure_water_PopeFry1997",
    "absorption_pure_water_Buiteveld1994",
    "PURE_WATER_ABSORPTION_METHODS",
    "absorption_pure_water",
    "pure_water_absorption_range_nm",
    "phytoplankton_absorption_range_nm",
    "absorption_detritus_Bricaud1998",
    "absorption_cdom_Bricaud1981",
    "absorption_phytoplankton_Bricaud1995",
    "DETRITUS_EXPONENT_WRITEUP",
    "DETRITUS_EXPONENT_ORIGINAL_CODE",
]

#: Exponent of chl in the detritus term as printed in the original write-up.
DETRITUS_EXPONENT_WRITEUP = 0.702
#: Exponent used by the original code (pbrt-v2/uwSim), equal to Bricaud et al. (1998).
DETRITUS_EXPONENT_ORIGINAL_CODE = 0.724


#: Data file behind each pure-water table.
PURE_WATER_ABSORPTION_FILES = {
    "smith-baker-1981": "water/pure_water_absorption_smith_baker_1981.csv",
    "pope-fry-1997": "water/pure_water_absorption_pope_fry_1997.csv",
    "buiteveld-1994": "water/pure_water_absorption_buiteveld_1994.csv",
}



def _check_nonnegative(value: float, field: str) -> float:
    value = float(value)
    if not np.isfinite(value) or value < 0:
        raise ConfigError(f"must be a finite number >= 0, got {value!r}", field=field, allowed=">= 0")
    return value


def absorption_pure_water_SmithBaker1981(wavelength_nm) -> np.ndarray:
    """Pure (clearest natural) water absorption of Smith & Baker (1981) [SB81], 1/m.

    Linear interpolation of the 10-nm table, 200–800 nm; exact at tabulated wavelengths.
    This is the original water volume's default.

    Examples
    --------
    >>> float(absorption_pure_water_SmithBaker1981(440.0))
    0.0145
    """
    t = load_table(PURE_WATER_ABSORPTION_FILES["smith-baker-1981"])
    return interp_table(wavelength_nm, t["wavelength_nm"], t["a_w_per_m"],
                        name="Smith & Baker 1981 pure-water absorption")


def absorption_pure_water_PopeFry1997(wavelength_nm) -> np.ndarray:
    """Pure water absorption of Pope & Fry (1997) [PF97], 1/m; 380–727.5 nm every 2.5 nm."""
    t = load_table(PURE_WATER_ABSORPTION_FILES["pope-fry-1997"])
    return interp_table(wavelength_nm, t["wavelength_nm"], t["a_w_per_m"],
                        name="Pope & Fry 1997 pure-water absorption")


def absorption_pure_water_Buiteveld1994(wavelength_nm) -> np.ndarray:
    """Pure water absorption of Buiteveld et al. (1994) [Bu94], 1/m; 300–800 nm every 2 nm."""
    t = load_table(PURE_WATER_ABSORPTION_FILES["buiteveld-1994"])
    return interp_table(wavelength_nm, t["wavelength_nm"], t["a_w_per_m"],
                        name="Buiteveld 1994 pure-water absorption")


#: Pure-water absorption tables by name (first is the default).
PURE_WATER_ABSORPTION_METHODS = {
    "smith-baker-1981": absorption_pure_water_SmithBaker1981,
    "pope-fry-1997": absorption_pure_water_PopeFry1997,
    "buiteveld-1994": absorption_pure_water_Buiteveld1994,
}


def pure_water_absorption_range_nm(method: str = "smith-baker-1981") -> tuple[float, float]:
    """Wavelength range (nm) covered by a pure-water absorption table."""
    if method not in PURE_WATER_ABSORPTION_FILES:
        raise unknown_name_error("pure-water absorption table", method,
                                 PURE_WATER_ABSORPTION_METHODS, field="pure_water")
    wl = load_table(PURE_WATER_ABSORPTION_FILES[method])["wavelength_nm"]
    return float(wl[0]), float(wl[-1])


def phytoplankton_absorption_range_nm() -> tuple[float, float]:
    """Wavelength range (nm) of the original code's phytoplankton absorption shape."""
    wl = load_table("water/reference_implementation_uwsim_pbrt_tables.csv")["wavelength_nm"]
    return float(wl[0]), float(wl[-1])


def absorption_pure_water(wavelength_nm, method: str = "smith-baker-1981") -> np.ndarray:
    """Pure water absorption (1/m) by table name, one of :data:`PURE_WATER_ABSORPTION_METHODS`."""
    try:
        fn = PURE_WATER_ABSORPTION_METHODS[method]
    except KeyError:
        raise unknown_name_error("pure-water absorption table", method,
                                 PURE_WATER_ABSORPTION_METHODS, field="pure_water") from None
    return fn(wavelength_nm)


def absorption_detritus_Bricaud1998(wavelength_nm, chl_mg_per_m3: float, *,
                                    exponent: float = DETRITUS_EXPONENT_WRITEUP,
                                    slope_per_nm: float = 0.011) -> np.ndarray:
    """Absorption by detritus (non-algal particles) tied to chlorophyll, 1/m.

    ``a_det(λ) = 0.0124 · chl^exponent · exp(−0.011 (λ − 440))``

    Parameters
    ----------
    wavelength_nm
        Wavelengths in nm.
    chl_mg_per_m3
        Chlorophyll-a concentration in mg/m³ (>= 0).
    exponent
        0.702 as printed in the original write-up (default), 0.724 as in the
        original code and in Bricaud et al. (1998) [Br98].
    slope_per_nm
        Spectral slope S in 1/nm (0.011 per [Br98]).
    """
    wl = as_wavelengths(wavelength_nm)
    chl = _check_nonnegative(chl_mg_per_m3, "chl_mg_per_m3")
    return 0.0124 * chl**exponent * np.exp(-slope_per_nm * (wl - 440.0))


def absorption_cdom_Bricaud1981(wavelength_nm, a_y440_per_m: float, *,
                                slope_per_nm: float = 0.014) -> np.ndarray:
    """Absorption by coloured dissolved organic matter (yellow substance) [Br81], 1/m.

    ``a_y(λ) = a_y(440) · exp(−0.014 (λ − 440))``
    """
    wl = as_wavelengths(wavelength_nm)
    a440 = _check_nonnegative(a_y440_per_m, "cdom_a440_per_m")
    return a440 * np.exp(-slope_per_nm * (wl - 440.0))


def absorption_phytoplankton_Bricaud1995(wavelength_nm, chl_mg_per_m3: float) -> np.ndarray:
    """Phytoplankton absorption as in the original code, 1/m.

    The original code's tabulated phytoplankton absorption shape (400–700 nm,
    ``data/water/reference_implementation_uwsim_pbrt_tables.csv``) scaled so that
    ``a_ph(440) = 0.0378 · chl^0.627`` — the 440-nm chlorophyll-specific law of
    Bricaud et al. (1995) [Br95].
    """
    chl = _check_nonnegative(chl_mg_per_m3, "chl_mg_per_m3")
    t = load_table("water/reference_implementation_uwsim_pbrt_tables.csv")
    wl_t, shape = t["wavelength_nm"], t["plankton_abs_shape"]
    shape_440 = float(np.interp(440.0, wl_t, shape))
    s = interp_table(wavelength_nm, wl_t, shape, name="original code's phytoplankton absorption shape")
    return 0.0378 * chl**0.627 * s / shape_440
