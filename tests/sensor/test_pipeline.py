"""Capture pipeline: camera equation, noise switches, seeds, exposure, two sensors differ."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.constants import c, h

from rigsim.errors import ConfigError
from rigsim.sensor import Exposure, Lens, NoiseSwitches, auto_exposure, capture, load_sensor
from rigsim.sensor.cfa import mosaic
from rigsim.sensor.noise import dark_current_e_per_s
from rigsim.spectral_image import SpectralImage

from .conftest import BW, PATCH, WL, chart_image, flat_image


def test_camera_equation_by_hand():
    """One band at 550 nm: photons = π T L Δλ A t λ/(4 N² h c); electrons = photons·QE."""
    s = load_sensor("sony_ilce-7rm2")
    L = 0.01
    rad = np.zeros((4, 4, 1))
    rad[...] = L
    si = SpectralImage(rad, np.array([550.0]), np.array([10.0]))
    ex = Exposure(0.01, 100, Lens(f_number=2.8, transmittance=0.8))
    cap = capture(si, s, ex, noise=NoiseSwitches.off(), develop=None)
    photons = np.pi * 0.8 * L * 10.0 / (4 * 2.8 ** 2) * (4.51e-6) ** 2 * 0.01 * 550e-9 / (h * c)
    qe = s.qe_at([550.0])[0]
    expected = mosaic(np.broadcast_to(photons * qe, (4, 4, 3)), "RGGB")
    np.testing.assert_allclose(cap.electrons, expected, rtol=1e-6)


def test_all_noise_off_gives_expected_electrons_and_dn_exactly(chart):
    s = load_sensor("nikon_d5100")
    ex = Exposure(0.002, 200, Lens(4.0))
    cap = capture(chart, s, ex, noise=NoiseSwitches.off(), develop=None)
    qe = s.qe_at(WL)
    ph = np.pi * 0.9 / (4 * 16.0) * s.pixel_area_m2 * 0.002 * BW * (WL * 1e-9) / (h * c)
    mu = mosaic(chart.radiance @ (ph[:, None] * qe), "RGGB")
    np.testing.assert_allclose(cap.electrons, np.minimum(mu, s.full_well_e), rtol=2e-7)
    k = s.iso_setting(200).gain_dn_per_e
    dn = np.clip(np.rint(np.float32(s.black_level_dn) + np.float32(k) * cap.electrons), 0, s.white_level_dn)
    np.testing.assert_array_equal(cap.raw, dn.astype(np.uint16))
    # and again: noise-free is deterministic whatever the seed
    np.testing.assert_array_equal(capture(chart, s, ex, seed=99, noise=NoiseSwitches.off(), develop=None).raw,
                                  cap.raw)


def test_each_noise_term_switches(chart):
    s = load_sensor("action_cam_1-2.3in")
    ex0 = auto_exposure(chart, s, iso=400, target=0.5)
    ex = Exposure(ex0.exposure_time_s, 400, Lens(4.0), temperature_c=40.0)
    base = capture(chart, s, ex, noise=NoiseSwitches.off(), develop=None)
    for term in ("shot", "read", "dark_current", "prnu", "dsnu"):
        on = NoiseSwitches(**{**NoiseSwitches.off().as_dict(), term: True})
        cap = capture(chart, s, ex, noise=on, seed=3, develop=None)
        # dark current over a short exposure is below 1 DN: compare electrons too
        assert not (np.array_equal(cap.raw, base.raw) and np.array_equal(cap.electrons, base.electrons)), term
    assert NoiseSwitches.parse("shot,read") == NoiseSwitches(True, True, False, False, False)
    with pytest.raises(ConfigError, match="unknown noise term"):
        NoiseSwitches.parse("shot,photon")


def test_dark_current_doubles_per_doubling_temperature():
    s = load_sensor("sony_ilce-7rm2")
    d0 = dark_current_e_per_s(s, s.dark_current_ref_temp_c)
    assert dark_current_e_per_s(s, s.dark_current_ref_temp_c + s.dark_current_doubling_c) == pytest.approx(2 * d0)
    # mean of a long dark exposure
    dark = flat_image(0.0, (64, 64))
    ex = Exposure(100.0, 100, Lens(4.0), temperature_c=s.dark_current_ref_temp_c + 2 * s.dark_current_doubling_c)
    cap = capture(dark, s, ex, noise=NoiseSwitches(shot=True, read=False, dark_current=True, prnu=False,
                                                   dsnu=False), develop=None)
    assert cap.electrons.mean() == pytest.approx(4 * d0 * 100.0, rel=0.03)


def test_seeds_reproduce(chart):
    s = load_sensor("sony_ilce-7rm2")
    ex = auto_exposure(chart, s)
    a, b, c2 = (capture(chart, s, ex, seed=k, develop=None).raw for k in (1, 1, 2))
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c2)


def test_auto_exposure_hits_target(chart):
    s = load_sensor("sony_ilce-7sm2")
    ex = auto_exposure(chart, s, percentile=99, target=0.5)
    cap = capture(chart, s, ex, noise=NoiseSwitches.off(), develop=None)
    assert np.percentile(cap.electrons, 99) == pytest.approx(0.5 * s.saturation_e(s.base_iso), rel=1e-3)
    with pytest.raises(ConfigError, match="black"):
        auto_exposure(flat_image(0.0), s)


def test_spot_metering_protects_the_frames_highlights():
    """A dim spot in a 2–6× brighter frame (a chart lost in backscatter): metering the spot alone
    would clip the whole frame; with highlight protection at most 0.5 % of it saturates, and a
    spot in a darker frame is still metered to the target."""
    s = load_sensor("sony_ilce-7rm2")
    ramp = np.linspace(2e-3, 6e-3, 40 * 60).reshape(40, 60)  # distinct values: no ties at the percentile
    rad = np.repeat(ramp[..., None], len(WL), axis=2)
    spot = np.zeros((40, 60), bool)
    spot[15:25, 25:35] = True
    rad[spot] = 1e-3
    si = SpectralImage(rad, WL, BW)
    loose = auto_exposure(si, s, percentile=99, target=0.8, mask=spot, highlight_clip_pct=99.9)
    cap = capture(si, s, loose, noise=NoiseSwitches.off(), develop=None)
    assert np.mean(cap.electrons[~spot] >= s.saturation_e(s.base_iso)) > 0.9
    ex = auto_exposure(si, s, percentile=99, target=0.8, mask=spot)
    cap = capture(si, s, ex, noise=NoiseSwitches.off(), develop=None)
    assert np.mean(cap.electrons >= s.saturation_e(ex.iso) * (1 - 1e-9)) <= 0.006
    assert np.percentile(cap.electrons, 99.5) == pytest.approx(s.saturation_e(ex.iso), rel=2e-3)
    # the frame darker than the spot: the spot is metered as before
    rad2 = np.where(spot[..., None], 4e-3, 1e-3) * np.ones(len(WL))
    si2 = SpectralImage(rad2, WL, BW)
    ex2 = auto_exposure(si2, s, percentile=99, target=0.5, mask=spot)
    cap2 = capture(si2, s, ex2, noise=NoiseSwitches.off(), develop=None)
    assert np.percentile(cap2.electrons[spot], 99) == pytest.approx(0.5 * s.saturation_e(s.base_iso), rel=1e-3)


def test_full_well_clipping():
    s = load_sensor("action_cam_1-2.3in")
    cap = capture(flat_image(10.0), s, Exposure(1.0, 100, Lens(2.0)), develop=None)
    assert cap.electrons.max() == s.full_well_e
    assert cap.raw.max() <= s.white_level_dn


def test_vignetting_cos4_and_resampling():
    s = load_sensor("sony_ilce-7rm2")
    from rigsim.scene.types import Camera, Rig, Scene

    # 90° horizontal field of view in air, square pixels (sensor height to the image's aspect)
    cam = Camera(sensor_width_mm=36.0, sensor_height_mm=36.0 * 41 / 61, focal_length_mm=18.0)
    si = SpectralImage(np.full((41, 61, len(WL)), 1e-3), WL, BW, scene=Scene(Rig("r", cam), None, ()))
    ex = Exposure(0.01, 100, Lens(4.0, vignetting=True))
    cap = capture(si, s, ex, noise=NoiseSwitches.off(), develop=None)
    g = cap.electrons
    corner, centre = g[0, 1], g[20, 31]  # G sites
    f = 30.5  # (cols / 2) / tan(45°), px
    cos2 = f ** 2 / (f ** 2 + 29.0 ** 2 + 20.0 ** 2)  # pixel (0, 1) is 29 and 20 px off axis
    cos2_c = f ** 2 / (f ** 2 + 1.0)                   # pixel (20, 31) is 1 px off axis
    assert corner / centre == pytest.approx((cos2 / cos2_c) ** 2, rel=1e-5)
    big = capture(flat_image(1e-3, (10, 10)), s, Exposure(0.01, 100), shape=(40, 60),
                  noise=NoiseSwitches.off(), develop=None)
    small = capture(flat_image(1e-3, (10, 10)), s, Exposure(0.01, 100), noise=NoiseSwitches.off(), develop=None)
    assert big.raw.shape == (40, 60)
    assert big.electrons[0::2, 1::2].mean() == pytest.approx(small.electrons[0::2, 1::2].mean(), rel=1e-5)


def test_bad_exposure_and_lens():
    with pytest.raises(ConfigError, match="shutter"):
        Exposure(0.0, 100)
    with pytest.raises(ConfigError, match="f-number"):
        Lens(f_number=0.1)


def test_two_sensors_differ_in_noise_and_colour():
    """Same render, same exposure settings: the small-pixel action camera is noisier, and the
    sensors see different raw colours."""
    # a dim coastal-like scene: green-blue light, one mid grey patch
    from .conftest import d65
    water = np.exp(-(0.05 + 0.6 * np.clip((WL - 520) / 180, 0, None) + 0.3 * np.clip((480 - WL) / 80, 0, None)) * 4)
    si = chart_image(illuminant=d65() * water)
    # a dim shot: the low-light camera's raw peaks at 5 % of saturation; same settings for both
    ex = auto_exposure(si, load_sensor("sony_ilce-7sm2"), lens=Lens(2.8), iso=800, target=0.05)
    box = (3 * PATCH + 3, 4 * PATCH - 3, 2 * PATCH + 3, 3 * PATCH - 3)
    snr, neutral = {}, {}
    for name in ("sony_ilce-7sm2", "action_cam_1-2.3in"):
        s = load_sensor(name)
        cap = capture(si, s, ex, seed=4, develop=None)
        g = cap.normalised_mosaic()[box[0]:box[1], box[2]:box[3]][0::2, 1::2]
        snr[name] = g.mean() / g.std()
        r = cap.normalised_mosaic()[box[0]:box[1], box[2]:box[3]][0::2, 0::2].mean()
        neutral[name] = r / g.mean()
    assert snr["sony_ilce-7sm2"] > 3 * snr["action_cam_1-2.3in"], snr
    assert abs(neutral["sony_ilce-7sm2"] / neutral["action_cam_1-2.3in"] - 1) > 0.1, neutral
