"""Wavelength grids and interpolation of tabulated spectra (wavelengths in nm).

Tabulated spectra are never extrapolated silently: asking for a wavelength a
table does not cover raises :class:`~rigsim.errors.SpectrumRangeError` naming
the table and its range.
"""

from __future__ import annotations

import numpy as np

from rigsim.errors import ConfigError, SpectrumRangeError

#: Default rendering bands: 400–700 nm every 10 nm (band centres, nm).
DEFAULT_WAVELENGTHS_NM = np.arange(400.0, 701.0, 10.0)

#: The range Mitsuba samples wavelengths from in spectral mode (nm); spectra given
#: to Mitsuba must cover it (a piecewise spectrum is zero outside its range).
MITSUBA_WAVELENGTH_RANGE_NM = (360.0, 830.0)


#: Most wavelengths a grid may have (a 1 nm grid over 300–2500 nm has 2201).
MAX_WAVELENGTHS = 10000

#: Colour groups of bands (nm, [lo, hi)): roughly a camera's blue, green and red channels.  The
#: Monte Carlo noise target and the fast engine's agreement tables look at each separately.
COLOUR_GROUPS_NM = {"blue": (0.0, 490.0), "green": (490.0, 580.0), "red": (580.0, float("inf"))}


def colour_groups(wavelength_nm) -> dict[str, np.ndarray]:
    """Band indices of each of :data:`COLOUR_GROUPS_NM` (empty groups left out)."""
    wl = np.asarray(wavelength_nm, float)
    out = {k: np.flatnonzero((wl >= lo) & (wl < hi)) for k, (lo, hi) in COLOUR_GROUPS_NM.items()}
    return {k: g for k, g in out.items() if g.size}


