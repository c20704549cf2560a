"""The Monte Carlo ambient light meter: closed forms, conservation laws, estimators, reproducibility."""

from __future__ import annotations

import numpy as np
import pytest

from rigsim.daylight.meter import QUANTITIES, Bottom, ambient_light_monte_carlo
from rigsim.daylight.sky import UniformSky
from rigsim.daylight.solar import surface_irradiance
from rigsim.daylight.surface import Surface, fresnel_reflectance_unpolarised, snell_cos_transmitted
from rigsim.errors import ConfigError

N = 1.34
Z = 4.0  # allowed deviation in standard errors


def _mu_w(sun_zenith):
    return float(snell_cos_transmitted(np.cos(np.radians(sun_zenith)), 1.0, N))


@pytest.mark.parametrize("sun_zenith", [0.0, 30.0, 60.0])
def test_absorbing_water_beam_follows_beer_lambert_with_snell_and_fresnel(water_factory, sun_zenith):
    a = 0.2
    w = water_factory(a, 0.0)
    z = np.array([0.0, 1.0, 3.0, 8.0])
    r = ambient_light_monte_carlo(w, [500.0], z, sun_zenith_deg=sun_zenith, sky="black", photons=20_000, seed=4)
    e0 = r.above.total[0]
    # flat-surface Fresnel transmittance for the sun: exact (deterministic weights at the surface)
    t = 1.0 - float(fresnel_reflectance_unpolarised(np.cos(np.radians(sun_zenith))))
    assert r["Ed"][0, 0] == pytest.approx(e0 * t, rel=1e-12)
    assert r.budget["reflected"][0] == pytest.approx(1 - t, rel=1e-12)
    expected = e0 * t * np.exp(-a * z / _mu_w(sun_zenith))
    err = r.stderr["Ed"][:, 0]
    assert np.all(np.abs(r["Ed"][:, 0] - expected) <= Z * err + 1e-12)
    # a collimated beam: Eo = Ed/μ_w, nothing goes up
    np.testing.assert_allclose(r["Eo"][:, 0], r["Ed"][:, 0] / _mu_w(sun_zenith), rtol=1e-9)
    assert np.all(r["Eu"] == 0) and np.all(r["Lu"] == 0)
    assert np.all(np.abs(r["Kd"][1:, 0] - a / _mu_w(sun_zenith)) <= Z * r.stderr["Kd"][1:, 0] + 1e-12)


def test_absorbing_water_uniform_sky_matches_quadrature(water_factory):
    a = 0.3
    w = water_factory(a, 0.0)
    z = np.array([0.0, 1.0, 4.0])
    above = surface_irradiance([500.0], 30.0, total_W_per_m2_nm=1.0, sky_fraction=1.0)
    r = ambient_light_monte_carlo(w, [500.0], z, sun_zenith_deg=30.0, sky="uniform", above=above,
                                  photons=40_000, seed=1)
    # Ed(z) = ∫ ℓ cos θ_a (1 − R(θ_a)) exp(−a z / cos θ_w) dΩ_a with ℓ = 1/π
    mu_a = (np.arange(20000) + 0.5) / 20000
    mu_w = snell_cos_transmitted(mu_a, 1.0, N)
    tr = 1.0 - fresnel_reflectance_unpolarised(mu_a)
    expected = np.array([2 * np.sum(mu_a * tr * np.exp(-a * zz / mu_w)) / 20000 for zz in z])
    assert np.all(np.abs(r["Ed"][:, 0] - expected) <= Z * r.stderr["Ed"][:, 0] + 1e-4)
    assert expected[0] == pytest.approx(1 - 0.0661, abs=2e-3)  # uniform-sky reflectance of a level sea ≈ 0.066


@pytest.mark.parametrize("surface", [Surface(), Surface(8.0)])
def test_lambertian_bottom_eu_is_r_times_ed_and_radiance_is_r_ed_over_pi(water_factory, surface):
    R, H = 0.3, 6.0
    w = water_factory(0.15, 0.0)
    r = ambient_light_monte_carlo(w, [500.0], [0.0, 3.0, H], sun_zenith_deg=30.0, sky="uniform", surface=surface,
                                  bottom=Bottom(H, R), photons=20_000, seed=2)
    # at the bottom: Eu = R Ed, the nadir radiance leaving it is R Ed / π (exact per photon, up to Russian
    # roulette of the rough surface's low-weight rays)
    rel = 1e-9 if surface.flat else 1e-3
    assert r["Eu"][-1, 0] == pytest.approx(R * r["Ed"][-1, 0], rel=rel)
    assert r["Lu"][-1, 0] == pytest.approx(R * r["Ed"][-1, 0] / np.pi, rel=rel)
    # above it in non-scattering water the nadir radiance is only attenuated
    np.testing.assert_allclose(r["Lu"][:, 0], R * r["Ed"][-1, 0] / np.pi * np.exp(-0.15 * (H - r.depth_m)), rtol=rel)
    # a diffuse upward stream (Lambertian bottom, μ̄ = 1/2) in absorbing water: Eou(H) = 2 Eu(H)
    assert r["Eou"][-1, 0] == pytest.approx(2 * r["Eu"][-1, 0], abs=Z * r.stderr["Eou"][-1, 0])


