"""Colour: ColorChecker ΔE2000 after chart WB + CCM (daylight, in air); white balance methods."""

from __future__ import annotations

import numpy as np
import pytest

from rigsim.errors import ConfigError
from rigsim.sensor import DevelopOptions, auto_exposure, capture, load_sensor
from rigsim.sensor.ccm import (ccm_ColorChecker, ccm_from_xyz_to_camera, colorchecker_reference_srgb,
                               delta_E_ColorChecker, xyz_to_camera_from_ccm)
from rigsim.sensor.white_balance import (neutral_from_illuminant, white_balance_from_illuminant,
                                         white_balance_gains)

from .conftest import PATCH, WL, chart_image, d65, patch_means

SENSORS = ["sony_ilce-7rm2", "sony_ilce-7sm2", "nikon_d5100", "canon_eos_5d_mark_ii", "action_cam_1-2.3in"]
GREY_BOX = (3 * PATCH + 4, 4 * PATCH - 4, 2 * PATCH + 4, 3 * PATCH - 4)  # 'neutral 6.5' patch


@pytest.mark.parametrize("name", SENSORS)
def test_colorchecker_delta_e_after_chart_wb_and_ccm(name, chart):
    s = load_sensor(name)
    cap = capture(chart, s, auto_exposure(chart, s, target=0.8), seed=11,
                  develop=DevelopOptions(white_balance="chart", wb_kwargs={"box": GREY_BOX}))
    got = patch_means(cap.linear_rgb)
    ref = colorchecker_reference_srgb("D65")[:24]
    got *= ref[20, 1] / got[20, 1]  # exposure normalisation on the grey patch used for WB
    de = delta_E_ColorChecker(got)
    assert de.mean() <= 2.0, de.round(2)


def test_delta_e_detects_a_wrong_ccm(chart):
    """The ΔE test can fail: identity instead of the fitted CCM is far off."""
    s = load_sensor("sony_ilce-7rm2")
    cap = capture(chart, s, auto_exposure(chart, s), seed=11,
                  develop=DevelopOptions(white_balance="chart", wb_kwargs={"box": GREY_BOX}, ccm=np.eye(3)))
    got = patch_means(cap.linear_rgb)
    got *= colorchecker_reference_srgb("D65")[20, 1] / got[20, 1]
    assert delta_E_ColorChecker(got).mean() > 4


def test_ccm_preserves_white_and_dng_matrix_inverts():
    s = load_sensor("nikon_d5100")
    m = ccm_ColorChecker(s, "D65")
    np.testing.assert_allclose(m.sum(axis=1), 1.0, atol=1e-12)
    gains = np.array([2.0, 1.0, 1.5])
    np.testing.assert_allclose(ccm_from_xyz_to_camera(xyz_to_camera_from_ccm(m, gains)), m, atol=1e-10)


def test_grayworld_on_grey_scene_matches_illuminant_prediction():
    s = load_sensor("sony_ilce-7rm2")
    grey = chart_image()
    grey = type(grey)(np.broadcast_to(grey.radiance[3 * PATCH + 8, 2 * PATCH + 8], grey.radiance.shape).copy(),
                      grey.wavelength_nm, grey.bandwidth_nm)
    cap = capture(grey, s, auto_exposure(grey, s), seed=1, develop=DevelopOptions(white_balance="grayworld"))
    pred = white_balance_from_illuminant(sensor=s, wavelength_nm=WL, illuminant=d65() * 0.6)
    np.testing.assert_allclose(cap.wb_gains, pred, rtol=0.02)  # neutral 6.5 is not exactly flat


def test_water_shifts_the_predicted_neutral():
    s = load_sensor("sony_ilce-7sm2")
    water = np.exp(-(0.02 + 1.5 * np.clip((WL - 550) / 150, 0, None)) * 5.0)  # red attenuated over 5 m
    n_air = neutral_from_illuminant(s, WL, d65())
    n_sea = neutral_from_illuminant(s, WL, d65(), water)
    assert (n_sea[0] / n_sea[1]) < 0.5 * (n_air[0] / n_air[1])
    g = white_balance_from_illuminant(sensor=s, wavelength_nm=WL, illuminant=d65(), water_transmission=water)
    assert g[0] > 2 * (n_air[1] / n_air[0])


def test_white_patch_and_manual():
    rgb = np.random.default_rng(0).random((50, 50, 3)).astype(np.float32) * [0.4, 0.8, 0.5]
    g = white_balance_gains(rgb, "white_patch", percentile=100, clip=2.0)
    assert g == pytest.approx([2.0, 1.0, 1.6], rel=0.01)
    assert white_balance_gains(None, "manual", gains=[4, 2, 3]) == pytest.approx([2, 1, 1.5])
    with pytest.raises(ConfigError, match="allowed"):
        white_balance_gains(None, "manual", gains=[1, -1, 1])
    with pytest.raises(ConfigError, match="did you mean 'grayworld'"):
        white_balance_gains(rgb, "greyworld")
    with pytest.raises(ConfigError, match="neutral patch"):
        white_balance_gains(rgb, "chart")


def test_ccm_cache_is_per_sensor_object_and_weak():
    import dataclasses
    import gc

    from rigsim.sensor import ccm as ccm_mod
    from rigsim.sensor import load_sensor

    s = load_sensor("sony_ilce-7rm2")
    mix = np.array([[0.7, 0.0, 0.0], [0.3, 1.0, 0.0], [0.0, 0.0, 1.0]])
    twin = dataclasses.replace(s, qe=s.qe @ mix)      # another object, red leaking into green
    a = ccm_mod.ccm_ColorChecker(s)
    a[0, 0] = 99.0                                    # callers get a copy
    assert ccm_mod.ccm_ColorChecker(s)[0, 0] != 99.0
    assert not np.allclose(ccm_mod.ccm_ColorChecker(twin), ccm_mod.ccm_ColorChecker(s))
    assert ccm_mod.ccm_ColorChecker(s, "A") is not None and set(ccm_mod._CCMS[s]) >= {"D65", "A"}
    n = len(ccm_mod._CCMS)
    del twin
    gc.collect()
    assert len(ccm_mod._CCMS) == n - 1               # the entry left with its sensor
