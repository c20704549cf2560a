"""``rigsim render``: every promised output, readable, with units and inputs in meta.json."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


def run(*args):
    return subprocess.run([sys.executable, "-m", "rigsim.cli", *args], capture_output=True, text=True,
                          timeout=300, cwd=ROOT)


@pytest.mark.render
def test_render_writes_everything(tmp_path):
    out = tmp_path / "r"
    r = run("render", "rigs/twin-strobes-45-wide.toml", "--water", "coastal", "--distance", "1.5",
            "--target", "colorchecker", "--size", "36x24", "--spp", "4", "--seed", "2", "--out", str(out))
    assert r.returncode == 0, r.stderr
    for f in ("spectral.exr", "spectral.npz", "preview.png", "clear.png", "object_id.png", "range_m.exr",
              "meta.json"):
        assert (out / f).is_file(), f
    meta = json.loads((out / "meta.json").read_text())
    assert meta["inputs"]["distance_m"] == 1.5 and meta["spp"] == 4 and meta["seed"] == 2
    assert meta["wall_time_s"] > 0 and len(meta["wavelength_nm"]) == 31
    assert meta["preview_png"]["observer"] == "CIE 1931 2 degree"
    from rigsim.spectral_image import SpectralImage

    si = SpectralImage.load(out)
    assert si.radiance.shape == (24, 36, 31) and "flash" in si.layers
    rng = si.layers["range_m"]
    centre = rng[12, 18]
    assert 1.4 < centre < 1.6  # the chart at 1.5 m on the axis
    from rigsim.render.variant import mitsuba  # never switch the process's variant in a test

    mi, _ = mitsuba()
    bmp = np.array(mi.Bitmap(str(out / "spectral.exr")))
    np.testing.assert_allclose(bmp, si.layers["flash"], rtol=1e-6)


def test_render_bad_input_is_one_line(tmp_path):
    r = run("render", "rigs/twin-strobes-45-wide.toml", "--water", "coastal", "--distance", "-1",
            "--out", str(tmp_path / "x"))
    assert r.returncode == 2 and "behind the camera" in r.stderr and r.stderr.strip().count("\n") == 0
    r = run("render", "rigs/nope.toml", "--water", "coastal", "--distance", "1", "--out", str(tmp_path / "x"))
    assert r.returncode == 2 and "file not found" in r.stderr
    r = run("render", "rigs/twin-strobes-45-wide.toml", "--water", "coastal", "--distance", "1", "--size", "10by4",
            "--out", str(tmp_path / "x"))
    assert r.returncode == 2 and "--size" in r.stderr


@pytest.mark.render
def test_render_noise_target(tmp_path):
    """--noise-target renders batches of --spp until the noise is met or --max-spp is reached."""
    out = tmp_path / "n"
    r = run("render", "rigs/twin-strobes-45-wide.toml", "--water", "coastal", "--distance", "1.5",
            "--size", "24x16", "--spp", "2", "--noise-target", "1e-6", "--max-spp", "6", "--out", str(out))
    assert r.returncode == 0, r.stderr
    meta = json.loads((out / "meta.json").read_text())
    assert meta["spp_per_pass"]["strobe:full"] == 6 and meta["inputs"]["noise_target"] == 1e-6
    assert meta["noise_p99"]["strobe:full"] > 1e-6
    r = run("render", "rigs/twin-strobes-45-wide.toml", "--water", "coastal", "--distance", "1.5",
            "--noise-target", "0", "--out", str(tmp_path / "x"))
    assert r.returncode == 2 and "noise_target" in r.stderr and r.stderr.strip().count("\n") == 0
