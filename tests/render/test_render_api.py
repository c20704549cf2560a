"""render(): ports and field of view, seeds, layers, light kinds, hero wavelengths in a render,
and clear one-line errors for bad input."""

from __future__ import annotations

import numpy as np
import pytest

from rigsim.errors import ConfigError
from rigsim.render import render
from rigsim.render.variant import mitsuba
from rigsim.scene.optics import camera_rays, fov_water_deg
from rigsim.scene.types import Camera, Port, Rig, Scene, Target
from rigsim.spectral_image import SpectralImage
from rigsim.water import preset
from rigsim.water.kd import WATER_INDEX
from tests.render.helpers import disk_scene, make_camera, make_light

pytestmark = pytest.mark.render
mi, dr = mitsuba()


# --------------------------------------------------------------------------- ports / FOV
def test_flat_port_fov_follows_snell_dome_keeps_air_fov():
    cam_flat = Camera(focal_length_mm=14.0, port=Port(kind="flat"))
    cam_dome = Camera(focal_length_mm=14.0, port=Port(kind="dome"))
    half_air = np.radians(cam_flat.fov_air_x_deg) / 2
    assert fov_water_deg(cam_dome) == pytest.approx(cam_dome.fov_air_x_deg)
    assert fov_water_deg(cam_flat) == pytest.approx(np.degrees(2 * np.arcsin(np.sin(half_air) / WATER_INDEX)))
    # the traced edge rays: right edge of the centre row
    for cam, expect in ((cam_flat, np.arcsin(np.sin(half_air) / WATER_INDEX)), (cam_dome, half_air)):
        o, d = camera_rays(cam, np.array([1.0, 0.5]), np.array([0.5, 0.5]), n_outside=WATER_INDEX)
        ang = np.arccos(np.clip(d[:, 2], -1, 1))
        assert ang[0] == pytest.approx(expect, rel=1e-5)
        assert ang[1] == pytest.approx(0.0, abs=1e-6)
        # the image's right is forward × up = −x for forward +z, up +y
        assert d[0, 0] < 0


