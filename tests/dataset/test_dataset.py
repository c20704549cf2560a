"""Datasets: consistent ground truth, determinism across workers, errors before rendering."""

import json
from pathlib import Path

import numpy as np
import pytest
import tifffile

from rigsim.dataset import load_dataset_spec, run_dataset
from rigsim.errors import ConfigError

ROOT = Path(__file__).resolve().parents[2]

SPEC = """
[dataset]
width = 36
height = 24
spp = 16

[water]
presets = ["coastal", "jerlov-II"]
constituent_probability = 0.5

[rig]
files = ["{root}/rigs/twin-strobes-45-wide.toml", "{root}/rigs/single-strobe-short-arm.toml"]
power_fraction = [0.5, 1.0]

[sensor]
names = ["sony_ilce-7rm2", "action_cam_1-2.3in"]
noise = {noise}

[scene]
distance_m = [1.0, 2.0]
objects = [1, 2]
kinds = ["colorchecker", "white-disk", "mesh"]
size_fraction = [0.3, 0.5]
bottom_probability = 0.5
"""


def spec_file(tmp_path, noise="true", **replace):
    text = SPEC.format(root=ROOT, noise=noise)
    for old, new in replace.items():
        text = text.replace(old, new)
    p = tmp_path / "spec.toml"
    p.write_text(text)
    return p


def read(d, name):
    """A float layer of a sample by its name, read with OpenEXR (:func:`rigsim.dataset.formats.read_exr`)."""
    from rigsim.dataset.formats import read_exr

    if name == "range_m":
        return read_exr(d / "depth_range_m.exr")["Z"]
    if name == "z_m":
        return read_exr(d / "depth_z_m.exr")["Z"]
    if name in ("image_linear", "clean_linear"):
        ch = read_exr(d / f"{name}.exr")
        return np.stack([ch[c] for c in "RGB"], axis=-1)
    ch = read_exr(d / "layers.exr")
    return np.stack([ch[f"{name}.{c}"] for c in "RGB"], axis=-1)


@pytest.mark.render
def test_four_samples_layers_consistent(tmp_path):
    spec = load_dataset_spec(spec_file(tmp_path, noise="false"))
    out = run_dataset(spec, 4, tmp_path / "ds", seed=5, serial=True, progress=False,
                      overrides={0: {"water": {"vacuum": True}}})
    manifest = (out / "manifest.csv").read_text().splitlines()
    assert len(manifest) == 5
    from rigsim.dataset.sample import channel_attenuation
    from rigsim.sensor import load_sensor

    for i in range(4):
        d = out / "samples" / f"{i:06d}"
        for f in ("image.png", "raw.dng", "clean.png", "depth_range_m.exr", "depth_z_m.exr", "layers.exr",
                  "mask.png", "record.json", "image_linear.exr", "clean_linear.exr", "instances.png",
                  "annotations.json", "labels.txt", "camera.json", "depth_range_mm.png", "depth_z_mm.png"):
            assert (d / f).is_file(), f
        rec = json.loads((d / "record.json").read_text())
        rng_m, trans = read(d, "range_m"), read(d, "transmission")
        c = np.array(rec["channel_attenuation_per_m"])
        fin = np.isfinite(rng_m)
        # transmission is exp(-c_channel * range) with the water's c weighted by the channel QE
        np.testing.assert_allclose(trans[fin], np.exp(-rng_m[fin][:, None] * c), rtol=1e-5)
        assert np.all(trans[~fin] == 0)
        if i > 0:
            from rigsim.dataset.sample import _water

            w = _water(rec)
            wl = np.arange(400.0, 701.0, 10.0)
            np.testing.assert_allclose(c, channel_attenuation(w, load_sensor(rec["sensor"]), wl, np.full(31, 10.0)),
                                       rtol=1e-9)
            assert w.c_per_m(wl).min() <= c.min() and c.max() <= w.c_per_m(wl).max()
        # objects are where the mask says, at finite range
        import imageio.v3 as iio

        mask = iio.imread(d / "mask.png")
        assert mask.dtype == np.uint16 and mask.shape == rng_m.shape
        assert np.all(np.isfinite(rng_m[mask > 0]))
        assert set(np.unique(mask[mask > 0]).tolist()) <= {int(k) for k in rec["object_ids"]}
    # vacuum: the underwater image is the clean image (no noise in this spec; Monte Carlo tolerance)
    d0 = out / "samples" / "000000"
    img, clean = read(d0, "image_linear"), read(d0, "clean_linear")
    assert np.mean(img) == pytest.approx(np.mean(clean), rel=0.05)
    assert np.all(np.abs(read(d0, "transmission")[np.isfinite(read(d0, "range_m"))] - 1) < 1e-6)
    assert np.abs(read(d0, "backscatter")).max() < 1e-6
    # in real water the clean image is brighter than the underwater one at the objects
    d1 = out / "samples" / "000001"
    m1 = iio.imread(d1 / "mask.png") > 0
    assert read(d1, "clean_linear")[m1].mean() > read(d1, "image_linear")[m1].mean() * 0.9


