"""Discrete particles (marine snow): the field's physics, the named levels, the placement (a Poisson
process: counts χ²-tested over many seeds, positions uniform in the volume), water files, the water report."""

from __future__ import annotations

import dataclasses
import doctest
import importlib
import json
import subprocess
import sys

import numpy as np
import pytest
from scipy import stats
from scipy.integrate import quad

from rigsim.config.rig import load_rig
from rigsim.config.water import load_water
from rigsim.errors import ConfigError
from rigsim.scene.build import build_scene
from rigsim.scene.particles import (MAX_PARTICLES, particle_footprints, particle_id_image, placement_frustum,
                                    scene_particles)
from rigsim.water import preset
from rigsim.water.model import with_particles
from rigsim.water.particles import (LAMBERT_SPHERE_BACKSCATTER_FRACTION, ParticleField, lambert_sphere_phase,
                                    particle_level, particle_level_names, power_law_moment_mm)


@pytest.mark.parametrize("module", ["rigsim.water.particles", "rigsim.scene.particles", "rigsim.metrics.specks"])
def test_doctests(module):
    res = doctest.testmod(importlib.import_module(module), optionflags=doctest.ELLIPSIS)
    assert res.failed == 0 and res.attempted > 0


def test_lambert_sphere_phase_is_normalised_and_backscatters_five_sixths():
    """∫ p dΩ = 1 and 5/6 of it beyond 90° (Russell 1916), by quadrature of the closed form."""
    total = quad(lambda t: 2 * np.pi * lambert_sphere_phase(np.cos(t)) * np.sin(t), 0, np.pi)[0]
    back = quad(lambda t: 2 * np.pi * lambert_sphere_phase(np.cos(t)) * np.sin(t), np.pi / 2, np.pi)[0]
    assert total == pytest.approx(1.0, abs=1e-9)
    assert back == pytest.approx(LAMBERT_SPHERE_BACKSCATTER_FRACTION, abs=1e-9)


