"""Rig files: the shipped rigs parse; every kind of mistake is one line naming file and field."""

from pathlib import Path

import numpy as np
import pytest

from rigsim.config import load_rig
from rigsim.errors import ConfigError
from rigsim.light import K_M_LM_PER_W, beam_solid_angle_sr, luminous_integral

RIGS = Path(__file__).resolve().parents[2] / "rigs"
SHIPPED = sorted(RIGS.glob("*.toml"))

BASE = """\
[rig]
name = "t"

[camera]
focal_length_mm = 24.0
f_number = 8.0
housing_radius_m = 0.12

[port]
kind = "dome"
radius_m = 0.1

[[lights]]
name = "a"
kind = "strobe"
arm_length_m = 0.4
arm_angle_deg = 180.0
aim = [0.0, 0.0, 1.0]
beam_angle_deg = 100.0
spectrum = "xenon-strobe"
guide_number_m = 24.0

[[lights]]
name = "b"
kind = "video"
position_m = [0.4, 0.0, 0.0]
aim_at_m = [0.0, 0.0, 1.0]
beam_angle_deg = 100.0
lumens = 3000.0
"""


def write(tmp_path, text, name="rig.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def one_line_error(path, *fragments):
    with pytest.raises(ConfigError) as e:
        load_rig(path)
    msg = str(e.value)
    assert "\n" not in msg, msg
    assert msg.count(str(path)) == 1, msg
    for frag in fragments:
        assert frag in msg, msg
    return msg


def test_shipped_rigs_exist():
    names = {p.name for p in SHIPPED}
    assert {"single-strobe-short-arm.toml", "twin-strobes-45-wide.toml", "twin-strobes-edge-lighting.toml",
            "video-lights-pair.toml", "ambient-only.toml"} <= names


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.name)
def test_every_shipped_rig_parses(path):
    rig = load_rig(path)
    assert rig.name == path.stem
    assert rig.source == str(path)
    cam = np.asarray(rig.camera.position_m)
    for lt in rig.lights:
        assert np.linalg.norm(np.asarray(lt.position_m) - cam) > rig.camera.housing_radius_m
        assert np.linalg.norm(lt.aim) == pytest.approx(1.0)
        assert len(lt.wavelength_nm) == len(lt.axial_intensity)
        assert lt.wavelength_nm[0] <= 360 and lt.wavelength_nm[-1] >= 830
        assert min(lt.axial_intensity) >= 0


def test_base_rig_and_frames(tmp_path):
    rig = load_rig(write(tmp_path, BASE))
    a, b = rig.lights
    # arm at 180 deg = image left = world +x for the default camera (image right = forward x up = -x)
    assert a.position_m == pytest.approx((0.4, 0.0, 0.0), abs=1e-12)
    assert b.position_m == pytest.approx((-0.4, 0.0, 0.0))
    assert b.aim == pytest.approx(tuple(np.array([0.4, 0, 1]) / np.hypot(0.4, 1)))
    assert b.kind == "continuous" and b.spectrum_name == "daylight-led"
    lm = K_M_LM_PER_W * beam_solid_angle_sr(b.beam) * luminous_integral(b.wavelength_nm, b.axial_intensity)
    assert lm == pytest.approx(3000.0, rel=1e-6)


def test_camera_pose_carries_lights(tmp_path):
    text = BASE.replace("[camera]\n", "[camera]\nposition_m = [1.0, 2.0, 3.0]\nforward = [1.0, 0.0, 0.0]\n")
    rig = load_rig(write(tmp_path, text))
    a = rig.lights[0]
    # forward +x, up +y → right = forward × up = +z; arm at 180° (left) → -z
    assert a.position_m == pytest.approx((1.0, 2.0, 2.6))
    assert a.aim == pytest.approx((1.0, 0.0, 0.0))


