"""Demosaicing: PSNR on a known image above a floor per method; CFA naming."""

from __future__ import annotations

import numpy as np
import pytest

from rigsim.errors import ConfigError
from rigsim.sensor.cfa import CFA_PATTERNS, channel_map, mosaic, pattern_codes, pattern_from_codes, superpixel
from rigsim.sensor.demosaic import DEMOSAICING_METHODS, demosaic

# PSNR floors (dB) on the test image below, ~1.5 dB under the values measured when written
FLOORS = {"bilinear": 32.5, "Malvar2004": 34.0, "Menon2007": 35.0, "OpenCV-bilinear": 32.5,
          "OpenCV-EA": 33.5, "LibRaw-AHD": 36.5, "LibRaw-AAHD": 36.0, "LibRaw-DCB": 36.0,
          "LibRaw-DHT": 43.0, "LibRaw-PPG": 37.0, "LibRaw-VNG": 36.5, "LibRaw-LINEAR": 32.5}


def known_image(n=128):
    y, x = np.mgrid[0:n, 0:n] / n
    img = np.stack([0.5 + 0.4 * np.sin(2 * np.pi * (2 * x + y)), 0.5 + 0.4 * np.cos(2 * np.pi * 3 * y),
                    0.5 + 0.3 * np.sin(2 * np.pi * (x + 1.5 * y))], axis=-1)
    img[40:90, 30:100] *= 0.4  # sharp-edged box
    return img


def psnr(ref, out, border=4):
    a, b = ref[border:-border, border:-border], out[border:-border, border:-border]
    return 10 * np.log10(1.0 / np.mean((a - b) ** 2))


def test_every_method_has_a_floor():
    assert set(FLOORS) == set(DEMOSAICING_METHODS)


@pytest.mark.parametrize("method", list(DEMOSAICING_METHODS))
@pytest.mark.parametrize("pattern", ["RGGB", "GBRG"])
def test_psnr_floor(method, pattern):
    img = known_image()
    out = demosaic(mosaic(img, pattern), pattern, method)
    assert out.shape == img.shape and out.dtype == np.float32
    assert psnr(img, out) > FLOORS[method]


def test_malvar_beats_bilinear():
    img = known_image()
    m = mosaic(img, "RGGB")
    assert psnr(img, demosaic(m, "RGGB", "Malvar2004")) > psnr(img, demosaic(m, "RGGB", "bilinear")) + 1.0


@pytest.mark.parametrize("method", ["OpenCV-bilinear", "OpenCV-EA", "Malvar2004", "LibRaw-AHD"])
@pytest.mark.parametrize("pattern", CFA_PATTERNS)
def test_red_stays_red(method, pattern):
    """Guards OpenCV's Bayer naming trap (and any pattern mix-up)."""
    red = np.zeros((32, 32, 3))
    red[..., 0] = 0.8
    out = demosaic(mosaic(red, pattern), pattern, method)[16, 16]
    assert out[0] == pytest.approx(0.8, abs=1e-3) and abs(out[1]) < 1e-3 and abs(out[2]) < 1e-3


def test_opencv_legacy_codes_are_the_trap():
    import cv2

    red = np.zeros((16, 16, 3))
    red[..., 0] = 1
    m = (mosaic(red, "RGGB") * 60000).astype(np.uint16)
    assert cv2.cvtColor(m, cv2.COLOR_BayerRG2RGB)[8, 8, 2] == 60000      # legacy name: swapped
    assert cv2.cvtColor(m, cv2.COLOR_BayerRGGB2RGB)[8, 8, 0] == 60000    # explicit name: right


def test_unknown_method():
    with pytest.raises(ConfigError, match="did you mean 'Malvar2004'"):
        demosaic(np.zeros((4, 4)), "RGGB", "malvar2004")


def test_cfa_helpers():
    assert pattern_codes("GRBG").tolist() == [[1, 0], [2, 1]]
    assert pattern_from_codes([[0, 1], [3, 2]]) == "RGGB"
    cm = channel_map("BGGR", (3, 5))
    assert cm.tolist() == [[2, 1, 2, 1, 2], [1, 0, 1, 0, 1], [2, 1, 2, 1, 2]]
    img = np.random.default_rng(0).random((6, 8, 3))
    sp = superpixel(mosaic(img, "RGGB"), "RGGB")
    assert sp.shape == (3, 4, 3)
    assert sp[0, 0, 0] == pytest.approx(img[0, 0, 0]) and sp[0, 0, 2] == pytest.approx(img[1, 1, 2])
    with pytest.raises(ConfigError, match="unsupported CFA pattern"):
        pattern_codes("RGBW")


@pytest.mark.parametrize("pattern", CFA_PATTERNS)
@pytest.mark.parametrize("shape", [(6, 8), (5, 7), (1, 1)])
@pytest.mark.parametrize("dtype", [np.float32, np.float64, np.uint16])
def test_mosaic_is_colour_demosaicing_and_sampling(pattern, shape, dtype):
    from colour_demosaicing import masks_CFA_Bayer, mosaicing_CFA_Bayer

    rng = np.random.default_rng(7)
    rgb = (rng.random((*shape, 3)) * 4000).astype(dtype)
    out = mosaic(rgb, pattern.lower())
    assert out.dtype == rgb.dtype and out.shape == shape
    assert np.array_equal(out, mosaicing_CFA_Bayer(rgb, pattern))      # exactly colour-demosaicing's
    codes = pattern_codes(pattern)                                      # and plain CFA sampling
    for dy in (0, 1):
        for dx in (0, 1):
            assert np.array_equal(out[dy::2, dx::2], rgb[dy::2, dx::2, codes[dy, dx]])
    # colour-demosaicing's masks name the same sites as our channel map
    cmap = channel_map(pattern, shape)
    for c, m in enumerate(masks_CFA_Bayer(shape, pattern)):
        assert np.array_equal(m, cmap == c)


def test_mosaic_rejects_bad_input():
    with pytest.raises(ConfigError, match="CFA pattern"):
        mosaic(np.zeros((2, 2, 3)), "RGBG")
    with pytest.raises(ValueError, match="rows, cols, 3"):
        mosaic(np.zeros((2, 2)), "RGGB")
