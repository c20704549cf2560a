"""Beam patterns: half-intensity angle, solid-angle integral, exact sampling (χ²)."""

import numpy as np
import pytest
from scipy import integrate, stats

from rigsim.errors import ConfigError
from rigsim.light.beam import (
    beam_angle_in_water_deg,
    beam_from_csv,
    beam_pdf,
    beam_solid_angle_sr,
    local_to_world,
    sample_beam_direction,
    soft_cone,
)
from rigsim.scene.types import BeamPattern


@pytest.mark.parametrize("angle", [20.0, 100.0, 110.0, 150.0])
@pytest.mark.parametrize("p", [1.0, 2.0, 6.0])
def test_half_intensity_at_half_angle(angle, p):
    b = soft_cone(angle, p)
    assert float(b.relative_intensity(0.0)) == 1.0
    assert float(b.relative_intensity(np.radians(angle / 2))) == pytest.approx(0.5, abs=1e-12)


def test_behind_the_light_is_dark():
    assert float(soft_cone(200.0).relative_intensity(np.radians(95.0))) == 0.0


@pytest.mark.parametrize("angle,p", [(100.0, 2.0), (60.0, 4.0), (170.0, 1.0)])
def test_solid_angle_matches_quadrature(angle, p):
    b = soft_cone(angle, p)
    ref, _ = integrate.quad(lambda t: 2 * np.pi * float(b.relative_intensity(t)) * np.sin(t), 0, np.pi / 2,
                            epsabs=1e-13, epsrel=1e-12, limit=200)
    assert beam_solid_angle_sr(b) == pytest.approx(ref, rel=1e-9)


def test_uniform_hemisphere_table_is_2pi():
    b = BeamPattern(kind="table", angle_deg=(0.0, 90.0), relative=(1.0, 1.0))
    assert beam_solid_angle_sr(b) == pytest.approx(2 * np.pi, rel=1e-12)


def _chi2_in_cos(beam, n=100_000, bins=40, seed=1):
    rng = np.random.default_rng(seed)
    d, pdf = sample_beam_direction(beam, rng.random(n), rng.random(n))
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
    tmax = np.pi / 2 if beam.kind == "soft-cone" else np.radians(beam.angle_deg[-1])
    edges = np.linspace(np.cos(tmax), 1.0, bins + 1)
    counts, _ = np.histogram(d[:, 2], bins=edges)
    omega, _ = integrate.quad(lambda t: float(beam.relative_intensity(t)) * np.sin(t), 0, tmax, limit=200)
    exp = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        m, _ = integrate.quad(lambda mu: float(beam.relative_intensity(np.arccos(np.clip(mu, -1, 1)))), lo, hi)
        exp.append(m / omega)
    exp = np.asarray(exp) * n
    keep = exp > 5
    # pool tiny tail bins into one
    obs = np.append(counts[keep], counts[~keep].sum())
    ex = np.append(exp[keep], exp[~keep].sum())
    if ex[-1] == 0:
        obs, ex = obs[:-1], ex[:-1]
    ex *= obs.sum() / ex.sum()
    return stats.chisquare(obs, ex).pvalue, d, pdf


@pytest.mark.parametrize("beam", [soft_cone(100.0), soft_cone(40.0, 4.0), soft_cone(150.0, 1.0),
                                  BeamPattern(kind="table", angle_deg=(0.0, 30.0, 60.0, 80.0),
                                              relative=(1.0, 0.9, 0.3, 0.0))])
def test_sampling_chi2(beam):
    p, d, pdf = _chi2_in_cos(beam)
    assert p > 1e-3
    # azimuth uniform
    phi = np.arctan2(d[:, 1], d[:, 0])
    c, _ = np.histogram(phi, bins=16, range=(-np.pi, np.pi))
    assert stats.chisquare(c).pvalue > 1e-3
    # reported pdf equals beam_pdf and ≈ f/Ω
    assert pdf == pytest.approx(beam_pdf(beam, d[:, 2]), rel=1e-9)
    f = beam.relative_intensity(np.arccos(d[:, 2])) / beam_solid_angle_sr(beam)
    ok = f > 1e-2 * f.max()
    assert np.max(np.abs(pdf[ok] / f[ok] - 1)) < 1e-2


def test_sampling_pdf_close_to_f_for_typical_beam():
    b = soft_cone(100.0)
    rng = np.random.default_rng(7)
    d, pdf = sample_beam_direction(b, rng.random(10_000), rng.random(10_000))
    f = b.relative_intensity(np.arccos(d[:, 2])) / beam_solid_angle_sr(b)
    assert np.max(np.abs(pdf / f - 1)) < 1e-3


def test_pdf_integrates_to_one():
    b = soft_cone(100.0)
    t = np.linspace(0, np.pi, 400_001)
    val = np.trapezoid(2 * np.pi * beam_pdf(b, np.cos(t)) * np.sin(t), t)
    assert val == pytest.approx(1.0, abs=1e-4)


def test_local_to_world_maps_axis_and_keeps_angles():
    rng = np.random.default_rng(3)
    aim = np.array([0.3, -0.5, 0.8])
    aim /= np.linalg.norm(aim)
    d, _ = sample_beam_direction(soft_cone(90.0), rng.random(1000), rng.random(1000))
    w = local_to_world(aim, d)
    assert np.allclose(w @ aim, d[:, 2])
    assert np.allclose(local_to_world(aim, [0, 0, 1]), aim)
    assert np.allclose(local_to_world([0, 0, -1], [0, 0, 1]), [0, 0, -1])


@pytest.mark.parametrize("angle", [0.0, -10.0, 360.0, 400.0])
def test_bad_beam_angle(angle):
    with pytest.raises(ConfigError, match="beam angle"):
        soft_cone(angle)


def test_beam_profile_csv(tmp_path):
    p = tmp_path / "beam.csv"
    p.write_text("# source: test\nangle_deg,relative\n0,200\n40,100\n70,0\n")
    b = beam_from_csv(p)
    assert b.relative[0] == 1.0 and float(b.relative_intensity(np.radians(40.0))) == pytest.approx(0.5)
    bad = tmp_path / "bad.csv"
    bad.write_text("angle_deg,relative\n5,1\n40,1\n")
    with pytest.raises(ConfigError, match="start at 0"):
        beam_from_csv(bad)


def test_in_air_angle_conversion():
    assert beam_angle_in_water_deg(120.0, 1.34) == pytest.approx(2 * np.degrees(np.arcsin(np.sin(np.radians(60)) / 1.34)))