def test_fov_instead_of_focal_length(tmp_path):
    text = BASE.replace("focal_length_mm = 24.0", "fov_deg = 73.7398")
    rig = load_rig(write(tmp_path, text))
    assert rig.camera.focal_length_mm == pytest.approx(24.0, rel=1e-5)


def test_relative_paths_resolve_against_rig_folder(tmp_path):
    sub = tmp_path / "myrigs"
    sub.mkdir()
    (sub / "spec.csv").write_text("# test\nwavelength_nm,relative\n380,1\n780,1\n")
    (sub / "beam.csv").write_text("# test\nangle_deg,relative\n0,1\n45,0.5\n80,0\n")
    text = BASE.replace('spectrum = "xenon-strobe"', 'spectrum = "spec.csv"').replace(
        'beam_angle_deg = 100.0\nspectrum', 'beam_profile = "beam.csv"\nspectrum')
    rig = load_rig(write(sub, text))
    assert rig.lights[0].beam.kind == "table"
    assert rig.lights[0].spectrum_name == "spec.csv"


# ------------------------------------------------------------------ bad inputs: one line each

def test_strobe_inside_housing(tmp_path):
    p = write(tmp_path, BASE.replace("arm_length_m = 0.4", "arm_length_m = 0.05"))
    one_line_error(p, "lights[0].arm_length_m", "inside the housing", "housing_radius_m = 0.12")
    p = write(tmp_path, BASE.replace("position_m = [0.4, 0.0, 0.0]", "position_m = [0.05, 0.0, 0.05]"))
    one_line_error(p, "lights[1].position_m", "inside the housing")


@pytest.mark.parametrize("angle", ["0.0", "-5.0", "360.0", "400.0"])
def test_bad_beam_angle(tmp_path, angle):
    p = write(tmp_path, BASE.replace("beam_angle_deg = 100.0\nlumens", f"beam_angle_deg = {angle}\nlumens"))
    one_line_error(p, "lights[1].beam_angle_deg", "< 360", "> 0")


def test_unknown_spectrum_suggests(tmp_path):
    p = write(tmp_path, BASE.replace('"xenon-strobe"', '"xenon-strob"'))
    one_line_error(p, "lights[0].spectrum", "unknown spectrum 'xenon-strob'", "did you mean 'xenon-strobe'")


@pytest.mark.parametrize("section,key,field", [
    ("[camera]\n", "focal_lenght_mm = 24.0\n", "camera.focal_lenght_mm"),
    ("[port]\n", "radius = 0.1\n", "port.radius"),
    ("[rig]\n", "colour = 'red'\n", "rig.colour"),
    ('name = "b"\n', "beam_angel_deg = 100.0\n", "lights[1].beam_angel_deg"),
])
def test_unknown_key_anywhere(tmp_path, section, key, field):
    p = write(tmp_path, BASE.replace(section, section + key, 1))
    one_line_error(p, field, "unknown key")


def test_unknown_key_suggests(tmp_path):
    p = write(tmp_path, BASE.replace("[camera]\n", "[camera]\nfocal_lenght_mm = 20\n"))
    one_line_error(p, "did you mean 'focal_length_mm'")


def test_unknown_top_level_table(tmp_path):
    p = write(tmp_path, BASE + "\n[lens]\nx = 1\n")
    one_line_error(p, "lens", "unknown key")


@pytest.mark.parametrize("old,new,field", [
    ("guide_number_m = 24.0", "guide_number_m = -24.0", "lights[0].guide_number_m"),
    ("guide_number_m = 24.0", "flash_energy_J = -10.0", "lights[0].flash_energy_J"),
    ("lumens = 3000.0", "lumens = -1.0", "lights[1].lumens"),
    ("guide_number_m = 24.0", "guide_number_m = 24.0\npower_fraction = 0.0", "lights[0].power_fraction"),
])
def test_negative_power(tmp_path, old, new, field):
    p = write(tmp_path, BASE.replace(old, new))
    one_line_error(p, field, "> 0")


