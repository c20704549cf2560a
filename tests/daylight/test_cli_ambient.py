"""``rigsim ambient`` end to end (through rigsim.cli.main; the module is added to COMMAND_MODULES here)."""

from __future__ import annotations

import json

import numpy as np
import pytest



def test_json_layout_and_textbook_single_wavelength(tmp_path, run):
    f = tmp_path / "textbook.toml"
    f.write_text('[water]\na_per_m = 0.2\nb_per_m = 0.0\nphase = "hg:0.9"\nwavelength_nm = 532\n')
    code, out, err = run("ambient", "--water", f, "--sun-zenith", 30, "--sky", "black", "--depths", "0,1,5",
                         "--surface-irradiance", 1.0, "--photons", 4000, "--json")
    assert code == 0, err
    d = json.loads(out)
    assert d["wavelength_nm"] == [532.0] and d["depth_m"] == [0.0, 1.0, 5.0]
    for q in ("Ed", "Eu", "Eo", "Eod", "Eou", "Lu", "Kd"):
        assert np.shape(d[q]) == (3, 1) and np.shape(d[f"{q}_stderr"]) == (3, 1)
    # the textbook answer: Ed(z) = (1 − R) exp(−a z / μ_w)
    mu_w = np.sqrt(1 - (0.5 / 1.34) ** 2)
    t = 1 - 0.02220  # Fresnel at 30°
    ed = np.array(d["Ed"])[:, 0]
    err = np.array(d["Ed_stderr"])[:, 0]
    assert np.all(np.abs(ed - t * np.exp(-0.2 * np.array([0, 1, 5]) / mu_w)) <= 4 * err + 2e-5)
    assert d["units"]["Lu"] == "W/(m2 sr nm)"


def test_table_output_and_kd_model(run):
    code, out, err = run("ambient", "--water", "jerlov-II", "--sun-zenith", 30, "--depths", "5,10",
                         "--wavelengths", "450,550", "--photons", 1000)
    assert code == 0, err
    assert "Ed (W/(m2 nm))" in out and "Lu (W/(m2 sr nm))" in out and "±" in out and "10 m" in out
    code, out, err = run("ambient", "--water", "coastal", "--sun-zenith", 30, "--model", "kd", "--json",
                         "--bottom-depth", 12, "--bottom-reflectance", 0.3, "--depths", "1,12")
    assert code == 0, err
    d = json.loads(out)
    assert len(d["wavelength_nm"]) == 7 and d["meta"]["model"] == "kd"


@pytest.mark.parametrize("args, needle", [
    (["--depths", "1,-2"], "--depths"),
    (["--depths", "a,b"], "cannot read depths"),
    (["--sky", "cloudy"], "unknown sky 'cloudy'"),
    (["--bottom-depth", 5, "--bottom-reflectance", 1.5], "--bottom-reflectance"),
    (["--bottom-reflectance", 0.3], "needs --bottom-depth"),
    (["--depths", 10, "--bottom-depth", 5], "below the bottom"),
    (["--surface-irradiance", -1], "--surface-irradiance"),
    (["--sky", "black", "--sky-fraction", 0.2], "black sky"),
    (["--model", "fast"], "unknown model"),
    (["--wind", -3], "--wind"),
])
def test_errors_are_one_line(run, args, needle):
    code, out, err = run("ambient", "--water", "coastal", "--sun-zenith", 30, "--photons", 100, *args)
    assert code == 2
    assert needle in err and err.strip().count("\n") == 0, err


def test_bad_sun_and_water(run):
    code, _, err = run("ambient", "--water", "coastal", "--sun-zenith", 90)
    assert code == 2 and "--sun-zenith" in err
    code, _, err = run("ambient", "--water", "coastl", "--sun-zenith", 30)
    assert code == 2 and "unknown water preset" in err
