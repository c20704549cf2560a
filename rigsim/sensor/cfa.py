"""Colour filter arrays: Bayer patterns, masks and mosaicking.

A pattern names the colours of the top-left 2×2 block row by row, e.g.
``"RGGB"`` = R at (0, 0), G at (0, 1) and (1, 0), B at (1, 1).  Channel indices
are R = 0, G = 1, B = 2 (also the DNG/TIFF-EP CFAPattern codes).
"""

from __future__ import annotations

import numpy as np

from rigsim.errors import ConfigError

CFA_PATTERNS = ("RGGB", "BGGR", "GRBG", "GBRG")
_CODE = {"R": 0, "G": 1, "B": 2}


def check_pattern(pattern: str) -> str:
    p = str(pattern).upper()
    if p not in CFA_PATTERNS:
        raise ConfigError(f"unsupported CFA pattern {pattern!r}", field="cfa_pattern",
                          allowed=", ".join(CFA_PATTERNS))
    return p


def pattern_codes(pattern: str) -> np.ndarray:
    """The 2×2 array of channel indices (0 R, 1 G, 2 B) of ``pattern``."""
    return np.array([_CODE[c] for c in check_pattern(pattern)], np.uint8).reshape(2, 2)


def pattern_from_codes(codes) -> str:
    """Inverse of :func:`pattern_codes` (accepts LibRaw's 0–3 codes with 3 = second green)."""
    c = np.asarray(codes).reshape(2, 2)
    names = {0: "R", 1: "G", 2: "B", 3: "G"}
    return check_pattern("".join(names[int(v)] for v in c.ravel()))


def channel_map(pattern: str, shape: tuple[int, int]) -> np.ndarray:
    """(rows, cols) uint8 map of the channel index at each pixel."""
    rows, cols = shape
    codes = pattern_codes(pattern)
    return np.tile(codes, ((rows + 1) // 2, (cols + 1) // 2))[:rows, :cols]


def mosaic(rgb: np.ndarray, pattern: str) -> np.ndarray:
    """Sample a (rows, cols, 3) image through the CFA: (rows, cols) mosaic, in the input's dtype.

    A thin wrapper of :func:`colour_demosaicing.mosaicing_CFA_Bayer` (same pattern names),
    which computes in float64; the result is cast back to ``rgb.dtype`` (exact: every output
    value is one of the input's).  Non-finite values (NaN, ±inf) in a channel spread to the
    sites of the other channels too (colour-demosaicing multiplies by 0/1 masks): inputs must
    be finite.

    Examples
    --------
    >>> mosaic(np.arange(12).reshape(2, 2, 3), "RGGB").tolist()
    [[0, 4], [7, 11]]
    """
    from colour_demosaicing import mosaicing_CFA_Bayer

    rgb = np.asarray(rgb)
    if rgb.ndim != 3 or rgb.shape[2] != 3:
        raise ValueError(f"mosaic needs a (rows, cols, 3) image, got shape {rgb.shape}")
    return np.asarray(mosaicing_CFA_Bayer(rgb, check_pattern(pattern))).astype(rgb.dtype, copy=False)


def superpixel(cfa: np.ndarray, pattern: str) -> np.ndarray:
    """Half-resolution RGB from 2×2 blocks (R, mean of the two G, B); for statistics, not display."""
    cfa = np.asarray(cfa, np.float32)
    r2, c2 = cfa.shape[0] // 2 * 2, cfa.shape[1] // 2 * 2
    codes = pattern_codes(pattern)
    out = np.zeros((r2 // 2, c2 // 2, 3), np.float32)
    for dy in (0, 1):
        for dx in (0, 1):
            out[..., codes[dy, dx]] += cfa[dy:r2:2, dx:c2:2]
    out[..., 1] *= 0.5
    return out