def test_strobe_without_power_and_with_both(tmp_path):
    one_line_error(write(tmp_path, BASE.replace("guide_number_m = 24.0\n", "")), "lights[0].flash_energy_J",
                   "missing")
    one_line_error(write(tmp_path, BASE.replace("guide_number_m = 24.0", "guide_number_m = 24.0\nflash_energy_J = 50")),
                   "give only one of")


def test_power_key_of_the_other_kind(tmp_path):
    p = write(tmp_path, BASE.replace("lumens = 3000.0", "lumens = 3000.0\nguide_number_m = 20.0"))
    one_line_error(p, "lights[1].guide_number_m", "not a field of a video light")


def test_wrong_types(tmp_path):
    one_line_error(write(tmp_path, BASE.replace("lumens = 3000.0", 'lumens = "lots"')), "lights[1].lumens",
                   "must be a number")
    one_line_error(write(tmp_path, BASE.replace("aim = [0.0, 0.0, 1.0]", "aim = [0.0, 1.0]")), "lights[0].aim",
                   "3 numbers")
    one_line_error(write(tmp_path, BASE.replace("aim = [0.0, 0.0, 1.0]", "aim = [0.0, 0.0, 0.0]")),
                   "lights[0].aim", "zero")
    one_line_error(write(tmp_path, BASE.replace('kind = "dome"', 'kind = "fisheye"')), "port.kind",
                   "unknown kind 'fisheye'", "allowed: dome, flat")
    one_line_error(write(tmp_path, BASE.replace('kind = "video"', 'kind = "torch"')), "lights[1].kind")


def test_missing_kind_and_position(tmp_path):
    one_line_error(write(tmp_path, BASE.replace('kind = "video"\n', "")), "lights[1].kind", "missing")
    one_line_error(write(tmp_path, BASE.replace("position_m = [0.4, 0.0, 0.0]\n", "")), "lights[1].position_m",
                   "missing")


def test_two_aims(tmp_path):
    p = write(tmp_path, BASE.replace("aim = [0.0, 0.0, 1.0]", "aim = [0.0, 0.0, 1.0]\nyaw_deg = 10.0"))
    one_line_error(p, "lights[0].yaw_deg", "only one of")


def test_duplicate_light_names(tmp_path):
    one_line_error(write(tmp_path, BASE.replace('name = "b"', 'name = "a"')), "lights[1].name", "duplicate")


def test_malformed_toml_names_line(tmp_path):
    p = write(tmp_path, BASE.replace("f_number = 8.0", "f_number 8.0"))
    msg = one_line_error(p, "malformed TOML", "line 6")
    assert msg.startswith(str(p))


def test_missing_file(tmp_path):
    p = tmp_path / "nope.toml"
    one_line_error(p, "file not found")


def test_missing_beam_profile(tmp_path):
    p = write(tmp_path, BASE.replace("beam_angle_deg = 100.0\nspectrum", 'beam_profile = "nope.csv"\nspectrum'))
    one_line_error(p, "lights[0].beam_profile", "not found")


def test_up_parallel_to_forward(tmp_path):
    p = write(tmp_path, BASE.replace("[camera]\n", "[camera]\nup = [0.0, 0.0, 2.0]\n"))
    one_line_error(p, "camera.up", "parallel")


def test_edge_lighting_rig_puts_subject_at_beam_edge():
    rig = load_rig(RIGS / "twin-strobes-edge-lighting.toml")
    for lt in rig.lights:
        pos, aim = np.asarray(lt.position_m), np.asarray(lt.aim)
        half = lt.beam.beam_angle_deg / 2

        def off_axis(point):
            d = np.asarray(point) - pos
            return np.degrees(np.arccos(d @ aim / np.linalg.norm(d)))

        assert half - 5 < off_axis([0, 0, 1.0]) < half + 2        # subject near the half-intensity edge
        assert off_axis([0, 0, 0.3]) > half + 15                  # water just in front of the dome: dim
