"""Seabed samples: rocks lie partly buried in the sand and charts stand on it, the rig looks down at
it, the seabed is in the instance mask but not in COCO; the fast engine's seabed image against Monte
Carlo; a bad [seabed] table fails before rendering."""

from __future__ import annotations

import json
import math
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest
from scipy import stats

from rigsim.dataset import load_dataset_spec, run_dataset
from rigsim.dataset.sample import build_sample_scene, draw_sample
from rigsim.errors import ConfigError
from rigsim.scene.meshes import placed_mesh
from rigsim.scene.seabed import SeabedSpec, height_at
from rigsim.scene.surfaces import target_surfaces

ROOT = Path(__file__).resolve().parents[2]
SPEC = f"""
[dataset]
width = 96
height = 64
engine = "fast"
wavelengths = "400:700:25"

[water]
presets = ["coastal"]
constituent_probability = 0.0

[rig]
files = ["{ROOT}/rigs/twin-strobes-45-wide.toml"]

[sensor]
names = ["sony_ilce-7rm2"]
noise = false

[scene]
distance_m = [1.0, 2.0]
objects = [1, 1]
kinds = ["colorchecker"]

[seabed]
probability = 1.0
rocks = [3, 3]
rubble = [4, 4]
extent_m = 8.0
cells = 256
"""


@pytest.fixture(scope="module")
def spec(tmp_path_factory):
    p = tmp_path_factory.mktemp("seabed") / "spec.toml"
    p.write_text(SPEC)
    return load_dataset_spec(p)


def test_rocks_rest_partly_buried_and_the_rig_looks_down(spec):
    for i in range(3):
        rec = draw_sample(spec, i, 1)
        scene, _ = build_sample_scene(spec, rec)
        sb = rec["seabed"]
        fwd = np.asarray(scene.camera.frame()[2])
        assert math.degrees(math.asin(-fwd[1])) == pytest.approx(sb["camera_pitch_deg"], abs=1e-9)
        bed = target_surfaces(scene.targets[0], scene.camera)[0]
        assert scene.targets[0].kind == "seabed"
        M = bed.matrix()
        assert float(scene.camera.position_m[1]) - M[1, 3] == pytest.approx(sb["altitude_m"])
        field = SeabedSpec(**sb["field"])
        rocks = [t for t in scene.targets[1:] if t.kind == "mesh"]
        assert len(rocks) >= 5  # of 7 (a pixel's ray may pass beyond the patch)
        for t in rocks:
            p = target_surfaces(t, scene.camera)[0]
            V, _, _ = placed_mesh(p.mesh_path, p.matrix())
            local = (V - M[:3, 3]) @ M[:3, :3]
            below = local[:, 1] < height_at(field, local[:, 0], local[:, 2])
            assert 0 < below.mean() < 0.9, "a rock lies in the sand: some of it below, most of it above"


def test_seabed_samples_label_objects_but_not_the_sand(spec, tmp_path):
    out = run_dataset(spec, 2, tmp_path / "ds", seed=1, serial=True, progress=False)
    coco = json.loads((out / "coco.json").read_text())
    for i in range(2):
        d = out / "samples" / f"{i:06d}"
        rec = json.loads((d / "record.json").read_text())
        inst = iio.imread(d / "instances.png")
        bed = [it for it in rec["instances"] if it["kind"] == "seabed"]
        assert len(bed) == 1 and bed[0]["stuff"]
        assert (inst == bed[0]["id"]).mean() > 0.3  # the rig looks down at the sand
        annotated = {a["instance_id"] for a in coco["annotations"] if a["image_id"] == i and "instance_id" in a}
        visible = {it["id"] for it in rec["instances"] if not it["stuff"] and (inst == it["id"]).any()}
        assert bed[0]["id"] not in annotated and annotated == visible  # every visible rock and chart; not the sand
        assert {it["category"] for it in rec["instances"] if it["id"] in annotated} == {"colorchecker", "rock"}
    assert [c["name"] for c in coco["categories"]] == ["colorchecker", "rock", "marine-snow"]


