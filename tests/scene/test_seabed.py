"""The procedural seabed: its heights against its parameters (ripple wavelength and height, relief rms,
slope), the mesh against the height function, rays meeting it, objects resting on it, errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigsim.errors import ConfigError
from rigsim.scene.seabed import SeabedSpec, height_at, seabed_mesh, seabed_points, seabed_skirt


def test_ripples_have_the_wavelength_and_height_asked_for():
    spec = SeabedSpec(seed=1, ripple_wavelength_m=0.3, ripple_height_m=0.04, ripple_direction_deg=30.0,
                      relief_m=0.0, slope_deg=0.0)
    r = math.radians(30.0)
    s = np.linspace(0.0, 6.0, 6001)  # across the crests, on a line where the wander is at a crest of its own
    h = height_at(spec, s * math.cos(r), s * math.sin(r))
    assert h.max() - h.min() == pytest.approx(0.04, rel=0.02)
    f = np.fft.rfftfreq(len(s), s[1] - s[0])
    peak = f[1 + np.argmax(np.abs(np.fft.rfft(h - h.mean()))[1:])]
    assert 1 / peak == pytest.approx(0.3, rel=0.02)
    # along the crests the height changes only through their slow wander (7 wavelengths)
    along = height_at(spec, -np.linspace(0, 0.05, 50) * math.sin(r), np.linspace(0, 0.05, 50) * math.cos(r))
    assert np.ptp(along) < 0.25 * 0.04


def test_relief_rms_and_slope_are_the_parameters():
    g = np.linspace(-30.0, 30.0, 601)
    X, Z = np.meshgrid(g, g)
    flat = SeabedSpec(seed=4, extent_m=60.0, cells=600, ripple_height_m=0.0, relief_m=0.2, relief_scale_m=2.0)
    assert height_at(flat, X, Z).std() == pytest.approx(0.2, rel=0.1)  # (24 modes over a 60 m square)
    tilted = SeabedSpec(seed=4, ripple_height_m=0.0, relief_m=0.0, slope_deg=10.0, slope_direction_deg=90.0)
    h = height_at(tilted, X, Z)
    gz = np.polyfit(Z.ravel(), h.ravel(), 1)[0]
    assert gz == pytest.approx(math.tan(math.radians(10.0)), rel=1e-9)
    assert np.ptp(np.gradient(h, g, axis=1)) < 1e-9  # no x-dependence: the slope rises towards +z only


def test_mesh_is_the_height_field_with_upward_normals_and_same_seed_same_bed():
    spec = SeabedSpec(seed=2, extent_m=4.0, cells=80, ripple_wavelength_m=0.2)
    V, F = seabed_mesh(spec)
    assert len(V) == 81 * 81 and len(F) == 2 * 80 * 80
    np.testing.assert_allclose(V[:, 1], height_at(spec, V[:, 0], V[:, 2]), atol=0)
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    assert np.all(n[:, 1] > 0)
    V2, _ = seabed_mesh(SeabedSpec(seed=2, extent_m=4.0, cells=80, ripple_wavelength_m=0.2))
    V3, _ = seabed_mesh(SeabedSpec(seed=3, extent_m=4.0, cells=80, ripple_wavelength_m=0.2))
    assert np.array_equal(V, V2) and not np.array_equal(V, V3)


def test_rays_meet_the_seabed_on_its_surface():
    spec = SeabedSpec(seed=5, extent_m=8.0, cells=200, ripple_wavelength_m=0.2, relief_m=0.2)
    M = np.eye(4)
    M[:3, 3] = (0.0, -1.5, 2.0)
    rng = np.random.default_rng(0)
    d = np.c_[rng.uniform(-0.5, 0.5, 200), -np.ones(200), rng.uniform(0.2, 1.5, 200)]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.zeros((200, 3))
    p = seabed_points(spec, M, o, d)
    ok = np.all(np.isfinite(p), axis=1)
    assert ok.mean() > 0.9
    local = p[ok] - M[:3, 3]
    np.testing.assert_allclose(local[:, 1], height_at(spec, local[:, 0], local[:, 2]), atol=1e-6)
    t = np.sum(p[ok] * d[ok], axis=1)
    np.testing.assert_allclose(p[ok], t[:, None] * d[ok], atol=1e-9)  # on the rays
    # first hit: no point of the ray before it is below the bed
    for k in np.flatnonzero(ok)[:20]:
        s = np.linspace(0.0, np.linalg.norm(p[k]) - 1e-4, 400)
        q = s[:, None] * d[k] - M[:3, 3]
        assert np.all(q[:, 1] > height_at(spec, q[:, 0], q[:, 2]))


def test_the_seabed_goes_on_beyond_the_patch_without_a_seam():
    """The far seabed starts on the patch's own boundary vertices (no crack for a ray to see water
    through), reaches ``far_m`` (a square of that side), keeps the slope, loses the ripples and relief
    one extent out, and faces up; and a camera 1.5 m above, looking 5° below the horizontal, sees the
    seabed (patch + far) in every direction down to the horizon where the patch alone ends at ~10 m."""
    from rigsim.preview.geometry import cast_rays, scene_surfaces
    from rigsim.scene.seabed import seabed_mesh_file
    from rigsim.scene.types import Camera, Port, Rig, Scene, Target

    spec = SeabedSpec(seed=6, extent_m=6.0, cells=120, ripple_wavelength_m=0.2, relief_m=0.1, slope_deg=3.0,
                      far_m=150.0)
    V, F = seabed_skirt(spec)
    P, _ = seabed_mesh(spec)
    patch_edge = P[(np.abs(P[:, 0]) == 3.0) | (np.abs(P[:, 2]) == 3.0)]
    ring0 = V[:4 * 120]
    assert len(patch_edge) == len(ring0)
    assert {tuple(v) for v in ring0} == {tuple(v) for v in patch_edge}  # the very same vertices
    assert np.max(np.abs(V[:, [0, 2]])) == pytest.approx(75.0)
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    assert np.all(n[:, 1] > 0)
    far = np.max(np.abs(V[:, [0, 2]]), axis=1) > 2 * 3.0  # one extent out: the slope's plane alone
    flat = SeabedSpec(seed=6, extent_m=6.0, cells=120, ripple_height_m=0.0, relief_m=0.0, slope_deg=3.0, far_m=150.0)
    np.testing.assert_allclose(V[far, 1], height_at(flat, V[far, 0], V[far, 2]), atol=1e-12)
    # through the engines' own surfaces: a level seabed (no slope) seen towards the horizon
    level = SeabedSpec(seed=6, extent_m=12.0, cells=240, ripple_wavelength_m=0.2)
    cam = Camera(focal_length_mm=20.0, sensor_width_mm=36.0, sensor_height_mm=24.0, port=Port(kind="dome"),
                 forward=(0.0, -math.sin(math.radians(5.0)), math.cos(math.radians(5.0))),
                 up=(0.0, math.cos(math.radians(5.0)), math.sin(math.radians(5.0))))
    surf = scene_surfaces(Scene(Rig("r", cam, ()), None, (Target("seabed", 1.5, mesh_path=str(seabed_mesh_file(level))),)))
    assert len(surf) == 2  # the patch and the seabed beyond it
    el = np.radians(np.linspace(-40.0, -1.0, 40))
    az = np.radians(np.linspace(-40.0, 40.0, 41))
    E, A = np.meshgrid(el, az)
    d = np.stack([np.cos(E) * np.sin(A), np.sin(E), np.cos(E) * np.cos(A)], -1)
    t, oid = cast_rays(surf, np.asarray(cam.position_m, float), d)
    assert np.all(oid > 0)  # the seabed everywhere below the horizon (down to 1° below it: 86 m away)
    assert np.any((oid == 2) & (t > 20.0)) and np.any(oid == 1)


def test_a_grid_too_coarse_for_the_ripples_is_refused():
    with pytest.raises(ConfigError, match="cannot draw ripples") as e:
        SeabedSpec(extent_m=12.0, cells=100, ripple_wavelength_m=0.2, ripple_height_m=0.02)
    assert "\n" not in str(e.value) and "SeabedSpec.cells" in str(e.value)
    with pytest.raises(ConfigError, match="slope_deg"):
        SeabedSpec(slope_deg=60.0)
    with pytest.raises(ConfigError, match="far_m"):
        SeabedSpec(extent_m=12.0, far_m=10.0)


def test_benthic_reflectances_have_the_features_of_their_kinds():
    """Maritorena et al. (1994)'s bottom types as loaded: carbonate sand brightest everywhere in the
    visible and rising to the red; every alga dips at chlorophyll a's red absorption (~675 nm) and rises
    into the near infrared; the green alga peaks in the green, the coralline red alga in the orange-red;
    held beyond the table (800 nm) to 830 nm."""
    from rigsim.scene.reflectances import REFLECTANCE_WAVELENGTHS_NM as wl, reflectance_benthic_Maritorena1994

    r = reflectance_benthic_Maritorena1994()
    vis = (wl >= 400) & (wl <= 700)
    for k in ("green_algae", "brown_algae", "red_algae"):
        assert np.all(r["coral_sand"][vis] > r[k][vis])
        i675 = int(np.argmin(np.abs(wl - 675)))
        assert r[k][i675] < r[k][int(np.argmin(np.abs(wl - 650)))] and r[k][i675] < r[k][int(np.argmin(np.abs(wl - 700)))]
        assert r[k][-1] > 2 * r[k][i675]
    assert np.all(np.diff(r["coral_sand"][vis]) > 0)
    mid = (wl >= 450) & (wl <= 650)  # (below the red edge)
    assert 540 <= wl[mid][np.argmax(r["green_algae"][mid])] <= 560
    assert 590 <= wl[mid][np.argmax(r["red_algae"][mid])] <= 650
    assert all(np.all(v[wl >= 800] == v[wl == 800][0]) for v in r.values())


def test_the_seabed_is_coral_sand_and_rocks_wear_benthic_covers():
    from rigsim.dataset import load_dataset_spec
    from rigsim.dataset.sample import build_sample_scene, draw_sample
    from rigsim.scene.reflectances import reflectance_benthic_Maritorena1994
    from rigsim.scene.surfaces import target_surfaces

    spec = load_dataset_spec("datasets/seabed.toml")
    rec = draw_sample(spec, 3, 0)
    scene, _ = build_sample_scene(spec, rec)
    bed = target_surfaces(scene.targets[0], scene.camera)[0]
    np.testing.assert_allclose(bed.reflectance, reflectance_benthic_Maritorena1994()["coral_sand"])
    covers = {o["reflectance"]["label"] for o in rec["seabed"]["rocks"] + rec["seabed"]["rubble"]}
    assert covers and covers <= {"coral_sand", "green_algae", "brown_algae", "red_algae"}
