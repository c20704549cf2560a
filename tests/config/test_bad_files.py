"""Every kind of config file — rig, water, sensor, study, dataset — goes through the one reader:
an unknown key (with a suggestion), a value out of range, NaN/inf, a wrong type, a bool for a
number, a binary or non-UTF-8 file or a syntax error is one line naming the file and the field."""

from __future__ import annotations

from pathlib import Path

import pytest

from rigsim.config import load_rig
from rigsim.config.water import load_water
from rigsim.dataset import load_dataset_spec
from rigsim.errors import ConfigError
from rigsim.sensor.model import SENSORS_DIR, load_sensor_file
from rigsim.study import load_study

ROOT = Path(__file__).resolve().parents[2]

RIG = """\
[camera]
focal_length_mm = 24.0
f_number = 8.0

[port]
kind = "dome"
radius_m = 0.1

[[lights]]
name = "a"
kind = "strobe"
arm_length_m = 0.4
arm_angle_deg = 180.0
beam_angle_deg = 100.0
guide_number_m = 24.0
"""

WATER = """\
[water]
preset = "coastal"
chl_mg_per_m3 = 1.0
detritus_exponent = 0.724
phytoplankton = true
"""

STUDY = f"""\
[study]
seed = 3

[sweep]
rigs = ["{ROOT}/rigs/twin-strobes-close-to-port.toml"]
sensors = ["sony_ilce-7rm2"]
waters = ["coastal"]
distances_m = [1.0, 2.0]
target_fill = 0.4

[render]
width = 24
height = 16
spp = 2
"""

DATASET = f"""\
[dataset]
width = 36
height = 24

[water]
presets = ["coastal"]
constituent_probability = 0.5

[rig]
files = ["{ROOT}/rigs/twin-strobes-45-wide.toml"]

[sensor]
names = ["sony_ilce-7rm2"]
noise = true

[scene]
distance_m = [1.0, 2.0]
kinds = ["colorchecker"]
bottom_probability = 0.5
"""

SENSOR = (SENSORS_DIR / "sony_ilce-7rm2.toml").read_text()

KINDS = {"rig": (load_rig, RIG), "water": (load_water, WATER), "sensor": (load_sensor_file, SENSOR),
         "study": (load_study, STUDY), "dataset": (load_dataset_spec, DATASET)}

CASES = [
    # rig
    ("rig", "f_number = 8.0", "f_numbr = 8.0", ["camera.f_numbr", "unknown key", "did you mean 'f_number'"]),
    ("rig", "beam_angle_deg = 100.0", "beam_angle_deg = 400.0",
     ["lights[0].beam_angle_deg", "out of range: 400", "allowed: > 0 and < 360 (deg"]),
    ("rig", "guide_number_m = 24.0", "guide_number_m = nan", ["lights[0].guide_number_m", "must be finite, got nan"]),
    ("rig", "radius_m = 0.1", "radius_m = inf", ["port.radius_m", "must be finite, got inf", "allowed: > 0 and <= 1"]),
    ("rig", "f_number = 8.0", 'f_number = "8"', ["camera.f_number", "must be a number, got '8'"]),
    ("rig", "arm_length_m = 0.4", "arm_length_m = true", ["lights[0].arm_length_m", "must be a number, got True"]),
    ("rig", 'name = "a"', "name = 3", ["lights[0].name", "must be a string"]),
    # water
    ("water", "detritus_exponent = 0.724", "detritus_exponnt = 0.724",
     ["water.detritus_exponnt", "unknown key", "did you mean 'detritus_exponent'"]),
    ("water", "detritus_exponent = 0.724", "detritus_exponent = 3",
     ["water.detritus_exponent", "out of range: 3", "allowed: >= 0 and <= 2"]),
    ("water", "chl_mg_per_m3 = 1.0", "chl_mg_per_m3 = nan", ["water.chl_mg_per_m3", "must be finite"]),
    ("water", "chl_mg_per_m3 = 1.0", "chlorophyllConc = -inf", ["water.chl_mg_per_m3", "must be finite"]),
    ("water", "phytoplankton = true", "phytoplankton = 1", ["water.phytoplankton", "must be true or false"]),
    ("water", "chl_mg_per_m3 = 1.0", "chl_mg_per_m3 = true", ["water.chl_mg_per_m3", "must be a number, got True"]),
    ("water", "chl_mg_per_m3 = 1.0", "chl_mg_per_m3 = 1.0\nchlorophyllConc = 2.0",
     ["water.chl_mg_per_m3", "given twice"]),
    # sensor
    ("sensor", "bit_depth = 14", "bit_dept = 14", ["sensor.bit_dept", "unknown key", "did you mean 'bit_depth'"]),
    ("sensor", "bit_depth = 14", "bit_depth = 20", ["sensor.bit_depth", "out of range: 20", "allowed: >= 8 and <= 16"]),
    ("sensor", "full_well_e = 50400", "full_well_e = nan", ["noise.full_well_e", "must be finite"]),
    ("sensor", "bit_depth = 14", "bit_depth = 12.5", ["sensor.bit_depth", "must be a whole number"]),
    ("sensor", "bit_depth = 14", "bit_depth = true", ["sensor.bit_depth", "must be a number, got True"]),
    ("sensor", "full_well_e = 50400", 'full_well_e = "lots"', ["noise.full_well_e", "must be a number"]),
    # study
    ("study", "spp = 2", "spq = 2", ["render.spq", "unknown key", "did you mean 'spp'"]),
    ("study", "width = 24", "width = 4", ["render.width", "out of range: 4", "allowed: >= 8 and <= 8192"]),
    ("study", "target_fill = 0.4", "target_fill = nan", ["sweep.target_fill", "must be finite"]),
    ("study", "seed = 3", 'seed = "three"', ["study.seed", "must be a number"]),
    ("study", "spp = 2", "spp = true", ["render.spp", "must be a number, got True"]),
    ("study", 'waters = ["coastal"]', "waters = [1]", ["sweep.waters", "list of names"]),
    ("study", "[render]", '[render]\nengine = "blender"', ["render.engine", "unknown engine 'blender'",
                                                           "allowed: mitsuba, preview"]),
    # dataset
    ("dataset", "distance_m = [1.0, 2.0]", "distanc_m = [1.0, 2.0]",
     ["scene.distanc_m", "unknown key", "did you mean 'distance_m'"]),
    ("dataset", "bottom_probability = 0.5", "bottom_probability = 1.5",
     ["scene.bottom_probability", "out of range: 1.5", "allowed: >= 0 and <= 1"]),
    ("dataset", "constituent_probability = 0.5", "constituent_probability = nan",
     ["water.constituent_probability", "must be finite"]),
    ("dataset", "noise = true", 'noise = "yes"', ["sensor.noise", "must be true or false"]),
    ("dataset", "distance_m = [1.0, 2.0]", "distance_m = [nan, 2.0]", ["scene.distance_m", "impossible range"]),
    ("dataset", "width = 36", "width = 36.5", ["dataset.width", "must be a whole number"]),
]