@pytest.mark.render
def test_deterministic_across_workers(tmp_path):
    spec = load_dataset_spec(spec_file(tmp_path))
    a = run_dataset(spec, 2, tmp_path / "serial", seed=11, serial=True, progress=False)
    b = run_dataset(spec, 2, tmp_path / "dask", seed=11, progress=False)
    for i in range(2):
        ra = json.loads((a / "samples" / f"{i:06d}" / "record.json").read_text())
        rb = json.loads((b / "samples" / f"{i:06d}" / "record.json").read_text())
        for r in (ra, rb):
            r.pop("wall_time_s")
            r["render"].pop("wall_time_s")
        assert ra == rb
        for f in ("image.png", "mask.png", "depth_range_mm.png", "instances.png", "labels.txt", "annotations.json"):
            assert (a / "samples" / f"{i:06d}" / f).read_bytes() == (b / "samples" / f"{i:06d}" / f).read_bytes()


@pytest.mark.render
def test_a_dataset_resumed_by_other_code_computes_its_samples_again(tmp_path, monkeypatch, caplog):
    import logging

    import rigsim.code_version as code_version_module
    import rigsim.dataset.writer as writer

    spec = load_dataset_spec(spec_file(tmp_path))
    computed = []
    compute = writer._compute
    monkeypatch.setattr(writer, "_compute", lambda args: computed.append(args[1]) or compute(args))
    out = run_dataset(spec, 1, tmp_path / "d", seed=5, serial=True, progress=False)
    rec_file = out / "samples" / "000000" / "record.json"
    assert json.loads(rec_file.read_text())["code"] == code_version_module.code_version()
    run_dataset(spec, 1, out, seed=5, serial=True, progress=False)
    assert computed == [0]  # the same code: not computed again
    for module in (writer, code_version_module):
        monkeypatch.setattr(module, "code_version", lambda: "0123456789ab")
    assert not writer._finished(out, 0)
    writer.write_manifest(out, 1)  # an update, then the tables before the run: no sample of other code in them
    assert (out / "manifest.csv").read_text() == ""
    with caplog.at_level(logging.WARNING, logger="rigsim.dataset.writer"):
        run_dataset(spec, 1, out, seed=5, serial=True, progress=False)
    assert computed == [0, 0] and "1 finished sample(s)" in caplog.text
    assert json.loads(rec_file.read_text())["code"] == "0123456789ab"
    assert (out / "manifest.csv").read_text().count("\n") == 2  # header + the sample
    # a worker that loaded rigsim after its files changed mid-run: named, and kept out of the manifest
    def edited_meanwhile(args):
        res = compute(args)
        res["record"]["code"] = "feedbeef0000"
        return res

    monkeypatch.setattr(writer, "_compute", edited_meanwhile)
    with caplog.at_level(logging.WARNING, logger="rigsim.dataset.writer"):
        run_dataset(spec, 1, tmp_path / "e", seed=5, serial=True, progress=False)
    assert "sample 000000 was computed by other rigsim code (feedbeef0000" in caplog.text
    assert (tmp_path / "e" / "manifest.csv").read_text() == ""


