"""White balance: per-channel gains that make a neutral surface neutral in camera RGB.

:data:`WHITE_BALANCE_METHODS` maps a name to a function returning gains
``(g_R, g_G, g_B)`` with ``g_G = 1``; :func:`white_balance_gains` dispatches.
Estimating methods take a camera-RGB image (rows, cols, 3), linear, black
subtracted; a cheap half-resolution image (:func:`rigsim.sensor.cfa.superpixel`)
is enough.  Pixels at or above ``clip`` are ignored.

=================  ==============================================================
name               estimate
=================  ==============================================================
``grayworld``      the scene averages to grey (Buchsbaum 1980)
``white_patch``    the brightest unclipped pixels are white (Land 1977 max-RGB),
                   taken at a high percentile for robustness
``chart``          mean of a given neutral patch (mask or box)
``illuminant``     predicted from an illuminant spectrum, optional water
                   transmission and the sensor QE (no image needed)
``manual``         gains given by the user
=================  ==============================================================

References
----------
Buchsbaum, G. (1980). A spatial processor model for object colour perception.
  J. Franklin Inst. 310(1), 1–26.
Land, E. H. (1977). The retinex theory of color vision. Sci. Am. 237(6), 108–128.
"""

from __future__ import annotations

import numpy as np

from rigsim.errors import ConfigError, unknown_name_error


def _gains_from_neutral(neutral) -> np.ndarray:
    n = np.asarray(neutral, float)
    if n.shape != (3,) or not np.all(np.isfinite(n)) or np.any(n <= 0):
        raise ConfigError(f"cannot white balance: neutral estimate {n.tolist()} is not positive",
                          field="white balance", allowed="an image/patch with signal in all three channels")
    return n[1] / n


def _valid(rgb: np.ndarray, clip: float) -> np.ndarray:
    rgb = np.asarray(rgb, np.float32).reshape(-1, 3)
    return rgb[np.all(rgb < clip, axis=1)]


def white_balance_GrayWorld(rgb: np.ndarray, *, clip: float = 0.98) -> np.ndarray:
    """Gray-world gains: the mean of unclipped pixels is taken as neutral."""
    v = _valid(rgb, clip)
    if len(v) == 0:
        raise ConfigError("gray world: every pixel is clipped", field="--wb", allowed="a less exposed image")
    return _gains_from_neutral(v.mean(axis=0))


def white_balance_WhitePatch(rgb: np.ndarray, *, clip: float = 0.98, percentile: float = 99.0) -> np.ndarray:
    """White-patch (max-RGB) gains: each channel's ``percentile`` of unclipped pixels is white."""
    v = _valid(rgb, clip)
    if len(v) == 0:
        raise ConfigError("white patch: every pixel is clipped", field="--wb", allowed="a less exposed image")
    return _gains_from_neutral(np.percentile(v, percentile, axis=0))


def white_balance_chart(rgb: np.ndarray, *, mask=None, box=None, clip: float = 0.98) -> np.ndarray:
    """Gains from a neutral chart patch given as a boolean ``mask`` (rows, cols) or
    ``box = (row0, row1, col0, col1)`` (pixel indices of ``rgb``)."""
    rgb = np.asarray(rgb, np.float32)
    if mask is not None:
        sel = rgb[np.asarray(mask, bool)]
    elif box is not None:
        r0, r1, c0, c1 = (int(b) for b in box)
        sel = rgb[r0:r1, c0:c1].reshape(-1, 3)
    else:
        raise ConfigError("chart white balance needs the neutral patch", field="--wb",
                          allowed="mask= or box=(row0, row1, col0, col1)")
    sel = sel[np.all(sel < clip, axis=-1)]
    if len(sel) == 0:
        raise ConfigError("chart white balance: the patch is empty or clipped", field="--wb-box",
                          allowed="a box inside the image on an unclipped neutral patch")
    return _gains_from_neutral(sel.mean(axis=0))


def neutral_from_illuminant(sensor, wavelength_nm, illuminant, water_transmission=None) -> np.ndarray:
    """Camera RGB of a perfect white reflector under ``illuminant`` (× water transmission).

    Parameters
    ----------
    sensor
        :class:`~rigsim.sensor.model.Sensor`.
    wavelength_nm
        Wavelengths (nm) of the spectra, within the sensor's QE table.
    illuminant
        Spectral irradiance (any units; only ratios matter), same length.
    water_transmission
        Optional transmission (0–1) along the light path in water, e.g.
        exp(−K_d z − c r), same length.

    Returns
    -------
    ndarray
        (3,) relative camera response Σ E(λ)·T(λ)·η_c(λ)·λ Δλ (photon-counting).
    """
    wl = np.asarray(wavelength_nm, float)
    e = np.asarray(illuminant, float) * (1.0 if water_transmission is None
                                         else np.asarray(water_transmission, float))
    if e.shape != wl.shape:
        raise ConfigError("illuminant and wavelength arrays differ in length", field="illuminant")
    w = np.gradient(wl) if len(wl) > 1 else np.ones(1)
    return (e * wl * w) @ sensor.qe_at(wl)


def white_balance_from_illuminant(rgb=None, *, sensor, wavelength_nm, illuminant,
                                  water_transmission=None) -> np.ndarray:
    """Gains predicted from a known illuminant and water path (``rgb`` is ignored)."""
    return _gains_from_neutral(neutral_from_illuminant(sensor, wavelength_nm, illuminant,
                                                       water_transmission))


def white_balance_manual(rgb=None, *, gains) -> np.ndarray:
    """User-given gains (R, G, B); normalised so that G = 1."""
    g = np.asarray(gains, float)
    if g.shape != (3,) or np.any(g <= 0) or not np.all(np.isfinite(g)):
        raise ConfigError(f"manual white balance gains must be 3 positive numbers, got {gains}",
                          field="--wb-gains", allowed="R,G,B > 0")
    return g / g[1]


#: White balance methods by name.
WHITE_BALANCE_METHODS = {
    "grayworld": white_balance_GrayWorld,
    "white_patch": white_balance_WhitePatch,
    "chart": white_balance_chart,
    "illuminant": white_balance_from_illuminant,
    "manual": white_balance_manual,
}


def white_balance_gains(rgb, method: str = "grayworld", **kwargs) -> np.ndarray:
    """White balance gains (R, G, B; G = 1) by the method named ``method``."""
    try:
        f = WHITE_BALANCE_METHODS[method]
    except KeyError:
        raise unknown_name_error("white balance method", method,
                                 list(WHITE_BALANCE_METHODS) + ["as_shot"], field="--wb") from None
    return np.asarray(f(rgb, **kwargs), float)
