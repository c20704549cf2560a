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


@pytest.mark.render
def test_an_edit_of_the_photograph_alone_redevelops_the_last_render(doc, monkeypatch):
    """With a render cache, a change of sensor, exposure, white balance or the 3-D view's depth makes only the
    photograph: the engine is not called again, and the prediction is the one made from scratch, bit for bit;
    a change of the scene (distance, water) or of the rig renders again."""
    from collections import OrderedDict

    import rigsim.ui.predict as P

    calls = []
    real = P.preview_engine

    def counting(quality=P.PREVIEW):
        name, fn = real(quality)

        def counted(*a, **kw):
            calls.append(a[1:3])
            return fn(*a, **kw)
        return name, counted

    monkeypatch.setattr(P, "preview_engine", counting)

    class LRU(OrderedDict):
        def put(self, k, v):
            self[k] = v

    cache, q = LRU(), P.Quality("preview", 160, None)
    cond = Conditions(water="coastal", distance_m=1.5)
    first = predict(doc.rig(), cond, quality=q, render_cache=cache, rig_key="a")
    assert len(calls) == 1 and not first.reused
    edits = [cond.replace(sensor="action_cam_1-2.3in"), cond.replace(exposure="manual", shutter_s=1 / 60, iso=400),
             cond.replace(white_balance="grayworld"), cond.replace(depth_m=25.0)]
    for c in edits:
        again = predict(doc.rig(), c, quality=q, render_cache=cache, rig_key="a")
        fresh = predict(doc.rig(), c, quality=q)
        assert again.reused and not fresh.reused
        assert np.array_equal(again.srgb, fresh.srgb) and again.metrics == fresh.metrics, c
    assert len(calls) == 1 + len(edits)  # the fresh ones only
    for c, rig_key in ((cond.replace(distance_m=2.0), "a"), (cond.replace(water="clear"), "a"), (cond, "b")):
        assert not predict(doc.rig(), c, quality=q, render_cache=cache, rig_key=rig_key).reused
    assert len(calls) == 4 + len(edits)


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
