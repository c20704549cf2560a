"""Relative spectral power distributions of underwater light sources (wavelengths in nm).

Every named spectrum is returned on a wavelength grid the caller chooses and is
defined over the whole range Mitsuba samples, 360–830 nm
(:data:`rigsim.spectrum.MITSUBA_WAVELENGTH_RANGE_NM`); values are relative
(dimensionless, peak 1 over 360–830 nm) and non-negative.  Absolute scale comes
from :mod:`rigsim.light.photometry`.

Named spectra (``SPECTRUM_METHODS``):

``xenon-strobe``
    Xenon flash tube, Psychtoolbox ``spd_xenonFlash`` (data/light/xenon_flash_tube_ptb.csv),
    valid 400–700 nm.  **Below 400 nm: zero.**  The table itself is zero there; we
    keep it as the UV cut of a dive strobe (UV-absorbing diffuser/front window, or
    the optional "UV-cut" filters most makers sell) — an *assumption*: a bare
    xenon tube does emit in the UV-A.  **Above 700 nm: the 700 nm value is held** to
    830 nm, because the table is truncated at the edge of its measurement range
    (xenon emits strongly in the near infrared, so zero would be wrong).
``xenon-vivitar283``
    Xenon flash "Vivitar 283" (ISETCam, data/light/xenon_flash_vivitar283_isetcam.csv),
    380–780 nm; zero below 380 nm (same UV-cut assumption), 780 nm value held to 830 nm.
``daylight-led``
    CIE LED-B5, a phosphor-converted blue LED of CCT ≈ 6600 K (CIE 15:2018 Table 9.2, as
    shipped with colour-science), 380–780 nm; **zero outside** (a white LED emits nothing
    below its blue pump and its phosphor tail is < 1 % of peak at 780 nm and falling).
``warm-led``
    CIE LED-B2, a phosphor-converted blue LED of CCT ≈ 3000 K (CIE 15:2018), same
    treatment as ``daylight-led``.
``daylight-d65``
    CIE standard illuminant D65: colour-science's table (300–780 nm) continued to 830 nm by
    colour-science's CIE D-series at the D65 chromaticity (:func:`spectrum_d65_CIE`), so it
    covers Mitsuba's whole range.
``blackbody:T``
    Planck's law at temperature ``T`` kelvin (e.g. ``blackbody:5500``), analytic.
a CSV file
    Columns ``wavelength_nm, relative``; must cover at least 400–700 nm; outside
    its range the end values are **held** (stated, since a user file's edges are
    usually measurement limits, not the source's).

References
----------
.. [CIE15] CIE 15:2018 *Colorimetry*, 4th edition, Table 9.2 (LED illuminants) and
   Annex (D-series daylight).
.. [PTB] D.H. Brainard et al., Psychtoolbox ``PsychColorimetricMatFiles/spd_xenonFlash.mat``.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from rigsim.data import load_table, read_csv_table
from rigsim.errors import ConfigError, DataError, unknown_name_error
from rigsim.spectrum import MITSUBA_WAVELENGTH_RANGE_NM, as_wavelengths

__all__ = [
    "LIGHT_WAVELENGTHS_NM",
    "SPECTRUM_METHODS",
    "spectrum_names",
    "light_spectrum",
    "spectrum_xenon_flash_PTB",
    "spectrum_xenon_flash_Vivitar283",
    "spectrum_led_CIE2018",
    "spectrum_d65_CIE",
    "spectrum_blackbody_Planck",
    "spectrum_from_csv",
]

#: The grid on which lights are tabulated for the renderer: 360–830 nm every 1 nm.
LIGHT_WAVELENGTHS_NM = np.arange(MITSUBA_WAVELENGTH_RANGE_NM[0], MITSUBA_WAVELENGTH_RANGE_NM[1] + 0.5, 1.0)

def _piecewise(wavelength_nm, table_nm, table_values, *, below: str, above: str,
               lo_valid: float | None = None, hi_valid: float | None = None) -> np.ndarray:
    """Interpolate a table, with an explicit rule ("zero" or "hold") outside its valid range."""
    wl = as_wavelengths(wavelength_nm)
    tnm = np.asarray(table_nm, float)
    tv = np.asarray(table_values, float)
    lo = tnm[0] if lo_valid is None else lo_valid
    hi = tnm[-1] if hi_valid is None else hi_valid
    keep = (tnm >= lo - 1e-9) & (tnm <= hi + 1e-9)
    tnm, tv = tnm[keep], tv[keep]
    out = np.interp(wl, tnm, tv)
    if below == "zero":
        out = np.where(wl < lo, 0.0, out)
    if above == "zero":
        out = np.where(wl > hi, 0.0, out)
    return np.clip(out, 0.0, None)


def _peak_one(fn: Callable[[np.ndarray], np.ndarray]) -> Callable[[np.ndarray], np.ndarray]:
    """Wrap a spectrum so that its maximum over the light grid (360–830 nm, 1 nm) is one."""

    @functools.wraps(fn)
    def wrapper(wavelength_nm, *args, **kwargs):
        peak = float(np.max(fn(LIGHT_WAVELENGTHS_NM, *args, **kwargs)))
        return fn(wavelength_nm, *args, **kwargs) / peak

    return wrapper


@_peak_one
def spectrum_xenon_flash_PTB(wavelength_nm) -> np.ndarray:
    """Xenon flash tube (Psychtoolbox ``spd_xenonFlash``), relative, peak 1.

    Parameters
    ----------
    wavelength_nm
        Wavelengths (nm), any positive values.

    Returns
    -------
    numpy.ndarray
        Relative spectral power.  0 below 400 nm (assumed UV cut of the strobe's
        diffuser), the table over 400–700 nm, the 700 nm value held above 700 nm
        (the table is truncated there).

    Examples
    --------
    >>> float(spectrum_xenon_flash_PTB([390.0])[0])
    0.0
    >>> bool(spectrum_xenon_flash_PTB([800.0])[0] == spectrum_xenon_flash_PTB([700.0])[0])
    True
    """
    t = load_table("light/xenon_flash_tube_ptb.csv")
    return _piecewise(wavelength_nm, t["wavelength_nm"], t["value"], below="zero", above="hold",
                      lo_valid=400.0, hi_valid=700.0)


@_peak_one
def spectrum_xenon_flash_Vivitar283(wavelength_nm) -> np.ndarray:
    """Xenon flash "Vivitar 283" (ISETCam), relative, peak 1; 0 below 380 nm, held above 780 nm."""
    t = load_table("light/xenon_flash_vivitar283_isetcam.csv")
    return _piecewise(wavelength_nm, t["wavelength_nm"], t["value"], below="zero", above="hold")


#: The CIE 15:2018 LED illuminants offered (names of colour-science's ``SDS_ILLUMINANTS``).
_LED_ILLUMINANTS = ("LED-B5", "LED-B2")


@_peak_one
def spectrum_led_CIE2018(wavelength_nm, illuminant: str = "LED-B5") -> np.ndarray:
    """A CIE 15:2018 LED illuminant (``"LED-B5"`` ≈ 6600 K, ``"LED-B2"`` ≈ 3000 K), relative, peak 1.

    The tables (380–780 nm, 5 nm) are colour-science's ``SDS_ILLUMINANTS["LED-B5"]`` and
    ``["LED-B2"]`` (CIE 15:2018 Table 9.2).  Zero outside 380–780 nm (phosphor-converted
    white LEDs emit nothing below their blue pump; their red tail is < 3 % of peak at 780 nm).
    """
    import colour

    if illuminant not in _LED_ILLUMINANTS:
        raise unknown_name_error("CIE LED illuminant", illuminant, _LED_ILLUMINANTS)
    sd = colour.SDS_ILLUMINANTS[illuminant]
    return _piecewise(wavelength_nm, sd.wavelengths, sd.values, below="zero", above="zero")


@functools.lru_cache(maxsize=1)
def _d65_table() -> tuple[np.ndarray, np.ndarray]:
    """CIE D65 300–830 nm every 5 nm: colour-science's table, extended past 780 nm by the D series."""
    import colour
    from colour.colorimetry.blackbody import CONSTANT_C2

    table = colour.SDS_ILLUMINANTS["D65"]  # CIE 15:2018 / ISO 11664-2, 300–780 nm
    # D65 is the D-series illuminant of nominal CCT 6500 K, i.e. 6500 × 1.4388/1.4380 K (CIE 15:2018)
    xy = colour.temperature.CCT_to_xy_CIE_D(6500.0 * CONSTANT_C2 / 1.4380e-2)
    series = colour.sd_CIE_illuminant_D_series(xy)  # S0, S1, S2 basis, 300–830 nm
    tail = series.wavelengths > table.wavelengths[-1]
    return (np.concatenate([table.wavelengths, series.wavelengths[tail]]),
            np.concatenate([table.values, series.values[tail]]))


