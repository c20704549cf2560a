"""One case of a study: build the scene, render it once, capture it with every sensor, measure.

Metrics per sensor (columns of ``results.csv``):

``contrast_radiance``
    Michelson contrast of the target from the noise-free scene radiance (photopic
    luminance, CIE 1931 ȳ), sensor-independent: ColorChecker white (patch 19) against
    black (patch 24); black/white disk against the surrounding water; slanted edge
    white against black.
``contrast_image``
    The same from the developed image (linear sRGB luminance) of that sensor.
``snr_white``
    Temporal SNR of the sensor (EMVA 1288 model, green channel) at the mean signal of the
    white patch (chart), the water around the disk, or the white half — the sensor's noise,
    not the Monte Carlo noise of the render.
``snr_white_image``
    Mean/σ of the developed luminance over the same pixels (includes render noise and any
    texture; for reference).
``delta_e_mean``
    Mean ΔE2000 of the 24 patches (chart only) against the chart under D65 in air,
    after the study's white balance and the sensor's colour correction; the image is
    scaled so the white patch has the reference luminance (exposure is not colour).
``backscatter_share``
    Share of the target pixels' radiance that is light scattered by the water
    without reaching a surface (ground-truth split).
``mtf50_cy_per_px``
    Slanted edge only: ISO 12233 MTF50 of the developed luminance.
"""

from __future__ import annotations

import io
import logging

import numpy as np

from rigsim.study.spec import Case, StudySpec, sensor_key

log = logging.getLogger(__name__)

__all__ = ["compute_case", "target_masks", "photopic_luminance"]


def photopic_luminance(spectral: np.ndarray, wavelength_nm: np.ndarray, bandwidth_nm: np.ndarray) -> np.ndarray:
    """Relative photopic luminance ∑ X(λ) ȳ(λ) Δλ of a spectral array (..., bands) (CIE 1931 2°)."""
    import colour

    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    ybar = np.interp(wavelength_nm, cmfs.wavelengths, cmfs.values[:, 1])
    return np.asarray(spectral, float) @ (ybar * bandwidth_nm)


def _erode(mask: np.ndarray, px: int) -> np.ndarray:
    import cv2

    if px <= 0:
        return mask
    k = np.ones((2 * px + 1, 2 * px + 1), np.uint8)
    out = cv2.erode(mask.astype(np.uint8), k).astype(bool)
    return out if out.sum() >= 4 else mask


def _dilate(mask: np.ndarray, px: int) -> np.ndarray:
    import cv2

    k = np.ones((2 * px + 1, 2 * px + 1), np.uint8)
    return cv2.dilate(mask.astype(np.uint8), k).astype(bool)


def target_masks(object_id: np.ndarray, legend: dict[str, str], target_kind: str) -> dict[str, np.ndarray]:
    """Pixel masks of the parts of a target, from the render's object-id layer.

    Returns keys among ``target`` (the whole target), ``signal``/``reference`` (the two
    regions whose contrast is measured), ``patch:<name>`` (chart patches, eroded by a
    pixel to avoid mixed edge pixels).
    """
    by_name = {}
    for k, label in legend.items():
        name = label.split(": ", 1)[-1]
        by_name[name] = object_id == int(k)
    out: dict[str, np.ndarray] = {}
    target = object_id > 0
    out["target"] = target
    if target_kind == "colorchecker":
        names = [n for n in by_name if n != "chart"]
        for n in names:
            out[f"patch:{n}"] = _erode(by_name[n], 1)
        white = next((n for n in names if n.startswith("white")), None)
        black = next((n for n in names if n.startswith("black")), None)
        if white and black:
            out["signal"], out["reference"] = out[f"patch:{white}"], out[f"patch:{black}"]
    elif target_kind in ("black-disk", "white-disk"):
        disk = by_name.get("disk", target)
        r = max(2, int(np.sqrt(disk.sum() / np.pi)))
        ring = _dilate(disk, r) & ~_dilate(disk, 2) & (object_id == 0)
        out["signal"], out["reference"] = _erode(disk, 1), ring
    elif target_kind == "slanted-edge":
        out["signal"], out["reference"] = _erode(by_name["white"], 2), _erode(by_name["black"], 2)
    return {k: v for k, v in out.items() if v.any()}


