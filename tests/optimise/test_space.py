"""The optimiser's search space: the rig file's conventions, mirrored pairs, limits, usable placements."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rigsim.config.rig import load_rig
from rigsim.config.rigdoc import RigDoc
from rigsim.errors import ConfigError
from rigsim.optimise.space import DEFAULT_LIMITS, Space, limits_for, parse_limits

RIGS = Path(__file__).parents[2] / "rigs"
PAIRS = ["twin-strobes-45-wide", "twin-strobes-close-to-port", "twin-strobes-edge-lighting", "video-lights-pair"]


@pytest.mark.parametrize("name", PAIRS)
def test_mirrored_start_reproduces_the_shipped_pair(name):
    """The shipped pairs are mirror images: their own placement, read as the pair's five numbers and written
    back, puts every light where the rig file put it (world frame, to the mm) and aims it the same way."""
    doc = RigDoc.load(RIGS / f"{name}.toml")
    space = Space.of(doc)
    assert space.pair is not None and sum(not p.options for p in space.parameters) == 5
    again = space.apply(space.start()).rig()
    for a, b in zip(doc.rig().lights, again.lights):
        assert np.allclose(a.position_m, b.position_m, atol=1e-3)
        assert np.allclose(np.asarray(a.aim) / np.linalg.norm(a.aim), np.asarray(b.aim) / np.linalg.norm(b.aim),
                           atol=1e-3)


def test_mirror_image_about_the_vertical_plane():
    """Any point of a pair's space gives lights that are mirror images: x → −x in the camera frame."""
    doc = RigDoc.load(RIGS / "twin-strobes-45-wide.toml")
    space = Space.of(doc)
    rng = np.random.default_rng(3)
    for _ in range(20):
        x = space.from_unit(rng.random(space.dim))
        try:
            d = space.apply(x)
        except ConfigError:
            continue
        rig = d.rig()
        r, u, f = rig.camera.frame()
        p = [np.array([np.dot(np.subtract(lt.position_m, rig.camera.position_m), e) for e in (r, u, f)]) for lt in rig.lights]
        a = [np.array([np.dot(lt.aim, e) for e in (r, u, f)]) for lt in rig.lights]
        assert np.allclose(p[0] * [-1, 1, 1], p[1], atol=2e-3)
        assert np.allclose(a[0] * [-1, 1, 1], a[1], atol=2e-3)


@pytest.mark.parametrize("name", [*PAIRS, "single-strobe-short-arm"])
def test_every_point_respects_the_limits(name):
    """Whatever point the searcher asks for, the rig it gets lies within the limits (read back through the
    rig file's own view of each light)."""
    doc = RigDoc.load(RIGS / f"{name}.toml")
    lim = limits_for(doc, parse_limits("arm_length_m=0.3:0.7,yaw_out_deg=-5:40,pitch_deg=-10:10,beam_angles_deg=80/110"))
    space = Space.of(doc, limits=lim)
    rng = np.random.default_rng(0)
    for u in [np.zeros(space.dim), np.ones(space.dim), *rng.random((30, space.dim)) * 1.4 - 0.2]:
        x = space.from_unit(u)
        for p, v in zip(space.parameters, x):
            assert p.lo - 1e-12 <= v <= p.hi + 1e-12
        try:
            d = space.apply(x)
        except ConfigError:
            continue
        for i in range(len(d.data["lights"])):
            v = d.light_view(i)
            assert 0.3 - 1e-3 <= v["arm_length_m"] <= 0.7 + 1e-3
            assert -10 - 0.01 <= v["pitch_deg"] <= 10 + 0.01
            assert v["beam_angle_deg"] in (80.0, 110.0) or v["beam_mode"] == "profile"
            if space.pair is not None:
                yaw_out = v["yaw_deg"] if i == space.pair[0] else -v["yaw_deg"]
                assert -5 - 0.01 <= yaw_out <= 40 + 0.01


def test_rig_file_limits_and_overrides(tmp_path):
    """The rig's [limits] replace the defaults; command-line limits replace the rig's."""
    text = (RIGS / "twin-strobes-close-to-port.toml").read_text() + "\n[limits]\narm_length_m = [0.3, 0.5]\n" \
        "beam_angles_deg = [80, 110]\n"
    (tmp_path / "r.toml").write_text(text)
    doc = RigDoc.load(tmp_path / "r.toml")
    lim = limits_for(doc)
    assert lim["arm_length_m"] == (0.3, 0.5) and lim["beam_angles_deg"] == (80.0, 110.0)
    assert lim["pitch_deg"] == DEFAULT_LIMITS["pitch_deg"]
    assert limits_for(doc, parse_limits("arm_length_m=0.4:0.6"))["arm_length_m"] == (0.4, 0.6)
    load_rig(tmp_path / "r.toml")  # the rig reader accepts the table


@pytest.mark.parametrize("text, field", [
    ("arm_length_m=0.9:0.2", "arm_length_m"),
    ("arm_length_m=abc", "arm_length_m"),
    ("bogus=1:2", "bogus"),
    ("arm_length_m", "--limits"),
    ("pitch_deg=-100:0", "pitch_deg"),
])
def test_bad_limits_are_one_line_errors(text, field):
    with pytest.raises(ConfigError) as e:
        parse_limits(text)
    assert field in str(e.value) and "\n" not in str(e.value)


def test_lights_in_the_picture_or_the_housing_are_refused():
    doc = RigDoc.load(RIGS / "twin-strobes-45-wide.toml")
    space = Space.of(doc)
    ahead = doc.place_lights({0: dict(arm_length_m=0.2, arm_angle_deg=180, arm_forward_m=0.6, yaw_deg=0,
                                      pitch_deg=0)})
    assert "in the picture" in space.feasible(ahead)
    beside = doc.place_lights({0: dict(arm_length_m=0.8, arm_angle_deg=180, arm_forward_m=0.1, yaw_deg=0,
                                       pitch_deg=0)})
    assert space.feasible(beside) is None
    with pytest.raises(ConfigError, match="inside the housing"):
        doc.place_lights({0: dict(arm_length_m=0.05, arm_angle_deg=180, arm_forward_m=0.0, yaw_deg=0, pitch_deg=0)})


def test_independent_space_and_rigs_without_lights():
    doc = RigDoc.load(RIGS / "single-strobe-short-arm.toml")
    space = Space.of(doc)
    assert space.pair is None and [p.key for p in space.parameters][:2] == ["arm_length_m", "arm_angle_deg"]
    with pytest.raises(ConfigError, match="two lights"):
        Space.of(doc, symmetric=True)
    with pytest.raises(ConfigError, match="no lights"):
        Space.of(RigDoc.load(RIGS / "ambient-only.toml"))
