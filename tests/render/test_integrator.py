"""``rigsim_vol`` (equiangular + MIS) against exact solutions and Mitsuba's ``volpath``.

* albedo 0: equals the Beer–Lambert strobe law (and ``volpath``'s ``direct`` pass);
* single scattering along one ray from a point light: equals quadrature of the
  single-scattering integral (in the equiangular angle, where it is smooth);
* the equiangular/phase-weighted distance sampler, the aureole directions and the target
  points of the target NEE realise the densities they report;
* against ``volpath`` on a small coastal scene (white patch + one strobe) from independent
  seeds: single scattering per 4×4-pixel block (both estimators have finite variance); deeper
  paths by the image mean (``volpath``'s NEE near a strobe has infinite variance, so per pixel
  its errors are heavy-tailed and one-sided) and per pixel against rigsim_vol without its extra
  next-event estimations; full depth marked slow;
* the checks can fail: deliberately wrong MIS weights are flagged;
* scenes outside the integrator's class are refused.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigsim.errors import ConfigError
from rigsim.render.integrators import (
    PLUGIN_NAME,
    RigsimVolIntegrator,
    integrator_dict,
    sample_target_point,
    target_table,
    with_integrator,
)
from rigsim.render.integrators.common import AureoleTable, PhaseAngleTable
from rigsim.render.integrators.common import Segment as _Segment
from rigsim.render.integrators.strobe import DEFAULT_EQUIANGULAR_VERTEX
from rigsim.render.mitsuba_scene import build_mitsuba_scene, forget_scenes
from rigsim.render.renderer import band_edges, render_pass
from rigsim.render.variant import mitsuba
from rigsim.scene.types import BeamPattern
from rigsim.water import preset
from tests.render.helpers import disk_scene, make_light, reference_direct, relative_error

pytestmark = pytest.mark.render
mi, dr = mitsuba()

WL = [450.0, 550.0, 650.0]
BW = 10.0
W, H = 16, 12


def _scene(water="coastal", *, reflectance=0.9, two_lights=False):
    lights = [make_light("strobe", position=(0.25, 0.0, 0.0), intensity=5.0)]
    if two_lights:  # a second, weaker strobe on the other side, closer to the target
        lights.append(make_light("strobe", position=(-0.3, 0.1, 0.5), aim=(0.5, -0.15, 0.85), intensity=2.0,
                                  name="strobe-2"))
    return disk_scene(preset(water), lights, distance=1.0, size=0.5, reflectance=reflectance)


def _renders(ms, scene, *, n, spp, seed0):
    wl, bw = band_edges(WL, BW)
    imgs = [render_pass(ms, scene.camera, width=W, height=H, spp=spp, seed=seed0 + i, band_lo=wl - bw / 2,
                        band_w=bw)[0] for i in range(n)]
    return np.stack(imgs)


def _ztest(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float]:
    """Per-pixel Z of the difference of two stacks of independent renders; and the image-mean Z."""
    ma, mb = a.mean(0), b.mean(0)
    va, vb = a.var(0, ddof=1) / len(a), b.var(0, ddof=1) / len(b)
    z = (ma - mb) / np.sqrt(va + vb)
    ia, ib = a.mean(axis=(1, 2, 3)), b.mean(axis=(1, 2, 3))
    z_mean = (ia.mean() - ib.mean()) / np.sqrt(ia.var(ddof=1) / len(ia) + ib.var(ddof=1) / len(ib))
    return z, float(z_mean)


def _assert_consistent(z: np.ndarray, z_mean: float, n: int):
    # with n seeds the per-pixel Z follows Student-like tails; the bounds are loose
    # enough for that and tight enough to catch a few-% bias (see the MIS test)
    assert abs(z_mean) < 3.5, z_mean
    assert 0.7 < np.std(z) < 1.35, np.std(z)
    assert abs(np.mean(z)) < 0.35, np.mean(z)
    assert np.mean(np.abs(z) > 3.5) < 0.01, np.sort(np.abs(z).ravel())[-10:]


def test_registered_and_options():
    integ = mi.load_dict(integrator_dict("rigsim", max_depth=3))
    assert isinstance(integ, RigsimVolIntegrator) and integ.max_depth == 3
    vp = mi.load_dict(integrator_dict("volpath"))
    assert not isinstance(vp, RigsimVolIntegrator) and "VolumetricSimplePath" in str(vp), str(vp)
    with pytest.raises(ConfigError):
        integrator_dict("bdpt")
    with pytest.raises(Exception):
        mi.load_dict({"type": PLUGIN_NAME, "mis": "cubic"})


def test_albedo_zero_is_the_strobe_law_and_volpath_direct():
    scene = _scene()
    ms = build_mitsuba_scene(scene, lights=scene.lights, mode="direct", integrator="volpath")
    assert not isinstance(ms.scene.integrator(), RigsimVolIntegrator)
    wl, bw = band_edges(WL, BW)
    img, dropped = render_pass(with_integrator(ms, "rigsim"), scene.camera, width=W, height=H, spp=16, seed=1,
                               band_lo=wl - bw / 2, band_w=bw)
    assert dropped == 0
    ref, inside = reference_direct(scene, W, H, wl, bw)
    rel, se = relative_error(img, ref, inside)
    assert np.all(np.abs(rel) < 4 * se + 2e-3), (rel, se)
    vp, _ = render_pass(ms, scene.camera, width=W, height=H, spp=64, seed=2, band_lo=wl - bw / 2, band_w=bw)
    rel_v, se_v = relative_error(img, vp, inside)
    assert np.all(np.abs(rel_v) < 4 * np.hypot(se, se_v) + 3e-3), (rel_v, se_v)
    assert np.all(img[~inside] == 0) or np.all(img[~inside] < 1e-6 + img[inside].max())


def _single_scattering_reference(water, light, o, d, lam, n=400_000):
    """(1/D) ∫ T(t) σ_s p(ψ) I f e^{−σ_t r} dθ along o + t d, t = Δ + D tan θ (midpoint rule)."""
    p = np.asarray(light.position_m, float)
    delta = float(np.dot(p - o, d))
    D = float(np.linalg.norm(p - o - delta * d))
    th = np.arctan2(-delta, D) + (np.arange(n) + 0.5) / n * (np.pi / 2 - np.arctan2(-delta, D))
    t = delta + D * np.tan(th)
    x = o[None, :] + t[:, None] * d[None, :]
    to_light = p[None, :] - x
    r = np.linalg.norm(to_light, axis=1)
    w_to = to_light / r[:, None]
    # phase values exactly as the plugin evaluates them (per wavelength)
    ms_phase = build_mitsuba_scene(_scene(), lights=[]).medium.phase_function()
    mei = dr.zeros(mi.MediumInteraction3f, len(t))
    mei.wi = mi.Vector3f(*[np.full(len(t), -c, np.float32) for c in d])
    mei.sh_frame = mi.Frame3f(mei.wi)
    mei.wavelengths = mi.Spectrum(*[np.full(len(t), v, np.float32) for v in lam])
    val, _ = ms_phase.eval_pdf(mi.PhaseFunctionContext(None), mei, mi.Vector3f(w_to.T.astype(np.float32)))
    ph = np.array(val)  # (4, n)
    c = water.c_per_m(np.asarray(lam))[:, None]
    b = water.b_per_m(np.asarray(lam))[:, None]
    axis = np.asarray(light.aim, float) / np.linalg.norm(light.aim)
    f = light.beam.relative_intensity(np.arccos(np.clip(-(w_to @ axis), -1, 1)))
    integrand = np.exp(-c * t[None, :]) * b * ph * light.axial_intensity[0] * f[None, :] * np.exp(-c * r[None, :])
    dth = (np.pi / 2 - np.arctan2(-delta, D)) / n
    return integrand.sum(axis=1) * dth / D


def test_single_scattering_along_a_ray_matches_quadrature():
    """max_depth = 2, no surface on the ray: the in-scattered radiance of one point light."""
    water = preset("coastal")
    light = make_light("strobe", position=(0.25, 0.3, 0.0), aim=(-1.0, 0.2, 0.0), intensity=5.0,
                       beam=BeamPattern(beam_angle_deg=120.0))
    scene = disk_scene(water, [light], distance=1.0, size=0.5)
    ms = with_integrator(build_mitsuba_scene(scene, lights=scene.lights), integrator_dict("rigsim", max_depth=2))
    n = 1 << 18
    lam = [450.0, 500.0, 550.0, 600.0]
    o, d = np.array([0.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])  # sideways: misses the disk
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(11, n)
    ray = mi.RayDifferential3f(mi.Point3f(*map(float, o)), mi.Vector3f(*map(float, d)))
    ray.wavelengths = mi.Spectrum(*lam)
    L, _, _ = ms.scene.integrator().sample(ms.scene, sampler, ray, ms.medium, mi.Bool(True))
    L = np.array(L).reshape(4, -1)
    if L.shape[1] == 1:
        pytest.skip("integrator returned a scalar (no vectorised variant)")
    mean, se = L.mean(axis=1), L.std(axis=1) / np.sqrt(L.shape[1])
    ref = _single_scattering_reference(water, light, o, d, lam)
    assert np.all(np.abs(mean - ref) < 4 * se + 2e-3 * ref), (mean, ref, se)
    assert np.all(se < 0.01 * ref)  # equiangular: a few % per-sample noise, not fireflies


@pytest.mark.parametrize("alpha", [0.0, 0.5])
def test_equiangular_sampler_realises_its_density(alpha):
    """E[1{t ∈ bin}/pdf(t)] = bin length for the uniform-angle and the phase-weighted sampler."""
    n = 1 << 18
    ph = build_mitsuba_scene(_scene("coastal-regions"), lights=[]).medium.phase_function()
    table = PhaseAngleTable(ph) if alpha > 0 else None
    wl = mi.Spectrum(450.0, 500.0, 550.0, 600.0)
    wbar = table.weights(wl) if table is not None else None
    o, d = mi.Point3f(0.0, 0.0, 0.0), mi.Vector3f(0.0, 0.0, 1.0)
    seg = _Segment(o, d, mi.Point3f(0.01, 0.0, 0.6), mi.Float(3.0), table, wbar, alpha)
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(5, n)
    t, pdf = seg.sample(sampler.next_1d(), sampler.next_1d(), sampler.next_1d())
    pdf_eval = seg.pdf(t)
    t, pdf, pdf_eval = (np.array(x, float) for x in (t, pdf, pdf_eval))
    assert np.all((t >= 0) & (t <= 3.0)) and np.all(pdf > 0)
    np.testing.assert_allclose(pdf_eval, pdf, rtol=2e-2)
    edges = np.array([0.0, 0.3, 0.5, 0.58, 0.6, 0.62, 0.7, 1.0, 2.0, 3.0])
    for a, b in zip(edges[:-1], edges[1:]):
        x = np.where((t >= a) & (t < b), 1.0 / pdf, 0.0)
        est, se = x.mean(), x.std() / np.sqrt(n)
        assert abs(est - (b - a)) < 4 * se + 1e-3 * (b - a), (a, b, est, se)


def test_aureole_sampler_realises_its_density():
    """E[1{α ∈ bin}/pdf(ω)] = solid angle of the bin, for directions drawn around an axis."""
    n = 1 << 18
    ph = build_mitsuba_scene(_scene("coastal-regions"), lights=[]).medium.phase_function()
    table = AureoleTable(ph)
    axis = dr.normalize(mi.Vector3f(0.3, -0.2, 0.9))
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(6, n)
    w = table.sample(axis, sampler.next_1d(), sampler.next_1d())
    pdf = np.array(table.pdf(axis, w), float)
    wn = np.array(w, float).T
    ax = np.array(axis, float).ravel()
    a = np.arctan2(np.linalg.norm(np.cross(ax, wn), axis=1), wn @ ax)  # exact at tiny angles (arccos is not)
    assert np.all(pdf > 0)
    # the sampler concentrates on small angles (the aureole): most samples within 10°
    assert np.mean(a < np.radians(10)) > 0.5
    edges = np.radians([0.0, 0.05, 0.5, 2.0, 10.0, 30.0, 90.0, 150.0, 180.0])
    for lo, hi in zip(edges[:-1], edges[1:]):
        x = np.where((a >= lo) & (a < hi), 1.0 / pdf, 0.0)
        est, se = x.mean(), x.std() / np.sqrt(n)
        omega = 2 * np.pi * (np.cos(lo) - np.cos(hi))
        assert abs(est - omega) < 4 * se + 2e-3 * omega, (np.degrees([lo, hi]), est, omega, se)


def test_target_point_sampler_realises_its_density():
    """The target NEE's points (a shape by area, a point uniform on it, density 1/total area):
    ``E[|cos θ_y| / (d² p_A)]`` over the samples is the solid angle the shapes subtend from a
    point, here two facing disks of different radii and distances (exact: 2π(1 − h/√(h²+R²)))."""
    T = mi.ScalarTransform4f
    scene = mi.load_dict({"type": "scene",
                          "a": {"type": "disk", "to_world": T().translate([0, 0, 1.0]).scale(0.3)},
                          "b": {"type": "disk", "to_world": T().translate([0, 0, -2.0]).scale(0.8)}})
    targets = target_table(scene)
    assert abs(float(targets[2][0]) - 1.0 / (np.pi * (0.3 ** 2 + 0.8 ** 2))) < 1e-6
    n = 1 << 20
    rng = np.random.default_rng(7)
    ps = sample_target_point(targets, mi.Float(0.0), mi.Float(rng.random(n)),
                             mi.Point2f(mi.Float(rng.random(n)), mi.Float(rng.random(n))), mi.Bool(True))
    p = np.stack([np.asarray(c) for c in ps.p])
    nrm = np.stack([np.asarray(c) for c in ps.n])
    d2 = (p ** 2).sum(0)
    cos = np.abs((nrm * p).sum(0)) / np.sqrt(d2)
    x = cos / (d2 * float(targets[2][0]))
    est, se = x.mean(), x.std() / np.sqrt(n)
    exact = sum(2 * np.pi * (1 - h / np.hypot(h, r)) for h, r in ((1.0, 0.3), (2.0, 0.8)))
    assert abs(est - exact) < 4 * se + 1e-3 * exact, (est, exact, se)
    # each disk gets its share of the area
    share_a = np.mean(p[2] > 0)
    assert abs(share_a - 0.09 / 0.73) < 4 * np.sqrt(0.12 * 0.88 / n)


def _pair(max_depth, *, n, spp, integrator=None, n_ref=None, spp_ref=None, reference=None, two_lights=False):
    """``n`` renders by rigsim_vol and ``n_ref`` by the reference: Mitsuba's ``volpath`` unless
    ``reference`` (integrator properties for another rigsim_vol) is given."""
    scene = _scene(two_lights=two_lights)
    # volpath explicitly: build_mitsuba_scene's default is rigsim_vol (until 2026-11-22 these
    # tests built it with the default and so compared rigsim_vol with itself)
    ms = build_mitsuba_scene(scene, lights=scene.lights, max_depth=max_depth, integrator="volpath")
    assert not isinstance(ms.scene.integrator(), RigsimVolIntegrator)
    rig = with_integrator(ms, integrator or integrator_dict("rigsim", max_depth=max_depth))
    ref = ms if reference is None else with_integrator(ms, {**integrator_dict("rigsim", max_depth=max_depth),
                                                            **reference})
    return (_renders(rig, scene, n=n, spp=spp, seed0=100),
            _renders(ref, scene, n=n_ref or n, spp=spp_ref or spp, seed0=900))


def _blocks(a: np.ndarray, k: int) -> np.ndarray:
    """Means over k×k pixel blocks of a stack (n, H, W, bands)."""
    n, h, w, b = a.shape
    return a.reshape(n, h // k, k, w // k, k, b).mean(axis=(2, 4))


def _assert_image_means_agree(a: np.ndarray, b: np.ndarray):
    """Image mean per band within 4 standard errors (from the render-to-render scatter)."""
    ia, ib = a.mean(axis=(1, 2)), b.mean(axis=(1, 2))
    se = np.sqrt(ia.var(0, ddof=1) / len(ia) + ib.var(0, ddof=1) / len(ib))
    z = (ia.mean(0) - ib.mean(0)) / se
    assert np.all(np.abs(z) < 4.0), (z, ia.mean(0), ib.mean(0), se)


def test_single_scattering_image_matches_volpath_ztest():
    """Single scattering, per 4×4-pixel block (volpath's next-event estimation from a vertex at r
    from the strobe ∝ 1/r² is heavy-tailed even here: per pixel and per 2×2 block, 8 renders of each
    gave maxima of |Z| of 4–6 with no shift of the mean; per 4×4 block 2.0–2.8)."""
    a, b = _pair(2, n=8, spp=256, spp_ref=1024)
    z, z_mean = _ztest(_blocks(a, 4), _blocks(b, 4))
    _assert_consistent(z, z_mean, 8)


# Beyond single scattering volpath's estimate of the light scattered near the strobe has infinite
# variance (its next-event estimation from a vertex at r from the strobe ∝ 1/r², and nothing draws
# directions toward the strobe): most of its renders miss part of that light and a few carry it
# as fireflies, so per-pixel Z-tests against it fail one-sidedly (measured at max_depth 3: 21 % of
# pixels with Z > 3.5, none below -3.5, while the image means agree within 1σ; 24 volpath renders
# of 8192 paths per pixel: 0.8426 ± 0.0029, 0.9288 ± 0.0042, 0.5519 ± 0.0016 against rigsim_vol's
# 0.8458, 0.9314, 0.5539).  So deeper paths are checked (1) by the image mean against volpath with
# many samples and (2) per pixel against rigsim_vol with the halo, target and surface-halo
# next-event estimations off (which agree with each other pixel by pixel).
_WITHOUT_NEE_EXTRAS = {"halo_nee": False, "target_nee": False, "surface_halo": False}


@pytest.mark.parametrize("max_depth", [3, 4])
def test_deeper_paths_match_volpath_image_mean(max_depth):
    """Two and three scattering events (or surfaces): hero-wavelength MIS over whole paths, the
    equiangular continuation vertex, the light-directed and aureole directions, the surfaces' direct
    light on every path, the halos seen from surfaces, Russian roulette."""
    a, b = _pair(max_depth, n=8, spp=512, n_ref=16, spp_ref=4096)
    _assert_image_means_agree(a, b)


@pytest.mark.parametrize("max_depth,two_lights", [(3, False), (4, False), (4, True)])
def test_next_event_extras_are_unbiased_per_pixel(max_depth, two_lights):
    """The halo NEE (water vertices), the target NEE and the halos seen from surfaces (one light
    chosen at random when there are two) change only the noise: per-pixel Z-test against the same
    integrator without them."""
    a, b = _pair(max_depth, n=8, spp=512, reference=_WITHOUT_NEE_EXTRAS, two_lights=two_lights)
    z, z_mean = _ztest(a, b)
    _assert_consistent(z, z_mean, 8)


#: The integrator's options before 2026-12-05: the light-directed share at every depth, roulette from depth 5.
_BEFORE_DEEP_DEFAULTS = {"light_directed_depth": 1 << 30, "rr_depth": 5, "rr_depth_max": 5}


def test_fewer_deep_light_directed_directions_and_later_roulette_are_unbiased_per_pixel():
    """The defaults (a smaller light-directed share from ``DEFAULT_LIGHT_DIRECTED_DEPTH`` on, Russian
    roulette from ``DEFAULT_RR_DEPTH``) change only the noise: per-pixel Z-test at max_depth 8 against
    the options before (the share at every depth, roulette from depth 5), in coastal water (albedo 0.94)."""
    a, b = _pair(8, n=8, spp=512, reference=_BEFORE_DEEP_DEFAULTS)
    z, z_mean = _ztest(a, b)
    _assert_consistent(z, z_mean, 8)


def test_smaller_equiangular_continuation_share_is_unbiased_per_pixel():
    """The equiangular continuation share 0.05 (``DEFAULT_EQUIANGULAR_VERTEX``, 0.2 until 2026-12-07) changes
    only the noise: per-pixel Z-test at max_depth 8 against the share 0.2, in coastal water (albedo 0.94)."""
    assert DEFAULT_EQUIANGULAR_VERTEX != 0.2  # else this compares the integrator with itself
    a, b = _pair(8, n=8, spp=512, reference={"equiangular_vertex": 0.2})
    z, z_mean = _ztest(a, b)
    _assert_consistent(z, z_mean, 8)


class _DeepShareMissingFromTheDensity(RigsimVolIntegrator):
    """Draws deep directions with the smaller light-directed share but reports the density of the full
    share (a mixture density that does not match its sampling)."""

    def _directed_pdf(self, wo, pdf_wo, axes, aureole, c=None):
        return super()._directed_pdf(wo, pdf_wo, axes, aureole, None)


def test_ztest_flags_a_deep_share_missing_from_the_density():
    props = mi.Properties(PLUGIN_NAME)
    props["max_depth"] = 8
    props["light_directed_depth"] = 1
    a, b = _pair(8, n=8, spp=256, integrator=_DeepShareMissingFromTheDensity(props),
                 reference=_BEFORE_DEEP_DEFAULTS)
    z, z_mean = _ztest(a, b)
    with pytest.raises(AssertionError):
        _assert_consistent(z, z_mean, 8)


class _WrongMIS(RigsimVolIntegrator):
    """Balance heuristic with the other technique's pdf halved: weights sum to > 1 (overcounting)."""

    def mis_weight(self, pdf_a, pdf_b):
        w = pdf_a / (pdf_a + 0.5 * pdf_b)
        return dr.select(dr.isfinite(w), w, 0.0)


