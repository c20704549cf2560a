"""The preview against the Mitsuba renderer, at small sizes.

Scenes where single (wide-angle) scattering dominates: a large white disk at 2 m lit
by two strobes beside a dome-port camera, in ``clear`` and ``coastal`` water.  The
renderer runs at a modest spp; its region means carry Monte Carlo errors estimated
from the per-pixel scatter (a white disk is uniform, so that scatter is the noise).
The issue's criterion: region means within 10 % (plus 3 standard errors).  The
renderer's strobe-lit scattering water has heavy-tailed noise, so the full-image
comparison uses the median of two seeds' region means.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mitsuba")

from rigsim.preview import render_preview  # noqa: E402
from rigsim.render import render  # noqa: E402
from rigsim.render.variant import mitsuba  # noqa: E402
from rigsim.scene.types import BeamPattern  # noqa: E402
from rigsim.water import preset  # noqa: E402
from tests.preview.helpers import disk_scene, dome_camera, interior_ids, make_light  # noqa: E402

pytestmark = pytest.mark.render
mi, dr = mitsuba()

WL = [450.0, 550.0, 650.0]
SIZE = 24


def _strobes():
    beam = BeamPattern(beam_angle_deg=100.0)
    return [make_light(position=(s * 0.35, 0.1, 0.0), aim=(0.0, 0.0, 1.0), beam=beam, intensity=0.05,
                       name=f"s{s}") for s in (-1, 1)]


def _region_stats(layer: np.ndarray, mask: np.ndarray):
    v = layer[mask].astype(float)
    return v.mean(axis=0), v.std(axis=0, ddof=1) / np.sqrt(mask.sum())


@pytest.mark.parametrize("water", ["clear", "coastal"])
def test_region_means_within_ten_percent_of_the_renderer(water):
    scene = disk_scene(preset(water), _strobes(), distance=2.0, size=0.9, reflectance=0.8,
                       camera=dome_camera(35.0))
    kw = dict(width=SIZE, height=SIZE, wavelengths_nm=WL, bandwidth_nm=10.0, split=True)
    refs = [render(scene, spp=128, seed=s, **kw) for s in (1, 2)]
    prev = render_preview(scene, **kw)
    ii = interior_ids(scene, SIZE, SIZE)
    disk, water_px = ii == 1, ii == 0
    assert disk.sum() > 100 and water_px.sum() > 100
    for key, mask in (("flash_direct", disk), ("flash_backscatter", disk), ("flash_backscatter", water_px),
                      ("flash", disk), ("flash", water_px)):
        stats = [_region_stats(r.layers[key], mask) for r in refs]
        means = np.array([m for m, _ in stats])
        ses = np.array([s for _, s in stats])
        mean = np.median(means, axis=0) if key == "flash" else means.mean(axis=0)
        se = ses.max(axis=0) if key == "flash" else np.sqrt((ses ** 2).sum(axis=0)) / 2
        pv = prev.layers[key][mask].mean(axis=0)
        rel = pv / mean - 1
        tol = (0.01 if key == "flash_direct" else 0.10) + 3 * se / mean
        assert np.all(np.abs(rel) < tol), (water, key, rel, se / mean)


def test_geometry_layers_identical_to_the_renderer():
    """object_id, range_m and the object-id legend come out the same (flat port, chart)."""
    from rigsim.config.rig import load_rig
    from rigsim.scene.build import build_scene

    rig = load_rig("rigs/twin-strobes-45-wide.toml")
    sc = build_scene(rig, "coastal", "colorchecker", 0.8)
    kw = dict(width=48, height=32, wavelengths_nm=[550.0], layers=("object_id", "range_m"))
    ref = render(sc, spp=1, **kw)
    prev = render_preview(sc, **kw)
    assert prev.meta["object_ids"] == ref.meta["object_ids"]
    assert (prev.layers["object_id"] == ref.layers["object_id"]).mean() > 0.995  # ties at patch edges
    same = prev.layers["object_id"] == ref.layers["object_id"]
    np.testing.assert_allclose(prev.layers["range_m"][same], ref.layers["range_m"][same], rtol=1e-4)
    assert set(prev.layers) == set(ref.layers)
    for k in ref.layers:
        assert prev.layers[k].dtype == ref.layers[k].dtype and prev.layers[k].shape == ref.layers[k].shape
    assert prev.meta["fov_water_x_deg"] == pytest.approx(ref.meta["fov_water_x_deg"])


def test_the_veil_from_behind_a_target_reaches_its_pixels_through_the_camera_leg(monkeypatch):
    """Small-angle scattering on the way to the camera brings part of the veil from the water behind a target
    into the target's pixels (:meth:`rigsim.preview.model._Group._behind`).  The demo's edge-lit black disk
    in Jerlov 3C at 1 m (0.4 of the field wide, 450 nm, bF r = 1.3): the veil in front of the disk (the
    ``backscatter`` layer, the disk's interior, 48 x 32) against 16 Monte Carlo renders of 64 paths per pixel:
    within 3 % + 3 standard errors (measured +1.5 % ± 0.75 %); without the term the fast engine's is more
    than 3 standard errors low (−3.3 %; at 96 x 64 0.3945 of the disk's radiance against Monte Carlo's
    0.427 ± 0.003, with it 0.418)."""
    import rigsim.preview.model as preview_model
    from rigsim.config.rig import load_rig
    from rigsim.metrics.agreement import comparison_regions
    from rigsim.scene.build import build_scene
    from rigsim.scene.optics import field_width_m

    rig = load_rig("rigs/twin-strobes-edge-lighting.toml")
    scene = build_scene(rig, preset("jerlov-3C"), "black-disk", 1.0, size_m=0.4 * field_width_m(rig.camera, 1.0))
    kw = dict(width=48, height=32, wavelengths_nm=[450.0], bandwidth_nm=10.0)
    fast = render_preview(scene, split=True, seed=1, layers=("object_id",), **kw)
    disk = comparison_regions(np.asarray(fast.layers["object_id"]), fast.meta.get("object_ids", {}), "black-disk")["disk"]
    refs = np.array([render(scene, spp=64, seed=101 + 7919 * i, layers=("object_id", "backscatter"), **kw)
                     .layers["flash_backscatter"][disk].mean() for i in range(16)])
    mean, se = refs.mean(), refs.std(ddof=1) / np.sqrt(len(refs))
    with_it = fast.layers["flash_backscatter"][disk].mean() / mean - 1
    monkeypatch.setattr(preview_model, "VEIL_BEHIND", False)
    without = render_preview(scene, split=True, seed=1, layers=("object_id",), **kw).layers["flash_backscatter"][disk].mean() / mean - 1
    assert abs(with_it) < 0.03 + 3 * se / mean, (with_it, se / mean)
    assert without < -3 * se / mean, (without, se / mean)


def test_the_daylight_path_radiance_is_not_blurred_in_from_behind_a_target(monkeypatch):
    """The daylight's path radiance is Duntley's, seen without a halo (as the renderer's), so the veil from
    behind a target that the camera leg brings into its pixels is the lights' alone: with video lights and
    daylight it changes the image exactly as with the video lights alone (and it does change it)."""
    import rigsim.preview.model as preview_model
    from rigsim.config.rig import load_rig
    from rigsim.scene.build import build_scene
    from rigsim.scene.types import Daylight

    rig = load_rig("rigs/video-lights-pair.toml")
    kw = dict(width=40, height=28, wavelengths_nm=[450.0, 550.0], bandwidth_nm=10.0, split=True, layers=("object_id",))

    def effect(daylight):
        scene = build_scene(rig, preset("jerlov-3C"), "black-disk", 1.5, size_m=0.6, daylight=daylight)
        on = render_preview(scene, **kw).radiance
        monkeypatch.setattr(preview_model, "VEIL_BEHIND", False)
        off = render_preview(scene, **kw).radiance
        monkeypatch.setattr(preview_model, "VEIL_BEHIND", True)
        return on - off, on

    alone, img = effect(None)
    with_day, _ = effect(Daylight(depth_m=5.0))
    assert np.abs(alone).max() > 1e-3 * img.max()
    np.testing.assert_allclose(with_day, alone, rtol=0, atol=0.01 * np.abs(alone).max())  # float32 rounding: 5e-4


def test_the_water_behind_a_single_target_is_in_its_shadow():
    """The shipped twin strobes 0.45 m beside the port, a black disk filling 0.4 of the field at 0.5 m in pure sea:
    the strobes light the water behind the disk from the side and the open water around it looks into the disk's
    shadow there.  The open water's flash within 1.5 % of the renderer's (and 4 standard errors); without the
    shadow in the veil (``shadows="auto"`` left it to meshes and several targets until 2026-12-05) it read
    +3.6 / +3.1 / +1.4 % (blue / green / red, 96 x 64); here +3.7 / +3.1 / +1.7 % at 450 / 550 / 650 nm (with it
    -0.2 / +0.1 / +0.5 %, the renders' SE 0.1-0.2 %)."""
    from rigsim.config.rig import load_rig
    from rigsim.metrics.agreement import comparison_regions
    from rigsim.scene.build import build_scene
    from rigsim.scene.optics import field_width_m

    rig = load_rig("rigs/twin-strobes-45-wide.toml")
    scene = build_scene(rig, "pure-sea", "black-disk", 0.5, size_m=0.4 * field_width_m(rig.camera, 0.5))
    kw = dict(width=48, height=32, wavelengths_nm=WL, bandwidth_nm=10.0)
    refs = [render(scene, spp=16, seed=s, layers=("object_id",), **kw) for s in (1, 2, 3)]
    fast = render_preview(scene, layers=("object_id",), **kw)
    oid = np.asarray(fast.layers["object_id"])
    water_px = comparison_regions(oid, fast.meta.get("object_ids", {}), "black-disk")["open water"]
    assert water_px.sum() > 300
    a = np.array([np.asarray(r.layers["flash"], float)[water_px].mean(axis=0) for r in refs])  # (seeds, bands)
    f = np.asarray(fast.layers["flash"], float)[water_px].mean(axis=0)
    rel, se = f / a.mean(axis=0) - 1, a.std(axis=0, ddof=1) / np.sqrt(len(a)) / a.mean(axis=0)
    assert np.all(np.abs(rel) < 0.015 + 4 * se), (rel, se)