def test_flat_port_image_narrows_by_snell():
    """A disk's image is wider behind a flat port by tan θ_air / tan θ_water (Snell)."""
    r, D, W, H = 0.6, 2.0, 120, 80
    widths = {}
    for kind in ("flat", "dome"):
        port = Port(kind=kind, radius_m=1e-4, thickness_m=1e-6, standoff_m=1e-6)
        cam = Camera(focal_length_mm=20.0, port=port)
        scene = Scene(Rig("r", cam, ()), None, (Target("white-disk", D, size_m=2 * r),))
        img = render(scene, width=W, height=H, spp=1, wavelengths_nm=[550.0], layers=("object_id", "range_m"))
        row = img.layers["object_id"][H // 2]
        cols = np.flatnonzero(row == 1)
        widths[kind] = (cols[-1] - cols[0] + 1) / 2  # half width in pixels
        tan_half = 36.0 / (2 * 20.0)
        th_w = np.arctan(r / D)
        th_a = np.arcsin(WATER_INDEX * np.sin(th_w)) if kind == "flat" else th_w
        assert widths[kind] == pytest.approx(W / 2 * np.tan(th_a) / tan_half, abs=1.0)
        # range at the centre pixel: the distance to the disk along that ray
        assert img.layers["range_m"][H // 2, W // 2] == pytest.approx(D, rel=1e-3)
        assert np.isinf(img.layers["range_m"][0, 0])
    assert widths["flat"] / widths["dome"] == pytest.approx(
        np.tan(np.arcsin(WATER_INDEX * np.sin(np.arctan(r / D)))) / (r / D), rel=0.03)


# --------------------------------------------------------------------------- seeds
def _scattering_scene():
    light = make_light("continuous", position=(0.2, 0.0, 0.0), intensity=2.0)
    return disk_scene(preset("coastal"), [light], distance=1.5, size=1.0)


def test_same_seed_same_image_other_seed_other_image():
    s = _scattering_scene()
    kw = dict(width=12, height=8, spp=8, wavelengths_nm=[450.0, 550.0], layers=())
    a, b, c = render(s, seed=1, **kw), render(s, seed=1, **kw), render(s, seed=2, **kw)
    assert np.array_equal(a.radiance, b.radiance)
    assert not np.array_equal(a.radiance, c.radiance)
    assert np.all(np.isfinite(a.radiance)) and a.meta["seed"] == 1 and a.meta["spp"] == 8


# --------------------------------------------------------------------------- hero wavelengths
def test_band_radiance_independent_of_the_other_bands_of_the_path():
    """Backscatter (all scattering) in coastal water: each band of a two-band render, whose
    paths mix wavelengths of both bands, equals a render of that band alone."""
    light = make_light("continuous", position=(0.3, 0.0, 0.0), intensity=1.0)
    scene = disk_scene(preset("coastal"), [light], distance=1.5, size=1.0)
    kw = dict(width=12, height=8, spp=256, layers=(), split=True, bandwidth_nm=10.0)
    both = render(scene, seed=4, wavelengths_nm=[450.0, 650.0], **kw).layers["backscatter"]
    for j, lam in enumerate((450.0, 650.0)):
        alone = render(scene, seed=9, wavelengths_nm=[lam], **kw).layers["backscatter"][..., 0]
        a, b = both[..., j], alone
        se = np.sqrt(a.var(ddof=1) / a.size + b.var(ddof=1) / b.size)
        assert abs(a.mean() - b.mean()) < 4 * se, (lam, a.mean(), b.mean(), se)
    assert both[..., 0].mean() > 1.2 * both[..., 1].mean()  # the bands really differ


# --------------------------------------------------------------------------- layers, lights
def test_strobes_and_continuous_lights_separate_and_linear():
    cont = make_light("continuous", position=(0.2, 0.0, 0.0), intensity=2.0, name="video")
    strobe = make_light("strobe", position=(-0.2, 0.0, 0.0), intensity=3.0, name="strobe")
    kw = dict(width=12, height=8, spp=4, wavelengths_nm=[500.0], layers=("clear",))
    mixed = render(disk_scene(None, [cont, strobe]), **kw)
    only_c = render(disk_scene(None, [cont]), **kw)
    only_s = render(disk_scene(None, [strobe]), **kw)
    # no water, one bounce: only the pixel jitter is random; the continuous pass comes first in
    # both renders (same random numbers), the strobe pass is the second one in ``mixed``
    assert np.allclose(mixed.radiance, only_c.radiance, rtol=1e-5, atol=1e-9)
    assert np.allclose(mixed.layers["flash"], only_s.layers["flash"], rtol=0.02)
    assert np.all(only_s.radiance == 0) and "flash" not in only_c.layers
    assert np.array_equal(mixed.layers["flash_clear"], mixed.layers["flash"])
    h = mixed.radiant_exposure(0.01)
    assert np.allclose(h, 0.01 * mixed.radiance + mixed.layers["flash"])


def test_colorchecker_ids_and_patch_ratios(tmp_path):
    light = make_light("continuous", position=(0.0, 0.0, 0.0), intensity=1.0)
    cam = make_camera("dome", focal_length_mm=40.0)
    scene = Scene(Rig("r", cam, (light,)), preset("clear"), (Target("colorchecker", 0.8, size_m=0.2794),))
    img = render(scene, width=90, height=60, spp=4, seed=0, wavelengths_nm=[450.0, 550.0, 650.0],
                 bandwidth_nm=10.0)
    oid = img.layers["object_id"]
    assert set(np.unique(oid)) >= set(range(1, 26))
    legend = img.meta["object_ids"]
    assert len(legend) == 25
    white = [k for k, v in legend.items() if "white" in v][0]
    black = [k for k, v in legend.items() if "black 2" in v][0]
    import colour

    sds = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    rw = np.array([sds["white 9.5 (.05 D)"][w] for w in (450, 550, 650)])
    rb = np.array([sds["black 2 (1.5 D)"][w] for w in (450, 550, 650)])
    clear = img.layers["clear"]

    def interior(k):  # pixels whose neighbours see the same patch (no board mixed in by the jitter)
        m = oid == int(k)
        return m & np.roll(m, 1, 0) & np.roll(m, -1, 0) & np.roll(m, 1, 1) & np.roll(m, -1, 1)

    ratio = clear[interior(white)].mean(axis=0) / clear[interior(black)].mean(axis=0)
    assert np.allclose(ratio, rw / rb, rtol=0.03)
    # a round trip through disk
    img.save(tmp_path / "r")
    back = SpectralImage.load(tmp_path / "r")
    assert np.allclose(back.radiance, img.radiance) and back.meta["object_ids"] == legend
    assert img.meta["water"]["name"] == "clear" and img.meta["wall_time_s"] > 0


def test_progress_callback_reaches_one():
    calls = []
    render(_scattering_scene(), width=6, height=4, spp=2, wavelengths_nm=[550.0], layers=("clear",), split=True,
           progress=lambda f, msg: calls.append((f, msg)))
    # passes: full (with the backscatter estimate from its paths), clear, direct
    assert calls and calls[-1][0] == pytest.approx(1.0) and len(calls) == 3
    assert [m for _, m in calls] == ["continuous full", "continuous clear", "continuous direct"]


# --------------------------------------------------------------------------- errors
@pytest.mark.parametrize("kwargs, match", [
    (dict(width=0), "width"),
    (dict(spp=1.5), "spp"),
    (dict(layers=("depth",)), "unknown layer"),
    (dict(wavelengths_nm=[300.0]), "leave the supported range"),
    (dict(wavelengths_nm=[550.0, 500.0]), "increase"),
    (dict(wavelengths_nm=[500.0, 510.0], bandwidth_nm=30.0), "overlap"),
])
def test_bad_arguments_are_one_line_config_errors(kwargs, match):
    args = dict(width=4, height=4, spp=1)
    args.update(kwargs)
    with pytest.raises(ConfigError, match=match) as e:
        render(_scattering_scene(), **args)
    assert "\n" not in str(e.value)


def test_bad_scene_inputs_are_config_errors(tmp_path):
    short = make_light("continuous", wavelength_nm=(500.0, 600.0), intensity=1.0)
    with pytest.raises(ConfigError, match="light"):
        render(disk_scene(None, [short]), width=4, height=4, spp=1, wavelengths_nm=[450.0])
    jerlov = preset("jerlov-IB")  # defined up to 700 nm
    with pytest.raises(ConfigError, match="jerlov"):
        render(disk_scene(jerlov, [make_light()]), width=4, height=4, spp=1, wavelengths_nm=[720.0])
    bad_refl = Scene(Rig("r", make_camera(), (make_light(),)), None,
                     (Target("white-disk", 1.0, reflectance_wavelength_nm=(360.0, 830.0), reflectance=(1.5, 1.5)),))
    with pytest.raises(ConfigError, match="reflectance"):
        render(bad_refl, width=4, height=4, spp=1)
    mesh = Scene(Rig("r", make_camera(), (make_light(),)), None,
                 (Target("mesh", 1.0, mesh_path=str(tmp_path / "nope.obj")),))
    with pytest.raises(ConfigError, match="mesh"):
        render(mesh, width=6, height=4, spp=1)


def test_few_samples_many_bands_still_unbiased():
    """4·spp < bands: bands drawn at random and scaled (Horvitz–Thompson); the disk's mean
    radiance still matches the exact value."""
    from rigsim.render.renderer import band_edges
    from tests.render.helpers import reference_direct, relative_error

    light = make_light("continuous", position=(0.0, 0.0, 0.0), intensity=1.0)
    scene = disk_scene(None, [light], distance=1.0, size=2.0)
    img = render(scene, width=24, height=16, spp=2, wavelengths_nm=np.arange(400.0, 701.0, 10.0), layers=())
    wl, bw = band_edges(np.arange(400.0, 701.0, 10.0))
    ref, inside = reference_direct(scene, 24, 16, wl, bw)
    rel, se = relative_error(img.radiance, ref, inside)
    assert np.all(np.abs(rel) < 4 * se + 1e-3)
    assert np.abs(rel.mean()) < 0.02


def test_mesh_target(tmp_path):
    obj = tmp_path / "quad.obj"
    obj.write_text("v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3\nf 1 3 4\n")
    light = make_light("continuous", position=(0.0, 0.0, 0.0), intensity=1.0)
    scene = Scene(Rig("r", make_camera(), (light,)), preset("clear"),
                  (Target("mesh", 1.0, size_m=0.1, mesh_path=str(obj)),))
    img = render(scene, width=12, height=8, spp=4, wavelengths_nm=[550.0])
    oid = img.layers["object_id"]
    assert oid[4, 6] == 1 and oid[0, 0] == 0
    assert img.layers["clear"][4, 6, 0] > 0
    assert img.layers["range_m"][4, 6] == pytest.approx(1.0, rel=1e-3)


def test_emitter_light_tracing_and_pattern():
    """sample_ray (light tracing) and sample_direction agree with I(λ) f(θ)."""
    from rigsim.render.emitter_plugin import make_emitter
    from rigsim.scene.types import BeamPattern

    light = make_light("continuous", position=(0.0, 0.0, 0.0), aim=(0.0, 0.0, 1.0), intensity=2.0,
                       beam=BeamPattern(beam_angle_deg=60.0, edge_exponent=2.0))
    em = make_emitter(light)
    n = 20000
    rng = np.random.default_rng(0)
    ray, w = em.sample_ray(0.0, mi.Float(rng.random(n)), mi.Point2f(0.5, 0.5),
                           mi.Point2f(rng.random(n), rng.random(n)))
    d = np.array(ray.d, float).T
    w = np.array(w, float)
    theta = np.arccos(np.clip(d[:, 2], -1, 1))
    assert np.all(np.isfinite(w)) and np.all(w[:, theta >= np.pi / 2] == 0)
    # E[weight] = ∫ I f dΩ × (spectral integral of I / I) — compare the direction profile:
    f = light.beam.relative_intensity(theta)
    ratio = w[0][f > 0.1] / f[f > 0.1]
    assert np.allclose(ratio, ratio[0], rtol=1e-4)
    # next-event estimation at 2 m, 30° off the axis: I f(30°) / d² with f(30°) = 1/2
    it = dr.zeros(mi.Interaction3f, 1)
    it.p = mi.Point3f(float(2 * np.sin(np.radians(30))), 0.0, float(2 * np.cos(np.radians(30))))
    it.wavelengths = mi.Spectrum(450.0, 500.0, 550.0, 600.0)
    ds, val = em.sample_direction(it, mi.Point2f(0.5, 0.5))
    assert np.allclose(np.array(val, float).ravel(), 2.0 * 0.5 / 4.0, rtol=1e-5)
    assert bool(np.array(ds.delta)[0]) and float(np.array(ds.dist)[0]) == pytest.approx(2.0, rel=1e-6)


def test_wavelengths_as_a_range_string_or_bad_values():
    from rigsim.spectrum import band_edges

    wl, bw = band_edges("400:700:50", None)
    assert wl.tolist() == [400.0, 450.0, 500.0, 550.0, 600.0, 650.0, 700.0] and np.allclose(bw, 50.0)
    with pytest.raises(ConfigError, match="cannot read wavelengths"):
        band_edges(["blue"], None)
    with pytest.raises(ConfigError, match="cannot read wavelengths"):
        band_edges("400-700", None)


# --------------------------------------------------------------------------- noise target
def test_relative_noise_p99_matches_the_chi_distribution():
    """Batches of a flat image with Gaussian noise σ: the per-pixel standard error of the mean
    is σ/√n · s/σ, s/σ ~ √(χ²_{n−1}/(n−1)); its 99th percentile is known exactly."""
    from scipy.stats import chi2

    from rigsim.render.renderer import relative_noise_p99

    rng = np.random.default_rng(3)
    sigma, n = 0.3, 4
    batches = [1.0 + sigma * rng.standard_normal((200, 200, 1)) for _ in range(n)]
    expect = sigma / np.sqrt(n) * np.sqrt(chi2.ppf(0.99, n - 1) / (n - 1))
    assert relative_noise_p99(batches) == pytest.approx(expect, rel=0.03)
    # relative to the local mean: scaling the image changes nothing; a noise-free image has none
    assert relative_noise_p99([5 * b for b in batches]) == pytest.approx(relative_noise_p99(batches), rel=1e-9)
    assert relative_noise_p99([np.ones((20, 20, 3))] * 3) == 0.0


def test_relative_noise_p99_sees_noise_in_one_colour_group():
    """Noise in two of six bands: averaged over all bands it is 3× smaller than in its own
    group, which is what the per-group measure reports (the largest group)."""
    from scipy.stats import chi2

    from rigsim.render.renderer import noise_groups, relative_noise_p99

    rng = np.random.default_rng(5)
    sigma, n = 0.3, 4
    batches = []
    for _ in range(n):
        b = np.ones((200, 200, 6))
        b[..., :2] += sigma * rng.standard_normal((200, 200, 2))
        batches.append(b)
    chi = np.sqrt(chi2.ppf(0.99, n - 1) / (n - 1))
    in_group = sigma / np.sqrt(2) / np.sqrt(n) * chi  # mean of two noisy bands
    groups = [[0, 1], [2, 3], [4, 5]]
    assert relative_noise_p99(batches, groups=groups) == pytest.approx(in_group, rel=0.03)
    assert relative_noise_p99(batches) == pytest.approx(in_group / 3, rel=0.03)
    # the renderer's groups: blue / green / red by band centre
    assert [list(g) for g in noise_groups([400, 450, 500, 550, 600, 650, 700])] == [[0, 1], [2, 3], [4, 5, 6]]
    assert [list(g) for g in noise_groups([600, 650])] == [[0, 1]]


def test_noise_target_renders_more_batches_until_it_is_met():
    scene = disk_scene(preset("coastal"), [make_light("strobe", position=(0.2, 0.0, 0.0))], distance=1.0,
                       size=0.4)
    kw = dict(width=16, height=12, spp=4, seed=5, wavelengths_nm=[450.0, 550.0, 650.0], layers=())
    easy = render(scene, noise_target=9.0, **kw)  # met as soon as it can be measured: two batches
    assert easy.meta["spp"] == 8 and easy.meta["noise_p99"]["strobe:full"] <= 9.0
    hard = render(scene, noise_target=1e-4, max_spp=16, **kw)  # never met: stops at max_spp
    assert hard.meta["spp"] == 16 and hard.meta["noise_p99"]["strobe:full"] > 1e-4
    assert hard.meta["spp_per_pass"] == {"strobe:full": 16}
    plain = render(scene, **kw)
    assert plain.meta["spp"] == 4 and plain.meta["noise_p99"] is None
    with pytest.raises(ConfigError, match="noise_target"):
        render(scene, noise_target=-1.0, **kw)
    with pytest.raises(ConfigError, match="max_spp"):
        render(scene, noise_target=0.1, max_spp=2, **kw)


# --------------------------------------------------------------------------- kernel reuse
def test_flat_targets_are_meshes_of_the_same_area_and_placement():
    """Rectangles are two triangles on their corners; disks a polygon of the disk's area."""
    from rigsim.render.targets import DISK_SEGMENTS, MESH_TYPE, flat_mesh

    M = np.eye(4)
    M[:3, 0], M[:3, 1], M[:3, 2], M[:3, 3] = (0.2, 0, 0), (0, 0.1, 0), (0, 0, 1), (1.0, 2.0, 3.0)

    def area(spec):
        V, F = spec["vertex_positions"], spec["faces"].astype(int)
        return 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1).sum()

    rect = flat_mesh("rectangle", M)
    assert rect["type"] == MESH_TYPE
    assert sorted(map(tuple, np.round(rect["vertex_positions"], 9))) == [
        (0.8, 1.9, 3.0), (0.8, 2.1, 3.0), (1.2, 1.9, 3.0), (1.2, 2.1, 3.0)]
    assert area(rect) == pytest.approx(0.4 * 0.2, rel=1e-12)
    disk = flat_mesh("disk", M)  # an ellipse with semi-axes 0.2 and 0.1
    assert len(disk["faces"]) == DISK_SEGMENTS
    assert area(disk) == pytest.approx(np.pi * 0.2 * 0.1, rel=1e-9)
    r = np.hypot(*((disk["vertex_positions"][1:, :2] - (1.0, 2.0)) / (0.2, 0.1)).T)
    assert np.all(np.abs(r - 1) < 1e-4)  # outline within 0.01 % of the circle
    # the normal of every face is the object's +z (what Mitsuba's rectangle and disk had)
    V, F = disk["vertex_positions"], disk["faces"].astype(int)
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    assert np.all(n[:, 2] > 0) and np.allclose(n[:, :2], 0)


def test_one_compiled_kernel_serves_every_target_distance():
    """A sweep over distances reuses the renderer's kernels: the target's placement and the
    lights are data, not constants compiled into the code (each compile took ~5 s)."""
    water = preset("coastal")
    hashes = []
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    try:
        for dist, size, x in ((1.0, 0.4, 0.3), (2.5, 0.9, 0.45)):  # another distance, strobes moved
            lights = [make_light("strobe", position=(x, 0.0, 0.0), aim=(x, 0.0, 1.0)),
                      make_light("strobe", position=(-x, 0.0, 0.0), aim=(-x, 0.0, 1.0))]
            scene = Scene(Rig("r", make_camera("dome", focal_length_mm=40.0), tuple(lights)), water,
                          (Target("colorchecker", dist, size_m=size),))
            dr.kernel_history()  # clears it
            render(scene, width=12, height=8, spp=2, seed=1, wavelengths_nm="450:650:100", layers=())
            big = max((k for k in dr.kernel_history() if "operation_count" in k), key=lambda k: k["operation_count"])
            hashes.append(big["hash"])
    finally:
        dr.set_flag(dr.JitFlag.KernelHistory, False)
    assert hashes[0] == hashes[1]