def test_ztest_flags_a_wrong_mis_weight():
    a, b = _pair(2, n=8, spp=256, spp_ref=1024, integrator=_WrongMIS(mi.Properties(PLUGIN_NAME)))
    z, z_mean = _ztest(_blocks(a, 4), _blocks(b, 4))
    with pytest.raises(AssertionError):
        _assert_consistent(z, z_mean, 8)


def test_image_mean_check_flags_a_wrong_mis_weight_in_deeper_paths():
    """The image-mean check can fail: the overcounting MIS weight above, at max_depth 4."""
    props = mi.Properties(PLUGIN_NAME)
    props["max_depth"] = 4
    a, b = _pair(4, n=8, spp=512, n_ref=16, spp_ref=4096, integrator=_WrongMIS(props))
    with pytest.raises(AssertionError):
        _assert_image_means_agree(a, b)


@pytest.mark.slow
def test_full_depth_matches_volpath_image_mean_and_is_unbiased_per_pixel():
    """All orders of scattering (volpath with many samples for its heavy tail)."""
    a, b = _pair(-1, n=16, spp=1024, n_ref=32, spp_ref=8192)
    _assert_image_means_agree(a, b)
    a, b = _pair(-1, n=8, spp=1024, reference=_WITHOUT_NEE_EXTRAS)
    z, z_mean = _ztest(a, b)
    _assert_consistent(z, z_mean, 8)


