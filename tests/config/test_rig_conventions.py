"""The rig file's conventions (arm, yaw/pitch) have one implementation in rigsim.config.rig,
with exact inverses: file values → position/aim → file values.  The designer uses it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rigsim.config.rig import (
    DEFAULT_SPECTRUM,
    SPECTRUM_NAMES,
    LightTable,
    arm_to_position,
    camera_to_world,
    direction_to_yaw_pitch,
    load_rig,
    position_to_arm,
    yaw_pitch_to_direction,
)
from rigsim.light.spectra import SPECTRUM_METHODS
from rigsim.scene.types import Camera

RIGS = sorted((Path(__file__).resolve().parents[2] / "rigs").glob("*.toml"))


@settings(max_examples=200, deadline=None)
@given(length=st.floats(0.01, 5.0), angle=st.floats(0.0, 359.99), forward=st.floats(-5.0, 5.0))
def test_arm_round_trip(length, angle, forward):
    back = position_to_arm(arm_to_position(length, angle, forward))
    assert back[0] == pytest.approx(length, abs=1e-12)
    assert back[2] == forward
    d = (back[1] - angle + 180.0) % 360.0 - 180.0  # 359.999… may come back as 0
    assert abs(d) < 1e-9 and 0.0 <= back[1] < 360.0


@settings(max_examples=200, deadline=None)
@given(yaw=st.floats(-179.9, 180.0), pitch=st.floats(-89.9, 89.9))
def test_yaw_pitch_round_trip(yaw, pitch):
    d = yaw_pitch_to_direction(yaw, pitch)
    assert np.linalg.norm(d) == pytest.approx(1.0)
    y, p = direction_to_yaw_pitch(d)
    assert y == pytest.approx(yaw, abs=1e-9) and p == pytest.approx(pitch, abs=1e-9)
    y2, p2 = direction_to_yaw_pitch(3.7 * d)  # any length
    assert y2 == pytest.approx(yaw, abs=1e-9) and p2 == pytest.approx(pitch, abs=1e-9)


def test_conventions_of_the_readme():
    """0° = image right, 90° = up; yaw + = towards the image's right, pitch + = up."""
    np.testing.assert_allclose(arm_to_position(0.5, 90.0), [0.0, 0.5, 0.0], atol=1e-15)
    np.testing.assert_allclose(arm_to_position(0.5, 180.0, -0.1), [-0.5, 0.0, -0.1], atol=1e-15)
    np.testing.assert_allclose(yaw_pitch_to_direction(90.0, 0.0), [1.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(yaw_pitch_to_direction(0.0, 90.0), [0.0, 1.0, 0.0], atol=1e-15)
    # camera frame [right, up, forward] → world: the default camera's right is world −x
    np.testing.assert_allclose(camera_to_world(Camera(), [1.0, 2.0, 3.0]), [-1.0, 2.0, 3.0])


def test_light_table_file_values_round_trip():
    t = LightTable(kind="strobe", arm_length_m=0.45, arm_angle_deg=165.0, arm_forward_m=-0.1, yaw_deg=-20.0,
                   pitch_deg=5.0, beam_angle_deg=100.0, guide_number_m=33.0)
    length, angle, forward = position_to_arm(t.local_position())
    yaw, pitch = direction_to_yaw_pitch(t.local_aim())
    assert (length, angle, forward, yaw, pitch) == pytest.approx((0.45, 165.0, -0.1, -20.0, 5.0))
    assert t.spectrum_name == DEFAULT_SPECTRUM["strobe"]


@pytest.mark.parametrize("path", RIGS, ids=lambda p: p.stem)
def test_designer_view_is_the_inverse_of_the_reader(path):
    """rigdoc's arm/yaw/pitch view, put back through the reader, gives the same world position and aim."""
    from rigsim.config.rigdoc import RigDoc

    doc = RigDoc.load(path)
    rig = load_rig(path)
    cam = rig.camera
    for i, light in enumerate(rig.lights):
        v = doc.light_view(i)
        pos = camera_to_world(cam, arm_to_position(v["arm_length_m"], v["arm_angle_deg"], v["arm_forward_m"]))
        aim = camera_to_world(cam, yaw_pitch_to_direction(v["yaw_deg"], v["pitch_deg"]), direction=True)
        np.testing.assert_allclose(pos, light.position_m, atol=1e-4)
        np.testing.assert_allclose(aim, light.aim, atol=1e-4)


def test_designer_spectra_are_the_readers():
    from rigsim.config import rigdoc

    assert rigdoc.SPECTRA is SPECTRUM_NAMES and set(SPECTRUM_NAMES) == set(SPECTRUM_METHODS)
    assert not hasattr(rigdoc, "_yaw_pitch") and not hasattr(rigdoc, "_local_position")
