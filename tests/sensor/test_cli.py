"""``rigsim capture`` / ``rigsim develop`` end to end (through rigsim.cli.main)."""

from __future__ import annotations

import json

import numpy as np
import pytest


from .conftest import PATCH, chart_image


def test_capture_then_develop(tmp_path, run):
    render = chart_image().save(tmp_path / "render")
    box = f"{3 * PATCH + 4},{4 * PATCH - 4},{2 * PATCH + 4},{3 * PATCH - 4}"
    code, out, err = run("capture", render, "--sensor", "sony_ilce-7rm2", "--auto-exposure", "--wb", "chart",
                         "--wb-box", box, "--demosaic", "Menon2007", "--seed", 3, "--out", tmp_path / "cap")
    assert code == 0, err
    for f in ("raw.dng", "rgb.png", "linear.tiff", "capture.json"):
        assert (tmp_path / "cap" / f).is_file()
    info = json.loads((tmp_path / "cap" / "capture.json").read_text())
    assert info["sensor"]["name"] == "Sony ILCE-7RM2" and info["seed"] == 3
    assert info["develop"]["demosaic"] == "Menon2007" and info["exposure"]["iso"] == 100

    code, out, err = run("develop", tmp_path / "cap" / "raw.dng", "--wb", "chart", "--wb-box", box,
                         "--demosaic", "Menon2007", "--out", tmp_path / "dev")
    assert code == 0, err
    import cv2

    a = cv2.imread(str(tmp_path / "cap" / "rgb.png"))
    b = cv2.imread(str(tmp_path / "dev" / "rgb.png"))
    assert a.shape == b.shape
    # same raw, same processing; the CCM comes back from the DNG's ColorMatrix1 (rationals)
    assert np.abs(a.astype(int) - b.astype(int)).max() <= 1


@pytest.mark.parametrize("args, needle", [
    (["--sensor", "nope", "--auto-exposure"], "unknown sensor 'nope'"),
    (["--sensor", "nikon_d5100"], "give exactly one of --shutter and --auto-exposure"),
    (["--sensor", "nikon_d5100", "--shutter", "1/x"], "cannot read shutter time"),
    (["--sensor", "nikon_d5100", "--auto-exposure", "--wb", "chart"], "--wb-box"),
    (["--sensor", "nikon_d5100", "--auto-exposure", "--demosaic", "AHD"], "unknown demosaicing method"),
    (["--sensor", "nikon_d5100", "--shutter", "0.01", "--iso", "10"], "below the sensor's lowest ISO"),
])
def test_capture_errors_are_one_line(tmp_path, run, args, needle):
    render = chart_image().save(tmp_path / "render")
    code, out, err = run("capture", render, *args, "--out", tmp_path / "o")
    assert code == 2 and needle in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def test_develop_unreadable_file(tmp_path, run):
    bad = tmp_path / "photo.NEF"
    bad.write_bytes(b"\x00" * 1000)
    code, out, err = run("develop", bad)
    assert code == 2 and "cannot read as a raw file" in err and str(bad) in err