def test_refuses_scenes_outside_its_class():
    d = {"type": "scene", "integrator": {"type": PLUGIN_NAME},
         "lamp": {"type": "rectangle", "emitter": {"type": "area", "radiance": 1.0}}}
    scene = mi.load_dict(d)
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(0, 4)
    ray = mi.RayDifferential3f(mi.Point3f(0, 0, -1), mi.Vector3f(0, 0, 1))
    with pytest.raises(ConfigError, match="point lights"):
        scene.integrator().sample(scene, sampler, ray, None, mi.Bool(True))


def test_backscatter_aov_matches_a_pass_with_black_targets():
    """The backscatter layer estimated from the full pass's paths (their light before the first
    surface) agrees with the separate pass in which the targets are black (per-pixel Z-test)."""
    scene = _scene()
    wl, bw = band_edges(WL, BW)
    full = build_mitsuba_scene(scene, lights=scene.lights, backscatter_aov=True)
    black = build_mitsuba_scene(scene, lights=scene.lights, mode="backscatter")
    a, b, f = [], [], []
    # 12 renders each: with 8, the per-pixel Welch t (ν ≈ 14) exceeds 3.5 in 0.35 % of pixels by
    # chance and the Monte Carlo tails of 8-sample variances add more: 0–7 of the 576 values over
    # six seed sets (limit 5); with 32 renders each, 1 of 576 (no bias)
    for i in range(12):
        aov: dict = {}
        img, _ = render_pass(full, scene.camera, width=W, height=H, spp=256, seed=300 + i, band_lo=wl - bw / 2,
                             band_w=bw, aov_out=aov)
        a.append(aov["backscatter"])
        f.append(img)
        b.append(render_pass(black, scene.camera, width=W, height=H, spp=256, seed=700 + i, band_lo=wl - bw / 2,
                             band_w=bw)[0])
    a, b, f = np.stack(a), np.stack(b), np.stack(f)
    z, z_mean = _ztest(a, b)
    _assert_consistent(z, z_mean, 12)
    # and it is not the full image: the white patch adds light where it is seen
    assert f.mean() > 1.2 * a.mean()


