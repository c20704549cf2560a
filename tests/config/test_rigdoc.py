"""Rig documents: TOML round trips of every shipped rig, edits in the designer's terms, refusals."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from rigsim.config.rig import load_rig
from rigsim.errors import ConfigError
from rigsim.config.rigdoc import RigDoc, dumps_toml

ROOT = Path(__file__).resolve().parents[2]
RIGS = sorted((ROOT / "rigs").glob("*.toml"))


def _same_rig(a, b):
    assert a.name == b.name and len(a.lights) == len(b.lights)
    assert a.camera == b.camera
    for la, lb in zip(a.lights, b.lights):
        assert np.allclose(la.position_m, lb.position_m, atol=1e-9)
        assert np.allclose(la.aim, lb.aim, atol=1e-9)
        assert la.beam == lb.beam and np.allclose(la.axial_intensity, lb.axial_intensity)


@pytest.mark.parametrize("path", RIGS, ids=[p.stem for p in RIGS])
def test_round_trip_of_shipped_rigs(path, tmp_path):
    doc = RigDoc.load(path)
    text = doc.to_toml(header="test")
    assert tomllib.loads(text) == doc.data
    out = tmp_path / path.name
    out.write_text(text)
    _same_rig(load_rig(out), load_rig(path))


@pytest.mark.parametrize("path", RIGS, ids=[p.stem for p in RIGS])
def test_views_rebuild_the_same_rig(path):
    """Rewriting every light in the arm + yaw/pitch form keeps its position and aim."""
    doc = RigDoc.load(path)
    ref = doc.rig()
    for i in range(len(doc.light_names())):
        v = doc.light_view(i)
        doc = doc.edit_light(i, "arm_length_m", v["arm_length_m"]).edit_light(i, "yaw_deg", v["yaw_deg"])
        assert "position_m" not in doc.data["lights"][i] and "aim" not in doc.data["lights"][i]
    new = doc.rig()
    for la, lb in zip(ref.lights, new.lights):
        assert np.allclose(la.position_m, lb.position_m, atol=1e-3)
        assert np.allclose(la.aim, lb.aim, atol=1e-4)


def test_edits_move_and_turn_the_light():
    doc = RigDoc.load(ROOT / "rigs" / "twin-strobes-45-wide.toml")
    d2 = doc.edit_light(1, "arm_length_m", "0.7").edit_light(1, "yaw_deg", 20)
    right = d2.rig().lights[1]
    # right strobe at 15°: image right is world −x
    assert right.position_m[0] == pytest.approx(-0.7 * math.cos(math.radians(15)), abs=1e-6)
    assert right.aim[0] == pytest.approx(-math.sin(math.radians(20)), abs=1e-6)
    assert doc.rig().lights[1].position_m[0] == pytest.approx(-0.45 * math.cos(math.radians(15)), abs=1e-6)
    d3 = d2.edit_light(0, "aim_at_m", [0, 0, 1.5])
    assert "yaw_deg" not in d3.data["lights"][0] and d3.data["lights"][0]["aim_at_m"] == [0.0, 0.0, 1.5]
    d4 = d3.set_power_mode(0, "energy").edit_light(0, "power_fraction", 0.25)
    assert "guide_number_m" not in d4.data["lights"][0] and d4.data["lights"][0]["power_fraction"] == 0.25
    d5 = d4.add_light("video").remove_light(0)
    assert [t["kind"] for t in d5.data["lights"]] == ["strobe", "video"]
    assert d5.edit_camera("focal_length_mm", 24).rig().camera.focal_length_mm == 24


@pytest.mark.parametrize("field,value,words", [
    ("arm_length_m", 0.05, "inside the housing"),
    ("arm_length_m", "abc", "must be a number"),
    ("beam_angle_deg", 400, "beam_angle_deg"),
    ("spectrum", "xenon-strob", "did you mean"),
    ("power_fraction", 2, "power_fraction"),
    ("yaw_deg", "nan", "finite"),
])
def test_invalid_edits_are_refused_with_one_line(field, value, words):
    doc = RigDoc.load(ROOT / "rigs" / "twin-strobes-45-wide.toml")
    with pytest.raises(ConfigError) as e:
        doc.edit_light(0, field, value)
    assert words in str(e.value) and "\n" not in str(e.value)
    assert doc.light_view(0)["arm_length_m"] == pytest.approx(0.45)  # the document is unchanged


def test_writer_quotes_and_formats():
    data = {"rig": {"name": 'odd "name"\n', "description": "ünïcode"},
            "camera": {"focal_length_mm": 16.0, "f_number": 8, "position_m": [0.0, 1e-5, 3.0]},
            "lights": [{"name": "a", "kind": "strobe", "guide_number_m": 0.30000000000000004}]}
    text = dumps_toml(data)
    assert tomllib.loads(text) == data
    with pytest.raises(ConfigError):
        dumps_toml({"camera": {"f_number": float("inf")}})


def test_relocated_keeps_csv_paths(tmp_path):
    src = tmp_path / "a"
    src.mkdir()
    (src / "beam.csv").write_text("angle_deg,relative\n0,1\n40,0.5\n80,0\n")
    (src / "r.toml").write_text('[[lights]]\nkind = "strobe"\narm_length_m = 0.4\nbeam_profile = "beam.csv"\n'
                                "guide_number_m = 20.0\n")
    doc = RigDoc.load(src / "r.toml")
    dst = tmp_path / "b"
    dst.mkdir()
    moved = doc.relocated(dst, "r.toml")
    (dst / "r.toml").write_text(moved.to_toml())
    assert load_rig(dst / "r.toml").lights[0].beam.kind == "table"


@pytest.mark.parametrize("mod", ["rigsim.config.rigdoc", "rigsim.ui.files"])
def test_doctests(mod):
    import doctest
    import importlib

    res = doctest.testmod(importlib.import_module(mod), optionflags=doctest.ELLIPSIS)
    assert res.failed == 0 and res.attempted > 0


@pytest.mark.parametrize("path", [p for p in RIGS if RigDoc.load(p).light_names()], ids=lambda p: p.stem)
def test_move_light_puts_it_there_and_keeps_the_aim(path):
    """A drag in the 3-D view: the light ends where it was dropped (to the mm), the rig
    file's way of aiming is kept (angles: the same world direction; an aim point: the same
    point, so the light turns to it), and nothing else changes."""
    doc = RigDoc.load(path)
    rig0 = doc.rig()
    cam = rig0.camera
    r, u, f = cam.frame()
    for i, light in enumerate(rig0.lights):
        local = np.array([np.dot(light.position_m - np.asarray(cam.position_m), e) for e in (r, u, f)])
        new_local = local * 1.4 + np.array([0.0, 0.05, 0.1])
        moved = doc.move_light(i, new_local)
        rig1 = moved.rig()
        world = np.asarray(cam.position_m) + new_local[0] * r + new_local[1] * u + new_local[2] * f
        assert np.allclose(rig1.lights[i].position_m, world, atol=1.5e-3)
        t0, t1 = doc.data["lights"][i], moved.data["lights"][i]
        if "aim_at_m" in t0:
            assert t1["aim_at_m"] == t0["aim_at_m"]
            aim_point = np.asarray(cam.position_m) + sum(c * e for c, e in zip(t0["aim_at_m"], (r, u, f)))
            want = (aim_point - rig1.lights[i].position_m) / np.linalg.norm(aim_point - rig1.lights[i].position_m)
            assert np.allclose(rig1.lights[i].aim, want, atol=1e-9)
        else:
            assert np.allclose(rig1.lights[i].aim, light.aim, atol=1e-4)  # angles rounded to 0.001°
        assert {k: v for k, v in t1.items() if not k.startswith(("arm_", "position_m", "yaw", "pitch", "aim"))} == \
            {k: v for k, v in t0.items() if not k.startswith(("arm_", "position_m", "yaw", "pitch", "aim"))}
        for j, other in enumerate(rig1.lights):
            if j != i:
                assert np.allclose(other.position_m, rig0.lights[j].position_m)


def test_move_light_refuses_the_housing_and_nonsense():
    doc = RigDoc.load(ROOT / "rigs" / "twin-strobes-45-wide.toml")
    with pytest.raises(ConfigError, match="inside the housing"):
        doc.move_light(0, [0.05, 0.0, 0.0])
    with pytest.raises(ConfigError, match=r"lights\[0\]\.position_m.*3 finite numbers"):
        doc.move_light(0, [float("nan"), 0.0, 0.0])
    with pytest.raises(ConfigError, match="no light number 7"):
        doc.move_light(7, [0.5, 0.0, 0.0])