def test_lambert_sphere_phase_is_the_integral_over_a_diffuse_sphere():
    """The closed form against a direct sum over the sphere's surface: radiance ρ/π E (n·l) seen at n·v."""
    rng = np.random.default_rng(1)
    n = rng.normal(size=(400_000, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    l = np.array([0.0, 0.0, 1.0])  # towards the light
    for alpha in (0.3, 1.0, 2.0):  # phase angle
        v = np.array([np.sin(alpha), 0.0, np.cos(alpha)])
        # intensity per unit irradiance, area and reflectance: ∫ (1/π)(n·l)+ (n·v)+ dA over a unit sphere
        est = np.mean(np.clip(n @ l, 0, None) * np.clip(n @ v, 0, None)) * 4 * np.pi / np.pi
        theta = np.pi - alpha  # scattering angle
        assert est == pytest.approx(np.pi * lambert_sphere_phase(np.cos(theta)), rel=0.01)


def test_size_distribution_moments_and_sampling():
    f = ParticleField(number_per_m3=1e4, d_min_mm=0.25, d_max_mm=5.0, size_slope=3.0)
    d = f.diameters_mm(np.random.default_rng(2).random(400_000))
    assert d.min() >= 0.25 and d.max() <= 5.0
    assert d.mean() == pytest.approx(power_law_moment_mm(1, 0.25, 5.0, 3.0), rel=0.01)
    assert np.mean(d ** 2) == pytest.approx(power_law_moment_mm(2, 0.25, 5.0, 3.0), rel=0.02)
    # the density ∝ d^-3: its CDF F(x) = (1 - (0.25/x)^2) / (1 - (0.25/5)^2)
    ks = stats.kstest(d, lambda x: (1 - (0.25 / x) ** 2) / (1 - 0.05 ** 2))
    assert ks.pvalue > 1e-3
    # the closed form of a moment (k = 3, p = 2: ∫ d^-1 / ∫ d^-3)
    assert power_law_moment_mm(2, 0.25, 5.0, 3.0) == pytest.approx(np.log(20) / ((0.25 ** -2 - 5 ** -2) / 2))


def test_the_field_is_stated_beside_the_water_not_added_to_it():
    w = preset("coastal")
    ws = load_water("coastal", particles="coastal")
    np.testing.assert_array_equal(ws.b_per_m([450, 550]), w.b_per_m([450, 550]))
    f = ws.particles
    c = f.number_per_m3 * np.pi / 4 * power_law_moment_mm(2, f.d_min_mm, f.d_max_mm, f.size_slope) * 1e-6
    assert f.c_per_m() == pytest.approx(c)
    assert f.b_per_m(550)[()] == pytest.approx(f.albedo * c) and f.a_per_m(550)[()] == pytest.approx((1 - f.albedo) * c)
    assert f.bb_per_m(550)[()] == pytest.approx(5 / 6 * f.albedo * c)


def test_named_levels_have_sources_and_grow_from_clear_ocean_to_silt():
    names = particle_level_names()
    assert names == ("clear-ocean", "coastal", "plankton-bloom", "silt-near-bottom")
    n = [particle_level(x).number_per_m3 for x in names]
    assert n == sorted(n)
    for x in names:
        assert "particle_levels.csv" in particle_level(x).source and len(particle_level(x).source) > 60
    with pytest.raises(ConfigError, match="unknown particle level 'foam'.*coastal"):
        particle_level("foam")


def _scene(water="clear", level="coastal", rig="rigs/twin-strobes-close-to-port.toml", seed=0, distance=1.5):
    w = with_particles(preset(water), particle_level(level)) if level else preset(water)
    sc = build_scene(load_rig(rig), w, "colorchecker", distance)
    return dataclasses.replace(sc, particle_seed=seed)


def test_same_seed_same_particles_other_seed_other():
    a, b, c = scene_particles(_scene(seed=3)), scene_particles(_scene(seed=3)), scene_particles(_scene(seed=4))
    assert np.array_equal(a.position_m, b.position_m) and np.array_equal(a.diameter_m, b.diameter_m)
    assert not np.array_equal(a.position_m[:10], c.position_m[:10])
    assert scene_particles(_scene(level=None)) is None


def test_counts_follow_the_poisson_law():
    """Over 200 seeds, the number of particles in a box well inside the placement volume is Poisson with
    mean n·V_box (χ² goodness of fit on the count histogram; and the mean within 4 SE)."""
    base = _scene(water="coastal", level="clear-ocean")
    box_lo, box_hi = np.array([-0.1, -0.1, 0.5]), np.array([0.1, 0.05, 0.8])
    lam = particle_level("clear-ocean").number_per_m3 * np.prod(box_hi - box_lo)  # 8000 × 0.009 = 72
    counts = []
    for s in range(200):
        p = scene_particles(dataclasses.replace(base, particle_seed=s)).position_m
        counts.append(int(np.all((p >= box_lo) & (p <= box_hi), axis=1).sum()))
    counts = np.array(counts)
    assert abs(counts.mean() - lam) < 4 * np.sqrt(lam / len(counts)), (counts.mean(), lam)
    edges = np.concatenate([[-0.5], np.arange(55.5, 90.5, 5.0), [np.inf]])
    obs = np.histogram(counts, edges)[0]
    cdf = stats.poisson.cdf(np.floor(edges[1:]), lam) - stats.poisson.cdf(np.floor(edges[:-1]), lam)
    exp = cdf * len(counts)
    chi2 = ((obs - exp) ** 2 / exp).sum()
    assert chi2 < stats.chi2.ppf(0.999, len(obs) - 1), (obs, exp.round(1), chi2)


def test_positions_are_uniform_in_depth():
    """Depths of the particles in the frustum are distributed as its cross-section's area (χ² over bins)."""
    sc = _scene(water="coastal", level="coastal")
    ps = scene_particles(sc)
    fr = placement_frustum(sc, ps.field, ps.depth_range_m[1])
    z0, z1 = 0.3, ps.depth_range_m[1]  # beyond the housing's exclusion
    depth = ps.position_m[:, 2]
    depth = depth[(depth > z0) & (depth < z1)]
    edges = np.linspace(z0, z1, 21)
    obs = np.histogram(depth, edges)[0]
    exp = np.array([fr.volume(b) - fr.volume(a) for a, b in zip(edges[:-1], edges[1:])])
    exp = exp / exp.sum() * obs.sum()
    chi2 = ((obs - exp) ** 2 / exp).sum()
    assert chi2 < stats.chi2.ppf(0.999, len(obs) - 1), chi2


def test_placement_stays_in_the_water_and_in_view():
    sc = _scene(level="coastal")
    ps = scene_particles(sc)
    d = np.linalg.norm(ps.position_m - np.asarray(sc.camera.position_m), axis=1)
    assert np.all(d > sc.camera.housing_radius_m)
    fp = particle_footprints(sc, ps, 640, 427)
    assert fp.imaged.mean() > 0.95  # the frustum hugs the field of view
    # a dense level is capped and says so
    dense = scene_particles(_scene(level="silt-near-bottom"))
    assert dense.truncated and abs(len(dense) - MAX_PARTICLES) < 5 * np.sqrt(MAX_PARTICLES)


def test_particle_ids_are_the_nearest_particle_reaching_into_the_pixel():
    sc = _scene(level="coastal")
    ps = scene_particles(sc)
    W, H = 320, 213
    ids = particle_id_image(sc, ps, W, H, np.full((H, W), np.inf))
    fp = particle_footprints(sc, ps, W, H)
    hit = np.unique(ids[ids > 0]) - 1
    assert hit.size > 100
    # every labelled particle's disc reaches into each pixel carrying its label
    for k in hit[:50]:
        rows, cols = np.nonzero(ids == k + 1)
        qx, qy = np.clip(fp.uv[k, 0], cols, cols + 1.0), np.clip(fp.uv[k, 1], rows, rows + 1.0)
        dm = np.stack([qx - fp.uv[k, 0], qy - fp.uv[k, 1]], axis=-1) @ np.linalg.inv(fp.jacobian[k]).T
        assert np.all(np.sum(dm * dm, axis=-1) <= fp.radius_m[k] ** 2 * (1 + 1e-9))
    # and the pixel its centre lies in carries it or a nearer particle's label
    for k in hit[:50]:
        c, r = int(fp.uv[k, 0]), int(fp.uv[k, 1])
        assert ids[r, c] == k + 1 or fp.range_m[ids[r, c] - 1] <= fp.range_m[k]
    # a target in front hides every particle behind it
    ids_near = particle_id_image(sc, ps, W, H, np.full((H, W), 0.25))
    assert np.all(fp.range_m[ids_near[ids_near > 0] - 1] < 0.25) and (ids_near > 0).sum() < (ids > 0).sum()


def test_water_files_and_their_errors(tmp_path):
    f = tmp_path / "w.toml"
    f.write_text('[water]\npreset = "coastal"\n[water.particles]\nlevel = "coastal"\nalbedo = 0.1\n')
    w = load_water(f)
    assert w.particles.albedo == 0.1 and w.particles.number_per_m3 == particle_level("coastal").number_per_m3
    f.write_text('[water]\na_per_m = 0.1\nb_per_m = 0.3\n[water.particles]\nnumber_per_m3 = 500\n')
    assert load_water(f).particles.number_per_m3 == 500
    for body, field in (('level = "coastal"\nd_max_mm = 0.1', "water.particles.d_max_mm"),
                        ('d_min_mm = 3', "water.particles.number_per_m3"),
                        ('level = "coastal"\nalbedo = 1.5', "water.particles.albedo"),
                        ('level = "coastal"\nspeed = 1', "water.particles.speed")):
        f.write_text(f'[water]\npreset = "clear"\n[water.particles]\n{body}\n')
        with pytest.raises(ConfigError) as e:
            load_water(f)
        assert str(f) in str(e.value) and field in str(e.value) and "\n" not in str(e.value)


def test_water_show_states_the_particles_contribution():
    out = subprocess.run([sys.executable, "-m", "rigsim.cli", "water", "show", "coastal", "--particles", "plankton-bloom",
                          "--wavelengths", "550", "--json"], capture_output=True, text=True, check=True).stdout
    d = json.loads(out)
    assert d["b_per_m"][0] == pytest.approx(float(preset("coastal").b_per_m(550.0)))  # not added to the water
    assert d["particles"]["level"] == "plankton-bloom"
    assert d["particles"]["c_per_m"][0] == pytest.approx(particle_level("plankton-bloom").c_per_m())
    assert "not included" in d["particles"]["note"]
    bad = subprocess.run([sys.executable, "-m", "rigsim.cli", "water", "show", "coastal", "--particles", "foam"],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and "particles" in bad.stderr


def test_a_scene_record_keeps_the_particles_and_their_seed():
    """An image's provenance (scene.json) brings back the same particles (capture, develop and reports read it)."""
    from rigsim.scene.record import scene_from_record, scene_record

    for water, level in (("coastal", "coastal"), ("jerlov-3C", "plankton-bloom")):
        sc = _scene(water=water, level=level, seed=7)
        back = scene_from_record(json.loads(json.dumps(scene_record(sc))))
        assert back.particle_seed == 7 and back.water.particles == sc.water.particles
        np.testing.assert_array_equal(scene_particles(back).position_m, scene_particles(sc).position_m)
