"""Write a raw CFA mosaic as a DNG file that LibRaw (rawpy) reads back bit-exact.

The DNG holds one uncompressed 16-bit CFA image in IFD0 (PhotometricInterpretation
32803 = CFA) with the tags a raw converter needs: CFARepeatPatternDim/CFAPattern,
BlackLevel (per CFA site), WhiteLevel, AsShotNeutral, ColorMatrix1 with
CalibrationIlluminant1, and the exposure (ExposureTime, FNumber, ISO).

References
----------
Adobe (2023). *Digital Negative (DNG) Specification*, version 1.7.1.0.
"""

from __future__ import annotations

import io
from fractions import Fraction
from pathlib import Path

import numpy as np

from rigsim.fileio import atomic_write_bytes
from rigsim.sensor.cfa import check_pattern, pattern_codes

#: EXIF LightSource codes for CalibrationIlluminant1.
CALIBRATION_ILLUMINANTS = {"A": 17, "D55": 20, "D65": 21, "D75": 22, "D50": 23}

_BYTE, _ASCII, _SHORT, _LONG, _RATIONAL, _SRATIONAL = 1, 2, 3, 4, 5, 10


def _rationals(values, signed=False):
    out = []
    for v in np.ravel(values):
        f = Fraction(float(v)).limit_denominator(1_000_000 if not signed else 100_000)
        num, den = f.numerator, f.denominator
        lim = 2 ** 31 - 1 if signed else 2 ** 32 - 1
        while abs(num) > lim or den > lim:
            num //= 2
            den = max(den // 2, 1)
        out += [num, den]
    return tuple(out)


def write_dng_bytes(raw: np.ndarray, *, cfa_pattern: str, black_level, white_level: int,
                    as_shot_neutral=(1.0, 1.0, 1.0), color_matrix=None,
                    calibration_illuminant: str = "D65", exposure_time_s: float | None = None,
                    f_number: float | None = None, iso: float | None = None,
                    make: str = "rigsim", model: str = "simulated sensor",
                    unique_camera_model: str | None = None) -> bytes:
    """Encode a CFA mosaic as DNG bytes.

    Parameters
    ----------
    raw
        (rows, cols) integer raw values (DN), stored as uint16.
    cfa_pattern
        Top-left 2×2 pattern, e.g. ``"RGGB"``.
    black_level
        Scalar or 4 values (per site of the 2×2 block, row-major), DN.
    white_level
        Saturation value (DN).
    as_shot_neutral
        Camera-native RGB of a neutral under the scene light (DNG AsShotNeutral), G = 1.
    color_matrix
        3×3 XYZ → camera-native matrix for ``calibration_illuminant`` (DNG ColorMatrix1);
        identity if ``None``.
    exposure_time_s, f_number, iso
        Exposure tags (omitted if ``None``).
    """
    import tifffile

    raw = np.asarray(raw)
    if raw.ndim != 2:
        raise ValueError(f"raw must be (rows, cols), got shape {raw.shape}")
    codes = pattern_codes(check_pattern(cfa_pattern))
    bl = np.broadcast_to(np.asarray(black_level, float).ravel(), (4,)) \
        if np.size(black_level) in (1, 4) else None
    if bl is None:
        raise ValueError("black_level must be a scalar or 4 values")
    cm = np.eye(3) if color_matrix is None else np.asarray(color_matrix, float)
    ucm = unique_camera_model or f"{make} {model}"
    tags = [
        (271, _ASCII, 0, make, True),
        (272, _ASCII, 0, model, True),
        (33421, _SHORT, 2, (2, 2), True),                       # CFARepeatPatternDim
        (33422, _BYTE, 4, tuple(int(c) for c in codes.ravel()), True),  # CFAPattern
        (50706, _BYTE, 4, (1, 4, 0, 0), True),                  # DNGVersion
        (50707, _BYTE, 4, (1, 1, 0, 0), True),                  # DNGBackwardVersion
        (50708, _ASCII, 0, ucm, True),                          # UniqueCameraModel
        (50710, _BYTE, 3, (0, 1, 2), True),                     # CFAPlaneColor
        (50711, _SHORT, 1, 1, True),                            # CFALayout: rectangular
        (50713, _SHORT, 2, (2, 2), True),                       # BlackLevelRepeatDim
        (50714, _RATIONAL, 4, _rationals(bl), True),            # BlackLevel
        (50717, _LONG, 1, int(white_level), True),              # WhiteLevel
        (50721, _SRATIONAL, 9, _rationals(cm, signed=True), True),  # ColorMatrix1
        (50728, _RATIONAL, 3, _rationals(as_shot_neutral), True),   # AsShotNeutral
        (50778, _SHORT, 1, CALIBRATION_ILLUMINANTS[calibration_illuminant], True),
    ]
    if exposure_time_s is not None:
        tags.append((33434, _RATIONAL, 1, _rationals([exposure_time_s]), True))
    if f_number is not None:
        tags.append((33437, _RATIONAL, 1, _rationals([f_number]), True))
    if iso is not None:
        tags.append((34855, _SHORT, 1, min(int(round(iso)), 65535), True))  # EXIF: 65535 means "or more"
    buf = io.BytesIO()
    tifffile.imwrite(buf, raw.astype(np.uint16), photometric=32803, compression=None,
                     planarconfig=None, subfiletype=0, extratags=tags, metadata=None)
    return buf.getvalue()


def write_dng(path: str | Path, raw: np.ndarray, **kwargs) -> Path:
    """Write :func:`write_dng_bytes` output atomically to ``path``."""
    path = Path(path)
    atomic_write_bytes(path, write_dng_bytes(raw, **kwargs))
    return path


def read_dng_tags(path: str | Path) -> dict:
    """Exposure and colour tags of a DNG written by :func:`write_dng` (read with tifffile)."""
    import tifffile

    out = {}
    with tifffile.TiffFile(str(path)) as tf:
        tags = tf.pages[0].tags
        names = {33434: "exposure_time_s", 33437: "f_number", 34855: "iso", 50728: "as_shot_neutral",
                 50721: "color_matrix", 50778: "calibration_illuminant", 50708: "unique_camera_model"}
        for code, name in names.items():
            t = tags.get(code)
            if t is None:
                continue
            v = t.value
            if isinstance(v, tuple) and t.dtype in (_RATIONAL, _SRATIONAL):
                v = [v[i] / v[i + 1] for i in range(0, len(v), 2)]
                if len(v) == 1:
                    v = v[0]
            out[name] = v
    if "color_matrix" in out:
        out["color_matrix"] = np.asarray(out["color_matrix"], float).reshape(3, 3)
    return out
