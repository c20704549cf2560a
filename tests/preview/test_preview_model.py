"""The preview against exact solutions and independent integrals; its layers, outputs and errors.

No Mitsuba here (the comparisons with the renderer are in ``test_preview_vs_render.py``).
These check the analytic model (the paths with at most one wide-angle scattering), so every
image here is made without the multiply scattered light (``multiple=False``), which
``test_multiple.py`` checks.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigsim.config.rig import load_rig
from rigsim.errors import ConfigError
from rigsim.preview import PREVIEW_LAYERS, RENDERER_NAME
from rigsim.preview import render_preview as _render_preview
from rigsim.preview.forward import SmallAngle
from rigsim.scene.build import build_scene
from rigsim.scene.phase_tables import phase_tables
from rigsim.scene.types import BeamPattern, Daylight, Rig, Scene, Target
from rigsim.spectral_image import SpectralImage
from rigsim.water import preset
from tests.preview.helpers import (
    absorbing_water,
    backscatter_brute_force,
    direct_reference,
    disk_scene,
    dome_camera,
    make_light,
)

WL = [450.0, 550.0, 650.0]
BW = 10.0


def render_preview(scene, **kw):
    """The analytic model alone (see module docstring), at the pixel centres (the exact solutions below
    are per pixel centre; the edge pixels' box mean is tested on its own)."""
    return _render_preview(scene, **{"multiple": False, "edge_samples": 1, **kw})


def _two_lights(kind="strobe"):
    return [make_light(kind, position=(0.4, 0.2, 0.0), aim=(np.sin(np.radians(20)), 0.0, np.cos(np.radians(20))),
                       intensity=3.0, beam=BeamPattern(beam_angle_deg=60.0), name="a"),
            make_light(kind, position=(-0.3, 0.1, 0.05), intensity=(1.0, 2.0), name="b")]


# --------------------------------------------------------------------------- exact solutions
@pytest.mark.parametrize("kind", ["strobe", "continuous"])
def test_non_scattering_water_is_beer_lambert_exactly(kind):
    """b = 0: L = ρ I f(θ) cos θ_i/(π r²) exp(−c (r_l + r_c)) per pixel; no backscatter, no forward part."""
    scene = disk_scene(absorbing_water(), _two_lights(kind), distance=1.5, size=0.9)
    w, h = 18, 18
    img = render_preview(scene, width=w, height=h, wavelengths_nm=WL, bandwidth_nm=BW, split=True)
    ref, on = direct_reference(scene, w, h, WL, BW)
    prefix = "flash_" if kind == "strobe" else ""
    full = img.layers["flash"] if kind == "strobe" else img.radiance
    assert on.sum() > 50
    np.testing.assert_allclose(img.layers[f"{prefix}direct"][on], ref[on], rtol=2e-3)
    np.testing.assert_allclose(full, img.layers[f"{prefix}direct"], rtol=1e-6, atol=0)
    assert np.all(img.layers[f"{prefix}backscatter"] == 0)
    assert np.all(full[~on] == 0)
    if kind == "strobe":
        assert np.all(img.radiance == 0)


def test_no_water_equals_clear_layer():
    scene = disk_scene(None, _two_lights(), distance=1.5, size=0.9)
    img = render_preview(scene, width=14, height=14, wavelengths_nm=WL, bandwidth_nm=BW, split=True,
                         layers=("clear",))
    ref, on = direct_reference(scene, 14, 14, WL, BW)
    np.testing.assert_allclose(img.layers["flash"][on], ref[on], rtol=2e-3)
    np.testing.assert_allclose(img.layers["flash_clear"], img.layers["flash"], rtol=1e-6)
    assert np.all(img.layers["flash_backscatter"] == 0)


def test_clear_layer_is_the_view_without_water():
    lights = _two_lights()
    wet = render_preview(disk_scene(preset("coastal"), lights, size=0.9), width=12, height=12,
                         wavelengths_nm=WL, bandwidth_nm=BW)
    dry = render_preview(disk_scene(None, lights, size=0.9), width=12, height=12, wavelengths_nm=WL, bandwidth_nm=BW)
    np.testing.assert_allclose(wet.layers["flash_clear"], dry.layers["flash"], rtol=1e-6)


@pytest.mark.parametrize("pixel", [(0.5, 0.5), (0.05, 0.1), (0.8, 0.7)])
def test_single_backscatter_matches_brute_force_integral(pixel):
    """Classical single scattering (forward_scatter=False) against a 200 001-point integral with phase.eval."""
    water = preset("coastal")
    lights = [make_light(position=(-0.4, 0.1, 0.0)),
              make_light(position=(0.3, 0.1, 0.0), aim=(0.2, 0.0, 1.0), intensity=(2.0, 0.5))]
    scene = disk_scene(water, lights, distance=3.0, size=0.5, camera=dome_camera(24.0, (36.0, 24.0)))
    w, h = 30, 20
    col, row = int(pixel[0] * w), int(pixel[1] * h)
    ref = backscatter_brute_force(scene, (col + 0.5) / w, (row + 0.5) / h, WL)
    for grid in (None, 16):
        img = render_preview(scene, width=w, height=h, wavelengths_nm=WL, bandwidth_nm=1e-3, split=True,
                             forward_scatter=False, backscatter_grid=grid)
        np.testing.assert_allclose(img.layers["flash_backscatter"][row, col], ref, rtol=2e-3)


def test_vanishing_forward_cutoff_is_the_single_scattering_model():
    scene = disk_scene(preset("coastal"), _two_lights(), distance=2.0, size=0.6)
    kw = dict(width=16, height=16, wavelengths_nm=WL, bandwidth_nm=BW, split=True)
    a = render_preview(scene, forward_scatter=False, **kw)
    b = render_preview(scene, forward_cutoff_deg=1e-3, **kw)
    for k in ("flash", "flash_direct", "flash_backscatter"):
        np.testing.assert_allclose(b.layers[k], a.layers[k], rtol=2e-3, atol=1e-12)


# --------------------------------------------------------------------------- layers
def test_layers_add_up():
    """radiance = direct + forward-scattered + backscatter: exact without forward scattering; the forward
    part is ≥ 0 and vanishes off the target far from it."""
    scene = disk_scene(preset("coastal"), _two_lights(), distance=2.0, size=0.6)
    kw = dict(width=24, height=24, wavelengths_nm=WL, bandwidth_nm=BW, split=True)
    single = render_preview(scene, forward_scatter=False, **kw)
    np.testing.assert_allclose(single.layers["flash"],
                               single.layers["flash_direct"] + single.layers["flash_backscatter"], rtol=1e-5)
    img = render_preview(scene, **kw)
    fwd = img.layers["flash"] - img.layers["flash_direct"] - img.layers["flash_backscatter"]
    assert fwd.min() > -1e-6 * img.layers["flash"].max()
    on = img.layers["object_id"] > 0
    assert np.all(fwd[on].mean(axis=0) > 0.2 * img.layers["flash_direct"][on].mean(axis=0))
    # the unscattered part is the same in both models
    np.testing.assert_allclose(img.layers["flash_direct"], single.layers["flash_direct"], rtol=1e-6)


def test_outputs_match_the_renderer_interface():
    scene = disk_scene(preset("clear"), _two_lights() + [make_light("continuous", position=(0, 0.3, 0), name="v")],
                       size=0.6)
    img = render_preview(scene, width=12, height=12, layers=PREVIEW_LAYERS, spp=128, seed=7)
    assert isinstance(img, SpectralImage)
    assert img.radiance.shape == (12, 12, 31) and img.radiance.dtype == np.float32
    assert set(img.layers) == {"range_m", "object_id", "clear", "direct", "backscatter", "flash", "flash_clear",
                               "flash_direct", "flash_backscatter", "particles", "flash_particles", "particle_id"}
    # a water without discrete particles: no specks, no particle ids
    assert not np.any(img.layers["particles"]) and not np.any(img.layers["particle_id"])
    assert img.layers["object_id"].dtype == np.int32 and img.layers["range_m"].dtype == np.float32
    assert img.meta["renderer"] == RENDERER_NAME
    assert img.meta["object_ids"] == {"1": "target 0 white-disk: disk"}
    for k in ("wall_time_s", "fov_water_x_deg", "radiance_reference", "scene_hash", "wavelength_nm"):
        assert k in img.meta
    assert img.layers["range_m"][6, 6] == pytest.approx(1.5, rel=1e-3)
    assert np.isinf(img.layers["range_m"][0, 0])
    again = render_preview(scene, width=12, height=12, layers=PREVIEW_LAYERS)
    np.testing.assert_array_equal(again.radiance, img.radiance)  # deterministic, spp/seed ignored


def test_colorchecker_object_ids_follow_target_surfaces():
    from rigsim.config.rig import load_rig
    from rigsim.scene.build import build_scene

    sc = build_scene(load_rig("rigs/twin-strobes-45-wide.toml"), "coastal", "colorchecker", 1.0)
    img = render_preview(sc, width=60, height=40, layers=("object_id",), wavelengths_nm=[550.0])
    assert len(img.meta["object_ids"]) == 25
    assert img.meta["object_ids"]["20"] == "target 0 colorchecker: white 9.5 (.05 D)"
    assert set(np.unique(img.layers["object_id"])) >= {0, 1, 20}


@pytest.mark.parametrize("kw, msg", [
    (dict(width=0), "width"),
    (dict(layers=("nope",)), "unknown layer"),
    (dict(wavelengths_nm=[500.0, 400.0]), "increase"),
    (dict(forward_cutoff_deg=120.0), "cut-off"),
])
def test_bad_input_is_a_config_error(kw, msg):
    scene = disk_scene(preset("clear"), _two_lights())
    with pytest.raises(ConfigError, match=msg):
        render_preview(scene, **{"width": 8, "height": 8, **kw})


def test_shadows_darken_what_is_hidden_from_a_light():
    """A small disk in front of a large one shadows it from a light on the axis (shadows=True; the default
    "auto" turns them on for two targets)."""
    cam = dome_camera(35.0)
    light = make_light(position=(0.0, 0.0, 0.2))
    t_front = Target("black-disk", 1.0, size_m=0.2)
    t_back = Target("white-disk", 2.0, size_m=1.5)
    scene = Scene(Rig("r", cam, (light,)), absorbing_water(), (t_front, t_back))
    kw = dict(width=32, height=32, wavelengths_nm=[550.0], split=True)
    lit = render_preview(scene, shadows=False, **kw)
    shad = render_preview(scene, shadows=True, **kw)
    np.testing.assert_array_equal(render_preview(scene, **kw).layers["flash_direct"], shad.layers["flash_direct"])
    oid = shad.layers["object_id"]
    # back-disk pixels just outside the front disk's image are in its shadow (light behind the camera)
    ring = (oid == 2) & (shad.layers["flash_direct"][..., 0] < 0.5 * lit.layers["flash_direct"][..., 0])
    assert ring.sum() > 10
    assert np.all(shad.layers["flash_direct"] <= lit.layers["flash_direct"] + 1e-12)


# --------------------------------------------------------------------------- small-angle machinery
def test_small_angle_kernel_is_normalised_and_conserves_energy():
    water = preset("coastal")
    comps = phase_tables(water.phase, water.wavelength_range_nm)
    wl = np.array(WL)
    sa = SmallAngle(comps, np.pi / 2, water.b_per_m(wl), comps.weights_at(wl))
    assert np.allclose(sa.q(np.array([0.0]))[0], sa.F)
    np.testing.assert_allclose(sa.F, 1 - water.phase.backscatter_fraction(wl), rtol=1e-6)
    assert np.allclose(sa.kernel(np.array([0.0]), sa.b * 2.0)[0], 1.0)
    src = np.zeros((64, 64, 3))
    src[28:36, 28:36] = 1.0
    # a frame of 64 × 3° holds the whole forward hemisphere of the kernel: energy is conserved
    out = sa.blur_image(src, np.full((64, 64), 2.0), (np.radians(3.0), np.radians(3.0)))
    assert out.min() > -1e-6
    np.testing.assert_allclose(out.sum(axis=(0, 1)), src.sum(axis=(0, 1)), rtol=0.01)
    # a narrow frame (64 × 0.2°) loses the wide-angle part of the kernel, keeps the core
    narrow = sa.blur_image(src, np.full((64, 64), 2.0), (np.radians(0.2), np.radians(0.2)))
    kept = narrow.sum(axis=(0, 1)) / src.sum(axis=(0, 1))
    assert np.all((kept > 0.3) & (kept < 0.95))
    assert np.all(narrow[32, 32] < 1.0) and np.all(narrow[10, 10] > 0)


@pytest.mark.parametrize("port", [0.0, 0.12])
def test_the_camera_legs_blur_has_the_spread_of_its_scatterings_in_the_water(port):
    """The blur of a point 1 m away spreads it by the scatterings in the water between the port and the point:
    N of them (Poisson, mean ``b F s``, ``s`` the water crossed, given at least one) each seen ``ψ u / D`` off the
    point (ψ from the phase function's cells below ψ_c, ``u`` uniform over the water, ``D`` the distance from the
    rays' viewpoint): the image's mean squared offset is ``E[N | N ≥ 1] ⟨ψ²⟩ a² / 3``, ``a = s / D``.  Behind an
    0.12 m dome (the water starts 0.12 m from the pupil) that is 0.67 of the spread with the water taken to
    start at the pupil, which this tells apart (``port = 0``: the same formula with s = D = 1 m)."""
    water = preset("coastal")
    comps = phase_tables(water.phase, water.wavelength_range_nm)
    wl = np.array([550.0])
    cut = np.radians(30.0)
    sa = SmallAngle(comps, cut, water.b_per_m(wl), comps.weights_at(wl))
    n, pitch = 255, np.radians(0.5)
    src = np.zeros((1, n, n), np.float32)
    src[0, n // 2, n // 2] = 1.0
    rng = np.full((n, n), np.inf)
    rng[n // 2, n // 2] = 1.0
    plan = sa.blur_plan(rng, (pitch, pitch), src[0] > 0, port_m=port)
    out = plan.blur(0, src[0]).astype(float)
    y, x = (np.mgrid[:n, :n] - n // 2) * pitch
    m2 = np.sum(out * (x * x + y * y)) / np.sum(out)
    cells = comps.forward_cells(cut)
    e = comps.grid.psi_edges
    lo, hi = e[:-1][cells], e[1:][cells]
    psi = np.where(lo > 0, np.sqrt(np.maximum(lo, 1e-300) * hi), hi / 2)  # as saa_transform's nodes
    m = sa.w[0] @ comps.masses[:, cells]
    s_w, D = 1.0 - port, 1.0
    mu = sa.b[0] * sa.F[0] * s_w
    expected = mu / -np.expm1(-mu) * (m @ psi ** 2) / m.sum() * (s_w / D) ** 2 / 3
    assert np.sum(out) == pytest.approx(1.0, rel=0.01)
    assert m2 == pytest.approx(expected, rel=0.03)


def test_the_camera_legs_blur_is_the_same_in_angle_at_the_image_centre_and_off_it():
    """On the azimuthal equidistant grid (:func:`rigsim.scene.optics.equidistant_maps`) the halo of a point 30°
    off the axis of a 24 mm lens behind a dome spreads as far in angle as one on the axis: its mean squared
    angle from the point (within 6°, inside the frame at both places) within 2 % of the centre's (0.998).
    Laid out on the pixels with the centre's pitch it was 0.942 of it (the pixels there are cos² θ narrower
    along the radius)."""
    import dataclasses as dc

    from rigsim.scene.optics import angular_pitch_rad, camera_rays, equidistant_maps

    rig = load_rig("rigs/single-strobe-short-arm.toml")
    cam = rig.camera
    W, H = 240, 160
    n_out = 1.34
    water = preset("coastal")
    comps = phase_tables(water.phase, water.wavelength_range_nm)
    wl = np.array([550.0])
    sa = SmallAngle(comps, np.radians(30.0), water.b_per_m(wl), comps.weights_at(wl))
    pitch = angular_pitch_rad(cam, W, H, n_outside=n_out)
    X, Y = np.meshgrid((np.arange(W) + 0.5) / W, (np.arange(H) + 0.5) / H)
    _, d = camera_rays(cam, X, Y, n_outside=n_out)
    fwd = np.asarray(cam.frame()[2], float)
    omega = (d @ fwd) ** 3  # a pinhole's pixel solid angle, relative

    def spread(row, col, warp):
        src = np.zeros((H, W), np.float32)
        src[row, col] = 1.0
        rng = np.where(src > 0, 0.6, np.inf)
        kw = {"warp": equidistant_maps(cam, W, H, n_outside=n_out, pitch_rad=pitch)} if warp else {}
        out = sa.blur_plan(rng, pitch, src > 0, port_m=0.1, **kw).blur(0, src).astype(float)
        ang = np.arccos(np.clip(d @ d[row, col], -1, 1))
        near = ang < np.radians(6.0)  # the halo's core, inside the frame at both places
        wgt = out * omega * near
        return np.sum(wgt * ang ** 2) / np.sum(wgt)

    r_off, c_off = H // 2 - 45, W // 2 + 82  # about 30° off the axis, up and to the right
    assert np.degrees(np.arccos(d[r_off, c_off] @ fwd)) > 28
    centre = spread(H // 2, W // 2, True)
    assert spread(r_off, c_off, True) == pytest.approx(centre, rel=0.02)
    assert spread(r_off, c_off, False) < 0.96 * spread(H // 2, W // 2, False)  # the pixel grid's (can fail)


def test_phase_tables_reproduce_the_water_phase_function():
    water = preset("coastal")
    comps = phase_tables(water.phase, water.wavelength_range_nm)
    mu = np.cos(np.radians([0.05, 1.0, 10.0, 60.0, 120.0, 175.0]))
    for lam in WL:
        val = comps.eval_components(mu) @ comps.weights_at([lam])[0]
        np.testing.assert_allclose(val, water.phase.eval(mu, lam), rtol=2e-3)


# --------------------------------------------------------------------------- daylight
def test_daylight_lights_the_target_and_the_water():
    cam = dome_camera(35.0)
    scene = Scene(Rig("r", cam, ()), preset("coastal"), (Target("white-disk", 2.0, size_m=0.6),),
                  daylight=Daylight(depth_m=5.0, sun_zenith_deg=30.0))
    img = render_preview(scene, width=16, height=16, wavelengths_nm=WL, bandwidth_nm=BW, split=True)
    on = img.layers["object_id"] > 0
    # the disk is lit: white is brighter than black in the same place (whether it is brighter than the
    # water beside it depends on the field's angular shape: the water looking up is brighter)
    black = render_preview(Scene(scene.rig, scene.water, (Target("black-disk", 2.0, size_m=0.6),),
                                 daylight=scene.daylight), width=16, height=16, wavelengths_nm=WL, bandwidth_nm=BW)
    assert np.all(img.radiance[on].mean(axis=0) > 1.5 * black.radiance[on].mean(axis=0))
    assert np.all(img.layers["backscatter"][~on] > 0)
    assert "flash" not in img.layers
    assert img.meta["daylight_rendered"] is True
    # deeper is darker
    deep = Scene(scene.rig, scene.water, scene.targets, daylight=Daylight(depth_m=15.0, sun_zenith_deg=30.0))
    img2 = render_preview(deep, width=16, height=16, wavelengths_nm=WL, bandwidth_nm=BW)
    assert np.all(img2.radiance.mean(axis=(0, 1)) < img.radiance.mean(axis=(0, 1)))


def test_a_band_straddling_a_step_in_the_light_spectrum_gets_its_average():
    """A flash spectrum that starts at 400 nm (zero below, as the renderer reads a table): the band
    395–405 nm holds half the light of the band 405–415 nm, in the direct image and in the veil
    (the fast engine read the band centre for the veil: +85 % in that band against Monte Carlo)."""
    from rigsim.spectrum import band_average

    wl_tab = (360.0, 399.999, 400.0, 830.0)
    light = make_light("strobe", position=(0.3, 0.0, 0.0), intensity=(0.0, 0.0, 1.0, 1.0), wavelength_nm=wl_tab)
    assert float(band_average(wl_tab, (0.0, 0.0, 1.0, 1.0), 395.0, 405.0)) == pytest.approx(0.5, abs=1e-4)
    water = preset("clear")

    def band_ratio(lt, layer):
        img = render_preview(disk_scene(water, [lt], size=0.6), width=32, height=32, wavelengths_nm=[400.0, 410.0],
                             bandwidth_nm=10.0, split=True)
        a = np.asarray(img.layers[layer], float)
        return a[..., 0].sum() / a[..., 1].sum()

    flat = make_light("strobe", position=(0.3, 0.0, 0.0), intensity=1.0, wavelength_nm=wl_tab)
    for layer in ("flash_direct", "flash_backscatter"):
        # the same scene with a flat spectrum takes out the water's and target's own difference between the bands
        ratio = band_ratio(light, layer) / band_ratio(flat, layer)
        assert ratio == pytest.approx(0.5, rel=0.01), (layer, ratio)


def test_edge_pixels_box_mean_equals_full_supersampling():
    """Supersampling only the pixels on an edge (4 × 4 jittered samples) gives the image that a 16 × 16
    grid in every pixel gives (the surfaces' light and the veil are smooth inside an object), and it
    differs from the pixel centres' image on the edges.  A disk: its rim crosses the pixels at every
    angle (along a straight edge on the pixel grid a fixed grid is wrong the same way in every pixel;
    the jittered samples are not, and their mean over a region is unbiased)."""
    rig = load_rig("rigs/twin-strobes-close-to-port.toml")
    scene = build_scene(rig, "clear", "white-disk", 1.0, size_m=0.5)
    kw = dict(width=48, height=32, wavelengths_nm=WL, bandwidth_nm=BW, split=True)
    edge = render_preview(scene, edge_samples=4, **kw).layers["flash"]
    full = render_preview(scene, pixel_samples=16, **kw).layers["flash"]
    centre = render_preview(scene, edge_samples=1, **kw).layers["flash"]
    np.testing.assert_allclose(edge.sum(axis=(0, 1)), full.sum(axis=(0, 1)), rtol=3e-3)
    assert np.max(np.abs(edge - full)) <= 0.1 * np.max(full)  # one rim pixel: 16 jittered samples
    assert np.max(np.abs(centre - full)) > 0.2 * np.max(full)  # the rim aliases


def _jerlov_9c_at_450():
    """Jerlov 9C at 450 nm with ψ_c = 30°: ``(tables, ψ_c rad, b (1,), SmallAngle, bw (K, 1), F, β per cell,
    β by more than ψ_c per cell)`` (β in 1/(m sr))."""
    water = preset("jerlov-9C")
    wl = np.array([450.0])
    comps = phase_tables(water.phase, water.wavelength_range_nm)
    cut = np.radians(30.0)
    w = comps.weights_at(wl)
    b = water.b_per_m(wl)
    sa = SmallAngle(comps, cut, b, w)
    full = (comps.densities.T @ w[0]) * b[0]  # (cells,) phase function (1/sr) times b
    return comps, cut, b, sa, (b[:, None] * w).T, float(sa.F[0]), full, np.where(comps.forward_cells(cut), 0.0, full)


def _turned(d: np.ndarray, N: np.ndarray, comps, wavelength_nm: float, cutoff_rad: float, rng) -> np.ndarray:
    """Unit directions ``d`` (n, 3) each turned ``N`` times about a random axis, each turn drawn from the phase
    function's cells below ψ_c: the component by its share ``w_k F_k`` of the scattering by less than ψ_c, the
    cell by mass among its forward cells (its cdf's first ``F_k``), uniform in ``1 − cos`` inside the cell."""
    w = comps.weights_at([wavelength_nm])[0]
    F_k = comps.forward_fraction(cutoff_rad)
    share = np.cumsum(w * F_k) / np.sum(w * F_k)
    d = d.copy()
    for k in range(int(N.max(initial=0))):
        m = N > k
        comp = np.minimum(np.searchsorted(share, rng.random(m.sum()), side="right"), len(w) - 1)
        u = rng.random(m.sum()) * F_k[comp]
        cell = np.empty(u.shape, np.int64)
        for j in range(len(w)):
            sel = comp == j
            cell[sel] = np.searchsorted(comps.cdfs[j], u[sel], side="right") - 1
        v0, v1 = comps.v_edges[cell], comps.v_edges[cell + 1]
        cos_t = 1.0 - (v0 + rng.random(m.sum()) * (v1 - v0))
        sin_t = np.sqrt(np.clip(1 - cos_t ** 2, 0, None))
        phi = 2 * np.pi * rng.random(m.sum())
        dm = d[m]
        a = np.where(np.abs(dm[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
        u = np.cross(dm, a)
        u /= np.linalg.norm(u, axis=1, keepdims=True)
        v = np.cross(dm, u)
        d[m] = cos_t[:, None] * dm + sin_t[:, None] * (np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v)
    return d


def test_the_spread_of_forward_scattered_light_matches_its_turned_directions():
    """:meth:`SmallAngle.spread_beta` (the wide-angle volume scattering function averaged over the directions
    that N ≥ 1 scatterings by less than ψ_c, N Poisson of mean bF r, give the beam's light; Legendre moments
    on the sphere) against drawing those turns: from a start direction, N turns each drawn from the phase
    function's cells below ψ_c about a random axis, then β by more than ψ_c at the angle between the final
    direction and a fixed one.  Jerlov 9C, 450 nm, after 0.3 and 1 m of water; angles 60–175° from the
    line (where the quasi-single veil is seen from).  Z-tests of the drawn means; and the spread function
    integrates to b (1 − F) over the sphere (a rotation average keeps the integral)."""
    rng = np.random.default_rng(7)
    comps, cut, b, sa, bw, F, _, wide = _jerlov_9c_at_450()
    psi = np.linspace(0.0, np.pi, 4001)
    for r in (0.3, 1.0):
        total = 2 * np.pi * np.trapezoid(sa.spread_beta(np.cos(psi), np.full(psi.shape, r), bw)[:, 0] * np.sin(psi), psi)
        assert total == pytest.approx(b[0] * (1 - F), rel=0.01)
        mu = b[0] * F * r
        n = 200_000
        N = rng.poisson(mu, n)
        while np.any(N == 0):  # N ≥ 1 (the light that has been turned at least once)
            N[N == 0] = rng.poisson(mu, int(np.sum(N == 0)))
        d = _turned(np.tile([0.0, 0.0, 1.0], (n, 1)), N, comps, 450.0, cut, rng)
        for ang in (60.0, 100.0, 140.0, 175.0):
            view = np.array([np.sin(np.radians(ang)), 0.0, np.cos(np.radians(ang))])
            samples = wide[comps.grid.cell_index(np.clip(d @ view, -1, 1))]
            got = sa.spread_beta(np.cos(np.radians(ang)), r, bw)[0]
            # within 1 % (the series' window, the tables' nodes) beyond the draws' 4 standard errors
            excess = max(abs(samples.mean() - got) - 0.01 * got, 0.0)
            assert excess < 4.0 * samples.std() / np.sqrt(n), (r, ang, samples.mean(), got)
            # and the turns matter here: β itself (the light going straight on) is off by more
            if ang >= 140.0:
                straight = wide[comps.grid.cell_index(np.cos(np.radians(ang)))]
                assert abs(straight / samples.mean() - 1) > 0.02, (r, ang, straight, samples.mean())


def test_the_turns_of_both_legs_give_the_veil_the_phase_function_of_their_drawn_directions():
    """:meth:`SmallAngle.two_leg_beta` (the quasi-single veil's β with small-angle turns on the light's leg and
    on the camera's, each leg's count Poisson of mean bF times its length) against drawing them: the light's
    direction turned N_r times from the line from the light, the line of sight's N_s times from the line to
    the camera (reciprocity: the light that reaches the pupil along it left the scattering along a direction
    so spread), β by more than ψ_c at the angle between the two (β itself where neither turned).  Jerlov 9C,
    450 nm, 60–175°; ``beta_s`` is the mean over N_r = 0, ``delta / (1 − e^{−μ_r})`` over N_r ≥ 1.  Z-tests
    of the drawn means; and the camera leg's turns matter there (β seen straight is off by more)."""
    rng = np.random.default_rng(11)
    comps, cut, b, sa, bw, F, full, wide = _jerlov_9c_at_450()
    n = 100_000
    for r, s in ((0.5, 0.3), (1.0, 1.0)):
        mu_r, mu_s = b[0] * F * r, b[0] * F * s
        N_s = rng.poisson(mu_s, n)
        N_r = rng.poisson(mu_r, n)
        while np.any(N_r == 0):  # the light turned at least once on its leg
            N_r[N_r == 0] = rng.poisson(mu_r, int(np.sum(N_r == 0)))
        light_turned = _turned(np.tile([0.0, 0.0, 1.0], (n, 1)), N_r, comps, 450.0, cut, rng)
        for ang in (60.0, 100.0, 140.0, 175.0):
            cos_psi = np.cos(np.radians(ang))
            view = np.array([np.sin(np.radians(ang)), 0.0, cos_psi])
            view_turned = _turned(np.tile(view, (n, 1)), N_s, comps, 450.0, cut, rng)
            straight = full[comps.grid.cell_index(np.array([cos_psi]))]  # (1,)
            beta_s, delta = sa.two_leg_beta(np.array([cos_psi]), straight[:, None], np.array([r]), np.array([s]), bw)
            # N_r = 0: the light along its line, the line of sight turned (β itself where it was not)
            cos_s = np.clip(view_turned[:, 2], -1, 1)
            drawn_s = np.where(N_s > 0, wide[comps.grid.cell_index(cos_s)], straight[0])
            # N_r ≥ 1: both turned
            drawn_rs = wide[comps.grid.cell_index(np.clip(np.sum(light_turned * view_turned, axis=1), -1, 1))]
            for drawn, got in ((drawn_s, beta_s[0, 0]), (drawn_rs, delta[0, 0] / -np.expm1(-mu_r))):
                # within 0.5 % (the series' window, the tables' nodes; measured ≤ 0.3 %) beyond the draws' 4 SE
                excess = max(abs(drawn.mean() - got) - 0.005 * got, 0.0)
                assert excess < 4.0 * drawn.std() / np.sqrt(n), (r, s, ang, drawn.mean(), got)
            if ang >= 140.0 and s >= 1.0:  # the camera leg's turns matter: the light leg's spread alone is off by more
                alone = sa.spread_beta(np.array([cos_psi]), np.array([r]), bw)[0, 0]
                assert abs(alone / drawn_rs.mean() - 1) > 0.02, (r, s, ang, alone, drawn_rs.mean())
                assert abs(straight[0] / drawn_s.mean() - 1) > 0.02, (r, s, ang, straight[0], drawn_s.mean())
