"""One lens from rig to capture: a render photographed through the CLI and through a study with the
same settings gives the same raw file (the rig's f-number reaches the sensor in both ways; until
2026-12 ``rigsim capture`` used f/4 whatever the rig said, two stops from a study's f/8)."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import tifffile

from rigsim.config.rig import load_rig
from rigsim.study import load_study, run_study

ROOT = Path(__file__).resolve().parents[2]
RIG = ROOT / "rigs" / "twin-strobes-45-wide.toml"

STUDY = f"""
[study]
name = "one-lens"
seed = 11

[sweep]
rigs = ["{RIG}"]
sensors = ["sony_ilce-7rm2"]
waters = ["clear"]
distances_m = [1.5]
targets = ["colorchecker"]
target_fill = 0.4
extend_visibility = false

[render]
engine = "preview"
width = 48
height = 32
wavelengths = "400:700:20"

[capture]
exposure = "manual"
shutter_s = 0.004
iso = 200
white_balance = "grayworld"
save_raw = true
"""


def _cli(*args) -> subprocess.CompletedProcess:
    r = subprocess.run([sys.executable, "-m", "rigsim.cli", *map(str, args)], capture_output=True, text=True,
                       cwd=ROOT)
    assert r.returncode == 0, r.stderr
    return r


def _raw(path: Path) -> np.ndarray:
    with tifffile.TiffFile(path) as t:
        return max(t.pages, key=lambda p: p.shape[0] * p.shape[1] if len(p.shape) >= 2 else 0).asarray()


def test_cli_capture_and_study_give_the_same_raw(tmp_path):
    assert load_rig(RIG).camera.f_number == 8.0
    spec_path = tmp_path / "study.toml"
    spec_path.write_text(STUDY)
    out = run_study(load_study(spec_path), tmp_path / "study", serial=True, progress=False)
    (row,) = list(csv.DictReader((out / "results.csv").open()))
    (case_dir,) = [p for p in (out / "cases").iterdir() if p.is_dir()]
    seed = json.loads((case_dir / "result.json").read_text())["meta"]["seed"]
    study_raw = _raw(case_dir / "sony_ilce-7rm2.dng")
    # the same scene through the command line: render, then capture with the study's settings
    _cli("render", RIG, "--engine", "preview", "--water", "clear", "--distance", 1.5, "--target", "colorchecker",
         "--target-size", row["target_size_m"], "--size", "48x32", "--wavelengths", "400:700:20",
         "--seed", seed, "--out", tmp_path / "r")  # (the seed of the multiply scattered light's photons)
    _cli("capture", tmp_path / "r", "--sensor", "sony_ilce-7rm2", "--shutter", 0.004, "--iso", 200,
         "--wb", "grayworld", "--seed", seed, "--out", tmp_path / "c")
    cli_raw = _raw(tmp_path / "c" / "raw.dng")
    assert cli_raw.shape == study_raw.shape
    np.testing.assert_array_equal(cli_raw, study_raw)
    record = json.loads((tmp_path / "c" / "capture.json").read_text())
    assert record["exposure"]["f_number"] == 8.0 and record["exposure"]["f_number_source"] == "camera"
    assert float(row["f_number"]) == 8.0
    # an explicit override is used and stated
    _cli("capture", tmp_path / "r", "--sensor", "sony_ilce-7rm2", "--shutter", 0.004, "--iso", 200,
         "--wb", "grayworld", "--seed", seed, "--f-number", 4, "--out", tmp_path / "c4")
    rec4 = json.loads((tmp_path / "c4" / "capture.json").read_text())
    assert rec4["exposure"]["f_number"] == 4.0 and rec4["exposure"]["f_number_source"] == "override"
    # two stops more light: 4× the signal above black where neither is clipped
    black = float(np.mean(record["black_level"]))
    raw4 = _raw(tmp_path / "c4" / "raw.dng").astype(float)
    ok = raw4 < 0.9 * record["white_level"]
    ratio = np.median((raw4[ok] - black) / np.maximum(cli_raw[ok] - black, 1.0))
    assert 3.6 < ratio < 4.4, ratio
