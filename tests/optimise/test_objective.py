"""The optimiser's numbers: the light on the subject against the inverse-square and cosine laws, the
weights, and the setting's checks."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigsim.errors import ConfigError
from rigsim.optimise.objective import (
    DEFAULT_WEIGHTS,
    Fidelity,
    Setting,
    Weights,
    illumination_metrics,
    parse_weights,
    render_fast,
)


def _point_light_scene(distance_m: float, beam_deg: float):
    from rigsim.light.beam import soft_cone
    from rigsim.light.sources import strobe_light
    from rigsim.scene.build import build_scene
    from rigsim.scene.types import Camera, Rig

    cam = Camera()
    light = strobe_light("s", np.asarray(cam.position_m, float), np.asarray(cam.forward, float),
                         soft_cone(beam_deg, 2.0), guide_number_m=20.0)
    rig = Rig(name="t", camera=cam, lights=(light,))
    return build_scene(rig, None, "colorchecker", distance_m, size_m=1.2 * distance_m), cam


@pytest.mark.parametrize("distance_m, beam_deg", [(1.0, 100.0), (2.0, 60.0)])
def test_light_on_the_chart_follows_the_inverse_square_and_cosine_laws(distance_m, beam_deg):
    """A strobe at the pupil, in air, lighting a chart square to its axis: the irradiance at a patch is
    I f(θ) cos θ / r² with cos θ = d / r and f the beam's 2^{−(θ/θ½)²}.  The unevenness and the corner
    ratio measured from the rendered image (unscattered image over each patch's reflectance) equal those
    of the law at the patches' centres (found by casting the camera's rays through the patch centroids)."""
    from rigsim.metrics.scene import target_masks
    from rigsim.scene.optics import camera_rays

    scene, cam = _point_light_scene(distance_m, beam_deg)
    si = render_fast(scene, 192, 128, Fidelity("t", 192))
    masks = target_masks(np.asarray(si.layers["object_id"]), si.meta["object_ids"], "colorchecker")
    got = illumination_metrics(si, masks, "colorchecker")
    cents = np.array([np.argwhere(m).mean(axis=0) for k, m in masks.items() if k.startswith("patch:")])
    assert len(cents) == 24
    # the patches' centroids → film positions in [0, 1] → the optics layer's rays (in air)
    o, d = camera_rays(cam, (cents[:, 1] + 0.5) / 192, (cents[:, 0] + 0.5) / 128, n_outside=1.0)
    o, d = np.asarray(o, float), np.asarray(d, float)
    fwd = np.asarray(cam.forward, float) / np.linalg.norm(cam.forward)
    t = (distance_m - (o - np.asarray(cam.position_m)) @ fwd) / (d @ fwd)
    p = o + t[:, None] * d - np.asarray(cam.position_m)
    r = np.linalg.norm(p, axis=1)
    cos_t = (p @ fwd) / r
    half = math.radians(beam_deg) / 2
    e = 2.0 ** (-(np.arccos(cos_t) / half) ** 2) * cos_t / r ** 2
    order = np.argsort(np.hypot(*(cents - cents.mean(axis=0)).T), kind="stable")
    want_ratio = e[order[-4:]].mean() / e[order[:4]].mean()
    want_cv = e.std() / e.mean()
    assert got["corner_ratio"] == pytest.approx(want_ratio, rel=0.02)
    assert got["evenness_cv"] == pytest.approx(want_cv, rel=0.04)
    assert got["corner_ratio"] < 0.9  # the test has teeth: the chart is visibly uneven


def test_weights_and_their_errors():
    m = {"backscatter_share": 0.2, "evenness_cv": 0.1, "snr_white": 50.0, "delta_e_mean": 8.0, "speck_light": 0.005,
         "speck_count": 40}
    terms = DEFAULT_WEIGHTS.terms(m)
    assert terms == pytest.approx({"backscatter": 0.2, "evenness": 0.1, "noise": 0.2, "colour": 0.4, "specks": 0.5})
    w = parse_weights("backscatter=2, evenness=0")
    assert w.score(m) == pytest.approx(0.4 + 0.2 + 0.4 + 0.5)
    for bad in ("backscatter", "glare=1", "noise=x", "noise=-1"):
        with pytest.raises(ConfigError) as e:
            parse_weights(bad)
        assert "--weights" in str(e.value) and "\n" not in str(e.value)
    with pytest.raises(ConfigError):
        Weights(noise=float("nan"))


@pytest.mark.parametrize("kw", [dict(distance_m=0), dict(distance_m=float("inf")), dict(distance_m="2"),
                                dict(subject_fill=0), dict(subject_fill=2.0), dict(subject="data/meshes/missing.obj"),
                                dict(subject="bogus")])
def test_bad_settings_are_refused(kw):
    with pytest.raises(ConfigError):
        Setting(**kw)


def test_a_mesh_subject_is_measured_as_the_shape_it_is(tmp_path):
    """A disk given as a mesh (a fan of 720 triangles) and the white disk: the same light on the subject
    (evenness, corner ratio: reflectance cancels); the mesh has the subject's numbers but no ΔE2000; and
    the shipped rock is measured."""
    from rigsim.config.rigdoc import RigDoc
    from rigsim.optimise.objective import evaluate

    a = np.linspace(0.0, 2 * np.pi, 720, endpoint=False)
    with open(tmp_path / "disk.obj", "w") as f:
        f.write("v 0 0 0\n")
        f.writelines(f"v {math.cos(t):.12g} {math.sin(t):.12g} 0\n" for t in a)
        f.writelines(f"f 1 {2 + i} {2 + (i + 1) % 720}\n" for i in range(720))
    rig = RigDoc.load("rigs/twin-strobes-45-wide.toml").rig()
    fid = Fidelity("test", 96, False)
    disk = evaluate(rig, Setting(water="coastal", distance_m=1.5, subject="white-disk"), fid).metrics
    mesh = evaluate(rig, Setting(water="coastal", distance_m=1.5, subject=str(tmp_path / "disk.obj")), fid).metrics
    for k in ("evenness_cv", "corner_ratio"):
        assert mesh[k] == pytest.approx(disk[k], rel=0.01), k
    rock = evaluate(rig, Setting(water="coastal", distance_m=1.5, subject="data/meshes/rock.obj"), fid).metrics
    for m in (mesh, rock):
        assert {"backscatter_share", "evenness_cv", "corner_ratio", "snr_white", "contrast"} <= set(m)
        assert "delta_e_mean" not in m and 0 < m["backscatter_share"] < 1
