"""Slanted-edge MTF (ISO 12233 e-SFR) and MTF50.

References
----------
.. [ISO12233] ISO 12233:2017, *Photography — Electronic still picture imaging —
   Resolution and spatial frequency responses*, Annex D (edge-based SFR).
.. [Bu00] P.D. Burns, "Slanted-edge MTF for digital camera and scanner analysis",
   Proc. IS&T PICS 2000, 135–138.
"""

from __future__ import annotations

import numpy as np

__all__ = ["mtf_slanted_edge", "mtf50"]


def _centroids(img: np.ndarray) -> np.ndarray:
    d = np.zeros_like(img)
    d[:, 1:-1] = 0.5 * (img[:, 2:] - img[:, :-2])
    d = np.abs(d)
    n = img.shape[1]
    w = np.hamming(n)
    x = np.arange(n)
    first = (d * x).sum(1) / np.maximum(d.sum(1), 1e-300)
    # second pass: Hamming window centred on the first estimate (ISO 12233 Annex D)
    out = np.empty(img.shape[0])
    for r in range(img.shape[0]):
        shift = int(round(first[r] - (n - 1) / 2))
        wr = np.roll(w, shift)
        dr = d[r] * wr
        out[r] = (dr * x).sum() / max(dr.sum(), 1e-300)
    return out


def mtf_slanted_edge(image: np.ndarray, *, oversampling: int = 4) -> tuple[np.ndarray, np.ndarray]:
    """MTF of a region holding one straight, slightly slanted edge (ISO 12233 e-SFR).

    Parameters
    ----------
    image
        2-D array (linear signal, e.g. luminance) with one edge crossing it; near-vertical
        or near-horizontal (it is transposed so that the edge runs along the rows).  The
        edge should be tilted by 2–10° from the pixel grid.
    oversampling
        Bins per pixel of the edge spread function (4 per ISO 12233).

    Returns
    -------
    frequency_cy_per_px, mtf
        Spatial frequencies in cycles/pixel (0 … 1) and the MTF normalised to 1 at 0.
    """
    img = np.asarray(image, float)
    if img.ndim != 2 or min(img.shape) < 8:
        raise ValueError("need a 2-D region of at least 8×8 pixels")
    # edge direction: compare gradient energy across columns and rows
    gx = np.abs(np.diff(img, axis=1)).sum()
    gy = np.abs(np.diff(img, axis=0)).sum()
    if gy > gx:
        img = img.T
    rows, cols = img.shape
    cent = _centroids(img)
    r = np.arange(rows)
    slope, icpt = np.polyfit(r, cent, 1)
    angle = np.degrees(np.arctan(slope))
    if abs(angle) < 0.5 or abs(angle) > 45:
        raise ValueError(f"edge angle {angle:.2f}° off the pixel grid: need ~2–10° (at least 0.5°)")
    # use an integer number of phase cycles (ISO): trim rows
    ncyc = int(rows * abs(slope))
    if ncyc >= 1:
        rows_used = int(ncyc / abs(slope))
        img = img[:rows_used]
        r = r[:rows_used]
    # distance of each pixel centre from the edge along x
    x = np.arange(cols)[None, :] - (slope * r[:, None] + icpt)
    dist = x * np.cos(np.arctan(slope))
    nb = oversampling * cols
    bins = np.floor(dist * oversampling).astype(int) + nb // 2
    ok = (bins >= 0) & (bins < nb)
    sums = np.bincount(bins[ok], weights=img[ok], minlength=nb)
    counts = np.bincount(bins[ok], minlength=nb)
    # fill empty bins by interpolation
    good = counts > 0
    esf = np.interp(np.arange(nb), np.flatnonzero(good), sums[good] / counts[good])
    lsf = np.zeros(nb)
    lsf[1:-1] = 0.5 * (esf[2:] - esf[:-2])
    peak = int(np.argmax(np.abs(lsf)))
    # Hamming window centred on the LSF peak
    half = max(peak, nb - 1 - peak)
    win = np.hamming(2 * half + 1)[half - peak: half - peak + nb]
    lsf *= win
    spec = np.abs(np.fft.rfft(lsf))
    mtf = spec / spec[0]
    freq = np.fft.rfftfreq(nb, d=1.0 / oversampling)  # cycles per pixel
    # correct for the central-difference derivative (ISO 12233:2017 D.5)
    arg = 2 * np.pi * freq / oversampling
    corr = np.where(arg > 0, np.sin(arg) / np.where(arg > 0, arg, 1), 1.0)
    mtf = mtf / np.maximum(corr, 0.1)
    keep = freq <= 1.0
    return freq[keep], mtf[keep]


def mtf50(frequency: np.ndarray, mtf: np.ndarray) -> float:
    """Frequency (same unit as ``frequency``) where the MTF first falls to 0.5 (linear interpolation)."""
    f = np.asarray(frequency, float)
    m = np.asarray(mtf, float)
    below = np.flatnonzero(m < 0.5)
    if below.size == 0:
        return float("nan")
    i = below[0]
    if i == 0:
        return float(f[0])
    return float(f[i - 1] + (0.5 - m[i - 1]) * (f[i] - f[i - 1]) / (m[i] - m[i - 1]))
