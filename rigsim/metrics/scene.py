"""The numbers of one rendered scene and its capture: target regions from the render's
object-id layer, then contrast, SNR, ΔE, backscatter share and MTF.

Metrics (keys of :func:`scene_metrics`):

``contrast_radiance``
    Michelson contrast of the target from the noise-free scene radiance (photopic
    luminance, CIE 1931 ȳ), sensor-independent: ColorChecker white (patch 19) against
    black (patch 24); black/white disk or a mesh (a rock) against the surrounding water;
    slanted edge white against black.
``backscatter_share``
    Share of the target pixels' radiance that is light scattered by the water
    without reaching a surface (ground-truth split).
``contrast_image``
    The same contrast from the developed image (linear sRGB luminance) of a sensor.
``snr_white``
    Temporal SNR of the sensor (EMVA 1288 model, green channel) at the mean signal of the
    white patch (chart), the white disk or a mesh, the water around a black disk, or the white half — the sensor's noise,
    not the Monte Carlo noise of the render.
``snr_white_image``
    Mean/σ of the developed luminance over the same pixels (includes render noise and any
    texture; for reference).
``delta_e_mean``
    Mean ΔE2000 of the 24 patches (chart only) against the chart under D65 in air, after
    the capture's white balance and colour correction; the image is scaled so the white
    patch has the reference luminance (exposure is not colour).
``mtf50_cy_per_px``
    Slanted edge only: ISO 12233 MTF50 of the developed luminance (cycles/pixel).
"""

from __future__ import annotations

import logging
import math

import numpy as np

from rigsim.metrics.color import chart_delta_e
from rigsim.metrics.contrast import backscatter_share, contrast_michelson, luminance, patch_snr
from rigsim.metrics.mtf import mtf50, mtf_slanted_edge

log = logging.getLogger(__name__)

__all__ = ["photopic_luminance", "target_masks", "chart_delta_e_of_image", "scene_metrics"]


def photopic_luminance(spectral: np.ndarray, wavelength_nm, bandwidth_nm) -> np.ndarray:
    """Relative photopic luminance ∑ X_b ∫_band ȳ dλ of a spectral array (..., bands) (CIE 1931 2°,
    :func:`rigsim.colorimetry.XYZ_from_bands`)."""
    from rigsim.spectral_image import xyz_from_spectral

    return xyz_from_spectral(spectral, wavelength_nm, bandwidth_nm)[..., 1]


def _morph(mask: np.ndarray, px: int, erode: bool) -> np.ndarray:
    import cv2

    if px <= 0:
        return mask
    k = np.ones((2 * px + 1, 2 * px + 1), np.uint8)
    out = (cv2.erode if erode else cv2.dilate)(mask.astype(np.uint8), k).astype(bool)
    return out if (not erode or out.sum() >= 4) else mask


def target_masks(object_id: np.ndarray, legend: dict[str, str], target_kind: str) -> dict[str, np.ndarray]:
    """Pixel masks of the parts of a target, from the render's object-id layer.

    Returns keys among ``target`` (the whole target), ``signal``/``reference`` (the two
    regions whose contrast is measured), ``patch:<name>`` (chart patches, eroded by a
    pixel to avoid mixed edge pixels).
    """
    by_name = {}
    for k, label in legend.items():
        by_name[label.split(": ", 1)[-1]] = object_id == int(k)
    out: dict[str, np.ndarray] = {}
    target = object_id > 0
    out["target"] = target
    if target_kind == "colorchecker":
        names = [n for n in by_name if n != "chart"]
        for n in names:
            out[f"patch:{n}"] = _morph(by_name[n], 1, True)
        white = next((n for n in names if n.startswith("white")), None)
        black = next((n for n in names if n.startswith("black")), None)
        if white and black:
            out["signal"], out["reference"] = out[f"patch:{white}"], out[f"patch:{black}"]
    elif target_kind in ("black-disk", "white-disk", "mesh"):
        disk = by_name.get("disk", target)  # (a mesh: the whole object, against the water around it)
        r = max(2, int(np.sqrt(disk.sum() / np.pi)))
        ring = _morph(disk, r, False) & ~_morph(disk, 2, False) & (object_id == 0)
        out["signal"], out["reference"] = _morph(disk, 1, True), ring
    elif target_kind == "slanted-edge":
        out["signal"], out["reference"] = _morph(by_name["white"], 2, True), _morph(by_name["black"], 2, True)
    return {k: v for k, v in out.items() if v.any()}


