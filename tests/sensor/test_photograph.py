"""The one "photograph" step (expose, capture, develop) that the designer and the studies share."""

from __future__ import annotations

import numpy as np
import pytest

from rigsim.errors import ConfigError
from rigsim.sensor import load_sensor
from rigsim.sensor.photograph import photograph
from rigsim.sensor.pipeline import DevelopOptions, Exposure, auto_exposure, capture
from rigsim.sensor.optics import Lens

from .conftest import PATCH, chart_image


@pytest.fixture(scope="module")
def sensor():
    return load_sensor("sony_ilce-7rm2")


def _masks(shape, patch=PATCH):
    """Chart masks as rigsim.metrics.scene.target_masks names them (whole chart + neutral 5)."""
    target = np.ones(shape, bool)
    n5 = np.zeros(shape, bool)
    r, c = divmod(21, 6)  # patch 22: neutral 5
    n5[r * patch + 2:(r + 1) * patch - 2, c * patch + 2:(c + 1) * patch - 2] = True
    return {"target": target, "patch:neutral 5 (.70 D)": n5}


def test_auto_is_spot_meter_and_chart_white_balance(sensor):
    si = chart_image()
    masks = _masks(si.shape)
    shot = photograph(si, sensor, f_number=8.0, masks=masks, target_kind="colorchecker", seed=3)
    assert shot.white_balance == "chart" and shot.metered == "spot"
    ex = auto_exposure(si, sensor, lens=Lens(f_number=8.0), mask=masks["target"])
    assert shot.exposure == ex
    ref = capture(si, sensor, ex, seed=3, develop=DevelopOptions(white_balance="chart",
                                                                 wb_kwargs={"mask": masks["patch:neutral 5 (.70 D)"]}))
    assert np.array_equal(shot.capture.srgb, ref.srgb)


def test_auto_without_chart_is_frame_meter_and_gray_world(sensor):
    si = chart_image()
    shot = photograph(si, sensor, f_number=8.0, masks={"target": np.ones(si.shape, bool)}, target_kind="white-disk")
    assert shot.white_balance == "grayworld" and shot.metered == "frame"
    assert shot.exposure == auto_exposure(si, sensor, lens=Lens(f_number=8.0))


def test_clipped_neutral_patch_falls_back_to_gray_world(sensor):
    si = chart_image()
    masks = _masks(si.shape)
    # manual exposure 8× the metered one: the neutral patch clips, the chart white balance is refused
    ex = auto_exposure(si, sensor, lens=Lens(f_number=8.0), mask=masks["target"])
    over = Exposure(ex.exposure_time_s * 8, ex.iso, ex.lens)
    with pytest.raises(ConfigError):
        capture(si, sensor, over, develop=DevelopOptions(white_balance="chart",
                                                         wb_kwargs={"mask": masks["patch:neutral 5 (.70 D)"]}))
    shot = photograph(si, sensor, f_number=8.0, exposure=over, masks=masks, target_kind="colorchecker")
    assert shot.white_balance == "grayworld" and shot.metered == "manual" and shot.exposure is over


def test_named_white_balance_and_iso_rules(sensor):
    si = chart_image()
    low = photograph(si, sensor, f_number=8.0, white_balance="white_patch", iso=sensor.base_iso / 2)
    assert low.white_balance == "white_patch" and low.exposure.iso == sensor.base_iso   # below base → base
    with pytest.raises(ConfigError, match="exposure"):
        photograph(si, sensor, f_number=8.0, exposure="sunny-16")
