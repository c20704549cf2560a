"""Strobes: the flash layer does not scale with the shutter; TTL auto-exposure."""

import numpy as np
import pytest

from rigsim.sensor import load_sensor
from rigsim.sensor.cfa import mosaic
from rigsim.sensor.pipeline import Exposure, auto_exposure, mean_electrons_rgb
from rigsim.spectral_image import SpectralImage

WL = np.arange(400.0, 701.0, 10.0)


def _si(cont: float, flash: float | None, shape=(32, 48)):
    rng = np.random.default_rng(0)
    pattern = rng.uniform(0.2, 1.0, shape + (1,)) * np.ones(len(WL))
    layers = {} if flash is None else {"flash": (pattern * flash).astype(np.float32)}
    return SpectralImage((pattern * cont).astype(np.float32), WL, np.full(len(WL), 10.0), layers)


def test_flash_independent_of_shutter_and_linear_in_power():
    s = load_sensor("sony_ilce-7rm2")
    si = _si(0.0, 1e-4)
    e1 = mean_electrons_rgb(si, s, Exposure(1 / 250, 100))
    e2 = mean_electrons_rgb(si, s, Exposure(1 / 30, 100))
    np.testing.assert_allclose(e1, e2, rtol=1e-6)
    e3 = mean_electrons_rgb(si, s, Exposure(1 / 30, 100, flash_scale=0.25))
    np.testing.assert_allclose(e3, 0.25 * e1, rtol=1e-6)


def test_continuous_plus_flash_adds():
    s = load_sensor("sony_ilce-7rm2")
    both = mean_electrons_rgb(_si(0.01, 1e-4), s, Exposure(0.02, 100, flash_scale=0.5))
    cont = mean_electrons_rgb(_si(0.01, None), s, Exposure(0.02, 100))
    flash = mean_electrons_rgb(_si(0.0, 1e-4), s, Exposure(1.0, 100, flash_scale=0.5))
    np.testing.assert_allclose(both, cont + flash, rtol=1e-5)


def test_ttl_scales_the_flash_to_the_target():
    s = load_sensor("sony_ilce-7rm2")
    si = _si(0.0, 1e-2)  # a very strong flash: TTL must turn it down
    ex = auto_exposure(si, s, percentile=99, target=0.8)
    assert 0 < ex.flash_scale < 1 and ex.exposure_time_s == pytest.approx(1 / 125)
    e = mosaic(mean_electrons_rgb(si, s, ex), s.cfa_pattern)
    assert np.percentile(e, 99) == pytest.approx(0.8 * s.saturation_e(ex.iso), rel=1e-6)


def test_ttl_with_continuous_light_too_reaches_the_target():
    """With continuous light beside the flash the level is not proportional to the flash output (the
    flash-only shortcut does not apply): TTL still puts the 99th percentile at the target."""
    s = load_sensor("sony_ilce-7rm2")
    si = _si(0.002, 1e-2)
    ex = auto_exposure(si, s, percentile=99, target=0.8)
    assert 0 < ex.flash_scale < 1 and ex.exposure_time_s == pytest.approx(1 / 125)
    e = mosaic(mean_electrons_rgb(si, s, ex), s.cfa_pattern)
    assert np.percentile(e, 99) == pytest.approx(0.8 * s.saturation_e(ex.iso), rel=1e-6)
    only = auto_exposure(_si(0.0, 1e-2), s, percentile=99, target=0.8)
    assert ex.flash_scale < only.flash_scale  # the continuous light takes part of the target


def test_weak_flash_raises_iso():
    s = load_sensor("sony_ilce-7rm2")
    si = _si(0.0, 1e-9)
    ex = auto_exposure(si, s)
    assert ex.flash_scale == 1.0 and ex.iso > s.base_iso


def test_auto_exposure_never_overshoots_when_it_raises_the_iso():
    """Between ISO steps (a factor ~2) full power would overshoot: TTL trims the flash at the chosen ISO
    (it did not: a strobe-lit black disk at 3 m came out 63 % clipped at ISO 1600)."""
    s = load_sensor("sony_ilce-7rm2")
    raised = 0
    for strength in np.geomspace(1e-9, 1e-2, 29):
        si = _si(0.0, float(strength))
        ex = auto_exposure(si, s, percentile=99, target=0.8)
        e = np.percentile(mosaic(mean_electrons_rgb(si, s, ex), s.cfa_pattern), 99)
        assert e <= 0.8 * s.saturation_e(ex.iso) * (1 + 1e-6), (strength, ex)
        if ex.iso > s.base_iso and ex.flash_scale < 1:
            raised += 1
            assert e == pytest.approx(0.8 * s.saturation_e(ex.iso), rel=1e-6)
    assert raised >= 3  # the sweep met the case between ISO steps


def test_continuous_only_sets_shutter():
    s = load_sensor("sony_ilce-7rm2")
    si = _si(0.05, None)
    ex = auto_exposure(si, s, target=0.5)
    e = mosaic(mean_electrons_rgb(si, s, ex), s.cfa_pattern)
    assert np.percentile(e, 99) == pytest.approx(0.5 * s.saturation_e(ex.iso), rel=1e-6)


def test_snr_emva1288_limits():
    from rigsim.sensor.noise import snr_emva1288

    s = load_sensor("sony_ilce-7rm2")
    # shot-noise limit: SNR -> sqrt(mu) for large signals
    assert snr_emva1288(1e6, s, iso=100, exposure_time_s=1e-3) == pytest.approx(1e3, rel=1e-3)
    # read-noise limit: SNR -> mu / sigma_d for tiny signals
    sd = s.iso_setting(100).read_noise_e
    assert snr_emva1288(1e-3, s, iso=100, exposure_time_s=1e-6) == pytest.approx(1e-3 / sd, rel=0.05)


def test_port_factor_from_the_typed_scene():
    import dataclasses

    from rigsim.scene.types import Camera, Port, Rig, Scene
    from rigsim.sensor.optics import port_factor_map
    from rigsim.water import preset

    scene = Scene(Rig("r", Camera(port=Port(kind="dome", glass_index=1.49))), preset("clear"), ())
    s = load_sensor("sony_ilce-7rm2")
    si = _si(0.0, 1e-4)
    si_w = dataclasses.replace(si, scene=scene)
    r1 = ((1.34 - 1.49) / (1.34 + 1.49)) ** 2
    r2 = (0.49 / 2.49) ** 2
    factor = port_factor_map(si_w)
    np.testing.assert_allclose(factor, (1 - r1) * (1 - r2) / 1.34**2, rtol=1e-12)  # a dome: every pixel
    assert port_factor_map(dataclasses.replace(si, scene=dataclasses.replace(scene, water=None))) == 1.0
    assert port_factor_map(si) == 1.0
    e_air = mean_electrons_rgb(si, s, Exposure(0.01, 100))
    np.testing.assert_allclose(mean_electrons_rgb(si_w, s, Exposure(0.01, 100)), e_air * factor[..., None],
                               rtol=1e-5)
