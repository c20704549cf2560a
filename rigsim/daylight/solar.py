"""Sunlight above the sea: spectral irradiance of the direct sun and of the sky, W·m⁻²·nm⁻¹.

Two spectra are offered:

* ``"astm-g173"`` (default) — a clear-sky model scaled from the ASTM G173-03
  reference spectra (``data/daylight/astm_g173.csv``, public domain, AM1.5) to any
  sun zenith angle, see :func:`irradiance_clear_sky_ASTMG173`.
* ``"cie-d"`` — the relative CIE daylight illuminant of a given correlated colour
  temperature (colour-science ``sd_CIE_illuminant_D_series``), scaled so that the
  total plane irradiance at 550 nm has a given value (default that of the G173
  model for the same sun), split between sun and sky by a fixed sky share.

All functions return *plane* irradiance on a horizontal surface just above the
water (the quantity a cosine collector pointing up would read), per nm.

References
----------
.. [G173] ASTM G173-03, *Standard Tables for Reference Solar Spectral Irradiances:
   Direct Normal and Hemispherical on 37° Tilted Surface* (2003/2012).
.. [KY89] F. Kasten, A.T. Young, "Revised optical air mass tables and
   approximation formula", Appl. Opt. 28(22):4735–4738 (1989).
.. [CIE15] CIE 015:2018 *Colorimetry*, §4.1 (daylight illuminants).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from rigsim.data import load_table
from rigsim.errors import ConfigError
from rigsim.spectrum import as_wavelengths, interp_table

__all__ = [
    "ASTM_G173_ZENITH_DEG",
    "ASTM_G173_TILT_DEG",
    "ASTM_G173_GROUND_ALBEDO",
    "solar_spectrum_ASTMG173",
    "air_mass_KastenYoung1989",
    "irradiance_clear_sky_ASTMG173",
    "irradiance_CIE_daylight",
    "SOLAR_SPECTRA",
    "SurfaceIrradiance",
    "surface_irradiance",
]

#: Sun zenith of the ASTM G173 spectra: air mass 1.5 = 1/cos(48.19°).
ASTM_G173_ZENITH_DEG = float(np.degrees(np.arccos(1.0 / 1.5)))
#: Tilt of the G173 global-tilt receiver (facing the sun), deg.
ASTM_G173_TILT_DEG = 37.0
#: Broadband ground albedo assumed when converting the tilted global spectrum to a
#: horizontal diffuse one (G173 used a spectral "light soil" albedo, about 0.2–0.3).
ASTM_G173_GROUND_ALBEDO = 0.2


def _check_zenith(sun_zenith_deg: float) -> float:
    z = float(sun_zenith_deg)
    if not np.isfinite(z) or not 0.0 <= z < 90.0:
        raise ConfigError(f"sun zenith must be in [0, 90) deg, got {sun_zenith_deg}", field="sun_zenith_deg",
                          allowed="0 ≤ zenith < 90 deg")
    return z


@functools.lru_cache(maxsize=None)
def _g173():
    t = load_table("daylight/astm_g173.csv")
    return (t["wavelength_nm"], t["etr_W_per_m2_nm"], t["global_tilt_W_per_m2_nm"],
            t["direct_circumsolar_W_per_m2_nm"])


def solar_spectrum_ASTMG173(wavelength_nm, which: str = "direct") -> np.ndarray:
    """The ASTM G173-03 reference spectra [G173], W·m⁻²·nm⁻¹ (280–1000 nm here).

    Parameters
    ----------
    wavelength_nm
        Wavelengths, nm (linear interpolation; outside 280–1000 nm is an error).
    which
        ``"etr"`` (top of atmosphere), ``"global-tilt"`` (37° tilted plane facing
        the sun at AM1.5) or ``"direct"`` (direct normal + circumsolar at AM1.5).

    Examples
    --------
    >>> float(solar_spectrum_ASTMG173(550.0, "etr"))
    1.863
    """
    wl, etr, gt, dn = _g173()
    col = {"etr": etr, "global-tilt": gt, "direct": dn}.get(which)
    if col is None:
        raise ConfigError(f"unknown G173 spectrum {which!r}", field="which", allowed="etr, global-tilt, direct")
    return interp_table(wavelength_nm, wl, col, name="ASTM G173 (data/daylight/astm_g173.csv)")


def air_mass_KastenYoung1989(sun_zenith_deg) -> np.ndarray:
    """Relative optical air mass [KY89]: ``m = 1/(cos θ + 0.50572 (96.07995° − θ)^−1.6364)``.

    Examples
    --------
    >>> round(float(air_mass_KastenYoung1989(0.0)), 4)
    0.9997
    >>> round(float(air_mass_KastenYoung1989(60.0)), 3)
    1.994
    """
    z = np.asarray(sun_zenith_deg, float)
    return 1.0 / (np.cos(np.radians(z)) + 0.50572 * (96.07995 - z) ** -1.6364)


def irradiance_clear_sky_ASTMG173(wavelength_nm, sun_zenith_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Direct-sun and diffuse-sky plane irradiance above the sea for a clear sky, W·m⁻²·nm⁻¹.

    Parameters
    ----------
    wavelength_nm
        Wavelengths, nm (280–1000).
    sun_zenith_deg
        Sun zenith angle, deg, in [0, 90).

    Returns
    -------
    direct, diffuse
        Horizontal plane irradiance from the sun's disc and from the sky.

    Notes
    -----
    At the G173 geometry (θ₀ = 48.19°, air mass m₀ = 1.5) the direct normal
    spectrum ``S_n`` is the G173 direct+circumsolar column.  The horizontal diffuse
    spectrum ``D₀`` is derived from the global-tilt column ``G_t`` for an
    isotropic sky and a ground of albedo ρ = 0.2 seen by the 37° tilted receiver
    (incidence i = 11.19°)::

        G_t = S_n cos i + D₀ (1 + cos 37°)/2 + ρ (D₀ + S_n cos θ₀)(1 − cos 37°)/2

    (the isotropic-sky assumption under-weights the circumsolar brightening the
    tilted receiver sees, so ``D₀`` is an upper estimate by a few per cent).  At
    another zenith θ with air mass m (Kasten & Young) the beam follows Bouguer's
    law with the G173 atmosphere, ``S_n(θ) = ETR · τ^m`` with ``τ = (S_n/ETR)^{1/1.5}``,
    and the diffuse part scales with the horizontal flux removed from the beam::

        D(θ) = D₀ · cos θ (1 − τ^m) / (cos θ₀ (1 − τ^{1.5}))

    This reproduces G173 exactly at 48.19° and is a first-order clear-sky model
    elsewhere (expect ±10–20 % against a radiative-transfer code such as SMARTS
    or Gregg & Carder (1990) at low sun); valid to a zenith of about 80°.

    Examples
    --------
    >>> d, s = irradiance_clear_sky_ASTMG173(550.0, 30.0)
    >>> round(float(d), 2), round(float(s), 2)
    (1.27, 0.21)
    """
    z = _check_zenith(sun_zenith_deg)
    wl = as_wavelengths(wavelength_nm)
    etr = solar_spectrum_ASTMG173(wl, "etr")
    sn0 = solar_spectrum_ASTMG173(wl, "direct")
    gt = solar_spectrum_ASTMG173(wl, "global-tilt")
    z0 = np.radians(ASTM_G173_ZENITH_DEG)
    tilt = np.radians(ASTM_G173_TILT_DEG)
    cos_i = np.cos(z0 - tilt)
    rho = ASTM_G173_GROUND_ALBEDO
    view_sky, view_ground = (1 + np.cos(tilt)) / 2, (1 - np.cos(tilt)) / 2
    d0 = (gt - sn0 * cos_i - rho * sn0 * np.cos(z0) * view_ground) / (view_sky + rho * view_ground)
    d0 = np.maximum(d0, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = np.where(etr > 0, np.clip(sn0 / etr, 1e-12, 1.0) ** (1.0 / 1.5), 0.0)
    m = float(air_mass_KastenYoung1989(z))
    cz = np.cos(np.radians(z))
    direct = etr * tau ** m * cz
    removed0 = np.cos(z0) * (1.0 - tau ** 1.5)
    with np.errstate(divide="ignore", invalid="ignore"):
        diffuse = np.where(removed0 > 0, d0 * cz * (1.0 - tau ** m) / removed0, 0.0)
    return direct, diffuse


#: Second radiation constant (m·K) the CIE D-series nominal CCTs were defined with (CIE 15:2018).
_C2_D_SERIES_M_K = 1.4380e-2


def irradiance_CIE_daylight(wavelength_nm, cct_K: float, *, e550_W_per_m2_nm: float,
                            sky_fraction: float) -> tuple[np.ndarray, np.ndarray]:
    """CIE daylight of correlated colour temperature ``cct_K`` as direct and diffuse plane irradiance.

    The relative spectral distribution of the CIE D-series illuminant [CIE15]
    (4000–25000 K, colour-science) is scaled so that the *total* plane irradiance
    at 550 nm is ``e550_W_per_m2_nm``, and split ``(1 − f, f)`` between the sun
    and the sky at every wavelength (``f = sky_fraction``).
    """
    import colour
    from colour.colorimetry.blackbody import CONSTANT_C2

    wl = as_wavelengths(wavelength_nm)
    cct = float(cct_K)
    if not 4000.0 <= cct <= 25000.0:
        raise ConfigError(f"CIE daylight CCT must be in 4000–25000 K, got {cct_K}", field="cct_K",
                          allowed="4000–25000 K")
    if not 0.0 <= sky_fraction <= 1.0:
        raise ConfigError(f"sky fraction must be in [0, 1], got {sky_fraction}", field="sky_fraction",
                          allowed="0 ≤ f ≤ 1")
    # the D-series CCTs are nominal: the tables were computed with c2 = 1.4380e-2 m·K; with the
    # ITS-90 value c2 = 1.4388e-2 m·K (colour's CONSTANT_C2) D65 "6500 K" is 6504 K (CIE 15:2018)
    xy = colour.temperature.CCT_to_xy_CIE_D(cct * CONSTANT_C2 / _C2_D_SERIES_M_K)
    sd = colour.sd_CIE_illuminant_D_series(xy)
    lo, hi = sd.wavelengths[0], sd.wavelengths[-1]
    rel = interp_table(wl, sd.wavelengths, sd.values, name=f"CIE daylight D ({lo:g}–{hi:g} nm)")
    rel550 = float(np.interp(550.0, sd.wavelengths, sd.values))
    total = rel / rel550 * float(e550_W_per_m2_nm)
    return total * (1.0 - sky_fraction), total * sky_fraction


#: Names of the spectra :func:`surface_irradiance` accepts.
SOLAR_SPECTRA = ("astm-g173", "cie-d:CCT", "flat")


@dataclass(frozen=True, eq=False)
class SurfaceIrradiance:
    """Downwelling spectral plane irradiance just above the sea, split into sun and sky.

    Attributes
    ----------
    wavelength_nm
        Band centres, nm.
    sun, sky
        Horizontal plane irradiance from the sun's disc and from the sky, W·m⁻²·nm⁻¹.
    spectrum
        How it was made (for reports), e.g. ``"astm-g173"``.
    """

    wavelength_nm: np.ndarray
    sun: np.ndarray
    sky: np.ndarray
    spectrum: str = "astm-g173"

    @property
    def total(self) -> np.ndarray:
        """Ed(0+) = sun + sky, W·m⁻²·nm⁻¹."""
        return self.sun + self.sky

    @property
    def sky_fraction(self) -> np.ndarray:
        t = self.total
        return np.divide(self.sky, t, out=np.zeros_like(t), where=t > 0)


def surface_irradiance(wavelength_nm, sun_zenith_deg: float, *, spectrum: str = "astm-g173",
                       sky_fraction: float | None = None, total_W_per_m2_nm: float | None = None,
                       black_sky: bool = False) -> SurfaceIrradiance:
    """Spectral sun and sky plane irradiance just above the surface (W·m⁻²·nm⁻¹).

    Parameters
    ----------
    wavelength_nm
        Wavelengths, nm.
    sun_zenith_deg
        Sun zenith, deg in [0, 90).
    spectrum
        ``"astm-g173"`` (clear-sky model, :func:`irradiance_clear_sky_ASTMG173`),
        ``"cie-d:6500"`` (CIE daylight of that CCT, with the G173 model's total at
        550 nm), or ``"flat"`` (1 W·m⁻²·nm⁻¹ at every wavelength; the textbook case).
    sky_fraction
        Share of the total plane irradiance that comes from the sky, in [0, 1]
        (None: the G173 model's own share per wavelength; for ``cie-d`` and ``flat``
        that model's share at 550 nm).
    total_W_per_m2_nm
        If given, the total plane irradiance Ed(0+) at *every* wavelength (a flat
        spectrum of this value), split by the sky share.
    black_sky
        No sky light: everything comes from the sun (``sky_fraction`` must be None or 0).
    """
    wl = np.atleast_1d(as_wavelengths(wavelength_nm))
    z = _check_zenith(sun_zenith_deg)
    if sky_fraction is not None and not (np.isfinite(sky_fraction) and 0.0 <= sky_fraction <= 1.0):
        raise ConfigError(f"sky fraction must be in [0, 1], got {sky_fraction}", field="sky_fraction",
                          allowed="0 ≤ f ≤ 1")
    if black_sky:
        if sky_fraction not in (None, 0.0):
            raise ConfigError("a black sky has no sky light; sky fraction must be 0", field="sky_fraction")
        sky_fraction = 0.0
    if total_W_per_m2_nm is not None:
        e = float(total_W_per_m2_nm)
        if not np.isfinite(e) or e < 0:
            raise ConfigError(f"surface irradiance must be >= 0 W/m²/nm, got {total_W_per_m2_nm}",
                              field="surface_irradiance", allowed=">= 0 W/(m²·nm)")
    spec = spectrum.lower()
    if spec == "astm-g173":
        if total_W_per_m2_nm is None and (wl.min() < 280 or wl.max() > 1000):
            solar_spectrum_ASTMG173(wl)  # raises the range error
        if total_W_per_m2_nm is None:
            sun, sky = irradiance_clear_sky_ASTMG173(wl, z)
        else:
            sun, sky = irradiance_clear_sky_ASTMG173(np.clip(wl, 280, 1000), z)
        tot = sun + sky
        f = np.divide(sky, tot, out=np.zeros_like(tot), where=tot > 0) if sky_fraction is None else \
            np.full(wl.shape, float(sky_fraction))
        if total_W_per_m2_nm is not None:
            tot = np.full(wl.shape, float(total_W_per_m2_nm))
        return SurfaceIrradiance(wl, tot * (1 - f), tot * f, "astm-g173" if total_W_per_m2_nm is None
                                 else f"flat {total_W_per_m2_nm:g} W/m2/nm")
    s550, k550 = irradiance_clear_sky_ASTMG173(550.0, z)
    f = float(k550 / (s550 + k550)) if sky_fraction is None else float(sky_fraction)
    if spec.startswith("cie-d:"):
        try:
            cct = float(spec[6:])
        except ValueError:
            raise ConfigError(f"cannot read CCT in {spectrum!r}", field="spectrum",
                              allowed="cie-d:CCT (K), e.g. cie-d:6500") from None
        e550 = float(s550 + k550) if total_W_per_m2_nm is None else float(total_W_per_m2_nm)
        sun, sky = irradiance_CIE_daylight(wl, cct, e550_W_per_m2_nm=e550, sky_fraction=f)
        return SurfaceIrradiance(wl, sun, sky, f"cie-d {cct:g} K, {e550:.4g} W/m2/nm at 550 nm")
    if spec == "flat":
        e = 1.0 if total_W_per_m2_nm is None else float(total_W_per_m2_nm)
        tot = np.full(wl.shape, e)
        return SurfaceIrradiance(wl, tot * (1 - f), tot * f, f"flat {e:g} W/m2/nm")
    raise ConfigError(f"unknown solar spectrum {spectrum!r}", field="spectrum", allowed=", ".join(SOLAR_SPECTRA))