@_peak_one
def spectrum_d65_CIE(wavelength_nm) -> np.ndarray:
    """CIE standard illuminant D65, relative, peak 1 over 360–830 nm.

    300–780 nm: colour-science's ``SDS_ILLUMINANTS["D65"]`` (the CIE 15:2018 table); 785–830 nm:
    colour-science's CIE D-series illuminant (``sd_CIE_illuminant_D_series``) at the D65
    chromaticity (nominal 6500 K = 6504 K with c₂ = 1.4388e-2 m·K), which reproduces the
    300–780 nm table to 7.2e-6 of its peak.  Zero outside 300–830 nm.
    """
    wl_table, values = _d65_table()
    return _piecewise(wavelength_nm, wl_table, values, below="zero", above="zero")


@_peak_one
def spectrum_blackbody_Planck(wavelength_nm, temperature_K: float) -> np.ndarray:
    """Planck's law, relative spectral radiance of a blackbody at ``temperature_K``, peak 1.

    Parameters
    ----------
    wavelength_nm
        Wavelengths (nm).
    temperature_K
        Temperature (K), 500–100 000.

    Returns
    -------
    numpy.ndarray
        Relative spectral radiance (dimensionless), peak 1 over 360–830 nm.

    Notes
    -----
    ``B(λ, T) ∝ λ⁻⁵ / (exp(c₂ / λT) − 1)``, evaluated by colour-science's
    :func:`colour.colorimetry.planck_law` (λ in m, T in K) with its second radiation
    constant c₂ = 1.4388e-2 m·K (``colour.colorimetry.blackbody.CONSTANT_C2``, the ITS-90 value
    CIE 15:2018 uses for the Planckian radiator).
    """
    from colour.colorimetry import planck_law

    t = float(temperature_K)
    if not (500.0 <= t <= 100_000.0):
        raise ConfigError(f"blackbody temperature must be 500–100000 K, got {t:g}",
                          field="spectrum", allowed="blackbody:T with 500 <= T <= 100000 (K)")
    wavelength_m = np.atleast_1d(as_wavelengths(wavelength_nm)) * 1e-9
    return np.asarray(planck_law(wavelength_m, t), float).reshape(np.shape(as_wavelengths(wavelength_nm)))


