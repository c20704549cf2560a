"""Ambient daylight at depth in the renderer (rigsim.render.daylight + rigsim_vol)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rigsim.scene.types import Camera, Daylight, Rig, Scene, Target

pytest.importorskip("mitsuba")

from rigsim.render import render  # noqa: E402
from rigsim.render.daylight import ambient_tables  # noqa: E402
from rigsim.scene.daylight_field import daylight_from_options  # noqa: E402
from rigsim.water import preset  # noqa: E402

from .helpers import make_camera  # noqa: E402

WL = [450.0, 550.0, 650.0]
BW = [2.0, 2.0, 2.0]  # narrow bands: the 1-nm tables are ~constant inside
RHO = 0.8


def _plate(distance, size=1.0, offset=(0.0, 0.0), rho=RHO):
    return Target("white-disk", distance, size_m=size, reflectance_wavelength_nm=(360.0, 830.0),
                  reflectance=(rho, rho), offset_m=offset)


def _down_camera(focal=300.0):
    # looking straight down: right = −x, up (image) = +z
    return make_camera(focal_length_mm=focal, forward=(0.0, -1.0, 0.0), up=(0.0, 0.0, 1.0))


def _render(scene, **kw):
    args = dict(width=12, height=8, spp=64, seed=1, wavelengths_nm=WL, bandwidth_nm=BW, layers=("clear",))
    args.update(kw)
    return render(scene, **args)


def _plate_expected(scene, y, *, beam=True):
    """ρ/π E(y) of an upward plate at height y (field at the camera's height y0 = 0)."""
    tab = ambient_tables(scene, 449.0, 651.0)  # the field the render used: the scene's own
    f = tab.field
    wl = np.asarray(WL)
    i = np.round(wl - 360).astype(int)
    c = np.asarray(tab.c, float)[i]
    kd = np.asarray(tab.k_diffuse, float)[i]
    kb = np.asarray(tab.k_beam, float)[i]
    # the integrator's 1-nm tables at the band centres, integrated over the upper hemisphere
    d = np.asarray(tab.diffuse, float).reshape(-1, tab.n_theta, tab.n_phi)[i]
    dirs, dw = f.bin_directions(4)
    cosw = np.clip(dirs[..., 1], 0.0, None).sum(axis=-1) * dw
    e_dif = np.einsum("ltp,tp->l", d, cosw) * np.exp(kd * y)
    mu_w = np.cos(np.radians(f.sun.zenith_water_deg))
    e_beam = np.asarray(tab.beam, float)[i] * mu_w * np.exp(kb * y)
    return RHO / np.pi * (e_dif + (e_beam if beam else 0.0)), c


def test_ambient_only_rig_renders_at_depth_coastal_is_greener_and_darker():
    """The write-up's coastal-region water (chlorophyll 5 mg/m³, CDOM 0.25 /m) absorbs the blue."""
    from rigsim.config.rig import load_rig

    rig = load_rig("rigs/ambient-only.toml")
    out = {}
    for w in ("clear", "coastal-regions"):
        sc = Scene(rig, preset(w), (_plate(1.5, size=3.0),), Daylight(depth_m=5.0, sun_zenith_deg=30.0))
        sc = dataclasses.replace(sc, rig=dataclasses.replace(rig, camera=dataclasses.replace(
            rig.camera, forward=(0.0, -1.0, 0.0), up=(0.0, 0.0, 1.0))))
        im = render(sc, width=12, height=8, spp=16, seed=2, wavelengths_nm=WL, bandwidth_nm=[20.0] * 3)
        assert np.all(np.isfinite(im.radiance)) and np.all(im.radiance > 0)
        assert im.meta["daylight_rendered"] and im.meta["daylight"]["field"]["model"] == "kd"
        out[w] = im.radiance[2:6, 4:8].mean(axis=(0, 1))
    # the coastal plate is darker and its light greener (relative to blue) than in clear water
    assert out["coastal-regions"].sum() < out["clear"].sum()
    assert out["coastal-regions"][1] / out["coastal-regions"][0] > out["clear"][1] / out["clear"][0]


@pytest.mark.parametrize("model", ["kd", "monte-carlo"])
def test_upward_plate_has_rho_Ed_over_pi(model):
    """Clear layer (no water between camera and plate): L = ρ/π (E_beam μ_w + E_diffuse) at the plate's depth."""
    dl = Daylight(depth_m=4.0, sun_zenith_deg=30.0, model=model, photons=2000)
    sc = Scene(Rig("t", _down_camera()), preset("coastal"), (_plate(0.5),), dl)
    im = _render(sc, spp=128)
    got = im.layers["clear"].reshape(-1, 3)
    exp, c = _plate_expected(sc, -0.5)
    m, se = got.mean(axis=0), got.std(axis=0, ddof=1) / np.sqrt(got.shape[0])
    assert np.all(np.abs(m - exp) <= 4 * se + 0.02 * exp), (m, exp, se)
    # the full image adds the water between: e^{−ct} L_plate + the field's path radiance (≥ 0)
    full = im.radiance.reshape(-1, 3).mean(axis=0)
    assert np.all(full >= 0.9 * np.exp(-c * 0.5) * exp)


def test_horizontal_view_without_target_is_the_field_radiance():
    """Open water: the renderer returns the field's horizontal radiance (the transport is exact in equilibrium)."""
    dl = Daylight(depth_m=5.0, sun_zenith_deg=30.0, model="monte-carlo", photons=2000)
    sc = Scene(Rig("t", make_camera(focal_length_mm=3000.0)), preset("coastal"), (), dl)
    im = _render(sc, width=6, height=4, spp=4, layers=())
    tab = ambient_tables(sc, 449.0, 651.0)  # the field the render used: the scene's own
    i = np.round(np.asarray(WL) - 360).astype(int)
    d = np.asarray(tab.diffuse, float).reshape(-1, tab.n_theta, tab.n_phi)[i]
    h = tab.n_theta // 2
    exp = 0.5 * (d[:, h - 1, 0] + d[:, h, 0])  # looking along +z = towards the sun's azimuth, at the horizon
    got = im.radiance.reshape(-1, 3).mean(axis=0)
    np.testing.assert_allclose(got, exp, rtol=0.02)
    # and it is the field of the meter at that depth (resampled spectrally as a ratio to the Kd Ed)
    f = tab.field
    hz = f.radiance(np.array([[0.0, 0.0, 1.0]]))[0]
    np.testing.assert_allclose(got, np.interp(WL, f.wavelength_nm, hz), rtol=0.1)


def test_plate_in_the_shadow_of_another_gets_the_diffuse_light_only():
    # sun at 40°: refracted beam 28.7° from the vertical, travelling towards −z; an occluder 2 m above the
    # plate, 2 m·tan(28.7°) = 1.095 m towards +z (image "up"), out of the narrow field of view
    dl = Daylight(depth_m=6.0, sun_zenith_deg=40.0)
    shift = 2.0 * np.tan(np.arcsin(np.sin(np.radians(40.0)) / 1.34))
    lit = Scene(Rig("t", _down_camera()), preset("clear"), (_plate(2.5),), dl)
    shaded = Scene(Rig("t", _down_camera()), preset("clear"), (_plate(2.5), _plate(0.5, 0.8, (0.0, shift))), dl)
    a = _render(lit).layers["clear"].reshape(-1, 3).mean(axis=0)
    b = _render(shaded).layers["clear"].reshape(-1, 3).mean(axis=0)
    exp_all, _ = _plate_expected(lit, -2.5)
    exp_dif, _ = _plate_expected(lit, -2.5, beam=False)
    np.testing.assert_allclose(a, exp_all, rtol=0.03)
    # the occluder also hides ~3 % of the (uniform, Kd-model) downwelling sky of the shaded plate
    assert np.all(b < exp_dif * 1.02) and np.all(b > exp_dif * 0.93), (b, exp_dif)


def test_monte_carlo_and_kd_fields_differ_as_the_meter_says():
    scenes = {m: Scene(Rig("t", _down_camera()), preset("coastal"), (_plate(0.5),),
                       Daylight(depth_m=4.0, model=m, photons=2000)) for m in ("kd", "monte-carlo")}
    got = {m: _render(s, spp=128).layers["clear"].reshape(-1, 3).mean(axis=0) for m, s in scenes.items()}
    exp = {m: _plate_expected(s, -0.5)[0] for m, s in scenes.items()}
    np.testing.assert_allclose(got["monte-carlo"] / got["kd"], exp["monte-carlo"] / exp["kd"], rtol=0.04)


def test_caustics_pattern_the_plate_and_keep_its_mean():
    base = dict(depth_m=2.0, sun_zenith_deg=20.0)
    wide = make_camera(focal_length_mm=24.0, forward=(0.0, -1.0, 0.0), up=(0.0, 0.0, 1.0))
    flat = Scene(Rig("t", wide), preset("clear"), (_plate(1.5, size=6.0),), Daylight(**base))
    wavy = Scene(Rig("t", wide), preset("clear"), (_plate(1.5, size=6.0),),
                 Daylight(**base, waves="sines", wave_amplitude_m=0.02, wave_length_m=0.5))
    kw = dict(width=48, height=32, spp=8, wavelengths_nm=[550.0], bandwidth_nm=[2.0])
    a = _render(flat, **kw).layers["clear"][..., 0]
    b = _render(wavy, **kw).layers["clear"][..., 0]
    assert b.std() > 3 * a.std()  # light patterns on the plate
    assert b.mean() == pytest.approx(a.mean(), rel=0.06)


def test_daylight_from_cli_options():
    d = daylight_from_options(8.0, sun_zenith_deg=45.0, model="monte-carlo")
    assert d.depth_m == 8.0 and d.model == "monte-carlo"
    assert daylight_from_options(None) is None
    from rigsim.errors import ConfigError

    with pytest.raises(ConfigError):
        daylight_from_options(-1.0)
    with pytest.raises(ConfigError):
        daylight_from_options(5.0, model="sunny")
