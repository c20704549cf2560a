"""Demosaicing by name, through existing libraries.

:data:`DEMOSAICING_METHODS` maps a name to a function ``f(cfa, pattern) ->
(rows, cols, 3) float32`` taking a linear, black-subtracted mosaic.  Use
:func:`demosaic` to dispatch.

=====================  =============================================================
name                   implementation
=====================  =============================================================
``bilinear``           colour-demosaicing ``demosaicing_CFA_Bayer_bilinear``
``Malvar2004``         colour-demosaicing ``demosaicing_CFA_Bayer_Malvar2004`` [1]
``Menon2007``          colour-demosaicing ``demosaicing_CFA_Bayer_Menon2007`` [2]
``OpenCV-bilinear``    OpenCV ``cv2.COLOR_Bayer<PATTERN>2RGB``
``OpenCV-EA``          OpenCV edge-aware ``cv2.COLOR_Bayer<PATTERN>2RGB_EA``
``LibRaw-<ALG>``       LibRaw (rawpy) ``postprocess`` of a temporary DNG; ALG one of
                       AHD, AAHD, DCB, DHT, PPG, VNG, LINEAR
=====================  =============================================================

OpenCV naming trap: OpenCV's historic codes (``COLOR_BayerBG2RGB`` …) name the
pattern by the *second* row's second and third pixels, so an RGGB sensor is
``BayerBG`` in that scheme.  We use the explicit four-letter codes
(``COLOR_BayerRGGB2RGB``) that name the top-left 2×2 block, and a test checks
that a red patch comes out red.

References
----------
[1] Malvar, H. S., He, L.-W., Cutler, R. (2004). High-quality linear interpolation for
    demosaicing of Bayer-patterned color images. ICASSP 2004, iii-485.
[2] Menon, D., Andriani, S., Calvagno, G. (2007). Demosaicing with directional filtering
    and a posteriori decision. IEEE Trans. Image Process. 16(1), 132–141.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

from rigsim.errors import unknown_name_error
from rigsim.sensor.cfa import check_pattern


def demosaicing_bilinear(cfa: np.ndarray, pattern: str) -> np.ndarray:
    """Bilinear interpolation (colour-demosaicing)."""
    from colour_demosaicing import demosaicing_CFA_Bayer_bilinear

    return demosaicing_CFA_Bayer_bilinear(np.asarray(cfa, np.float64), check_pattern(pattern)).astype(np.float32)


def demosaicing_Malvar2004(cfa: np.ndarray, pattern: str) -> np.ndarray:
    """Malvar, He and Cutler (2004) gradient-corrected linear interpolation (colour-demosaicing)."""
    from colour_demosaicing import demosaicing_CFA_Bayer_Malvar2004

    return demosaicing_CFA_Bayer_Malvar2004(np.asarray(cfa, np.float64), check_pattern(pattern)).astype(np.float32)


def demosaicing_Menon2007(cfa: np.ndarray, pattern: str) -> np.ndarray:
    """Menon, Andriani and Calvagno (2007) DDFAPD (colour-demosaicing)."""
    from colour_demosaicing import demosaicing_CFA_Bayer_Menon2007

    return demosaicing_CFA_Bayer_Menon2007(np.asarray(cfa, np.float64), check_pattern(pattern)).astype(np.float32)


def _opencv(cfa: np.ndarray, pattern: str, suffix: str) -> np.ndarray:
    import cv2

    code = getattr(cv2, f"COLOR_Bayer{check_pattern(pattern)}2RGB{suffix}")
    cfa = np.asarray(cfa, np.float32)
    scale = max(float(cfa.max(initial=0.0)), 1e-12)
    u = np.clip(cfa, 0.0, None)
    u *= np.float32(65535.0 / scale)
    u += np.float32(0.5)
    rgb = cv2.cvtColor(u.astype(np.uint16), code)
    del u
    out = rgb.astype(np.float32)
    out *= np.float32(scale / 65535.0)
    return out


def demosaicing_OpenCV_bilinear(cfa: np.ndarray, pattern: str) -> np.ndarray:
    """OpenCV bilinear demosaicing (16-bit internally, ~1.5e-5 relative quantisation)."""
    return _opencv(cfa, pattern, "")


def demosaicing_OpenCV_EA(cfa: np.ndarray, pattern: str) -> np.ndarray:
    """OpenCV edge-aware demosaicing (16-bit internally)."""
    return _opencv(cfa, pattern, "_EA")


def _libraw(algorithm: str):
    def f(cfa: np.ndarray, pattern: str) -> np.ndarray:
        import rawpy

        from rigsim.sensor.dng import write_dng_bytes

        cfa = np.asarray(cfa, np.float32)
        scale = max(float(cfa.max(initial=0.0)), 1e-12)
        u16 = np.rint(np.clip(cfa / scale, 0, 1) * 65535.0).astype(np.uint16)
        data = write_dng_bytes(u16, cfa_pattern=pattern, black_level=0, white_level=65535,
                               as_shot_neutral=(1.0, 1.0, 1.0), color_matrix=np.eye(3))
        with tempfile.TemporaryDirectory() as d:
            p = Path(d) / "mosaic.dng"
            p.write_bytes(data)
            with rawpy.imread(str(p)) as raw:
                rgb = raw.postprocess(demosaic_algorithm=getattr(rawpy.DemosaicAlgorithm, algorithm),
                                      use_camera_wb=False, use_auto_wb=False, user_wb=[1, 1, 1, 1],
                                      output_color=rawpy.ColorSpace.raw, gamma=(1, 1),
                                      no_auto_bright=True, output_bps=16, user_flip=0,
                                      user_black=0, user_sat=65535)
        return rgb.astype(np.float32) * np.float32(scale / 65535.0)

    f.__name__ = f"demosaicing_LibRaw_{algorithm}"
    f.__doc__ = f"LibRaw {algorithm} demosaicing through rawpy on a temporary DNG (16-bit internally)."
    return f


#: Demosaicing methods by name.
DEMOSAICING_METHODS = {
    "bilinear": demosaicing_bilinear,
    "Malvar2004": demosaicing_Malvar2004,
    "Menon2007": demosaicing_Menon2007,
    "OpenCV-bilinear": demosaicing_OpenCV_bilinear,
    "OpenCV-EA": demosaicing_OpenCV_EA,
    **{f"LibRaw-{a}": _libraw(a) for a in ("AHD", "AAHD", "DCB", "DHT", "PPG", "VNG", "LINEAR")},
}


def demosaic(cfa: np.ndarray, pattern: str, method: str = "Malvar2004") -> np.ndarray:
    """Demosaic a linear mosaic with the method named ``method``.

    Parameters
    ----------
    cfa
        (rows, cols) linear mosaic (black level subtracted).
    pattern
        CFA pattern of the top-left 2×2 block (``RGGB``, ``BGGR``, ``GRBG``, ``GBRG``).
    method
        A key of :data:`DEMOSAICING_METHODS`.

    Returns
    -------
    ndarray
        (rows, cols, 3) float32 camera RGB.
    """
    try:
        f = DEMOSAICING_METHODS[method]
    except KeyError:
        raise unknown_name_error("demosaicing method", method, DEMOSAICING_METHODS, field="--demosaic") from None
    return f(cfa, pattern)