def test_class_a_aov_is_the_single_scattering_at_zero_and_the_backscatter_at_180_deg():
    """The fast engine's class A from the full pass's paths (``class_split_deg``): with the split at 0 deg every
    turn is wide, so class A is the light scattered once (no surface) - a pass of depth 2 with black targets, from
    other seeds (per-pixel Z-test); at 180 deg no turn is, so it is the backscatter AOV itself, path by path."""
    scene = _scene()
    wl, bw = band_edges(WL, BW)
    kw = dict(width=W, height=H, spp=256, band_lo=wl - bw / 2, band_w=bw)
    at0 = build_mitsuba_scene(scene, lights=scene.lights, backscatter_aov=True, class_split_deg=0.0)
    single = build_mitsuba_scene(scene, lights=scene.lights, mode="backscatter", max_depth=2)
    a, s, bs = [], [], []
    for i in range(12):
        aov: dict = {}
        render_pass(at0, scene.camera, seed=300 + i, aov_out=aov, **kw)
        a.append(aov["class_a"])
        bs.append(aov["backscatter"])
        s.append(render_pass(single, scene.camera, seed=700 + i, **kw)[0])
    a, s, bs = np.stack(a), np.stack(s), np.stack(bs)
    z, z_mean = _ztest(a, s)
    _assert_consistent(z, z_mean, 12)
    # the multiply scattered light is the rest of the backscatter (a few per cent in this water), so the
    # test sees the difference the split is for
    assert bs.mean() > 1.08 * a.mean(), bs.mean() / a.mean()  # 1.17 at 1024 paths per pixel
    at180 = build_mitsuba_scene(scene, lights=scene.lights, backscatter_aov=True, class_split_deg=180.0)
    aov = {}
    render_pass(at180, scene.camera, seed=5, aov_out=aov, **kw)
    np.testing.assert_array_equal(aov["class_a"], aov["backscatter"])
    with pytest.raises(ConfigError, match="class_split_deg"):
        build_mitsuba_scene(scene, lights=scene.lights, class_split_deg=190.0)


def test_a_rendered_scene_is_freed_with_its_lights():
    """Rendering must not tie the scene to its integrator in a cycle Python cannot collect (it
    did: every scene stayed alive with its lights registered, and the indirect calls over them
    made each later render slower — 2–5× within the test suite)."""
    import gc
    import weakref

    scene = _scene()
    ms = build_mitsuba_scene(scene, lights=scene.lights)
    wl, bw = band_edges(WL, BW)
    render_pass(ms, scene.camera, width=8, height=6, spp=4, seed=1, band_lo=wl - bw / 2, band_w=bw)
    light = weakref.ref(list(ms.scene.emitters())[0])
    integrator = weakref.ref(ms.scene.integrator())
    assert isinstance(integrator(), RigsimVolIntegrator) and light() is not None
    del ms
    forget_scenes()  # the loaded scene is kept for the next render of the same scene until then
    gc.collect()
    assert light() is None and integrator() is None
