"""A dataset's files read back by the libraries a user's loader uses: OpenEXR, imageio, pycocotools,
pandas/pyarrow, OpenCV's projection, rawpy; masks, boxes and depth against the scene; the README's
PyTorch Dataset."""

from __future__ import annotations

import dataclasses
import json
import sys
import types
from pathlib import Path

import imageio.v3 as iio
import numpy as np
import pytest
import tifffile

from rigsim.dataset import load_dataset_spec, run_dataset
from rigsim.dataset.formats import PYTORCH_EXAMPLE, depth_png_mm, intrinsics, pose, read_exr

ROOT = Path(__file__).resolve().parents[2]

SPEC = f"""
[dataset]
width = 96
height = 64
engine = "fast"
wavelengths = "400:700:20"

[water]
presets = ["coastal"]
constituent_probability = 0.0
particle_levels = ["coastal"]
particle_probability = 0.5

[rig]
files = ["{ROOT}/rigs/twin-strobes-45-wide.toml"]

[sensor]
names = ["sony_ilce-7rm2"]

[scene]
distance_m = [1.0, 2.5]
objects = [2, 3]
kinds = ["colorchecker", "white-disk", "mesh"]
meshes = ["{ROOT}/data/meshes/rock.obj"]
size_fraction = [0.2, 0.35]
bottom_probability = 0.5
"""


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("formats")
    (tmp / "spec.toml").write_text(SPEC)
    spec = load_dataset_spec(tmp / "spec.toml")
    return run_dataset(spec, 4, tmp / "ds", seed=7, serial=True, progress=False), spec


def test_manifest_parquet_and_csv_agree_and_name_existing_files(dataset):
    import pandas as pd

    out, _ = dataset
    pq = pd.read_parquet(out / "manifest.parquet")
    csv = pd.read_csv(out / "manifest.csv")
    assert len(pq) == len(csv) == 4
    assert list(pq["index"]) == [0, 1, 2, 3]
    for col in ("image", "image_linear", "depth_z_m", "depth_range_mm", "instances", "annotations", "camera"):
        assert list(pq[col]) == list(csv[col])
        assert all((out / p).is_file() for p in pq[col])
    np.testing.assert_allclose(pq["fx_px"], csv["fx_px"])


def test_coco_masks_and_boxes_are_the_rendered_objects(dataset):
    """pycocotools reads coco.json; every annotation's mask is its instance in instances.png (or its speck
    in specks.png), its box the mask's extent, its area the pixel count; YOLO lines are the same boxes."""
    from pycocotools.coco import COCO

    out, spec = dataset
    coco = COCO(str(out / "coco.json"))
    assert {c["name"] for c in coco.loadCats(coco.getCatIds())} == {"colorchecker", "white-disk", "rock", "marine-snow"}
    assert sorted(coco.getImgIds()) == [0, 1, 2, 3]
    seen = 0
    for img_id in coco.getImgIds():
        d = out / "samples" / f"{img_id:06d}"
        inst = iio.imread(d / "instances.png")
        rec = json.loads((d / "record.json").read_text())
        anns = coco.loadAnns(coco.getAnnIds(imgIds=[img_id]))
        objects = [a for a in anns if "instance_id" in a]
        # every visible object (not the bottom) has one annotation
        visible = {it["id"] for it in rec["instances"] if not it["stuff"] and (inst == it["id"]).any()}
        assert {a["instance_id"] for a in objects} == visible
        specks = tifffile.imread(d / "specks.tiff") if (d / "specks.tiff").is_file() else None  # (uint32: whole ids)
        for a in anns:
            m = coco.annToMask(a).astype(bool)
            want = inst == a["instance_id"] if "instance_id" in a else specks == a["particle_index"]
            np.testing.assert_array_equal(m, want)
            rr, cc = np.nonzero(m)
            assert a["bbox"] == [cc.min(), rr.min(), cc.max() - cc.min() + 1, rr.max() - rr.min() + 1]
            assert a["area"] == m.sum()
            seen += 1
        lines = (d / "labels.txt").read_text().splitlines()
        assert len(lines) == len(anns)
        h, w = inst.shape
        for a, line in zip(anns, lines):
            k, cx, cy, bw, bh = line.split()
            x, y, ww, hh = a["bbox"]
            assert int(k) == a["category_id"] - 1
            np.testing.assert_allclose([float(cx) * w, float(cy) * h, float(bw) * w, float(bh) * h],
                                       [x + ww / 2, y + hh / 2, ww, hh], atol=1e-3)
    assert seen >= 8
    names = (out / "yolo" / "data.yaml").read_text()
    assert "0: colorchecker" in names and "3: marine-snow" in names
    assert (out / "yolo" / "images" / "000000.png").resolve() == (out / "samples" / "000000" / "image.png").resolve()


