"""Raw file I/O: a Capture to DNG (and a capture folder), real raw files to a Capture.

:func:`read_raw` reads anything LibRaw (rawpy) reads — DNG, CR2/CR3, NEF, ARW … —
into the same :class:`~rigsim.sensor.pipeline.Capture` type the simulation makes,
so a real photo and a prediction are developed by the same code.
"""

from __future__ import annotations

import io
import json
import logging
import os
from pathlib import Path

import numpy as np

from rigsim.errors import ConfigError
from rigsim.fileio import atomic_write_bytes, atomic_write_text
from rigsim.sensor.cfa import pattern_from_codes
from rigsim.sensor.ccm import ccm_from_xyz_to_camera, xyz_to_camera_from_ccm
from rigsim.sensor.dng import read_dng_tags, write_dng
from rigsim.sensor.optics import Lens
from rigsim.sensor.pipeline import Capture, Exposure
from rigsim.sensor.white_balance import neutral_from_illuminant

log = logging.getLogger(__name__)

_RAW_ALLOWED = "a raw file LibRaw reads (DNG, CR2, CR3, NEF, ARW, RAF …) with a 2×2 Bayer CFA"


def save_dng(cap: Capture, path: str | Path) -> Path:
    """Write the raw mosaic of ``cap`` as a DNG (CFA, levels, AsShotNeutral, ColorMatrix1, exposure).

    ColorMatrix1 (D65) encodes the capture's CCM and, for a simulated sensor, its
    D65 neutral, so LibRaw develops it with the same colours.
    """
    if cap.sensor is not None:
        import colour

        wl = np.arange(400.0, 701.0, 5.0)
        d65 = colour.SDS_ILLUMINANTS["D65"]
        n = neutral_from_illuminant(cap.sensor, wl, np.interp(wl, d65.wavelengths, d65.values))
        gains_d65 = n[1] / n
    else:
        gains_d65 = np.ones(3) if cap.as_shot_neutral is None else \
            np.asarray(cap.as_shot_neutral)[1] / np.asarray(cap.as_shot_neutral)
    cm = xyz_to_camera_from_ccm(np.eye(3) if cap.ccm is None else cap.ccm, gains_d65)
    neutral = cap.as_shot_neutral if cap.as_shot_neutral is not None else \
        (np.asarray(cap.wb_gains)[1] / np.asarray(cap.wb_gains) if cap.wb_gains is not None else 1 / gains_d65)
    ex = cap.exposure
    # Make is "rigsim" on purpose: LibRaw replaces the colour matrix of cameras it knows
    # by make/model (its built-in Adobe table), which would ignore ColorMatrix1.
    return write_dng(path, cap.raw, cfa_pattern=cap.cfa_pattern, black_level=cap.black_level,
                     white_level=int(cap.white_level), as_shot_neutral=neutral, color_matrix=cm,
                     exposure_time_s=ex.exposure_time_s if ex else None,
                     f_number=ex.lens.f_number if ex else None, iso=ex.iso if ex else None,
                     make="rigsim", model=cap.camera or "simulated",
                     unique_camera_model=f"rigsim {cap.camera}")


def _ratio(v) -> float:
    if isinstance(v, tuple) and len(v) == 2:
        return float(v[0]) / float(v[1]) if v[1] else float("nan")
    if isinstance(v, tuple):
        v = v[0]
    return float(v)


def read_exif(path: str | Path) -> dict:
    """Make, model and exposure of a TIFF-based raw file (ARW, NEF, CR2, DNG, PEF …); {} otherwise.

    Keys (when present): ``make``, ``model``, ``exposure_time_s``, ``f_number``, ``iso``.
    """
    import tifffile

    out: dict = {}
    try:
        with tifffile.TiffFile(str(path)) as tf:
            tags = tf.pages[0].tags
            for code, key in ((271, "make"), (272, "model")):
                t = tags.get(code)
                if t is not None and isinstance(t.value, str) and t.value.strip():
                    out[key] = t.value.strip()
            exif = tags.get(34665)
            ex = exif.value if exif is not None and isinstance(exif.value, dict) else {}
            for name, key in (("ExposureTime", "exposure_time_s"), ("FNumber", "f_number"),
                              ("ISOSpeedRatings", "iso"), ("PhotographicSensitivity", "iso")):
                if name in ex and key not in out:
                    v = _ratio(ex[name])
                    if np.isfinite(v) and v > 0:
                        out[key] = v
    except tifffile.TiffFileError:  # not a TIFF container (CR3, RAF, CRW …): these have no TIFF tags
        return {}
    except OSError as exc:
        raise ConfigError(f"cannot read the file's tags: {exc.strerror or exc}", file=path) from None
    return out


