"""Triangle meshes in the fast engine: ray casting against exact solutions, a mesh disk against the
flat disk it approximates (every layer, multiple scattering and daylight included), and a rock
against the Monte Carlo renderer (statistical)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy import stats

from rigsim.preview import render_preview
from rigsim.preview.geometry import cast_rays, occluded, scene_surfaces
from rigsim.scene.types import BeamPattern, Daylight, Rig, Scene, Target
from rigsim.water import preset
from tests.preview.helpers import WL_ENDS, dome_camera, interior_ids, make_light

ROCK = "data/meshes/rock.obj"


def _write_obj(path, V, F):
    with open(path, "w") as f:
        f.writelines(f"v {x:.12g} {y:.12g} {z:.12g}\n" for x, y, z in V)
        f.writelines(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in F)
    return str(path)


def _disk_obj(path, segments=720):
    """A unit-radius disk in the xy plane (normal +z: towards the camera), as a fan of triangles."""
    a = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    V = np.r_[[[0.0, 0.0, 0.0]], np.c_[np.cos(a), np.sin(a), np.zeros(segments)]]
    F = [(0, 1 + i, 1 + (i + 1) % segments) for i in range(segments)]
    return _write_obj(path, V, F)


def _sphere_obj(path, n=96):
    """A UV sphere of radius 1 (vertices on the sphere; outward winding)."""
    th = np.linspace(0.0, np.pi, n + 1)
    ph = np.linspace(0.0, 2 * np.pi, 2 * n, endpoint=False)
    V = [(0.0, 0.0, 1.0)]
    for t in th[1:-1]:
        V += [(math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)) for p in ph]
    V.append((0.0, 0.0, -1.0))
    m = len(ph)
    ring = lambda i, j: 1 + i * m + (j % m)  # noqa: E731
    F = [(0, ring(0, j), ring(0, j + 1)) for j in range(m)]
    for i in range(n - 2):
        for j in range(m):
            F += [(ring(i, j), ring(i + 1, j), ring(i + 1, j + 1)), (ring(i, j), ring(i + 1, j + 1), ring(i, j + 1))]
    last = len(V) - 1
    F += [(ring(n - 2, j), last, ring(n - 2, j + 1)) for j in range(m)]
    return _write_obj(path, np.array(V), F), 2 * math.sin(math.pi / (2 * n)) ** 2  # (file, sag bound / r)


def _scene(target, water="coastal", lights=None, daylight=None, pitch_deg=0.0):
    beam = BeamPattern(beam_angle_deg=100.0)
    lights = lights if lights is not None else tuple(
        make_light(position=(s * 0.35, 0.1, 0.0), beam=beam, intensity=0.05, name=f"s{s}") for s in (-1, 1))
    p = math.radians(pitch_deg)
    cam = dataclasses.replace(dome_camera(35.0), forward=(0.0, -math.sin(p), math.cos(p)),
                              up=(0.0, math.cos(p), math.sin(p)))
    return Scene(Rig("r", cam, lights), preset(water) if water else None, (target,), daylight=daylight)


def test_rays_meet_a_sphere_mesh_where_the_sphere_is(tmp_path):
    """Hits, distances and shading normals of a tessellated sphere against the exact sphere; shadows
    against the exact segment–sphere test."""
    obj, sag = _sphere_obj(tmp_path / "sphere.obj")
    size = 0.5  # diameter: the mesh is scaled to this largest extent
    scene = _scene(Target("mesh", 2.0, size_m=size, mesh_path=obj), water=None, lights=())
    surf = scene_surfaces(scene)
    assert surf.is_mesh.tolist() == [True] and len(surf.meshes) > 10_000
    centre, R = np.array(surf.center[0]), size / 2
    rng = np.random.default_rng(3)
    o = np.array([0.0, 0.0, 0.0]) + 0.01 * rng.normal(size=(20_000, 3))
    aim = centre + rng.uniform(-0.35, 0.35, size=(20_000, 3))
    d = (aim - o) / np.linalg.norm(aim - o, axis=1, keepdims=True)
    t, oid, nrm = cast_rays(surf, o, d, normals=True)
    # the exact sphere: |o + t d − c|² = R²
    oc = o - centre
    bq = np.sum(oc * d, axis=1)
    disc = bq * bq - (np.sum(oc * oc, axis=1) - R * R)
    t_exact = np.where(disc > 0, -bq - np.sqrt(np.maximum(disc, 0)), np.inf)
    inside = np.isfinite(t_exact) & (disc > (0.02 * R) ** 2)  # away from the silhouette
    outside = ~np.isfinite(t_exact)
    assert inside.sum() > 5000 and outside.sum() > 2000
    assert np.all(oid[inside] == 1) and np.all(oid[outside] == 0)
    # the facets are at most sag·R inside the sphere: along a ray, that over the cosine of incidence
    cos_inc = np.sqrt(disc[inside]) / R
    assert np.all(np.abs(t[inside] - t_exact[inside]) <= 1.01 * sag * R / cos_inc)
    assert np.median(np.abs(t[inside] - t_exact[inside])) < sag * R
    p = o[inside] + t_exact[inside, None] * d[inside]
    n_exact = (p - centre) / R
    ang = np.degrees(np.arccos(np.clip(np.sum(nrm[inside] * n_exact, axis=1), -1, 1)))
    assert np.percentile(ang, 99) < 0.5  # smooth shading: the interpolated normal is the sphere's
    # shadows: points on a plane behind the sphere, a light in front of it
    light = centre + np.array([0.0, 0.0, -1.0])
    q = centre + np.c_[rng.uniform(-0.4, 0.4, (5000, 2)), np.full(5000, 0.5)]
    blocked = occluded(surf, q, light)
    v = q - light
    dist = np.linalg.norm(v, axis=1)
    u = v / dist[:, None]
    lc = light - centre
    b2 = u @ lc
    miss_by = np.sqrt(np.maximum(lc @ lc - b2 * b2, 0.0))  # closest approach to the centre
    clear_in, clear_out = miss_by < R * (1 - 2 * sag), miss_by > R * 1.0001
    assert clear_in.sum() > 500 and clear_out.sum() > 500
    assert np.all(blocked[clear_in]) and not np.any(blocked[clear_out])
    # a point on the sphere's lit side is not shadowed by the sphere itself, one on the far side is
    on = centre + R * np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0]])
    assert occluded(surf, on, light).tolist() == [False, True]


@pytest.mark.parametrize("daylight, pitch_deg", [(None, 0.0), (Daylight(depth_m=5.0, sun_zenith_deg=30.0), 0.0),
                                                (Daylight(depth_m=5.0, sun_zenith_deg=30.0), 37.0)],
                         ids=["strobes", "daylight", "daylight-pitched"])
def test_a_mesh_disk_images_as_the_flat_disk_it_approximates(tmp_path, monkeypatch, daylight, pitch_deg):
    """The same disk as a fan of 720 triangles and as a flat disk: every layer's region means agree
    (multiple scattering on the same random numbers — a mesh's class-B light comes from the photons' hits
    alone, so the flat disk's too here, without the flights to flat targets; the daylight's diffuse light of a
    mesh comes from its grid of normals, between nodes for the camera pitched 37° down)."""
    import functools

    import rigsim.preview.multiple as multiple

    monkeypatch.setattr(multiple, "trace_multiple", functools.partial(multiple.trace_multiple, surface_nee=False))
    obj = _disk_obj(tmp_path / "disk.obj")
    refl = dict(reflectance_wavelength_nm=WL_ENDS, reflectance=(0.6, 0.6))
    lights = () if daylight else None
    flat = _scene(Target("white-disk", 1.5, size_m=0.8, **refl), lights=lights, daylight=daylight, pitch_deg=pitch_deg)
    mesh = _scene(Target("mesh", 1.5, size_m=0.8, mesh_path=obj, **refl), lights=lights, daylight=daylight,
                  pitch_deg=pitch_deg)
    kw = dict(width=40, height=40, wavelengths_nm=[450.0, 550.0, 650.0], bandwidth_nm=10.0, split=True, shadows=True)
    a, b = render_preview(flat, **kw), render_preview(mesh, **kw)
    assert set(a.layers) == set(b.layers)
    ii = interior_ids(flat, 40, 40)
    disk, water = ii == 1, ii == 0
    assert disk.sum() > 300 and water.sum() > 300
    assert np.array_equal(a.layers["object_id"][ii >= 0], b.layers["object_id"][ii >= 0])
    compared = 0
    for key, la in a.layers.items():
        if key in ("object_id", "particle_id"):
            continue
        for m in (disk, water):
            ma, mb = np.asarray(la)[m].astype(float), np.asarray(b.layers[key])[m].astype(float)
            if key == "range_m":
                np.testing.assert_allclose(mb, ma, rtol=0, atol=1e-5)  # (inf = inf in open water)
                continue
            ra, rb = ma.mean(axis=0), mb.mean(axis=0)
            if np.all(ra == 0):
                assert np.all(rb == 0), key
                continue
            assert np.max(np.abs(rb / ra - 1)) < 0.005, (key, rb / ra - 1)
            compared += 1
    assert compared >= (2 if daylight else 6)


def test_the_grid_of_normals_interpolates_a_smooth_field():
    """Bilinear interpolation on the daylight's grid of normals against an exact smooth function of the
    normal (the cardioid (1 + n_y)/2 and an azimuthal term): error below the grid's second-order bound."""
    from rigsim.preview.model import _NORMAL_GRID, _on_normal_grid

    th = np.linspace(0.0, np.pi, _NORMAL_GRID[0])
    ph = np.linspace(-np.pi, np.pi, _NORMAL_GRID[1])
    TH, PH = np.meshgrid(th, ph, indexing="ij")
    f = lambda n: (1 + n[..., 1]) / 2 + 0.2 * n[..., 0]  # noqa: E731
    nodes = np.stack([np.sin(TH) * np.sin(PH), np.cos(TH), np.sin(TH) * np.cos(PH)], -1)
    grid = f(nodes)[..., None]
    n = np.random.default_rng(0).normal(size=(20_000, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    step = max(th[1] - th[0], ph[1] - ph[0])
    err = np.abs(_on_normal_grid(grid, n)[:, 0] - f(n))
    assert np.max(err) < 0.7 * step ** 2 / 8 * 2  # |f''| ≤ 0.7 in θ and φ; two directions
    assert np.median(err) > 0  # (not exact: the normals fall between nodes)


@pytest.mark.render
def test_a_rock_agrees_with_the_monte_carlo_renderer():
    """The shipped rock lit by two strobes in coastal water: the fast engine's mean radiance on the rock
    and in open water against four Monte Carlo renders (tolerance 5 % + Student t · SE)."""
    from rigsim.render import render

    scene = _scene(Target("mesh", 1.2, size_m=0.6, mesh_path=ROCK))
    kw = dict(width=32, height=32, wavelengths_nm=[450.0, 550.0, 650.0], bandwidth_nm=10.0, split=True)
    fast = render_preview(scene, **kw)
    refs = [render(scene, spp=64, seed=s, **kw) for s in range(4)]
    assert all(np.array_equal(r.layers["object_id"], fast.layers["object_id"]) for r in refs)
    ii = interior_ids(scene, 32, 32)
    k = stats.t.ppf(0.975, len(refs) - 1)
    for key, m in (("flash", ii == 1), ("flash_direct", ii == 1), ("flash", ii == 0)):
        assert m.sum() > 60
        f = np.asarray(fast.layers[key])[m].mean(axis=0)
        per = np.array([np.asarray(r.layers[key])[m].mean(axis=0) for r in refs])
        ref, se = per.mean(axis=0), per.std(axis=0, ddof=1) / math.sqrt(len(refs))
        dev = f / ref - 1
        assert np.all(np.abs(dev) <= 0.05 + k * se / ref), (key, dev, se / ref)


@pytest.mark.render
@pytest.mark.parametrize("light", ["strobe", "sun"])
def test_shadows_of_a_rock_on_the_bottom_match_monte_carlo(light):
    """A rock on a sand bottom lit from the side by a strobe, or by the sun at 5 m: where the fast engine
    puts the rock's shadow (its image with shadows under 60 % of that without), Monte Carlo's mean
    radiance is within 20 % (the shadow's edge pixels, which the engines sample differently, and no
    inter-reflections of strobe light: measured −12 % strobe, −9 % sun), and inside the sun's shadow (the
    mask eroded by a pixel: lit by the diffuse daylight the rock does not hide, and what it reflects)
    within 5 % + t·SE (measured −1.0 ± 0.4 %; +20 % before the rock hid the diffuse daylight), while
    without shadows the fast engine would be more than twice as bright there."""
    from scipy import ndimage
    from rigsim.config.rig import load_rig
    from rigsim.dataset.sample import pitched_rig
    from rigsim.render import render

    rig = load_rig("rigs/twin-strobes-45-wide.toml")
    strobe = make_light(position=(0.8, 0.3, 0.0), aim=(-0.3, -0.3, 1.0), beam=BeamPattern(beam_angle_deg=100.0),
                        intensity=0.2)
    rig = pitched_rig(dataclasses.replace(rig, lights=(strobe,) if light == "strobe" else ()), 45.0)
    day = Daylight(depth_m=5.0, sun_zenith_deg=40.0) if light == "sun" else None
    scene = Scene(rig, preset("clear"), (Target("bottom", 1.5, size_m=50.0),
                                         Target("mesh", 1.6, size_m=0.5, mesh_path=ROCK)), daylight=day)
    kw = dict(width=48, height=32, wavelengths_nm=[550.0], bandwidth_nm=10.0)
    with_s = render_preview(scene, **kw).radiant_exposure(1.0)[..., 0]  # ("auto": on, two targets and a mesh)
    without = render_preview(scene, shadows=False, **kw).radiant_exposure(1.0)[..., 0]
    shade = with_s / without < 0.6
    assert shade.sum() >= 8
    mc = np.array([render(scene, spp=64, seed=s, **kw).radiant_exposure(1.0)[..., 0] for s in range(4)])
    per = mc[:, shade].mean(axis=1)
    ref, se = per.mean(), per.std(ddof=1) / 2
    k = stats.t.ppf(0.975, 3)
    assert abs(with_s[shade].mean() / ref - 1) <= 0.2 + k * se / ref
    assert without[shade].mean() > 2 * ref
    if light == "sun":
        inner = ndimage.binary_erosion(shade)
        assert inner.sum() >= 6
        per = mc[:, inner].mean(axis=1)
        ref, se = per.mean(), per.std(ddof=1) / 2
        assert abs(with_s[inner].mean() / ref - 1) <= 0.05 + k * se / ref


def test_targets_hide_the_diffuse_daylight_as_the_integral_over_the_hemisphere_says():
    """Points on the bottom beside a tall black wall (the sun overhead: the wall casts no shadow): the
    diffuse daylight the wall hides, as the fast engine estimates it (16 cosine-weighted directions per
    point), against the integral over the hemisphere by fine quadrature — over the directions that meet
    the wall, the field beyond it, ``L_amb(v) e^{K Δy} e^{−(c − K v_y) s}`` (Duntley).  Per point the
    estimate is noisy (a few directions), unbiased: the mean relative error over 200 points within
    3 standard errors + 0.5 %, and that standard error under 2 %."""
    from rigsim.preview.model import _F64, _Daylight, _Hits
    from rigsim.scene.daylight_field import scene_daylight

    black = dict(reflectance_wavelength_nm=WL_ENDS, reflectance=(0.0, 0.0))
    wall = Target("white-disk", 4.0, size_m=12.0, offset_m=(1.5, 0.0), yaw_deg=90.0, **black)
    scene = Scene(Rig("r", dome_camera(35.0), ()), preset("coastal"), (Target("bottom", 1.0, size_m=50.0), wall),
                  daylight=Daylight(depth_m=5.0, sun_zenith_deg=0.0))
    surf = scene_surfaces(scene)
    assert np.allclose(np.abs(surf.normal[1]), [1.0, 0.0, 0.0])  # the wall stands upright, across x
    wl, bw = np.array([450.0, 550.0, 650.0]), np.full(3, 10.0)
    field = scene_daylight(scene, 440.0, 660.0)
    shadowed = _Daylight(field, wl, surf, bw, shadows=True)
    free = _Daylight(field, wl, surf, bw, shadows=False)
    x_wall = float(surf.center[1, 0])
    rng = np.random.default_rng(3)
    n = 200
    p = np.c_[x_wall - np.sign(x_wall) * rng.uniform(0.05, 1.5, n), np.full(n, surf.center[0, 1]),
              rng.uniform(2.0, 6.0, n)]
    up = np.tile([0.0, 1.0, 0.0], (n, 1))
    side = np.full(n, int(surf.normal[0, 1] < 0))
    hits = _Hits(np.arange(n), p, up, side, np.ones(n, np.int32), np.full(n, 3.0))
    rho = np.zeros((3, 3))  # (the wall is black; the bottom's own reflectance plays no part)
    est = free.irradiance(hits, _F64, rho) - shadowed.irradiance(hits, _F64, rho)
    # quadrature over the upper hemisphere (midpoints in θ and φ)
    nt, nph = 90, 180
    th = (np.arange(nt) + 0.5) * (np.pi / 2) / nt
    ph = (np.arange(nph) + 0.5) * 2 * np.pi / nph
    TH, PH = np.meshgrid(th, ph, indexing="ij")
    d = np.stack([np.sin(TH) * np.cos(PH), np.cos(TH), np.sin(TH) * np.sin(PH)], -1).reshape(-1, 3)
    dw = (np.sin(TH) * (np.pi / 2 / nt) * (2 * np.pi / nph)).reshape(-1)
    look = field.band_means(wl, bw).radiance(d, wl)  # (D, 3)
    c, k = shadowed.c, shadowed.k
    exact = np.zeros((n, 3))
    for i in range(n):
        s, oid = cast_rays(surf, np.broadcast_to(p[i] + [0.0, 1e-9, 0.0], d.shape), d)
        m = oid == 2
        beyond = look[m] * np.exp(k * (p[i, 1] - field.y0) - (c - k * d[m, 1:2]) * s[m, None])
        exact[i] = ((d[m, 1] * dw[m])[:, None] * beyond).sum(axis=0)
    assert np.all(exact > 0.05 * free.irradiance(hits, _F64, rho))  # the wall hides a real share everywhere
    rel = est / exact - 1
    mean, se = rel.mean(axis=0), rel.std(axis=0, ddof=1) / np.sqrt(n)
    assert np.all(se < 0.02), se
    assert np.all(np.abs(mean) <= 3 * se + 0.005), (mean, se)
