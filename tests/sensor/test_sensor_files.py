"""Sensor files: the shipped ones load and cite their noise figures; bad files fail clearly."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rigsim.errors import ConfigError
from rigsim.sensor.model import NOISE_KEYS, SENSORS_DIR, available_sensors, load_sensor, load_sensor_file

SHIPPED = ["sony_ilce-7rm2", "sony_ilce-7sm2", "nikon_d5100", "canon_eos_5d_mark_ii", "action_cam_1-2.3in"]


def test_required_sensors_are_shipped():
    assert set(SHIPPED) <= set(available_sensors())


@pytest.mark.parametrize("name", SHIPPED)
def test_shipped_sensor_is_plausible_and_cited(name):
    s = load_sensor(name)
    assert 0.2 < s.qe.max() <= 1.0 and s.qe.min() >= 0
    assert s.qe.shape == (len(s.wavelength_nm), 3)
    for key in NOISE_KEYS:
        src = s.sources[key].lower()
        assert "http" in src or "assumption" in src or "derived" in src, (name, key, src)
    assert s.saturation_e(s.base_iso) <= s.full_well_e
    assert all(a.iso < b.iso for a, b in zip(s.iso_settings, s.iso_settings[1:]))


def test_7rm2_gain_from_photonstophotos():
    s = load_sensor("sony_ilce-7rm2")
    assert s.iso_setting(100).gain_dn_per_e == pytest.approx(0.315)
    # ISO 500 lies in the low-conversion-gain step of ISO 400: K ∝ ISO (Claff: 1.587 DN/e-)
    assert s.iso_setting(500).gain_dn_per_e == pytest.approx(1.587, rel=0.01)
    assert s.iso_setting(500).read_noise_e == s.iso_setting(400).read_noise_e
    with pytest.raises(ConfigError, match="below the sensor's lowest ISO"):
        s.iso_setting(50)


def _write(tmp_path: Path, text: str) -> Path:
    base = (SENSORS_DIR / "sony_ilce-7rm2.toml").read_text()
    p = tmp_path / "s.toml"
    p.write_text(text(base) if callable(text) else text)
    return p


def test_unknown_key_names_file_and_key(tmp_path):
    p = _write(tmp_path, lambda b: b.replace("full_well_e = 50400", "full_well_e = 50400\nfull_wel = 1"))
    with pytest.raises(ConfigError) as e:
        load_sensor_file(p)
    msg = str(e.value)
    assert str(p) in msg and "noise.full_wel" in msg and "unknown key" in msg and "full_well_e" in msg


def test_unknown_top_level_section(tmp_path):
    p = _write(tmp_path, lambda b: b + "\n[lense]\nf = 2\n")
    with pytest.raises(ConfigError, match="unknown key 'lense'"):
        load_sensor_file(p)


def test_out_of_range_value_names_allowed_range(tmp_path):
    p = _write(tmp_path, lambda b: b.replace("full_well_e = 50400", "full_well_e = -5"))
    with pytest.raises(ConfigError) as e:
        load_sensor_file(p)
    assert "noise.full_well_e" in str(e.value) and "allowed: > 0" in str(e.value)


def test_bad_cfa_pattern(tmp_path):
    p = _write(tmp_path, lambda b: b.replace('cfa_pattern = "RGGB"', 'cfa_pattern = "RGBW"'))
    with pytest.raises(ConfigError, match="sensor.cfa_pattern"):
        load_sensor_file(p)


def test_peak_qe_above_one(tmp_path):
    p = _write(tmp_path, lambda b: b.replace("peak_qe = 0.55", "peak_qe = 1.5"))
    with pytest.raises(ConfigError, match="spectral.peak_qe"):
        load_sensor_file(p)


def test_missing_source_is_an_error(tmp_path):
    p = _write(tmp_path, lambda b: "\n".join(l for l in b.splitlines() if not l.startswith("dsnu_e = \"")))
    with pytest.raises(ConfigError, match="no source given for dsnu_e"):
        load_sensor_file(p)


def test_missing_csv(tmp_path):
    p = _write(tmp_path, lambda b: b.replace("camera_sony_ilce-7rm2.csv", "nope.csv"))
    with pytest.raises(ConfigError, match="spectral.file.*not found"):
        load_sensor_file(p)


def test_invalid_toml(tmp_path):
    p = _write(tmp_path, "[sensor\nname=")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_sensor_file(p)


def test_unknown_sensor_name_suggests():
    with pytest.raises(ConfigError, match="did you mean 'sony_ilce-7rm2'"):
        load_sensor("sony_ilce7rm2")


def test_ir_cut_filter_and_per_channel_qe(tmp_path):
    csv = tmp_path / "ir.csv"
    csv.write_text("# test filter: 1 below 650 nm, 0 above; units: transmittance\nwavelength_nm,value\n"
                   "300,1\n650,1\n651,0\n1200,0\n")
    p = _write(tmp_path, lambda b: b.replace('peak_qe = 0.55', f'peak_qe = [0.3, 0.5, 0.4]\nir_cut_file = "{csv}"'))
    s = load_sensor_file(p)
    assert np.all(s.qe[s.wavelength_nm > 651] == 0)
    assert s.qe.max(axis=0) == pytest.approx([0.3, 0.5, 0.4], rel=1e-9) or s.qe[:, 1].max() == pytest.approx(0.5)
