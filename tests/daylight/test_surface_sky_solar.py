"""Surface optics, sky radiance models and the above-water solar spectra."""

from __future__ import annotations

import numpy as np
import pytest

from rigsim.daylight.sky import CIEGeneralSky, UniformSky, cie_sky_parameters, radiance_CIE_general_sky, sky_model
from rigsim.daylight.solar import (
    ASTM_G173_GROUND_ALBEDO,
    ASTM_G173_ZENITH_DEG,
    irradiance_clear_sky_ASTMG173,
    solar_spectrum_ASTMG173,
    surface_irradiance,
)
from rigsim.daylight.surface import (
    Surface,
    critical_angle_deg,
    fresnel_reflectance_unpolarised,
    refract,
    slope_variance_CoxMunk1954,
    snell_cos_transmitted,
)
from rigsim.errors import ConfigError

N = 1.34


def _fresnel_complex(theta_i, n1, n2):
    """Independent form: complex amplitude coefficients with cos t = sqrt(1 - (n1/n2)^2 sin^2 i) as complex."""
    ci = np.cos(theta_i).astype(complex)
    ct = np.sqrt(1 - (n1 / n2) ** 2 * np.sin(theta_i).astype(complex) ** 2)
    rs = (n1 * ci - n2 * ct) / (n1 * ci + n2 * ct)
    rp = (n1 * ct - n2 * ci) / (n1 * ct + n2 * ci)
    return 0.5 * (abs(rs) ** 2 + abs(rp) ** 2)


def test_fresnel_normal_incidence_published_value():
    # Mobley (1994) §4.3: R(0) = ((n-1)/(n+1))^2 = 0.0211 for n = 1.34
    assert fresnel_reflectance_unpolarised(1.0) == pytest.approx(((N - 1) / (N + 1)) ** 2, rel=1e-12)
    assert round(float(fresnel_reflectance_unpolarised(1.0)), 4) == 0.0211


@pytest.mark.parametrize("n1, n2", [(1.0, N), (N, 1.0)])
def test_fresnel_matches_complex_amplitudes(n1, n2):
    th = np.radians(np.linspace(0, 89.9, 500))
    np.testing.assert_allclose(fresnel_reflectance_unpolarised(np.cos(th), n1, n2), _fresnel_complex(th, n1, n2),
                               atol=1e-12)


def test_fresnel_reciprocity_and_total_internal_reflection():
    th_a = np.radians(np.linspace(0, 89, 90))
    cos_w = snell_cos_transmitted(np.cos(th_a), 1.0, N)
    np.testing.assert_allclose(fresnel_reflectance_unpolarised(np.cos(th_a), 1.0, N),
                               fresnel_reflectance_unpolarised(cos_w, N, 1.0), atol=1e-12)
    assert critical_angle_deg() == pytest.approx(np.degrees(np.arcsin(1 / N)))
    beyond = np.cos(np.radians(critical_angle_deg() + np.array([0.01, 10, 40])))
    assert np.all(fresnel_reflectance_unpolarised(beyond, N, 1.0) == 1.0)


def test_refract_obeys_snell_and_reflect_branch():
    rng = np.random.default_rng(1)
    th = rng.uniform(0, np.pi / 2 - 1e-3, 1000)
    ph = rng.uniform(0, 2 * np.pi, 1000)
    d = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=1)  # going down
    n = np.tile([0.0, 0.0, -1.0], (1000, 1))
    t, ok = refract(d, n, 1 / N)
    assert ok.all()
    sin_t = np.linalg.norm(t[:, :2], axis=1)
    np.testing.assert_allclose(sin_t * N, np.sin(th), atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(t, axis=1), 1.0)
    # from below beyond the critical angle: total internal reflection (mirror direction)
    up = -d
    t2, ok2 = refract(up, -n, N)
    tir = np.sin(th) > 1 / N
    assert np.array_equal(~ok2, tir)
    np.testing.assert_allclose(t2[tir, 2], -up[tir, 2])


def test_cox_munk_slope_variance_and_facet_weights():
    assert slope_variance_CoxMunk1954(10.0) == pytest.approx(0.003 + 0.0512)
    with pytest.raises(ConfigError):
        slope_variance_CoxMunk1954(-1)
    s = Surface(10.0)
    rng = np.random.default_rng(3)
    for zen in (0.0, 40.0, 75.0):
        t = np.radians(zen)
        for sign in (1, -1):
            d = np.tile([np.sin(t), 0.0, sign * np.cos(t)], (200_000, 1))
            nrm, w = s.sample_normals(d, rng)
            # weights have mean one (energy conserved) and only facets facing the ray carry weight
            assert w.mean() == pytest.approx(1.0, abs=4 * w.std() / np.sqrt(w.size))
            assert np.all(np.sum(d * nrm, axis=1)[w > 0] < 0)
            # the slope variance is σ² (sum of both components)
            zx, zy = nrm[:, 0] / np.abs(nrm[:, 2]), nrm[:, 1] / np.abs(nrm[:, 2])
            assert np.mean(zx ** 2 + zy ** 2) == pytest.approx(s.slope_variance, rel=0.02)


