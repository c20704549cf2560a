"""Contrast, SNR and backscatter share of image regions."""

from __future__ import annotations

import numpy as np

__all__ = ["luminance", "region_mean", "contrast_michelson", "contrast_weber", "patch_snr", "backscatter_share"]

#: Rec. 709 / sRGB luminance weights of linear R, G, B (ITU-R BT.709-6).
LUMINANCE_WEIGHTS_BT709 = np.array([0.2126, 0.7152, 0.0722])


def luminance(linear_rgb: np.ndarray) -> np.ndarray:
    """Relative luminance Y of linear sRGB/Rec.709 values, ``(..., 3) → (...)``."""
    rgb = np.asarray(linear_rgb, float)
    if rgb.shape[-1] != 3:
        raise ValueError(f"expected (..., 3) linear RGB, got shape {rgb.shape}")
    return rgb @ LUMINANCE_WEIGHTS_BT709


def region_mean(image: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Mean over the pixels of ``mask`` (rows, cols) of an image (rows, cols[, channels])."""
    img = np.asarray(image, float)
    m = np.asarray(mask, bool)
    if m.shape != img.shape[:2]:
        raise ValueError(f"mask shape {m.shape} does not match image {img.shape[:2]}")
    if not m.any():
        raise ValueError("empty region mask")
    return img[m].mean(axis=0)


def contrast_michelson(target: np.ndarray, background: np.ndarray) -> np.ndarray:
    """Michelson contrast ``|L_t − L_b| / (L_t + L_b)`` of mean signals (per channel).

    0 where both are 0; NaN where either is negative — a developed image's mean below its black level
    is noise, and the ratio of two such means is not a contrast (a dark chart at 6 m in Jerlov 3C read
    7.2 from means of ±0.001).

    Parameters
    ----------
    target, background
        Mean signals of the target and its background (scalars or per-channel arrays),
        in any linear unit (radiance, electrons, linear RGB).
    """
    t = np.asarray(target, float)
    b = np.asarray(background, float)
    s = t + b
    out = np.divide(np.abs(t - b), s, out=np.zeros(np.broadcast(t, b).shape), where=s > 0)
    return np.where((t < 0) | (b < 0), np.nan, out)


def contrast_weber(target: np.ndarray, background: np.ndarray) -> np.ndarray:
    """Weber contrast ``(L_t − L_b) / L_b`` (signed; −1 for a black target on any background)."""
    t = np.asarray(target, float)
    b = np.asarray(background, float)
    return np.divide(t - b, b, out=np.full(np.broadcast(t, b).shape, np.nan), where=b > 0)


def patch_snr(image: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Signal-to-noise ratio of a uniform patch: mean / standard deviation over its pixels
    (per channel; inf where the patch is noise-free)."""
    img = np.asarray(image, float)
    m = np.asarray(mask, bool)
    vals = img[m]
    if vals.shape[0] < 2:
        raise ValueError("need at least two pixels for an SNR")
    mean = vals.mean(axis=0)
    std = vals.std(axis=0, ddof=1)
    return np.divide(mean, std, out=np.full(np.shape(mean), np.inf), where=std > 0)


def backscatter_share(backscatter: np.ndarray, total: np.ndarray, mask: np.ndarray | None = None) -> float:
    """Fraction of the recorded signal that is backscatter (veiling light), from the ground-truth
    split: ``Σ backscatter / Σ total`` over ``mask`` (all pixels by default), all bands summed."""
    bs = np.asarray(backscatter, float)
    tot = np.asarray(total, float)
    if mask is not None:
        m = np.asarray(mask, bool)
        bs, tot = bs[m], tot[m]
    s = tot.sum()
    return float(bs.sum() / s) if s > 0 else float("nan")