def as_wavelengths(wavelength_nm) -> np.ndarray:
    """Return wavelengths (nm) as a float array, checking they are finite and positive.

    A string is read by :func:`parse_wavelength_range` (``"400:700:10"``, ``"450,550"``).
    """
    if isinstance(wavelength_nm, str):
        return parse_wavelength_range(wavelength_nm)
    try:
        wl = np.asarray(wavelength_nm, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(f"cannot read wavelengths {wavelength_nm!r}", field="wavelength_nm",
                          allowed="numbers in nm, or START:STOP:STEP") from None
    if not np.all(np.isfinite(wl)) or np.any(wl <= 0):
        raise ConfigError("wavelengths must be finite and > 0 nm", field="wavelength_nm")
    return wl


def as_wavelength_grid(wavelength_nm) -> np.ndarray:
    """:func:`as_wavelengths` for a grid a user asks for (bands of an image, a table's rows): at most
    :data:`MAX_WAVELENGTHS` of them.  (Per-sample wavelengths inside Monte Carlo, one per path, are
    arrays of any length and go through :func:`as_wavelengths`.)"""
    wl = as_wavelengths(wavelength_nm)
    if wl.size > MAX_WAVELENGTHS:
        raise ConfigError(f"{wl.size} wavelengths, more than {MAX_WAVELENGTHS}", field="wavelength_nm",
                          allowed=f"at most {MAX_WAVELENGTHS} wavelengths")
    return wl


def parse_wavelength_range(text: str) -> np.ndarray:
    """Parse ``"400:700:10"`` (start:stop:step, stop included) or ``"450,550"`` into nm.

    Examples
    --------
    >>> parse_wavelength_range("400:440:20").tolist()
    [400.0, 420.0, 440.0]
    >>> parse_wavelength_range("532").tolist()
    [532.0]
    """
    text = text.strip()
    allowed = "START:STOP:STEP in nm (e.g. 400:700:10) or a comma list"
    try:
        if ":" in text:
            parts = [float(p) for p in text.split(":")]
            if len(parts) != 3 or not all(np.isfinite(parts)) or parts[2] <= 0 or parts[1] < parts[0]:
                raise ValueError
            start, stop, step = parts
            n = int(np.floor((stop - start) / step + 1e-9)) + 1
            if n > MAX_WAVELENGTHS:
                raise ConfigError(f"{text!r} gives {n:.3g} wavelengths, more than {MAX_WAVELENGTHS}",
                                  field="--wavelengths", allowed=f"{allowed}; at most {MAX_WAVELENGTHS} wavelengths")
            wl = start + step * np.arange(n)
        else:
            wl = np.array([float(p) for p in text.split(",") if p.strip()])
            if wl.size == 0:
                raise ValueError
    except ConfigError:
        raise
    except (ValueError, OverflowError):
        raise ConfigError(f"cannot read wavelengths {text!r}", field="--wavelengths", allowed=allowed) from None
    return as_wavelengths(wl)


def interp_table(wavelength_nm, table_nm, table_values, *, name: str) -> np.ndarray:
    """Linear interpolation of a tabulated spectrum, exact at tabulated wavelengths.

    Parameters
    ----------
    wavelength_nm
        Wavelengths to evaluate at (nm), any shape.
    table_nm, table_values
        The table (strictly increasing wavelengths, nm).
    name
        Name of the table for the error message.

    Raises
    ------
    SpectrumRangeError
        If any wavelength is outside ``[table_nm[0], table_nm[-1]]``.
    """
    wl = as_wavelengths(wavelength_nm)
    lo, hi = float(table_nm[0]), float(table_nm[-1])
    if wl.size and (wl.min() < lo - 1e-9 or wl.max() > hi + 1e-9):
        bad = wl[(wl < lo - 1e-9) | (wl > hi + 1e-9)]
        raise SpectrumRangeError(
            f"{name} covers {lo:g}–{hi:g} nm; asked for {bad.min():g}–{bad.max():g} nm",
            field="wavelength_nm", allowed=f"{lo:g}–{hi:g} nm")
    return np.interp(wl, table_nm, table_values)


def extend_to_range(wavelength_nm: np.ndarray, values: np.ndarray,
                    lo_nm: float, hi_nm: float) -> tuple[np.ndarray, np.ndarray]:
    """Pad a sampled spectrum to ``[lo_nm, hi_nm]`` by holding its end values.

    Used only where a consumer (Mitsuba) needs a spectrum defined over its whole
    sampling range although the result is only ever read inside the original
    range (the film has no response outside it).
    """
    wl = np.asarray(wavelength_nm, float)
    v = np.asarray(values, float)
    if wl[0] > lo_nm:
        wl = np.concatenate([[lo_nm], wl])
        v = np.concatenate([[v[0]], v])
    if wl[-1] < hi_nm:
        wl = np.concatenate([wl, [hi_nm]])
        v = np.concatenate([v, [v[-1]]])
    return wl, v


def band_edges(wavelength_nm, bandwidth_nm=None) -> tuple[np.ndarray, np.ndarray]:
    """Band centres and widths (nm) of a spectral image, checked.

    Default widths: the grid spacing (the smaller neighbour distance), 10 nm for a
    single band; bands may not overlap and must lie inside Mitsuba's 360–830 nm
    (the renderer and the preview use the same bands).
    """
    wl = np.atleast_1d(as_wavelength_grid(wavelength_nm)).astype(float)
    if wl.size > 1 and np.any(np.diff(wl) <= 0):
        raise ConfigError("wavelengths must increase strictly", field="wavelengths_nm")
    if bandwidth_nm is None:
        if wl.size == 1:
            bw = np.array([10.0])
        else:
            d = np.diff(wl)
            bw = np.minimum(np.concatenate([[d[0]], d]), np.concatenate([d, [d[-1]]]))
    else:
        bw = np.broadcast_to(np.asarray(bandwidth_nm, float), wl.shape).copy()
        if np.any(~np.isfinite(bw)) or np.any(bw <= 0):
            raise ConfigError("band widths must be > 0 nm", field="bandwidth_nm", allowed="> 0")
        if wl.size > 1 and np.any(wl[1:] - bw[1:] / 2 < wl[:-1] + bw[:-1] / 2 - 1e-9):
            raise ConfigError("bands overlap", field="bandwidth_nm",
                              allowed="widths no larger than the band spacing")
    lo, hi = MITSUBA_WAVELENGTH_RANGE_NM
    if wl[0] - bw[0] / 2 < lo - 1e-9 or wl[-1] + bw[-1] / 2 > hi + 1e-9:
        raise ConfigError(f"bands {wl[0] - bw[0] / 2:g}–{wl[-1] + bw[-1] / 2:g} nm leave the supported range",
                          field="wavelengths_nm", allowed=f"{lo:g}–{hi:g} nm")
    return wl, bw


def band_average(table_nm, table_values, lo_nm, hi_nm) -> np.ndarray:
    """Averages of a tabulated spectrum over bands ``[lo, hi]`` (nm), exactly as the renderer sees it.

    The table is linear between its nodes and zero outside them (as a Mitsuba spectrum given by
    (wavelength, value) pairs); the average over a band is the trapezoid rule on the table's own
    nodes inside the band plus the band's ends, which is exact for such a function.  A spectrum
    with a step (a flash spectrum that starts at 400 nm) thus gets the band straddling the step
    right, where values at a few points inside the band would not.

    Returns an array of the bands' shape; a band of zero width gets the value at its centre.
    """
    wl = np.asarray(table_nm, float)
    v = np.asarray(table_values, float)
    lo = np.atleast_1d(np.asarray(lo_nm, float))
    hi = np.atleast_1d(np.asarray(hi_nm, float))
    out = np.empty(np.broadcast_shapes(lo.shape, hi.shape))
    for i, (a, b) in enumerate(zip(np.broadcast_to(lo, out.shape).ravel(), np.broadcast_to(hi, out.shape).ravel())):
        if b <= a:
            out.flat[i] = np.interp(0.5 * (a + b), wl, v, left=0.0, right=0.0)
            continue
        x = np.concatenate([[a], wl[(wl > a) & (wl < b)], [b]])
        y = np.interp(x, wl, v, left=0.0, right=0.0)
        out.flat[i] = np.trapezoid(y, x) / (b - a)
    return out if np.ndim(lo_nm) or np.ndim(hi_nm) else out.reshape(())