def read_raw(path: str | Path) -> Capture:
    """Read a real (or rigsim) raw file into a :class:`Capture`.

    The visible area of the mosaic, per-site black levels, white level, the
    camera's as-shot white balance and its colour matrix (dcraw/Adobe
    ``rgb_xyz_matrix`` → CCM) are kept; exposure tags are read for DNG files.

    Raises
    ------
    ConfigError
        If the file is missing, not a raw file LibRaw can read, or not a 2×2 Bayer mosaic.
    """
    import rawpy

    path = Path(path)
    if not os.path.isfile(path):
        raise ConfigError("file not found", file=path, allowed=_RAW_ALLOWED)
    try:
        with rawpy.imread(str(path)) as r:
            colors = np.asarray(r.raw_colors_visible)
            desc = r.color_desc.decode(errors="replace")
            if r.num_colors != 3 or colors.ndim != 2 or desc not in ("RGBG", "RGGB") \
                    or np.asarray(r.raw_pattern).shape != (2, 2):
                raise ConfigError(f"unsupported colour filter array ({desc}, pattern shape "
                                  f"{np.asarray(r.raw_pattern).shape})", file=path, allowed=_RAW_ALLOWED)
            codes = colors[:2, :2]
            pattern = pattern_from_codes(np.where(codes == 3, 1, codes) if desc == "RGBG" else codes)
            raw = np.array(r.raw_image_visible, dtype=np.uint16, copy=True)
            bl_ch = np.asarray(r.black_level_per_channel, float)
            black = bl_ch[codes.ravel()]
            white = float(r.white_level)
            wb = np.asarray(r.camera_whitebalance, float)[:3]
            neutral = (wb[1] / wb) if np.all(wb > 0) else None
            # LibRaw's rgb_cam (``color_matrix``): white-balanced camera → linear sRGB, built
            # from the DNG ColorMatrix or its Adobe table; else from rgb_xyz_matrix the dcraw way
            rgb_cam = np.asarray(r.color_matrix, float)[:3, :3]
            xyz_cam = np.asarray(r.rgb_xyz_matrix, float)[:3]
            ccm = rgb_cam if np.any(rgb_cam) and np.all(np.isfinite(rgb_cam)) else \
                (ccm_from_xyz_to_camera(xyz_cam) if np.any(xyz_cam) else None)
            model = getattr(r, "camera_model", None)
    except ConfigError:
        raise
    except (rawpy.LibRawError, OSError, ValueError) as exc:
        why = "format not recognised" if isinstance(exc, (rawpy.LibRawFileUnsupportedError,
                                                         rawpy.LibRawIOError)) else str(exc)
        raise ConfigError(f"cannot read as a raw file: {why} ({type(exc).__name__})", file=path,
                          allowed=_RAW_ALLOWED) from None
    exposure = None
    tags = read_exif(path)
    if path.suffix.lower() == ".dng":
        import tifffile

        try:
            tags.update(read_dng_tags(path))
        except tifffile.TiffFileError as exc:
            # LibRaw read the file, but tifffile cannot parse its TIFF structure: the DNG-only
            # tags (exposure, UniqueCameraModel) are extras, the raw data and EXIF are read
            log.warning("%s: DNG tags not read (%s); using the EXIF tags", path, exc)
    if "exposure_time_s" in tags and "iso" in tags:
        exposure = Exposure(float(tags["exposure_time_s"]), float(tags["iso"]),
                            Lens(f_number=float(tags.get("f_number", 4.0))))
    make_model = " ".join(tags[k] for k in ("make", "model") if k in tags)
    camera = tags.get("unique_camera_model") or make_model or (str(model) if model else path.stem)
    return Capture(raw=raw, cfa_pattern=pattern, black_level=black, white_level=white,
                   exposure=exposure, camera=str(camera), as_shot_neutral=neutral, ccm=ccm,
                   meta={"source_file": str(path), "ccm_source": "file colour matrix" if ccm is not None
                         else "none (identity)"})


def save_capture(cap: Capture, out_dir: str | Path, *, extra: dict | None = None,
                 dng: bool = True) -> dict[str, Path]:
    """Write ``raw.dng`` (if ``dng``), ``rgb.png`` (8-bit sRGB), ``linear.tiff`` (float32 linear
    sRGB) and ``capture.json`` into ``out_dir`` (atomically); returns the paths."""
    import cv2
    import tifffile

    from rigsim.fileio import ensure_folder

    out = ensure_folder(out_dir)
    paths = {"dng": save_dng(cap, out / "raw.dng")} if dng else {}
    if cap.srgb is not None:
        ok, png = cv2.imencode(".png", np.ascontiguousarray(cap.srgb[..., ::-1]))
        if not ok:
            raise RuntimeError("PNG encoding failed")
        atomic_write_bytes(out / "rgb.png", png.tobytes())
        paths["png"] = out / "rgb.png"
    if cap.linear_rgb is not None:
        buf = io.BytesIO()
        tifffile.imwrite(buf, np.asarray(cap.linear_rgb, np.float32), photometric="rgb",
                         metadata={"description": "scene-linear sRGB (D65), white level = 1"})
        atomic_write_bytes(out / "linear.tiff", buf.getvalue())
        paths["linear"] = out / "linear.tiff"
    info = cap.describe()
    if extra:
        info.update(extra)
    atomic_write_text(out / "capture.json", json.dumps(info, indent=2, default=_json_default))
    paths["json"] = out / "capture.json"
    return paths


def _json_default(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        return o.item()
    if isinstance(o, Path):
        return str(o)
    return str(o)
