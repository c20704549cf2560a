"""build_scene: targets, placement checks, meshes."""

from pathlib import Path

import numpy as np
import pytest

from rigsim.config import load_rig
from rigsim.errors import ConfigError
from rigsim.scene.build import build_scene, make_target
from rigsim.scene.optics import port_reach_m
from rigsim.scene.reflectances import REFLECTANCE_WAVELENGTHS_NM
from rigsim.scene.surfaces import TARGET_KINDS, target_surfaces
from rigsim.scene.types import Camera, Port, Rig, Scene, Target

RIGS = Path(__file__).resolve().parents[2] / "rigs"


@pytest.fixture(scope="module")
def rig():
    return load_rig(RIGS / "twin-strobes-45-wide.toml")


@pytest.mark.parametrize("kind", TARGET_KINDS)
def test_build_each_target(rig, kind):
    sc = build_scene(rig, None, kind, 1.5)
    assert isinstance(sc, Scene) and sc.targets[0].kind == kind and sc.targets[0].distance_m == 1.5
    assert sc.lights == rig.lights and sc.water is None
    surfaces = target_surfaces(sc.targets[0], sc.camera)
    assert [s.object_id for s in surfaces] == list(range(1, len(surfaces) + 1))
    for s in surfaces:
        r = np.asarray(s.reflectance)
        assert s.wavelength_nm[0] == 360 and s.wavelength_nm[-1] == 830
        assert np.all((r >= 0) & (r <= 1))


def test_build_with_water_preset_and_daylight(rig):
    from rigsim.scene.types import Daylight

    sc = build_scene(rig, "coastal", "white-disk", 2.0, daylight=Daylight(depth_m=10.0))
    assert sc.water is not None and sc.daylight.depth_m == 10.0


@pytest.mark.parametrize("d", [0.0, -1.0])
def test_target_behind_camera(rig, d):
    with pytest.raises(ConfigError, match="behind the camera") as e:
        build_scene(rig, None, "colorchecker", d)
    assert "distance_m" in str(e.value) and "\n" not in str(e.value)


def test_target_inside_port(rig):
    reach = port_reach_m(rig.camera)
    assert reach == pytest.approx(0.108)
    with pytest.raises(ConfigError, match="closer than the port") as e:
        build_scene(rig, None, "white-disk", 0.1)
    assert "0.108" in str(e.value)
    flat = Rig(name="f", camera=Camera(port=Port(kind="flat", standoff_m=0.03, thickness_m=0.01)))
    assert port_reach_m(flat.camera) == pytest.approx(0.04)
    build_scene(flat, None, "white-disk", 0.05)
    with pytest.raises(ConfigError, match="closer than the port"):
        build_scene(flat, None, "white-disk", 0.035)


def test_bottom_must_clear_housing(rig):
    with pytest.raises(ConfigError, match="housing"):
        build_scene(rig, None, "bottom", 0.1)
    sc = build_scene(rig, None, "bottom", 2.0)
    (s,) = target_surfaces(sc.targets[0], sc.camera)
    assert s.center_m == pytest.approx((0.0, -2.0, 0.0)) and s.normal == pytest.approx((0, 1, 0))


def test_unknown_target_suggests(rig):
    with pytest.raises(ConfigError, match="did you mean 'colorchecker'"):
        build_scene(rig, None, "colourchecker", 1.0)


def test_mesh_missing_and_unreadable(rig, tmp_path):
    with pytest.raises(ConfigError, match="mesh file not found") as e:
        build_scene(rig, None, str(tmp_path / "fish.obj"), 1.0)
    assert "fish.obj" in str(e.value)
    bad = tmp_path / "bad.ply"
    bad.write_bytes(b"not a ply at all\n")
    with pytest.raises(ConfigError, match="cannot read mesh") as e:
        build_scene(rig, None, str(bad), 1.0)
    assert "bad.ply" in str(e.value) and "\n" not in str(e.value)
    empty = tmp_path / "empty.obj"
    empty.write_text("# nothing\n")
    with pytest.raises(ConfigError, match="no usable vertices"):
        build_scene(rig, None, str(empty), 1.0)


def _cube_obj(path, half=0.1):
    lines = [f"v {x} {y} {z}" for x in (-half, half) for y in (-half, half) for z in (-half, half)]
    lines += ["f 1 2 4 3", "f 5 6 8 7"]
    path.write_text("\n".join(lines) + "\n")


def test_mesh_obj_and_ply_place_and_scale(rig, tmp_path):
    obj = tmp_path / "cube.obj"
    _cube_obj(obj)
    sc = build_scene(rig, None, obj, 2.0, reflectance=0.5)
    t = sc.targets[0]
    assert t.kind == "mesh" and t.size_m == pytest.approx(0.2) and t.mesh_path == str(obj.resolve())
    (s,) = target_surfaces(t, sc.camera)
    m = s.matrix()
    assert m[:3, :3] @ np.zeros(3) + m[:3, 3] == pytest.approx(np.array([0, 0, 2.0]))
    assert np.linalg.det(m[:3, :3]) > 0          # no mirroring
    assert np.allclose(s.reflectance, 0.5)
    # binary PLY with the same vertices, scaled to 0.4 m
    verts = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], "<f4") * 0.1
    ply = tmp_path / "cube.ply"
    header = ("ply\nformat binary_little_endian 1.0\nelement vertex 8\nproperty float x\nproperty float y\n"
              "property float z\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n")
    ply.write_bytes(header.encode() + verts.tobytes())
    sc = build_scene(rig, None, ply, 2.0, size_m=0.4)
    (s,) = target_surfaces(sc.targets[0], sc.camera)
    assert np.linalg.norm(s.matrix()[:3, 0]) == pytest.approx(2.0)   # scale 0.4 / 0.2


def test_reflectance_overrides(rig, tmp_path):
    csv = tmp_path / "r.csv"
    csv.write_text("# test\nwavelength_nm,reflectance\n400,0.1\n700,0.3\n")
    t = make_target("bottom", 3.0, reflectance=csv)
    r = np.asarray(t.reflectance)
    assert r[0] == pytest.approx(0.1) and r[-1] == pytest.approx(0.3)   # edge-held
    with pytest.raises(ConfigError, match="0–1"):
        make_target("white-disk", 1.0, reflectance=1.5)
    with pytest.raises(ConfigError, match="fixed reflectances"):
        make_target("colorchecker", 1.0, reflectance=0.5)


def test_ready_target_is_checked(rig):
    with pytest.raises(ConfigError, match="closer than the port"):
        build_scene(rig, None, Target(kind="white-disk", distance_m=0.05))
    assert build_scene(rig, None, Target(kind="white-disk", distance_m=3.0)).targets[0].distance_m == 3.0