def test_lambertian_bottom_in_scattering_water(water_factory):
    R, H = 0.5, 5.0
    r = ambient_light_monte_carlo(water_factory(0.1, 0.5, 0.8), [500.0], [0.0, 2.5, H], sun_zenith_deg=30.0,
                                  sky="cie", bottom=Bottom(H, R), photons=20_000, seed=3)
    # Russian roulette acts between the bottom hit and the upward crossing: equal within the MC error
    assert r["Eu"][-1, 0] == pytest.approx(R * r["Ed"][-1, 0], abs=Z * r.stderr["Eu"][-1, 0])


def test_gershun_law_in_absorbing_scattering_water(water_factory):
    """d(Ed − Eu)/dz = −a Eo: the net flux lost between two planes equals a ∫ Eo dz (an
    independent tally: crossings vs 1/|μ|-weighted crossings)."""
    a = 0.08
    z = np.linspace(0.0, 8.0, 33)
    r = ambient_light_monte_carlo(water_factory(a, 0.6, 0.85), [500.0], z, sun_zenith_deg=40.0, sky="uniform",
                                  bottom=Bottom(8.0, 0.2), photons=20_000, seed=6)
    net = r["Ed"][:, 0] - r["Eu"][:, 0]
    lost = net[0] - net[-1]
    absorbed = a * np.trapezoid(r["Eo"][:, 0], z)
    assert absorbed == pytest.approx(lost, rel=0.01)
    # and the column's energy budget closes
    total = sum(v[0] for v in r.budget.values())
    assert total == pytest.approx(1.0, abs=0.01)
    assert r.budget["absorbed_water"][0] == pytest.approx(absorbed / r.above.total[0], rel=0.02)


def test_non_absorbing_column_conserves_net_flux(water_factory):
    z = np.linspace(0.0, 10.0, 11)
    r = ambient_light_monte_carlo(water_factory(0.0, 0.5, 0.8), [500.0], z, sun_zenith_deg=30.0, sky="uniform",
                                  bottom=Bottom(10.0, 0.0), photons=10_000, seed=2)
    net = r["Ed"][:, 0] - r["Eu"][:, 0]
    np.testing.assert_allclose(net, net[0], rtol=1e-9)
    # all light that entered (Ed(0−) − Eu(0−)) leaves through the black bottom
    assert net[0] / r.above.total[0] == pytest.approx(r.budget["absorbed_bottom"][0], rel=1e-9)
    assert r.budget["absorbed_water"][0] == 0.0
    with pytest.raises(ConfigError, match="bottom depth"):
        ambient_light_monte_carlo(water_factory(0.0, 0.5), [500.0], [1.0], photons=100)


def test_single_scattering_limit_matches_closed_form(water_factory):
    """b ≪ a, sun at zenith: Eu(0−)/Ed(0−) = (b/c) 2π ∫ p(−μ) μ/(1+μ) dμ and Lu/Ed = (b/c) p(π)/2."""
    a, b, g = 1.0, 0.002, 0.9
    w = water_factory(a, b, g)
    r = ambient_light_monte_carlo(w, [500.0], [0.0], sun_zenith_deg=0.0, sky="black", photons=40_000, seed=8)
    ed = r["Ed"][0, 0]
    mu = (np.arange(20000) + 0.5) / 20000
    eu_ss = b / (a + b) * 2 * np.pi * np.sum(w.phase.eval(-mu) * mu / (1 + mu)) / 20000
    lu_ss = b / (a + b) * float(w.phase.eval(-1.0)) / 2
    assert r["Eu"][0, 0] / ed == pytest.approx(eu_ss, abs=Z * r.stderr["Eu"][0, 0] / ed + 0.005 * eu_ss)
    # higher orders add ~b/(2c) = 0.1 %
    assert r["Lu"][0, 0] / ed == pytest.approx(lu_ss, abs=Z * r.stderr["Lu"][0, 0] / ed + 0.002 * lu_ss)


