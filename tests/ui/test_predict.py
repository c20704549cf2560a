"""Predictions for the designer: numbers respond the way a diver expects; the CLI command exists."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from rigsim.errors import ConfigError
from rigsim.ui.predict import Conditions, contrast_curve, predict
from rigsim.config.rigdoc import RigDoc

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def doc():
    return RigDoc.load(ROOT / "rigs" / "twin-strobes-45-wide.toml")


@pytest.mark.render
def test_wider_arms_less_backscatter_more_contrast(doc):
    cond = Conditions(water="coastal", distance_m=1.5)
    close = predict(doc.edit_light(0, "arm_length_m", 0.2).edit_light(1, "arm_length_m", 0.2).rig(), cond)
    wide = predict(doc.edit_light(0, "arm_length_m", 0.8).edit_light(1, "arm_length_m", 0.8).rig(), cond)
    assert close.srgb.dtype == np.uint8 and close.srgb.shape == (close.height, close.width, 3)
    for k in ("contrast_radiance", "contrast_image", "backscatter_share", "snr_white", "delta_e_mean"):
        assert k in close.metrics and math.isfinite(close.metrics[k]), k
    assert wide.metrics["backscatter_share"] < close.metrics["backscatter_share"]
    assert wide.metrics["contrast_radiance"] > close.metrics["contrast_radiance"]
    clear = predict(doc.rig(), cond.replace(water="clear"))
    coastal = predict(doc.rig(), cond)
    assert clear.metrics["contrast_radiance"] > coastal.metrics["contrast_radiance"]


@pytest.mark.render
def test_contrast_falls_with_distance(doc):
    pts = contrast_curve(doc.rig(), Conditions(water="coastal"), [0.1, 1.0, 3.0])
    assert [p["distance_m"] for p in pts] == [1.0, 3.0]  # 0.1 m is inside the dome: skipped
    assert pts[1]["contrast_radiance"] < pts[0]["contrast_radiance"]


@pytest.mark.render
def test_marine_snow_specks_fall_as_the_strobes_swing_out(doc):
    """With marine snow chosen, the designer counts the lit specks; dragging both strobes from 0.2 to 0.8 m
    lights fewer of them (the same particles: they only dim), and without particles there is no such row."""
    from rigsim.ui.app import metric_rows

    cond = Conditions(water="coastal", distance_m=1.5, particles="coastal")
    close = predict(doc.edit_light(0, "arm_length_m", 0.2).edit_light(1, "arm_length_m", 0.2).rig(), cond)
    wide = predict(doc.edit_light(0, "arm_length_m", 0.8).edit_light(1, "arm_length_m", 0.8).rig(), cond)
    assert close.metrics["speck_count"] > 100
    assert wide.metrics["speck_count"] < 0.7 * close.metrics["speck_count"]
    assert wide.metrics["speck_share"] < close.metrics["speck_share"]
    assert "speck_count" in {r["key"] for r in metric_rows(close)}
    plain = predict(doc.rig(), cond.replace(particles="none"))
    assert "speck_count" not in plain.metrics and "speck_count" not in {r["key"] for r in metric_rows(plain)}


def test_bad_conditions_are_one_line(doc):
    with pytest.raises(ConfigError, match="closer than the port"):
        predict(doc.rig(), Conditions(distance_m=0.05))
    with pytest.raises(ConfigError, match="target"):
        predict(doc.rig(), Conditions(target="teapot"))


def test_cli_registers_app_command():
    from typer.testing import CliRunner

    import rigsim.cli.designer  # noqa: F401  (registers the command)
    from rigsim.cli import app

    r = CliRunner().invoke(app, ["app", "--help"])
    assert r.exit_code == 0 and "--port" in r.output and "--workdir" in r.output