@pytest.mark.parametrize("old,new,pattern", [
    ("distance_m = [1.0, 2.0]", "distance_m = [3.0, 1.0]", r"scene.distance_m: impossible range \[3, 1\]"),
    ("distance_m = [1.0, 2.0]", "distance_m = [0.05, 1.0]", r"scene.distance_m: .*touch the port"),
    ("objects = [1, 2]", "objects = [0, 2]", r"scene.objects: impossible range"),
    ("[water]", "[water]\nchl_mg_per_m3 = [0.0, 1.0]", r"water.chl_mg_per_m3: impossible range"),
    ("power_fraction = [0.5, 1.0]", "power_fraction = [0.5, 1.5]", r"rig.power_fraction: impossible range"),
    ('presets = ["coastal", "jerlov-II"]', 'presets = ["coastl"]', r"water.presets\[0\].*did you mean 'coastal'"),
    ('kinds = ["colorchecker", "white-disk", "mesh"]', 'kinds = ["cube"]', r"scene.kinds\[0\]: unknown object kind"),
    ("spp = 16", "spp = 16\nfoo = 1", r"dataset.foo: unknown key"),
    ("spp = 16", 'spp = 16\nsnow_labels = "boxes"', r"dataset.snow_labels: unknown snow labels .boxes. \(allowed: crowd, instances, none\)"),
    ("[water]", '[water]\nparticle_levels = ["snowstorm"]\nparticle_probability = 0.5',
     r"water.particle_levels\[0\]: unknown particle level"),
])
def test_bad_spec_fails_before_rendering(tmp_path, monkeypatch, old, new, pattern):
    import rigsim.dataset.writer as writer

    monkeypatch.setattr(writer, "_compute", lambda *a: pytest.fail("rendered despite a bad spec"))
    p = spec_file(tmp_path)
    p.write_text(p.read_text().replace(old, new))
    with pytest.raises(ConfigError, match=pattern) as ei:
        run_dataset(load_dataset_spec(p), 2, tmp_path / "x", serial=True, progress=False)
    assert "\n" not in str(ei.value)


def test_marine_snow_samples_carry_the_particles_ground_truth(tmp_path):
    """With particle_probability = 1 every sample has marine snow: an instance mask whose labels are the
    particles whose light the particles layer holds, the placement recorded (level, seed, count); the same
    sample again gives the same particles."""
    p = spec_file(tmp_path, noise="false")
    p.write_text(p.read_text().replace("[water]", '[water]\nparticle_levels = ["coastal"]\nparticle_probability = 1.0')
                 .replace('kinds = ["colorchecker", "white-disk", "mesh"]', 'kinds = ["colorchecker"]')
                 .replace("width = 36\nheight = 24", "width = 72\nheight = 48"))
    spec = load_dataset_spec(p)
    out = run_dataset(spec, 2, tmp_path / "ds", seed=3, serial=True, progress=False)
    seeds = []
    for i in range(2):
        d = out / "samples" / f"{i:06d}"
        rec = json.loads((d / "record.json").read_text())
        assert rec["particles"]["level"] == "coastal" and rec["particles"]["count"] > 1000
        seeds.append(rec["particles"]["seed"])
        ids = tifffile.imread(d / "particle_id.tiff")
        specks = tifffile.imread(d / "specks.tiff")
        light = read(d, "particles")
        assert ids.dtype == np.uint32 and ids.shape == (48, 72) and light.shape == (48, 72, 3)
        assert ids.max() <= rec["particles"]["count"] and (ids > 0).mean() > 0.5  # at 72×48 particles are everywhere
        # the specks that show are a few of them, bright: each labelled pixel holds at least 5 % of the image's
        # median luminance of particle light, the pixels outside the mask less
        lum = light @ np.array([0.2126, 0.7152, 0.0722])
        ref = np.median(read(d, "image_linear") @ np.array([0.2126, 0.7152, 0.0722]))
        assert 0 < (specks > 0).sum() < 0.2 * specks.size
        assert np.all(lum[specks > 0] >= 0.05 * ref * 0.999) and np.all(lum[(specks == 0) & (ids > 0)] < 0.05 * ref)
        assert np.all((specks == ids) | (specks == 0))
    assert seeds[0] != seeds[1]  # every sample its own particles
    # the same sample drawn again has the same particles: its scene built anew from the spec and seed, its
    # particles imaged on the written range layer, give the written instance mask (without rendering again:
    # a marine-snow render loads a mesh of 21 million triangles twice, ~25 s)
    from rigsim.dataset.sample import build_sample_scene, draw_sample
    from rigsim.scene.particles import particle_id_image, scene_particles

    d0 = out / "samples" / "000000"
    scene0, _ = build_sample_scene(spec, draw_sample(spec, 0, 3))
    again = particle_id_image(scene0, scene_particles(scene0), 72, 48, read(d0, "range_m"))
    np.testing.assert_array_equal(again, tifffile.imread(d0 / "particle_id.tiff"))