@pytest.mark.render
def test_the_fast_engine_images_a_seabed_as_monte_carlo_does(spec):
    """Mean radiance of the sand and of the water above it, strobes in coastal water: the fast engine
    against four Monte Carlo renders (5 % + Student t · SE)."""
    from rigsim.preview import render_preview
    from rigsim.render import render

    rec = draw_sample(spec, 0, 1)
    rec["seabed"]["rocks"], rec["seabed"]["rubble"], rec["objects"] = [], [], []
    scene, _ = build_sample_scene(spec, rec)
    kw = dict(width=36, height=24, wavelengths_nm=[450.0, 550.0, 650.0], bandwidth_nm=10.0)
    fast = render_preview(scene, **kw)
    refs = [render(scene, spp=32, seed=s, **kw) for s in range(4)]
    oid = np.asarray(fast.layers["object_id"])
    agree = np.mean([np.mean(np.asarray(r.layers["object_id"]) == oid) for r in refs])
    assert agree > 0.97
    k = stats.t.ppf(0.975, len(refs) - 1)
    sand = oid == 1
    assert sand.sum() > 200
    f = fast.radiant_exposure(1.0)[sand].mean(axis=0)
    per = np.array([r.radiant_exposure(1.0)[sand].mean(axis=0) for r in refs])
    ref, se = per.mean(axis=0), per.std(axis=0, ddof=1) / 2
    print("seabed fast/MC - 1:", f / ref - 1, "SE:", se / ref)
    assert np.all(np.abs(f / ref - 1) <= 0.05 + k * se / ref), (f / ref - 1, se / ref)


@pytest.mark.parametrize("old,new,pattern", [
    ("probability = 1.0", "probability = 1.5", r"seabed.probability"),
    ("cells = 256", "cells = 20", r"seabed.cells: .*cannot draw ripples"),
    ("rocks = [3, 3]", "rocks = [3, 1]", r"seabed.rocks: impossible range"),
])
def test_a_bad_seabed_table_fails_before_rendering(tmp_path, old, new, pattern):
    p = tmp_path / "spec.toml"
    p.write_text(SPEC.replace(old, new))
    with pytest.raises(ConfigError, match=pattern) as e:
        load_dataset_spec(p)
    assert "\n" not in str(e.value) and "spec.toml" in str(e.value)


def test_daylight_samples_are_lit_by_the_sun_too(spec, tmp_path):
    """[daylight] draws a depth and a sun per sample and the scene carries it; its light adds to the
    strobes' everywhere (the same scene without it is nowhere brighter, and darker on the far seabed
    towards the horizon); the dataset writes such a sample."""
    import dataclasses

    from rigsim.preview import render_preview

    lit = dataclasses.replace(spec, daylight={"probability": 1.0, "depth_m": (5.0, 5.0), "sun_zenith_deg": (30.0, 30.0)})
    rec = draw_sample(lit, 0, 2)
    assert rec["daylight"]["depth_m"] == 5.0 and 0 <= rec["daylight"]["sun_azimuth_deg"] < 360
    scene, _ = build_sample_scene(lit, rec)
    assert scene.daylight.depth_m == 5.0 and scene.daylight.sun_zenith_deg == 30.0
    kw = dict(width=48, height=32, wavelengths_nm=[450.0, 550.0, 650.0], bandwidth_nm=10.0, multiple=False)
    with_sun = render_preview(scene, **kw).radiant_exposure(1.0)
    without = render_preview(dataclasses.replace(scene, daylight=None), **kw).radiant_exposure(1.0)
    assert np.all(with_sun >= without * (1 - 1e-6))
    ids = render_preview(scene, layers=("object_id",), **kw)
    oid = np.asarray(ids.layers["object_id"])
    far = [int(k) for k, v in ids.meta["object_ids"].items() if v.endswith("seabed far")]
    far = (oid == far[0]) | (oid == 0)  # the seabed beyond the patch (or water), towards the horizon
    assert far.sum() > 20 and (with_sun[far] > 1.01 * without[far]).all()
    out = run_dataset(lit, 1, tmp_path / "sun", seed=2, serial=True, progress=False)
    assert json.loads((out / "samples" / "000000" / "record.json").read_text())["daylight"] == rec["daylight"]