def _png_bytes(rgb8: np.ndarray) -> bytes:
    import imageio.v3 as iio

    buf = io.BytesIO()
    iio.imwrite(buf, rgb8, extension=".png")
    return buf.getvalue()


def _chart_delta_e(lin: np.ndarray, masks: dict[str, np.ndarray]) -> float:
    import colour

    from rigsim.scene.targets import reflectance_colorchecker_Ohta
    from rigsim.metrics.color import chart_delta_e

    refl = reflectance_colorchecker_Ohta(np.arange(380.0, 781.0, 5.0))
    names = [n for n in refl if f"patch:{n}" in masks]
    if len(names) < 24:
        return float("nan")
    illum = colour.SDS_ILLUMINANTS["D65"]
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    ref = np.array([colour.sd_to_XYZ(colour.SpectralDistribution(dict(zip(np.arange(380.0, 781.0, 5.0), refl[n]))),
                                     cmfs, illum) / 100.0 for n in names])
    meas_rgb = np.array([lin[masks[f"patch:{n}"]].mean(axis=0) for n in names])
    meas = colour.RGB_to_XYZ(meas_rgb, colour.RGB_COLOURSPACES["sRGB"], apply_cctf_decoding=False)
    wi = next(i for i, n in enumerate(names) if n.startswith("white"))
    if meas[wi, 1] <= 0:
        return float("nan")
    meas = meas * (ref[wi, 1] / meas[wi, 1])
    mean, _ = chart_delta_e(ref, meas)
    return mean