def write(tmp_path, kind, text) -> Path:
    p = tmp_path / f"{kind}.toml"
    p.write_text(text)
    return p


def one_line(load, path, fragments) -> str:
    with pytest.raises(ConfigError) as e:
        load(path)
    msg = str(e.value)
    assert "\n" not in msg, msg
    assert msg.startswith(f"{path}: "), msg
    for frag in fragments:
        assert frag in msg, msg
    return msg


def test_the_bases_are_valid(tmp_path):
    for kind, (load, text) in KINDS.items():
        load(write(tmp_path, kind, text))


@pytest.mark.parametrize("kind,old,new,fragments", CASES, ids=[f"{c[0]}-{c[2][:24]}" for c in CASES])
def test_bad_value(tmp_path, kind, old, new, fragments):
    load, text = KINDS[kind]
    assert old in text
    one_line(load, write(tmp_path, kind, text.replace(old, new, 1)), fragments)


@pytest.mark.parametrize("kind", KINDS)
def test_binary_non_utf8_and_malformed_files(tmp_path, kind):
    load, text = KINDS[kind]
    p = tmp_path / f"{kind}.toml"
    p.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00")
    one_line(load, p, ["binary file", "allowed: a UTF-8 TOML text file"])
    p.write_bytes(text.encode() + "# caf\xe9\n".encode("latin-1"))
    one_line(load, p, ["not UTF-8 text", "byte 0xe9"])
    p.write_text("[x\n" + text)
    one_line(load, p, ["malformed TOML", "line 1"])
    p.write_text(text + "\n[nonsense]\nkey = 1\n")
    one_line(load, p, ["nonsense", "unknown key 'nonsense'"])


def test_a_table_that_is_not_a_table(tmp_path):
    one_line(load_rig, write(tmp_path, "rig", "camera = 3\n" + RIG.replace("[camera]\n", "[lens]\n")),
             ["lens", "unknown key"])
    one_line(load_rig, write(tmp_path, "rig", "camera = 3\n"), ["camera", "must be a table, got 3"])
    one_line(load_water, write(tmp_path, "water", "water = [1, 2]\n"), ["water", "must be a table"])


def test_missing_table(tmp_path):
    one_line(load_water, write(tmp_path, "water", "# nothing\n"), ["water", "missing required field"])
    one_line(load_study, write(tmp_path, "study", STUDY.split("[sweep]")[0]), ["sweep", "missing required field"])


@pytest.mark.parametrize("key", ['"a\\nb"', '"tab\\there"', '"esc\\u001b[31m"', '"cr\\rx"'])
def test_a_key_holding_a_line_break_or_control_character_is_still_one_line(tmp_path, key):
    # found by the soak (seed 2027): an unknown key with a newline in it made a two-line message
    p = tmp_path / "w.toml"
    p.write_text(f'[water]\na_per_m = 0.2\nb_per_m = 0.8\n{key} = 1.0\n')
    with pytest.raises(ConfigError) as e:
        load_water(p)
    text = str(e.value)
    assert text.isprintable() and "\n" not in text and str(p) in text and "unknown key" in text, text