def chart_delta_e_of_image(linear_srgb: np.ndarray, masks: dict[str, np.ndarray]) -> float:
    """Mean ΔE2000 of the 24 chart patches of a linear-sRGB image against the chart under D65,
    after scaling the image so the white patch has the reference luminance (NaN if a patch is
    missing from ``masks``)."""
    import colour

    from rigsim.colorimetry import XYZ_from_bands
    from rigsim.scene.reflectances import reflectance_colorchecker_Ohta

    wl = np.arange(380.0, 781.0, 5.0)
    refl = reflectance_colorchecker_Ohta(wl)
    names = [n for n in refl if f"patch:{n}" in masks]
    if len(names) < 24:
        return float("nan")
    d65 = colour.SDS_ILLUMINANTS["D65"]
    ref = XYZ_from_bands(np.array([refl[n] for n in names]), wl,
                         illuminant=np.interp(wl, d65.wavelengths, d65.values))  # white: Y = 1
    meas_rgb = np.array([linear_srgb[masks[f"patch:{n}"]].mean(axis=0) for n in names])
    meas = colour.RGB_to_XYZ(meas_rgb, colour.RGB_COLOURSPACES["sRGB"], apply_cctf_decoding=False)
    wi = next(i for i, n in enumerate(names) if n.startswith("white"))
    if meas[wi, 1] <= 0:
        return float("nan")
    mean, _ = chart_delta_e(ref, meas * (ref[wi, 1] / meas[wi, 1]))
    return mean


def scene_metrics(si, target_kind: str, *, cap=None, sensor=None, exposure=None,
                  masks: dict[str, np.ndarray] | None = None,
                  radiance_metrics: bool = True) -> tuple[dict[str, float], dict]:
    """The numbers of one rendered scene (see the module docstring) and the masks used.

    Parameters
    ----------
    si
        SpectralImage with ``object_id`` (and ``backscatter``/``flash_backscatter`` for the share).
    target_kind
        The target's kind (selects the signal/reference regions).
    cap, sensor, exposure
        A developed capture of ``si`` and what made it; without them only the
        sensor-independent numbers.
    masks
        Precomputed :func:`target_masks` (optional).
    radiance_metrics
        Also the sensor-independent numbers (``contrast_radiance``, ``backscatter_share``); a caller
        measuring several captures of one image computes them once.
    """
    if masks is None:
        masks = target_masks(np.asarray(si.layers["object_id"]), si.meta.get("object_ids", {}), target_kind)
    out: dict[str, float] = {}
    if radiance_metrics:
        h_total = si.radiant_exposure(1.0)  # strobes: one flash at full power; continuous: 1 s
        lum = photopic_luminance(h_total, si.wavelength_nm, si.bandwidth_nm)
        if "signal" in masks and "reference" in masks:
            out["contrast_radiance"] = float(contrast_michelson(lum[masks["signal"]].mean(),
                                                                lum[masks["reference"]].mean()))
        if ("backscatter" in si.layers or "flash_backscatter" in si.layers) and "target" in masks:
            out["backscatter_share"] = float(backscatter_share(si.radiant_exposure(1.0, "backscatter"), h_total,
                                                               masks["target"]))
    if cap is not None:
        lin = np.asarray(cap.linear_rgb, float)
        if lin.shape[:2] != np.shape(si.radiance)[:2]:
            raise ValueError("the capture was resampled: metrics need the render's pixel grid")
        y = luminance(lin)
        if "signal" in masks and "reference" in masks:
            out["contrast_image"] = float(contrast_michelson(y[masks["signal"]].mean(),
                                                             y[masks["reference"]].mean()))
            # the white patch, the white half, the white disk; for a black disk the water around it
            region = masks["reference"] if target_kind == "black-disk" else masks["signal"]
            if region.sum() >= 4:
                out["snr_white_image"] = float(patch_snr(y, region))
                if sensor is not None and exposure is not None:
                    from rigsim.sensor.noise import snr_emva1288
                    from rigsim.sensor.pipeline import mean_electrons_rgb

                    mu_g = float(mean_electrons_rgb(si, sensor, exposure)[..., 1][region].mean())
                    out["snr_white"] = float(snr_emva1288(mu_g, sensor, iso=exposure.iso,
                                                          exposure_time_s=exposure.exposure_time_s))
        if target_kind == "colorchecker":
            out["delta_e_mean"] = chart_delta_e_of_image(lin, masks)
        if target_kind == "slanted-edge" and "target" in masks:
            rr, cc = np.nonzero(masks["target"])
            try:
                f, m = mtf_slanted_edge(y[rr.min():rr.max() + 1, cc.min():cc.max() + 1])
                out["mtf50_cy_per_px"] = mtf50(f, m)
            except ValueError as exc:
                log.warning("MTF not measured: %s", exc)
    return {k: v for k, v in out.items() if v is not None and math.isfinite(v)}, masks