def _read_user_spectrum(path: Path) -> tuple[np.ndarray, np.ndarray]:
    try:
        t = read_csv_table(path)
    except DataError as exc:
        raise ConfigError(f"cannot read spectrum file: {exc}", file=path) from None
    for col in ("wavelength_nm", "relative"):
        if col not in t.columns:
            raise ConfigError(f"spectrum file has no column {col!r} (has {', '.join(t.columns)})",
                              file=path, allowed="columns wavelength_nm, relative")
    wl, v = t.columns["wavelength_nm"], t.columns["relative"]
    if wl.dtype.kind != "f" or v.dtype.kind != "f" or not (np.all(np.isfinite(wl)) and np.all(np.isfinite(v))):
        raise ConfigError("spectrum file has non-numeric or blank values", file=path)
    if wl.size < 2 or np.any(np.diff(wl) <= 0):
        raise ConfigError("wavelengths must be strictly increasing (at least 2 rows)", file=path)
    if np.any(v < 0):
        raise ConfigError("relative spectral power must be >= 0", file=path)
    if wl[0] > 400.0 or wl[-1] < 700.0:
        raise ConfigError(f"spectrum covers {wl[0]:g}–{wl[-1]:g} nm", file=path,
                          allowed="a table covering at least 400–700 nm")
    if not np.any(v > 0):
        raise ConfigError("spectrum is zero everywhere", file=path)
    return wl, v