def test_lu_point_and_cone_estimators_agree(water_factory):
    w = water_factory(0.1, 0.4, 0.8)
    kw = dict(sun_zenith_deg=30.0, sky="cie", bottom=Bottom(8.0, 0.4), photons=30_000, seed=3)
    p = ambient_light_monte_carlo(w, [500.0], [0.0, 4.0], lu_method="point", **kw)
    c = ambient_light_monte_carlo(w, [500.0], [0.0, 4.0], lu_method="cone", **kw)
    err = np.hypot(p.stderr["Lu"], c.stderr["Lu"])
    assert np.all(np.abs(p["Lu"] - c["Lu"]) <= Z * err + 0.02 * p["Lu"])
    assert np.all(p.stderr["Lu"] < c.stderr["Lu"])  # the point estimator is the quieter one


@pytest.mark.parametrize("water", ["jerlov-IB", "coastal", "lakes-and-rivers"])
def test_scalar_irradiance_bounds(water):
    from rigsim.config.water import load_water

    r = ambient_light_monte_carlo(load_water(water), [450.0, 600.0], [0.0, 2.0, 10.0], sun_zenith_deg=50.0,
                                  sky="cie", photons=5_000, seed=1)
    assert np.all(r["Eo"] >= r["Ed"])
    assert np.all(r["Eod"] >= r["Ed"]) and np.all(r["Eou"] >= r["Eu"])
    np.testing.assert_allclose(r["Eo"], r["Eod"] + r["Eou"])
    assert np.all(r["Lu"] > 0) and np.all(r["Eu"] < r["Ed"])
    for q in QUANTITIES:
        assert np.all(np.isfinite(r.stderr[q]))


def test_rough_surface_conserves_energy_and_tends_to_flat(water_factory):
    w = water_factory(0.2, 0.0)
    kw = dict(sun_zenith_deg=30.0, sky="black", photons=40_000, seed=5)
    flat = ambient_light_monte_carlo(w, [500.0], [0.0, 2.0], **kw)
    calm = ambient_light_monte_carlo(w, [500.0], [0.0, 2.0], surface=Surface(0.0), **kw)
    windy = ambient_light_monte_carlo(w, [500.0], [0.0, 2.0], surface=Surface(12.0), **kw)
    for r in (calm, windy):
        assert r.budget["reflected"][0] + r["Ed"][0, 0] / r.above.total[0] == pytest.approx(1.0, abs=0.01)
    # σ² = 0.003: transmittance within 0.2 % of the level sea's
    assert calm["Ed"][0, 0] == pytest.approx(flat["Ed"][0, 0], rel=2e-3)
    # for a sun 30° from the zenith wind barely changes the transmittance (Mobley 1994, Fig. 4.12)
    assert windy["Ed"][0, 0] == pytest.approx(flat["Ed"][0, 0], rel=0.01)
    assert windy["Ed"][0, 0] != flat["Ed"][0, 0]


def test_reproducible_and_per_wavelength_streams(water_factory):
    from rigsim.config.water import load_water

    w = load_water("jerlov-II")
    kw = dict(sun_zenith_deg=30.0, photons=2_000, batches=4)
    r1 = ambient_light_monte_carlo(w, [450.0, 550.0], [1.0, 5.0], seed=7, **kw)
    r2 = ambient_light_monte_carlo(w, [450.0, 550.0], [1.0, 5.0], seed=7, **kw)
    r3 = ambient_light_monte_carlo(w, [550.0], [1.0, 5.0], seed=7, **kw)
    r4 = ambient_light_monte_carlo(w, [450.0, 550.0], [1.0, 5.0], seed=8, **kw)
    for q in QUANTITIES:
        np.testing.assert_array_equal(r1[q], r2[q])
        np.testing.assert_array_equal(r1[q][:, 1:], r3[q])
    assert not np.array_equal(r1["Ed"], r4["Ed"])


def test_errors(water_factory):
    w = water_factory(0.1, 0.1)
    for kw, needle in [({"depth_m": [-1.0]}, ">= 0"), ({"depth_m": [5.0], "bottom": Bottom(3.0)}, "below the bottom"),
                       ({"photons": 3}, "photons"), ({"batches": 1}, "batches"), ({"sky": "foggy"}, "unknown sky"),
                       ({"lu_method": "x"}, "Lu estimator"), ({"sun_zenith_deg": 90.0}, "zenith")]:
        args = {"depth_m": [1.0], **kw}
        with pytest.raises(ConfigError, match=needle):
            ambient_light_monte_carlo(w, [500.0], args.pop("depth_m"), **args)
    for bad in ({"depth_m": 0.0}, {"depth_m": 2.0, "reflectance": 1.5}, {"reflectance": 0.2}):
        with pytest.raises(ConfigError):
            Bottom(**bad)
