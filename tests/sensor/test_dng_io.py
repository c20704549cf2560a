"""DNG writing (read back bit-exact by LibRaw) and reading real raw files into a Capture."""

from __future__ import annotations

import numpy as np
import pytest
import rawpy

from rigsim.errors import ConfigError
from rigsim.sensor import DevelopOptions, auto_exposure, capture, develop, load_sensor, read_raw, save_capture
from rigsim.sensor.cfa import CFA_PATTERNS
from rigsim.sensor.dng import read_dng_tags, write_dng

from .conftest import chart_image


@pytest.mark.parametrize("pattern", CFA_PATTERNS)
def test_dng_round_trip_bit_exact(tmp_path, pattern):
    raw = np.random.default_rng(3).integers(0, 16384, (66, 98)).astype(np.uint16)
    p = write_dng(tmp_path / "t.dng", raw, cfa_pattern=pattern, black_level=512, white_level=16383,
                  as_shot_neutral=(0.5, 1.0, 0.8), exposure_time_s=1 / 125, f_number=5.6, iso=400)
    with rawpy.imread(str(p)) as r:
        np.testing.assert_array_equal(r.raw_image, raw)
        assert r.raw_image.dtype == np.uint16
        assert "".join({0: "R", 1: "G", 2: "B", 3: "G"}[int(c)] for c in r.raw_pattern.ravel()) == pattern
        assert list(r.black_level_per_channel) == [512] * 4
        assert r.white_level == 16383
        wb = np.asarray(r.camera_whitebalance)[:3]
        np.testing.assert_allclose(wb / wb[1], [2.0, 1.0, 1.25], rtol=1e-6)
    tags = read_dng_tags(p)
    assert tags["exposure_time_s"] == pytest.approx(1 / 125) and tags["f_number"] == pytest.approx(5.6)
    assert tags["iso"] == 400


def test_capture_dng_reads_back_identically(tmp_path):
    s = load_sensor("canon_eos_5d_mark_ii")
    si = chart_image()
    cap = capture(si, s, auto_exposure(si, s), seed=5)
    paths = save_capture(cap, tmp_path)
    with rawpy.imread(str(paths["dng"])) as r:
        np.testing.assert_array_equal(r.raw_image, cap.raw)
        assert list(r.black_level_per_channel) == [1024] * 4 and r.white_level == s.white_level_dn
        np.testing.assert_allclose(np.asarray(r.color_matrix)[:3, :3], cap.ccm, atol=5e-4)
    back = read_raw(paths["dng"])
    np.testing.assert_array_equal(back.raw, cap.raw)
    assert back.cfa_pattern == cap.cfa_pattern and back.white_level == cap.white_level
    np.testing.assert_allclose(back.as_shot_neutral, cap.as_shot_neutral, rtol=1e-5)
    assert back.exposure.iso == cap.exposure.iso
    assert back.exposure.exposure_time_s == pytest.approx(cap.exposure.exposure_time_s, rel=1e-5)
    # the same processing on the file gives the same picture
    dev = develop(back, DevelopOptions(white_balance="as_shot"))
    np.testing.assert_allclose(dev.linear_rgb, cap.linear_rgb, atol=2e-3)
    for name in ("rgb.png", "linear.tiff", "capture.json"):
        assert (tmp_path / name).stat().st_size > 0


def test_libraw_postprocess_opens_the_dng(tmp_path):
    s = load_sensor("sony_ilce-7rm2")
    si = chart_image()
    cap = capture(si, s, auto_exposure(si, s), seed=2)
    p = save_capture(cap, tmp_path)["dng"]
    with rawpy.imread(str(p)) as r:
        rgb = r.postprocess(use_camera_wb=True, gamma=(1, 1), no_auto_bright=True, output_bps=16,
                            adjust_maximum_thr=0.0)
    ours = cap.linear_rgb.reshape(-1, 3).mean(axis=0)
    theirs = rgb.reshape(-1, 3).mean(axis=0) / 65535.0
    np.testing.assert_allclose(theirs, ours, rtol=0.03)


def test_unreadable_raw_files_give_clear_errors(tmp_path):
    with pytest.raises(ConfigError, match="file not found"):
        read_raw(tmp_path / "nope.NEF")
    txt = tmp_path / "notes.CR2"
    txt.write_text("not a raw file")
    with pytest.raises(ConfigError) as e:
        read_raw(txt)
    assert str(txt) in str(e.value) and "cannot read as a raw file" in str(e.value) and "allowed:" in str(e.value)
    good = write_dng(tmp_path / "g.dng", np.zeros((64, 64), np.uint16), cfa_pattern="RGGB", black_level=0,
                     white_level=4095)
    trunc = tmp_path / "truncated.dng"
    trunc.write_bytes(good.read_bytes()[:200])
    with pytest.raises(ConfigError, match="cannot read as a raw file"):
        read_raw(trunc)


def test_read_exif_of_non_tiff_and_missing_files(tmp_path):
    from rigsim.errors import ConfigError
    from rigsim.sensor.raw_io import read_exif

    cr3_like = tmp_path / "photo.cr3"
    cr3_like.write_bytes(b"\x00\x00\x00\x18ftypcrx " + bytes(64))   # ISO-BMFF, not TIFF
    assert read_exif(cr3_like) == {}
    with pytest.raises(ConfigError, match="cannot read the file's tags") as e:
        read_exif(tmp_path / "gone.arw")
    assert "gone.arw" in str(e.value)
