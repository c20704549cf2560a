"""Marine snow in both engines: one particle against its exact radiance, the lens's defocus disc, and a
field of particles where the fast engine's specks must sit where Monte Carlo's are, as bright."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rigsim.config.rig import load_rig
from rigsim.preview import render_preview
from rigsim.render import render
from rigsim.scene.build import build_scene
from rigsim.scene.optics import aperture_diameter_water_m, cell_solid_angles, outside_index, port_reach_m
from rigsim.scene.particles import ParticleSet, scene_particles
from rigsim.scene.types import BeamPattern, Camera, Light, Port, Rig, Scene, Target
from rigsim.water import preset
from rigsim.water.model import Spectrum1D, TabulatedWater, with_particles
from rigsim.water.particles import ParticleField, lambert_sphere_phase, particle_level
from rigsim.water.phase import petzold_average_particle

pytestmark = pytest.mark.render

A = 0.05  # 1/m: absorbing water (b ≈ 0): the particle's light is exactly the formula's
W, H = 96, 64


def _inject(monkeypatch, ps):
    import rigsim.preview.model as pm
    import rigsim.render.mitsuba_scene as ms
    import rigsim.render.renderer as rr

    for mod in (pm, ms, rr):
        monkeypatch.setattr(mod, "scene_particles", lambda scene, _ps=ps: _ps)


def _one(pos, d, albedo=0.5, focus=None, light_at=(-0.2, 0.0, 0.0)):
    field = ParticleField(number_per_m3=1.0, albedo=albedo)
    ps = ParticleSet(position_m=np.array([pos], float), diameter_m=np.array([d]), field=field, seed=0,
                     depth_range_m=(0.1, 5.0), volume_m3=1.0, expected=1.0, truncated=False)
    water = with_particles(TabulatedWater("absorbing", Spectrum1D.constant(A), Spectrum1D.constant(1e-6),
                                          petzold_average_particle(), wavelength_nm=[550.0]), field)
    light = Light(name="s", kind="strobe", position_m=light_at, aim=(0.0, 0.0, 1.0),
                  beam=BeamPattern(beam_angle_deg=100.0), wavelength_nm=(300.0, 900.0), axial_intensity=(1.0, 1.0))
    cam = Camera(port=Port(kind="dome"), focal_length_mm=24.0, focus_distance_m=focus)
    scene = Scene(rig=Rig(name="t", camera=cam, lights=(light,)), water=water,
                  targets=(Target(kind="black-disk", distance_m=20.0, size_m=0.1),))
    return scene, ps


def _exact(scene, ps):
    """Irradiance at the pupil (J/m² per flash per nm) from the particle, by the formulas written out here."""
    light = scene.lights[0]
    p, d = ps.position_m[0], ps.diameter_m[0]
    v = p - np.asarray(light.position_m)
    r_l = np.linalg.norm(v)
    theta = np.arccos(v[2] / r_l)
    f = 2.0 ** (-(theta / np.radians(50.0)) ** 2)  # soft-cone beam of 100°: half intensity at 50°
    E = f / r_l ** 2 * np.exp(-A * r_l)  # irradiance on the particle, inverse square and attenuation
    r = np.linalg.norm(p)
    cos_scatter = (v / r_l) @ (-p / r)
    intensity = E * np.pi / 4 * d * d * ps.field.albedo * lambert_sphere_phase(cos_scatter)
    return intensity * np.exp(-A * (r - port_reach_m(scene.camera))) / r ** 2


def _flux(img, scene, w=W, h=H):
    om = cell_solid_angles(scene.camera, w, h, n_outside=outside_index(scene))
    return float((img.layers["flash_particles"][..., 0] * om).sum())


@pytest.mark.parametrize("pos,d,focus", [((0.0, 0.0, 0.4), 0.01, None), ((-0.1, -0.085, 0.3), 0.008, None),
                                         ((0.05, 0.02, 0.35), 0.01, 1.5)])
def test_one_particle_gives_its_exact_radiance(monkeypatch, pos, d, focus):
    """Geometry, beam pattern, inverse square, attenuation on both legs, reflectance, the diffuse sphere's
    phase function and the lens: the fast engine equals the formula; Monte Carlo agrees within its noise
    (Z < 4 over 8 renders) and the sphere's finite size (+1.5 % for 1 cm at 0.3 m by a sum over its surface;
    the formula takes the particle as a point)."""
    scene, ps = _one(pos, d, focus=focus)
    _inject(monkeypatch, ps)
    exact = _exact(scene, ps)
    w, h = 2 * W, 2 * H  # the particle covers ~20 pixels: enough paths meet it
    kw = dict(width=w, height=h, wavelengths_nm=[550.0], bandwidth_nm=1.0, layers=("particles",))
    assert _flux(render_preview(scene, **kw), scene, w, h) == pytest.approx(exact, rel=1e-5)
    mc = np.array([_flux(render(scene, spp=32, seed=s, **kw), scene, w, h) for s in range(8)])
    se = mc.std(ddof=1) / np.sqrt(len(mc))
    assert abs(mc.mean() - exact) < 0.02 * exact + 4 * se, (mc.mean(), exact, se)
    assert se < 0.03 * exact


def test_defocus_disc_has_the_thin_lens_size(monkeypatch):
    """A particle at 0.2 m with an f/2.8 lens focused at 3 m: in both engines its image is a disc of angular
    diameter D_w |1/z − 1/s_f| (the thin lens in the water's object space) widened by the particle's own
    size; measured by the image's second moment, E[ρ²] = R²/2 for a uniform disc of radius R (plus a
    pixel's 1/6 px² from the box of each pixel)."""
    scene, ps = _one((0.0, 0.0, 0.2), 0.001, focus=3.0)
    cam = dataclasses.replace(scene.camera, f_number=2.8)
    scene = dataclasses.replace(scene, rig=dataclasses.replace(scene.rig, camera=cam))
    _inject(monkeypatch, ps)
    w, h = 288, 192
    kw = dict(width=w, height=h, wavelengths_nm=[550.0], bandwidth_nm=1.0, layers=("particles",))
    blur = aperture_diameter_water_m(cam) * abs(1 / 0.2 - 1 / 3.0)  # rad, diameter: 24/2.8/1.34 mm × 4.67
    pitch = cam.sensor_width_mm / cam.focal_length_mm / w  # rad per pixel at the centre (a dome keeps angles)
    R = np.hypot(blur / 2, 0.0005 / 0.2) / pitch  # pixels
    assert R > 2.5
    for img in (render_preview(scene, **kw), render(scene, spp=64, seed=1, **kw)):
        a = np.clip(img.layers["flash_particles"][..., 0], 0, None)
        yy, xx = np.mgrid[:h, :w] + 0.5
        m = a.sum()
        cx, cy = (a * xx).sum() / m, (a * yy).sum() / m
        rho2 = (a * ((xx - cx) ** 2 + (yy - cy) ** 2)).sum() / m - 1.0 / 6.0
        assert abs(cx - w / 2) < 0.5 and abs(cy - h / 2) < 0.5
        assert np.sqrt(2 * rho2) == pytest.approx(R, rel=0.1), (np.sqrt(2 * rho2), R)


def test_fast_specks_sit_and_shine_where_monte_carlo_puts_them():
    """A field of coastal marine snow in pure sea water before the close-to-port rig: the same particle ids
    in both engines, the image's particle light within 8 % + 3 SE per colour, and each of the ten brightest
    specks (5×5 pixels about its peak) within 12 % + 3 SE of Monte Carlo."""
    from scipy.ndimage import maximum_filter

    rig = load_rig("rigs/twin-strobes-close-to-port.toml")
    scene = build_scene(rig, with_particles(preset("pure-sea"), particle_level("coastal")), "black-disk", 3.0,
                        size_m=0.3)
    w, h = 96, 64
    kw = dict(width=w, height=h, wavelengths_nm=[450.0, 550.0, 650.0], bandwidth_nm=20.0,
              layers=("range_m", "object_id", "particles", "particle_id"))
    fast = render_preview(scene, **kw)
    mcs = [render(scene, spp=32, seed=s, **kw) for s in range(4)]
    assert np.array_equal(fast.layers["particle_id"], mcs[0].layers["particle_id"])
    om = cell_solid_angles(scene.camera, w, h, n_outside=outside_index(scene))[..., None]
    pf = fast.layers["flash_particles"] * om
    pm = np.stack([m.layers["flash_particles"] for m in mcs]) * om
    tot_f, tot_m = pf.sum((0, 1)), pm.sum((1, 2))
    se = tot_m.std(0, ddof=1) / 2
    assert np.all(np.abs(tot_f - tot_m.mean(0)) < 0.08 * tot_m.mean(0) + 3 * se), (tot_f, tot_m.mean(0), se)
    lum = pf.sum(-1)
    peaks = np.argwhere((lum == maximum_filter(lum, 5)) & (lum > 0))
    top = peaks[np.argsort(-lum[peaks[:, 0], peaks[:, 1]])[:10]]
    for r, c in top:
        sl = (slice(max(r - 2, 0), r + 3), slice(max(c - 2, 0), c + 3))
        a = pf[sl].sum()
        b = pm[(slice(None),) + sl].sum(axis=(1, 2, 3))
        assert abs(a - b.mean()) < 0.12 * b.mean() + 3 * b.std(ddof=1) / 2, ((c, r), a, b.mean())


def test_in_scattering_water_their_light_and_their_shadows_agree_with_monte_carlo():
    """Coastal marine snow in coastal water (b = 0.16 /m), close-to-port rig, rendered with the particles as
    they are and as black (the same places): the particles' own light (as they are − black: direct, the
    forward-scattered beam and the multiply scattered light on them) within 6 % + 3 SE per colour band, and
    what they take from the rest of the image (without them − black: their shadows on the view and in the
    strobes' beams) within 10 % + 3 SE of Monte Carlo."""
    rig = load_rig("rigs/twin-strobes-close-to-port.toml")
    level = particle_level("coastal")
    scenes = [build_scene(rig, with_particles(preset("coastal"), f), "black-disk", 3.0, size_m=0.9)
              for f in (level, dataclasses.replace(level, albedo=0.0))]
    w, h = 64, 43
    kw = dict(width=w, height=h, wavelengths_nm=[450.0, 550.0, 650.0], bandwidth_nm=20.0, layers=("particles",))
    fast = [render_preview(sc, **kw) for sc in scenes]
    mc = [[render(sc, spp=32, seed=s, **kw) for s in range(4)] for sc in scenes]
    om = cell_solid_angles(scenes[0].camera, w, h, n_outside=outside_index(scenes[0]))[..., None]

    def parts(full, black):  # (light, hidden) per band
        return (((full.layers["flash"] - black.layers["flash"]) * om).sum((0, 1)),
                (-black.layers["flash_particles"] * om).sum((0, 1)))

    lf, hf = parts(*fast)
    per = np.array([parts(a, b) for a, b in zip(*mc)])  # (seeds, 2, bands)
    m, se = per.mean(0), per.std(0, ddof=1) / 2
    assert np.all(np.abs(lf - m[0]) < 0.06 * m[0] + 3 * se[0]), (lf / m[0] - 1, se[0] / m[0])
    assert np.all(np.abs(hf - m[1]) < 0.10 * m[1] + 3 * se[1]), (hf / m[1] - 1, se[1] / m[1])


def test_moving_the_strobes_outward_lowers_the_speck_count():
    """The close-to-port rig's strobes swung out from 0.2 to 0.9 m in coastal water with coastal marine snow:
    fewer visible specks at every step (rigsim.metrics.specks), and a smaller share of the light."""
    from rigsim.metrics.specks import speck_metrics

    rig = load_rig("rigs/twin-strobes-close-to-port.toml")
    water = with_particles(preset("coastal"), particle_level("coastal"))
    counts, shares = [], []
    for arm in (0.2, 0.35, 0.5, 0.7, 0.9):
        lights = tuple(dataclasses.replace(l, position_m=(np.sign(l.position_m[0]) * arm, 0.0, 0.0))
                       for l in rig.lights)
        sc = build_scene(dataclasses.replace(rig, lights=lights), water, "colorchecker", 1.5)
        im = render_preview(sc, width=320, height=213, layers=("object_id", "particles", "particle_id"),
                            multiple=False)
        m = speck_metrics(im, im.layers["object_id"] > 0)
        counts.append(m["speck_count"])
        shares.append(m["speck_share"])
    assert counts[0] > 50 and all(a > b for a, b in zip(counts, counts[1:])), counts
    assert all(a > b for a, b in zip(shares, shares[1:])), shares
    # the same particles in every scene (the placement does not depend on where the strobes are)
    assert len({len(scene_particles(build_scene(dataclasses.replace(rig, lights=(l,)), water, "colorchecker", 1.5)))
                for l in rig.lights}) == 1


@pytest.mark.parametrize("level", ["coastal", "plankton-bloom"])
def test_dense_near_particles_never_make_light_negative(level):
    """A chart 1 m away behind marine snow (the near particles' defocus discs overlap): every radiance is
    finite and >= 0 (the particles hide at most all of a pixel's light); only their own layer, a change,
    may be negative."""
    rig = load_rig("rigs/twin-strobes-close-to-port.toml")
    scene = build_scene(rig, with_particles(preset("coastal"), particle_level(level)), "colorchecker", 1.0)
    img = render_preview(scene, width=320, height=213, layers=("object_id", "backscatter", "particles", "particle_id"))
    for k in ("flash", "flash_backscatter"):
        a = img.layers[k]
        assert np.all(np.isfinite(a)) and a.min() >= 0.0, (k, a.min())
    assert np.all(np.isfinite(img.layers["flash_particles"]))