def spectrum_from_csv(wavelength_nm, path: str | Path) -> np.ndarray:
    """A user spectrum from a CSV (``wavelength_nm, relative``), relative, peak 1.

    The file must cover at least 400–700 nm; outside its range its end values are
    held (documented behaviour, see the module notes).
    """
    wl, v = _read_user_spectrum(Path(path))
    grid = _piecewise(LIGHT_WAVELENGTHS_NM, wl, v, below="hold", above="hold")
    return _piecewise(wavelength_nm, wl, v, below="hold", above="hold") / float(np.max(grid))


#: Named spectra → function of wavelength (nm) returning relative power (peak 1).
SPECTRUM_METHODS: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "xenon-strobe": spectrum_xenon_flash_PTB,
    "xenon-vivitar283": spectrum_xenon_flash_Vivitar283,
    "daylight-led": functools.partial(spectrum_led_CIE2018, illuminant="LED-B5"),
    "warm-led": functools.partial(spectrum_led_CIE2018, illuminant="LED-B2"),
    "daylight-d65": spectrum_d65_CIE,
}


def spectrum_names() -> list[str]:
    """Names accepted by :func:`light_spectrum` (besides ``blackbody:T`` and CSV paths)."""
    return [*SPECTRUM_METHODS, "blackbody:T"]


def light_spectrum(spec: str, wavelength_nm=LIGHT_WAVELENGTHS_NM, *,
                   base_dir: str | Path | None = None) -> np.ndarray:
    """Relative spectrum of a light by name, ``blackbody:T`` or CSV path (peak 1 over 360–830 nm).

    Parameters
    ----------
    spec
        A name from :data:`SPECTRUM_METHODS`, ``"blackbody:5600"`` (kelvin), or a path
        to a CSV file (ends in ``.csv``); relative paths resolve against ``base_dir``.
    wavelength_nm
        Wavelengths (nm); default the 360–830 nm, 1 nm light grid.
    base_dir
        Folder that relative CSV paths are relative to (the rig file's folder).

    Raises
    ------
    ConfigError
        Unknown name (with suggestions), bad temperature, unreadable file.

    Examples
    --------
    >>> s = light_spectrum("daylight-led")
    >>> s.shape, float(s.max())
    ((471,), 1.0)
    """
    text = spec.strip()
    if text in SPECTRUM_METHODS:
        return SPECTRUM_METHODS[text](wavelength_nm)
    if text.lower().startswith("blackbody:"):
        try:
            temp = float(text.split(":", 1)[1])
        except ValueError:
            raise ConfigError(f"cannot read a temperature in {text!r}", field="spectrum",
                              allowed="blackbody:T with T in kelvin, e.g. blackbody:5600") from None
        return spectrum_blackbody_Planck(wavelength_nm, temp)
    if text.lower().endswith(".csv") or "/" in text or "\\" in text:
        path = Path(text)
        if not path.is_absolute() and base_dir is not None:
            path = Path(base_dir) / path
        if not os.path.isfile(path):
            raise ConfigError(f"spectrum file not found: {path}", field="spectrum",
                              allowed="an existing CSV with columns wavelength_nm, relative")
        return spectrum_from_csv(wavelength_nm, path)
    raise unknown_name_error("spectrum", text, spectrum_names(), field="spectrum")