def test_depth_files_are_the_range_layer_and_z_is_the_distance_along_the_axis(dataset):
    """depth_range_m.exr is the engine's range layer exactly; the PNG holds it in mm; z equals the target's
    distance on a chart facing the camera (exact geometry: a dome port is a pinhole at the pupil)."""
    from rigsim.dataset.sample import build_sample_scene, draw_sample
    from rigsim.preview import render_preview

    out, spec = dataset
    for i in range(4):
        d = out / "samples" / f"{i:06d}"
        rng = read_exr(d / "depth_range_m.exr")["Z"]
        z = read_exr(d / "depth_z_m.exr")["Z"]
        rec = draw_sample(spec, i, 7)
        scene, _ = build_sample_scene(spec, rec)
        si = render_preview(scene, width=96, height=64, wavelengths_nm=spec.wavelengths_nm, layers=("range_m",))
        np.testing.assert_array_equal(rng, np.asarray(si.layers["range_m"], np.float32))
        assert np.array_equal(np.isinf(rng), np.isinf(z))
        np.testing.assert_array_equal(iio.imread(d / "depth_range_mm.png"), depth_png_mm(rng))
        np.testing.assert_array_equal(iio.imread(d / "depth_z_mm.png"), depth_png_mm(z))
        fin = np.isfinite(rng)
        assert np.all(z[fin] <= rng[fin] * (1 + 1e-6))  # z ≤ range: the axis is the shortest way
    # a chart square to the axis at 1.7 m: z is 1.7 m on its body, range grows towards its corners
    spec1 = dataclasses.replace(spec, kinds=("colorchecker",), objects=(1, 1), bottom_probability=0.0)
    rec = draw_sample(spec1, 0, 1)
    rec["objects"][0].update(distance_m=1.7, offset_frac=[0.0, 0.0], yaw_deg=0.0, pitch_deg=0.0, tilt_deg=0.0)
    from rigsim.dataset.formats import depth_maps

    scene, _ = build_sample_scene(spec1, rec)
    si = render_preview(scene, width=96, height=64, wavelengths_nm=spec.wavelengths_nm, layers=("range_m", "object_id"))
    r, z = depth_maps(si.layers["range_m"], scene.camera)
    body = [k for k, v in si.meta["object_ids"].items() if v.endswith("chart")]
    on_body = np.isin(si.layers["object_id"], [int(k) for k in body])
    assert on_body.sum() > 20
    np.testing.assert_allclose(z[on_body], 1.7, atol=2e-6)
    assert r[on_body].max() > 1.7 + 1e-3


@pytest.mark.parametrize("port", ["dome", "flat"])
def test_camera_json_projects_as_rigsim_does(port):
    """OpenCV's projectPoints with camera.json's K, distortion and pose puts world points where rigsim's
    camera model does: exactly for a dome (a pinhole), within the reported error for a flat port."""
    import cv2

    from rigsim.config.rig import load_rig
    from rigsim.scene.optics import WATER_INDEX, project_points
    from rigsim.scene.types import Port

    cam = load_rig(ROOT / "rigs/twin-strobes-45-wide.toml").camera
    if port == "flat":
        cam = dataclasses.replace(cam, port=Port(kind="flat"), focal_length_mm=24.0)
    W, H = 640, 427
    it, ps = intrinsics(cam, W, H), pose(cam)
    T = np.array(ps["T_camera_from_world"])
    rng = np.random.default_rng(0)
    for depth, key in ((2.0, "2 m"), (0.5, "0.5 m")):
        p_cam = np.c_[rng.uniform(-1.2, 1.2, (3000, 2)) * depth, np.full(3000, depth)]
        p_world = (p_cam - T[:3, 3]) @ T[:3, :3]  # inverse of x_cam = R x_world + t
        ref = project_points(cam, p_world, W, H, n_outside=WATER_INDEX)
        inside = np.all(np.isfinite(ref), 1) & (ref[:, 0] > 0) & (ref[:, 0] < W) & (ref[:, 1] > 0) & (ref[:, 1] < H)
        assert inside.sum() > 200
        rvec, _ = cv2.Rodrigues(T[:3, :3])
        img, _ = cv2.projectPoints(p_world[inside].reshape(-1, 1, 3), rvec, T[:3, 3], np.array(it["K"]),
                                   np.array(it["dist"]))
        err = np.abs(img.reshape(-1, 2) - ref[inside]).max()
        if port == "dome":
            assert err < 1e-6 and it["dist"] == [0.0] * 5
        else:
            assert err <= it["max_error_px"][key] * 1.05 + 1e-9
            assert it["dist"][0] > 0  # pincushion
    assert it["max_error_px"]["2 m"] < (1e-6 if port == "dome" else 0.1)


