"""What the renderer uses: sun beam and sky radiance below the surface, light field at depth; waves and caustics."""

from __future__ import annotations

import numpy as np
import pytest

from rigsim.config.water import load_water
from rigsim.daylight.shortcut import sky_fresnel_reflectance
from rigsim.daylight.sky import CIEGeneralSky
from rigsim.daylight.underwater import (
    ambient_light_field_at_depth,
    daylight_above_surface,
    sky_radiance_below_surface,
    sun_beam_below_surface,
)
from rigsim.daylight.waves import caustic_pattern, sine_waves, waves_PiersonMoskowitz1964
from rigsim.errors import ConfigError
from rigsim.scene.types import Daylight


def test_sun_beam_direction_and_energy():
    dl = Daylight(depth_m=5.0, sun_zenith_deg=40.0, sun_azimuth_deg=90.0)
    wl = [450.0, 550.0]
    b = sun_beam_below_surface(dl, wl)
    assert np.linalg.norm(b.direction) == pytest.approx(1.0)
    # going down (−y), away from the sun at +x, Snell's law
    assert b.direction[1] < 0 and b.direction[0] < 0 and abs(b.direction[2]) < 1e-12
    assert np.sin(np.radians(b.zenith_water_deg)) * 1.34 == pytest.approx(np.sin(np.radians(40.0)))
    above = daylight_above_surface(dl, wl)
    # horizontal flux through the surface is conserved apart from Fresnel reflection
    np.testing.assert_allclose(b.irradiance_normal * np.cos(np.radians(b.zenith_water_deg)),
                               above.sun * b.fresnel_transmittance)


def test_sky_radiance_below_surface_integrates_to_transmitted_sky_irradiance():
    dl = Daylight(depth_m=5.0, sun_zenith_deg=30.0)
    n_mu, n_phi = 2000, 180
    mu = (np.arange(n_mu) + 0.5) / n_mu
    phi = (np.arange(n_phi) + 0.5) / n_phi * 2 * np.pi - np.pi
    L = sky_radiance_below_surface(dl, [550.0], mu[:, None], phi[None, :], sky="cie")[..., 0]
    e = np.sum(L * mu[:, None]) / n_mu * 2 * np.pi / n_phi
    above = daylight_above_surface(dl, [550.0], "cie")
    assert e == pytest.approx(above.sky[0] * (1 - sky_fresnel_reflectance(CIEGeneralSky(30.0))), rel=2e-3)
    # Snell's window: nothing from the sky beyond the critical angle
    assert np.all(L[mu < np.cos(np.radians(48.3))] == 0)


def test_daylight_surface_irradiance_table_is_used():
    dl = Daylight(depth_m=3.0, surface_irradiance_wavelength_nm=(400.0, 700.0), surface_irradiance=(1.0, 2.0))
    a = daylight_above_surface(dl, [400.0, 550.0, 700.0])
    np.testing.assert_allclose(a.total, [1.0, 1.5, 2.0])
    with pytest.raises(ConfigError):
        daylight_above_surface(Daylight(depth_m=3.0, surface_irradiance_wavelength_nm=(400.0,),
                                        surface_irradiance=(1.0, 2.0)), [500.0])


@pytest.mark.parametrize("model", ["kd", "monte-carlo"])
def test_light_field_at_depth(model):
    w = load_water("jerlov-IB")
    dl = Daylight(depth_m=8.0, sun_zenith_deg=30.0, model=model)
    f = ambient_light_field_at_depth(dl, w, [450.0, 600.0], photons=3000)
    assert np.all(f.sun.irradiance_normal > 0) and np.all(f.diffuse_down_radiance >= 0)
    # the unscattered beam cannot carry more plane irradiance than Ed
    mu = np.cos(np.radians(f.sun.zenith_water_deg))
    assert np.all(f.sun.irradiance_normal * mu <= f.Ed * 1.02)
    assert np.all(f.up_radiance > 0) and f.model == model


def test_sine_waves_normals_and_caustics():
    w = sine_waves([0.02, 0.01], [1.0, 0.7], [0.0, 60.0], [0.0, 1.0])
    x, z = np.meshgrid(np.linspace(-1, 1, 7), np.linspace(-1, 1, 7))
    h = 1e-6
    hx = (w.height(x + h, z) - w.height(x - h, z)) / (2 * h)
    hz = (w.height(x, z + h) - w.height(x, z - h)) / (2 * h)
    n = w.normal(x, z)
    np.testing.assert_allclose(n[..., 0] / n[..., 1], -hx, atol=1e-6)
    np.testing.assert_allclose(n[..., 2] / n[..., 1], -hz, atol=1e-6)
    one = sine_waves(0.02, 1.0)
    pats = {d: caustic_pattern(one, sun_zenith_deg=20.0, depth_m=d, extent_m=2.0, resolution=24, rays_per_cell=9)
            for d in (0.5, 5.0)}
    for p in pats.values():
        assert p.mean() == pytest.approx(1.0, abs=0.03)  # refraction moves light, it does not make it
    # near the focal depth (≈ n/((n−1) k² A) ≈ 5 m) the pattern is far more contrasted than just below
    assert pats[5.0].std() > 3 * pats[0.5].std()


def test_pierson_moskowitz_sea():
    sea = waves_PiersonMoskowitz1964(6.0, seed=1)
    rng = np.random.default_rng(0)
    h = sea.height(rng.uniform(0, 200, 20000), rng.uniform(0, 200, 20000))
    hs = 4 * h.std()
    assert hs == pytest.approx(0.21 * 36 / 9.81, rel=0.1)  # H_s ≈ 0.21 U²/g
    with pytest.raises(ConfigError):
        waves_PiersonMoskowitz1964(0.0)
    with pytest.raises(ConfigError):
        sine_waves(-1.0, 1.0)
