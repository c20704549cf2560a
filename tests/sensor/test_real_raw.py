"""A real camera raw file (Sony A7R III ARW, fetched from PyPI) through rigsim's own development.

The photo comes from a package archive on PyPI (:mod:`rigsim.sensor.samples`);
``bash tools/setup.sh test`` downloads it once before the tests.  Without network the
tests fail with the download error, unless ``RIGSIM_OFFLINE=1`` says the machine is
offline on purpose (then they are skipped, with that reason).

What is checked: the mosaic, CFA, levels, make/model and exposure read from the file
against the values LibRaw and the file's EXIF give; the development (as-shot white
balance, the file's colour matrix, demosaicing, sRGB) against LibRaw's own development
of the same file with the same choices (linear sRGB, camera white balance, no auto
brightness): block means agree within 5 % per channel and correlate above 0.999.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

from rigsim.errors import ConfigError
from rigsim.sensor import DevelopOptions, develop, read_raw
from rigsim.sensor.samples import SAMPLE_RAWS, fetch_sample_raw


@pytest.fixture(scope="module")
def arw():
    try:
        return fetch_sample_raw("sony-ilce-7rm3")
    except ConfigError as exc:
        if os.environ.get("RIGSIM_OFFLINE") == "1":
            pytest.skip(f"RIGSIM_OFFLINE=1 and the sample raw file is not cached: {exc}")
        raise


def _blocks(x: np.ndarray, f: int = 16) -> np.ndarray:
    h, w = x.shape[0] // f * f, x.shape[1] // f * f
    return x[:h, :w].reshape(h // f, f, w // f, f, 3).mean(axis=(1, 3))


def test_sample_registry_names_source_and_checksums():
    s = SAMPLE_RAWS["sony-ilce-7rm3"]
    assert s.archive_url.startswith("https://files.pythonhosted.org/")
    assert len(s.sha256) == 64 and len(s.archive_sha256) == 64 and "MIT" in s.licence


def test_unknown_sample_is_a_clear_error():
    with pytest.raises(ConfigError, match="unknown sample raw file 'sony'.*allowed: sony-ilce-7rm3"):
        fetch_sample_raw("sony")


def test_real_arw_reads_into_a_capture(arw):
    import rawpy

    cap = read_raw(arw)
    with rawpy.imread(str(arw)) as r:
        np.testing.assert_array_equal(cap.raw, r.raw_image_visible)
        assert cap.black_level.tolist() == [512.0] * 4 == list(r.black_level_per_channel)
        assert cap.white_level == r.white_level == 16383
    assert cap.cfa_pattern == "RGGB" and cap.raw.shape == (3464, 5184)
    assert cap.camera == "SONY ILCE-7RM3"
    assert cap.exposure.exposure_time_s == pytest.approx(1 / 640) and cap.exposure.iso == 3200
    assert cap.exposure.lens.f_number == pytest.approx(6.3)
    assert cap.meta["ccm_source"] == "file colour matrix"
    # LibRaw's camera white balance (R, G, B multipliers 2528:1024:1564) as the as-shot neutral
    np.testing.assert_allclose(cap.as_shot_neutral, [1024 / 2528, 1.0, 1024 / 1564], rtol=1e-6)


def test_real_arw_develops_like_libraw(arw):
    import rawpy

    cap = develop(read_raw(arw), DevelopOptions(demosaic="OpenCV-EA", white_balance="as_shot"))
    ours = np.asarray(cap.linear_rgb, float)
    assert ours.shape == (3464, 5184, 3) and np.isfinite(ours).all()
    srgb = np.asarray(cap.srgb)
    assert srgb.dtype == np.uint8 and srgb.shape == ours.shape and 5 < srgb.mean() < 250
    with rawpy.imread(str(arw)) as r:
        ref = r.postprocess(use_camera_wb=True, no_auto_bright=True, gamma=(1, 1), output_bps=16,
                            output_color=rawpy.ColorSpace.sRGB, user_flip=0,
                            demosaic_algorithm=rawpy.DemosaicAlgorithm.LINEAR).astype(float) / 65535.0
    # LibRaw's integer output clips negative (out-of-gamut) values: compare clipped images
    a, b = _blocks(np.clip(ours, 0.0, 1.0)), _blocks(ref)
    np.testing.assert_allclose(a.mean(axis=(0, 1)), b.mean(axis=(0, 1)), rtol=0.05)
    for c in range(3):
        assert np.corrcoef(a[..., c].ravel(), b[..., c].ravel())[0, 1] > 0.999, c


def test_cli_develops_the_real_photo(run, arw, tmp_path):
    import imageio.v3 as iio
    import json

    code, out, err = run("develop", arw, "--demosaic", "OpenCV-EA", "--out", tmp_path / "dev")
    assert code == 0, err
    assert "SONY ILCE-7RM3" in out
    rgb = iio.imread(tmp_path / "dev" / "rgb.png")
    assert rgb.shape[:2] == (3464, 5184)
    meta = json.loads((tmp_path / "dev" / "capture.json").read_text())
    assert meta["camera"] == "SONY ILCE-7RM3" and meta["develop"]["white_balance"] == "as_shot"