def test_sky_models_are_normalised_and_sampled_by_radiance_cosine():
    mu = (np.arange(1000) + 0.5) / 1000
    phi = (np.arange(360) + 0.5) / 360 * 2 * np.pi - np.pi
    rng = np.random.default_rng(5)
    for sky in (UniformSky(), CIEGeneralSky(30.0, 12), CIEGeneralSky(60.0, 1), CIEGeneralSky(10.0, 15)):
        ell = sky.radiance(mu[:, None], phi[None, :])
        integral = np.sum(ell * mu[:, None]) / 1000 * 2 * np.pi / 360
        assert integral == pytest.approx(1.0, rel=2e-3), sky.describe()
        m, p = sky.sample(200_000, rng)
        # the mean of cos θ and of cos φ under ℓ cos θ
        w = ell * mu[:, None]
        exp_mu = np.sum(w * mu[:, None]) / w.sum()
        exp_cphi = np.sum(w * np.cos(phi)[None, :]) / w.sum()
        assert m.mean() == pytest.approx(exp_mu, abs=3e-3)
        assert np.cos(p).mean() == pytest.approx(exp_cphi, abs=5e-3)


def test_cie_sky_formula_and_table():
    assert cie_sky_parameters(12) == (-1.0, -0.32, 10.0, -3.0, 0.45)
    assert cie_sky_parameters(5)[:2] == (0.0, -1.0)
    # zenith value is 1 by definition; the clear sky is brighter towards the sun than away from it
    assert radiance_CIE_general_sky(1.0, 0.0, 30.0, cie_sky_parameters(12)) == pytest.approx(1.0)
    toward = radiance_CIE_general_sky(np.cos(np.radians(40)), 0.0, 30.0, cie_sky_parameters(12))
    away = radiance_CIE_general_sky(np.cos(np.radians(40)), np.pi, 30.0, cie_sky_parameters(12))
    assert toward > 2 * away
    # type 5 is uniform
    assert np.allclose(radiance_CIE_general_sky(np.array([0.1, 0.5, 1.0]), 1.0, 30.0, cie_sky_parameters(5)), 1.0)
    for bad in ("cie:0", "cie:16", "cloudy"):
        with pytest.raises(ConfigError):
            sky_model(bad)


def test_clear_sky_model_reproduces_astm_g173_at_its_geometry():
    wl = np.array([350.0, 450.0, 550.0, 650.0, 750.0])
    direct, diffuse = irradiance_clear_sky_ASTMG173(wl, ASTM_G173_ZENITH_DEG)
    cz = np.cos(np.radians(ASTM_G173_ZENITH_DEG))
    # (Kasten–Young gives m = 1.4995 at 48.19°, not exactly 1.5: 0.2 % in the UV)
    np.testing.assert_allclose(direct, solar_spectrum_ASTMG173(wl, "direct") * cz, rtol=3e-3)
    # rebuild the 37° tilted global spectrum from the parts (isotropic sky, albedo 0.2)
    tilt = np.radians(37.0)
    gt = (solar_spectrum_ASTMG173(wl, "direct") * np.cos(np.radians(ASTM_G173_ZENITH_DEG) - tilt)
          + diffuse * (1 + np.cos(tilt)) / 2 + ASTM_G173_GROUND_ALBEDO * (direct + diffuse) * (1 - np.cos(tilt)) / 2)
    np.testing.assert_allclose(gt, solar_spectrum_ASTMG173(wl, "global-tilt"), rtol=1e-3)
    # the sky's share rises towards the blue and with the sun's zenith angle
    f30 = diffuse / (direct + diffuse)
    assert np.all(np.diff(f30) < 0)
    d60, s60 = irradiance_clear_sky_ASTMG173(wl, 70.0)
    assert np.all(s60 / (d60 + s60) > f30)


def test_surface_irradiance_options():
    s = surface_irradiance([450, 550], 30.0, total_W_per_m2_nm=2.0, sky_fraction=0.25)
    np.testing.assert_allclose(s.total, 2.0)
    np.testing.assert_allclose(s.sky, 0.5)
    b = surface_irradiance([550], 30.0, black_sky=True)
    assert b.sky[0] == 0.0 and b.sun[0] > 1.0
    c = surface_irradiance([450, 550, 650], 30.0, spectrum="cie-d:6500")
    assert c.total[1] == pytest.approx(surface_irradiance([550], 30.0).total[0])
    for kw in ({"sky_fraction": 1.5}, {"total_W_per_m2_nm": -1.0}, {"spectrum": "nope"}):
        with pytest.raises(ConfigError):
            surface_irradiance([550], 30.0, **kw)
    with pytest.raises(ConfigError):
        surface_irradiance([550], 95.0)