def test_the_readme_pytorch_dataset_loads_the_samples(dataset):
    """The dataset card's PyTorch Dataset (no rigsim import) run against the folder, with a stand-in for
    torch's two calls it uses (torch is not a dependency of rigsim)."""
    out, _ = dataset
    fake = types.ModuleType("torch")

    class Tensor(np.ndarray):
        def permute(self, *axes):
            return np.transpose(self, axes).view(Tensor)

        def float(self):
            return self.astype(np.float32).view(Tensor)

    fake.from_numpy = lambda a: np.asarray(a).view(Tensor)
    fake.tensor = lambda x: np.asarray(x, float).view(Tensor)
    fake.utils = types.SimpleNamespace(data=types.SimpleNamespace(Dataset=object))
    sys.modules["torch"] = fake
    try:
        ns: dict = {}
        exec(PYTORCH_EXAMPLE, ns)
        ds = ns["UnderwaterDataset"](str(out))
        assert len(ds) == 4
        image, depth, inst, boxes = ds[1]
        assert image.shape == (3, 64, 96) and 0 <= image.min() and image.max() <= 1
        assert depth.shape == (64, 96) and depth.max() > 0.5
        assert inst.shape == (64, 96) and inst.max() >= 1
        assert boxes.shape[1] == 4 and len(boxes) == len(json.loads(
            (out / "samples" / "000001" / "annotations.json").read_text())["annotations"])
    finally:
        del sys.modules["torch"]
    card = (out / "README.md").read_text()
    assert PYTORCH_EXAMPLE in card
    assert PYTORCH_EXAMPLE.strip() in (ROOT / "README.md").read_text()


def test_raw_dng_opens_with_rawpy(dataset):
    import rawpy

    out, _ = dataset
    with rawpy.imread(str(out / "samples" / "000002" / "raw.dng")) as raw:
        assert raw.raw_image_visible.shape == (64, 96)


def test_marine_snow_labels_as_instances_as_one_crowd_region_or_not_at_all():
    """``snow_labels``: "instances" gives one COCO annotation per visible speck; "crowd" one region with
    ``iscrowd = 1`` whose mask is every visible speck (pycocotools reads it back) and no YOLO line for it;
    "none" no speck annotation; the objects' annotations are the same in all three."""
    from pycocotools.coco import COCO

    from rigsim.dataset.formats import categories_for, coco_annotations, yolo_lines

    inst = np.zeros((40, 60), np.uint16)
    inst[5:15, 10:30] = 1
    specks = np.zeros((40, 60), np.uint32)
    for k, (r, c) in enumerate([(20, 5), (30, 40), (35, 55), (2, 50)], start=7):
        specks[r:r + 2, c:c + 3] = k
    objs = [{"id": 1, "kind": "white-disk", "category": "white-disk", "stuff": False}]
    cats = categories_for(["white-disk"], [])
    by = {m: coco_annotations(inst, objs, cats, 3, specks, snow=m) for m in ("instances", "crowd", "none")}
    snow_id = next(c["id"] for c in cats if c["name"] == "marine-snow")
    assert [a["particle_index"] for a in by["instances"] if a["category_id"] == snow_id] == [7, 8, 9, 10]
    crowd = [a for a in by["crowd"] if a["category_id"] == snow_id]
    assert len(crowd) == 1 and crowd[0]["iscrowd"] == 1 and crowd[0]["area"] == (specks > 0).sum()
    assert not [a for a in by["none"] if a["category_id"] == snow_id]
    for m in by:
        assert [a for a in by[m] if "instance_id" in a] == [a for a in by["none"] if "instance_id" in a]
    coco = COCO()
    coco.dataset = {"images": [{"id": 3, "width": 60, "height": 40}], "categories": cats, "annotations": by["crowd"]}
    coco.createIndex()
    np.testing.assert_array_equal(coco.annToMask(crowd[0]).astype(bool), specks > 0)
    assert len(yolo_lines(by["crowd"], cats, 60, 40).splitlines()) == 1  # the disk only
    assert len(yolo_lines(by["instances"], cats, 60, 40).splitlines()) == 5
