"""The rig diagram: the camera-frame geometry behind it (checked against the rig files' own
numbers, also for a camera turned and moved in the world), and the PNG (written atomically,
a real image, everything in view)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pytest

from rigsim.config.rig import load_rig, parse_rig, world_to_camera
from rigsim.optimise.diagram import (
    REAR_VIEW,
    TOP_VIEW,
    beam_angle_half_intensity_deg,
    camera_frame_geometry,
    draw_rig_diagram,
    fov_water_xy_deg,
    rig_diagram,
)
from rigsim.schema import read_toml
from rigsim.scene.optics import fov_water_deg
from rigsim.scene.types import BeamPattern, Camera, Port

RIGS = Path(__file__).resolve().parents[2] / "rigs"


def _rig(name: str):
    return load_rig(RIGS / f"{name}.toml")


def _axes(fig):
    return {ax.get_label(): ax for ax in fig.axes}


def test_geometry_gives_back_the_rig_file_numbers():
    geo = {g.name: g for g in camera_frame_geometry(_rig("twin-strobes-45-wide"))}
    assert set(geo) == {"left", "right"}
    for name, angle in (("left", 165.0), ("right", 15.0)):
        g = geo[name]
        assert g.arm_length_m == pytest.approx(0.45, abs=1e-12)
        assert g.arm_angle_deg == pytest.approx(angle, abs=1e-9)
        assert g.arm_forward_m == pytest.approx(0.0, abs=1e-12)
        assert (g.yaw_deg, g.pitch_deg) == pytest.approx((0.0, 0.0), abs=1e-9)
        assert g.beam_angle_deg == 110.0
    # The shipped camera looks along +z with +y up, so the image's right is world −x: the left
    # strobe (arm at 165°) sits at world +x.
    left = next(lt for lt in _rig("twin-strobes-45-wide").lights if lt.name == "left")
    assert left.position_m[0] > 0 > geo["left"].position_m[0]


def test_geometry_with_the_camera_turned_and_moved():
    data = read_toml(RIGS / "twin-strobes-edge-lighting.toml")
    data["camera"].update(position_m=[1.0, -2.0, 3.0], forward=[1.0, 0.0, 1.0], up=[0.0, 0.0, 1.0])
    rig = parse_rig(data, source="turned", base_dir=RIGS)
    geo = {g.name: g for g in camera_frame_geometry(rig)}
    for name, angle, yaw in (("left", 180.0, -20.0), ("right", 0.0, 20.0)):
        g = geo[name]
        assert g.arm_length_m == pytest.approx(0.60, abs=1e-12)
        assert g.arm_angle_deg == pytest.approx(angle, abs=1e-9)
        assert g.arm_forward_m == pytest.approx(-0.15, abs=1e-12)
        assert (g.yaw_deg, g.pitch_deg) == pytest.approx((yaw, 0.0), abs=1e-9)
        assert np.linalg.norm(g.aim) == pytest.approx(1.0)


def test_to_camera_frame_inverts_the_pose():
    cam = Camera(position_m=(1.0, 2.0, 3.0), forward=(0.0, 0.0, -1.0), up=(0.0, 1.0, 0.0))
    r, u, f = cam.frame()
    p = np.array([1.0, 2.0, 3.0]) + 0.3 * r - 0.2 * u + 0.7 * f
    assert world_to_camera(cam, p) == pytest.approx([0.3, -0.2, 0.7])
    assert world_to_camera(cam, [f, r], direction=True) == pytest.approx(np.array([[0, 0, 1], [1, 0, 0]]))


def test_beam_angle_at_half_intensity():
    assert beam_angle_half_intensity_deg(BeamPattern(beam_angle_deg=110.0)) == 110.0
    table = BeamPattern(kind="table", angle_deg=(0.0, 30.0, 60.0, 90.0), relative=(1.0, 0.9, 0.3, 0.0))
    assert beam_angle_half_intensity_deg(table) == pytest.approx(2 * (30.0 + 30.0 * 0.4 / 0.6))
    flat = BeamPattern(kind="table", angle_deg=(0.0, 40.0), relative=(1.0, 0.8))  # dark beyond 40°
    assert beam_angle_half_intensity_deg(flat) == 80.0
    # The renderer's own profile agrees at the edge.
    half = np.radians(beam_angle_half_intensity_deg(table) / 2)
    assert float(table.relative_intensity(half)) == pytest.approx(0.5)


def test_fov_in_water():
    dome = _rig("twin-strobes-45-wide").camera
    h, v = fov_water_xy_deg(dome)
    assert h == pytest.approx(fov_water_deg(dome))
    assert h == pytest.approx(dome.fov_air_x_deg, abs=1e-6)
    assert v == pytest.approx(np.degrees(2 * np.arctan(12.0 / 16.0)), abs=1e-6)
    flat = dataclasses.replace(dome, port=Port(kind="flat"))
    hf, vf = fov_water_xy_deg(flat)
    assert hf < h and vf < v


def test_png_of_a_before_and_after_pair(tmp_path):
    out = tmp_path / "new" / "folder" / "rig.png"
    got = rig_diagram(_rig("twin-strobes-edge-lighting"), _rig("twin-strobes-45-wide"), distance_m=1.0,
                      subject_width_m=0.3, out_png=out, title="edge lighting", labels=("after", "before"))
    assert got == out and out.is_file()
    img = mpimg.imread(out)
    assert img.ndim == 3 and img.shape[2] in (3, 4)
    assert 600 <= img.shape[0] <= 2000 and 1200 <= img.shape[1] <= 2000
    assert img[..., :3].std() > 0.05  # not blank
    assert [p.name for p in out.parent.iterdir()] == ["rig.png"]  # no temporary file left behind


def test_rig_without_lights(tmp_path):
    rig = _rig("ambient-only")
    assert camera_frame_geometry(rig) == ()
    out = rig_diagram(rig, distance_m=2.0, out_png=tmp_path / "ambient.png")
    assert mpimg.imread(out).shape[0] > 300


def test_flat_port_and_a_table_beam(tmp_path):
    rig = _rig("single-strobe-short-arm")
    table = BeamPattern(kind="table", angle_deg=(0.0, 30.0, 60.0), relative=(1.0, 0.7, 0.0))
    rig = dataclasses.replace(rig, camera=dataclasses.replace(rig.camera, port=Port(kind="flat")),
                              lights=tuple(dataclasses.replace(lt, beam=table) for lt in rig.lights))
    assert camera_frame_geometry(rig)[0].beam_angle_deg == pytest.approx(2 * (30.0 + 30.0 * 0.2 / 0.7))
    assert rig_diagram(rig, _rig("twin-strobes-close-to-port"), distance_m=0.8,
                       out_png=tmp_path / "flat.png").is_file()


@pytest.mark.parametrize("after, before, distance_m", [
    ("twin-strobes-edge-lighting", "twin-strobes-45-wide", 1.0),
    ("single-strobe-short-arm", "video-lights-pair", 2.5),
    ("twin-strobes-close-to-port", None, 0.4),
])
def test_limits_contain_every_light_and_the_subject(after, before, distance_m):
    rigs = [_rig(after)] + ([_rig(before)] if before else [])
    fig = draw_rig_diagram(rigs[0], rigs[1] if before else None, distance_m=distance_m)
    axes = _axes(fig)
    top, rear = axes[TOP_VIEW], axes[REAR_VIEW]
    (x0, x1), (z0, z1) = top.get_xlim(), top.get_ylim()
    (u0, u1), (v0, v1) = rear.get_xlim(), rear.get_ylim()
    assert z0 < 0.0 and z1 > distance_m
    for rig in rigs:
        rh = rig.camera.housing_radius_m
        assert x0 < -rh and x1 > rh and u0 < -rh and u1 > rh and v0 < -rh and v1 > rh
        for g in camera_frame_geometry(rig):
            x, y, z = g.position_m
            assert x0 < x < x1 and z0 < z < z1
            assert u0 < x < u1 and v0 < y < v1
    # Equal aspect: one metre is as long across the page as up it.
    for ax in (top, rear):
        assert ax.get_aspect() == 1.0


def test_bad_distance():
    with pytest.raises(ValueError, match="distance_m"):
        draw_rig_diagram(_rig("ambient-only"), distance_m=0.0)
    with pytest.raises(ValueError, match="subject_width_m"):
        draw_rig_diagram(_rig("ambient-only"), distance_m=1.0, subject_width_m=-1.0)