def compute_case(spec: StudySpec, case: Case) -> dict:
    """Render one scene and capture it with every sensor of the study.

    Returns ``{"rows": [...], "files": {name: bytes}, "meta": {...}}`` (see the runner).
    """
    from rigsim.config.rig import load_rig
    from rigsim.config.water import load_water
    from rigsim.metrics.contrast import backscatter_share, contrast_michelson, luminance, patch_snr
    from rigsim.metrics.mtf import mtf50, mtf_slanted_edge
    from rigsim.scene.build import build_scene
    from rigsim.sensor import load_sensor
    from rigsim.sensor.optics import Lens
    from rigsim.sensor.pipeline import DevelopOptions, Exposure, auto_exposure, capture

    rig = load_rig(case.rig)
    water = load_water(case.water)
    target_kind = case.target if not case.target.lower().endswith((".obj", ".ply")) else "mesh"
    size_m = None
    if case.target_fill is not None:
        from rigsim.render.camera import fov_water_deg

        size_m = case.target_fill * 2 * case.distance_m * np.tan(np.radians(fov_water_deg(rig.camera)) / 2)
    scene = build_scene(rig, water, case.target, case.distance_m, size_m=size_m)
    seed = spec.case_seed(case)
    rs = spec.render
    if rs.engine == "preview":
        from rigsim.preview import render_preview as _render

        si = _render(scene, width=rs.width, height=rs.height, wavelengths_nm=rs.wavelengths_nm,
                     layers=("range_m", "object_id", "backscatter"))
    else:
        from rigsim.render import render as _render

        si = _render(scene, width=rs.width, height=rs.height, spp=rs.spp, seed=seed,
                     wavelengths_nm=rs.wavelengths_nm, layers=("range_m", "object_id", "backscatter"))
    wl, bw = np.asarray(si.wavelength_nm), np.asarray(si.bandwidth_nm)
    masks = target_masks(np.asarray(si.layers["object_id"]), si.meta.get("object_ids", {}), target_kind)
    has_flash = "flash" in si.layers
    base = {"rig": case.rig_name, "water": case.water_name, "target": target_kind if target_kind != "mesh"
            else case.target, "distance_m": case.distance_m, "depth_m": case.depth_m,
            "c_550_per_m": float(water.c_per_m(550.0)), "b_550_per_m": float(water.b_per_m(550.0)),
            "a_550_per_m": float(water.a_per_m(550.0)),
            "width": rs.width, "height": rs.height, "spp": rs.spp if rs.engine != "preview" else None,
            "engine": rs.engine, "case_id": spec.case_id(case)}

    # sensor-independent: noise-free radiant exposure (strobes: one flash at full power; continuous: 1 s)
    h_total = si.radiant_exposure(1.0)
    lum = photopic_luminance(h_total, wl, bw)
    if "signal" in masks and "reference" in masks:
        base["contrast_radiance"] = float(contrast_michelson(lum[masks["signal"]].mean(),
                                                             lum[masks["reference"]].mean()))
    if ("backscatter" in si.layers or "flash_backscatter" in si.layers) and "target" in masks:
        base["backscatter_share"] = backscatter_share(si.radiant_exposure(1.0, "backscatter"), h_total,
                                                      masks["target"])
    files = {}
    rows = []
    for sname in spec.sensors:
        sensor = load_sensor(sname)
        lens = Lens(f_number=rig.camera.f_number)
        cs = spec.capture
        if cs.exposure == "auto":
            # spot-meter the chart (its white patch lands at the target level); whole frame otherwise
            meter = masks.get("target") if target_kind == "colorchecker" else None
            ex = auto_exposure(si, sensor, lens=lens, iso=cs.iso if cs.iso >= sensor.base_iso else None,
                               percentile=cs.target_percentile, target=cs.target_level, mask=meter)
        else:
            ex = Exposure(cs.shutter_s, cs.iso, lens)
        wb, wb_kw = cs.white_balance, {}
        if wb == "auto":
            gray = next((k for k in masks if k.startswith("patch:neutral 5")), None)
            wb, wb_kw = ("chart", {"mask": masks[gray]}) if gray and masks[gray].sum() >= 4 else ("grayworld", {})
        cap = capture(si, sensor, ex, seed=seed, develop=DevelopOptions(demosaic=cs.demosaic, white_balance=wb,
                                                                       wb_kwargs=wb_kw))
        lin = np.asarray(cap.linear_rgb, float)
        if lin.shape[:2] != lum.shape:
            raise RuntimeError("capture resampled the image; studies keep the render's grid")
        y = luminance(lin)
        row = dict(base)
        skey = sensor_key(sname)
        row.update({"sensor": skey, "iso": ex.iso, "exposure_time_s": ex.exposure_time_s,
                    "f_number": lens.f_number, "flash_scale": ex.flash_scale if has_flash else None,
                    "raw_saturated_fraction": float(np.mean(cap.raw >= cap.white_level)),
                    "white_balance": wb, "target_size_m": scene.targets[0].size_m})
        if "signal" in masks and "reference" in masks:
            row["contrast_image"] = float(contrast_michelson(y[masks["signal"]].mean(), y[masks["reference"]].mean()))
            snr_region = masks["signal"] if target_kind in ("colorchecker", "slanted-edge") else masks["reference"]
            if snr_region.sum() >= 4:
                from rigsim.sensor.noise import snr_emva1288
                from rigsim.sensor.pipeline import mean_electrons_rgb

                mu_g = float(mean_electrons_rgb(si, sensor, ex)[..., 1][snr_region].mean())
                row["snr_white"] = float(snr_emva1288(mu_g, sensor, iso=ex.iso, exposure_time_s=ex.exposure_time_s))
                row["snr_white_image"] = float(patch_snr(y, snr_region))
        if target_kind == "colorchecker":
            row["delta_e_mean"] = _chart_delta_e(lin, masks)
        if target_kind == "slanted-edge" and "target" in masks:
            rr, cc = np.nonzero(masks["target"])
            roi = y[rr.min():rr.max() + 1, cc.min():cc.max() + 1]
            try:
                f, m = mtf_slanted_edge(roi)
                row["mtf50_cy_per_px"] = mtf50(f, m)
            except ValueError as exc:
                log.warning("MTF not measured: %s", exc)
        rows.append(row)
        files[f"{skey}.png"] = _png_bytes(cap.srgb)
    return {"rows": rows, "files": files, "meta": {"render_wall_time_s": si.meta.get("wall_time_s"),
                                                    "seed": seed}}
