"""Water files and bad input: one-line errors naming the field and allowed values."""

import json
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rigsim.config.water import load_water
from rigsim.errors import ConfigError, SpectrumRangeError
from rigsim.water import ConstituentWater, preset


def write(tmp_path, text, name="w.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_constituents_with_original_aliases(tmp_path):
    p = write(tmp_path, "[water]\nchlorophyllConc = 1.0\ndomConc = 0.1\nsmallPartConc = 0.1\nlargePartConc = 0.3\n")
    w = load_water(p)
    ref = preset("coastal-petzold")  # the same concentrations (the original code's names for them)
    np.testing.assert_allclose(w.c_per_m([450.0, 550.0]), ref.c_per_m([450.0, 550.0]))


def test_preset_with_overrides_and_model_options(tmp_path):
    p = write(tmp_path, '[water]\npreset = "coastal"\nchl_mg_per_m3 = 5\npure_water = "pope-fry-1997"\n'
                        'detritus_exponent = 0.724\nphytoplankton = true\n')
    w = load_water(p)
    assert w.chl_mg_per_m3 == 5 and w.small_particles_ppm == 0.1 and w.phytoplankton
    assert w.wavelength_range_nm == (400.0, 700.0)


def test_explicit_iops_single_wavelength(tmp_path):
    p = write(tmp_path, '[water]\na_per_m = 0.2\nb_per_m = 0.8\nphase = "hg:0.9"\nwavelength_nm = 532\n')
    w = load_water(p)
    assert float(w.c_per_m(532.0)) == pytest.approx(1.0)
    assert float(w.albedo(532.0)) == pytest.approx(0.8)
    assert w.phase.mean_cosine() == pytest.approx(0.9)
    with pytest.raises(SpectrumRangeError, match="posed only at"):
        w.a_per_m(550.0)


def test_explicit_iops_from_csv(tmp_path):
    (tmp_path / "a.csv").write_text("# test\nwavelength_nm,a\n400,0.1\n700,0.7\n")
    (tmp_path / "b.csv").write_text("# test\nwavelength_nm,b\n400,0.4\n700,0.1\n")
    (tmp_path / "p.csv").write_text("# test\nangle_deg,value\n0,100\n10,1\n90,0.01\n180,0.02\n")
    p = write(tmp_path, '[water]\na_per_m = "a.csv"\nb_per_m = "b.csv"\nphase = "p.csv"\n')
    w = load_water(p)
    assert float(w.a_per_m(550.0)) == pytest.approx(0.4)
    assert w.wavelength_range_nm == (400.0, 700.0)
    with pytest.raises(SpectrumRangeError, match="covers 400–700 nm"):
        w.b_per_m(380.0)


@pytest.mark.parametrize("spec,check", [
    ("petzold-average", lambda p: p.backscatter_fraction() == pytest.approx(0.0183, rel=0.01)),
    ("rayleigh", lambda p: p.backscatter_fraction() == 0.5),
    ("ff:0.02", lambda p: p.backscatter_fraction() == pytest.approx(0.02, rel=3e-3)),
    ("kopelevich", lambda p: p.wavelength_dependent),
])
def test_phase_specs(tmp_path, spec, check):
    p = write(tmp_path, f'[water]\na_per_m = 0.1\nb_per_m = 0.3\nphase = "{spec}"\n')
    assert check(load_water(p).phase)


BAD = [
    ("[water]\nchl_mg_per_m3 = -1\n", r"w.toml: water.chl_mg_per_m3: out of range: -1 \(allowed: >= 0\)"),
    ("[water]\nchl = 1\n", r"w.toml: water.chl: unknown key 'chl'.*allowed:"),
    ("[water]\nsmallPartConc = 'lots'\n", r"water.small_particles_ppm: must be a number"),
    ('[water]\npreset = "coastl"\n', r"w.toml: water.preset: unknown water preset 'coastl'; did you mean 'coastal'"),
    ("[water]\na_per_m = 0.1\n", r"water.b_per_m: missing"),
    ("[water]\na_per_m = 0.1\nb_per_m = 0.1\nchl_mg_per_m3 = 1\n", r"mixes explicit IOPs"),
    ('[water]\na_per_m = 0.1\nb_per_m = 0.1\nphase = "hg:1.5"\n', r"water.phase: HG asymmetry"),
    ('[water]\na_per_m = 0.1\nb_per_m = 0.1\nphase = "mie"\n', r"water.phase: unknown phase function 'mie'"),
    ('[water]\na_per_m = -0.1\nb_per_m = 0.1\n', r"water.a_per_m: must be >= 0"),
    ('[water]\na_per_m = "nope.csv"\nb_per_m = 0.1\n', r"water.a_per_m: CSV file .*nope.csv not found"),
    ("[water\nchl = 1\n", r"w.toml: malformed TOML"),
    ("[waters]\nchl_mg_per_m3 = 1\n", r"unknown key 'waters'"),
]


@pytest.mark.parametrize("text,pattern", BAD)
def test_bad_water_files(tmp_path, text, pattern):
    p = write(tmp_path, text)
    with pytest.raises(ConfigError, match=pattern) as ei:
        load_water(p)
    assert "\n" not in str(ei.value)


def test_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="file not found"):
        load_water(tmp_path / "missing.toml")


def test_spectrum_not_covering_range(tmp_path):
    w = load_water(write(tmp_path, '[water]\npreset = "clear"\npure_water = "pope-fry-1997"\n'))
    with pytest.raises(SpectrumRangeError, match="380–727.5 nm"):
        w.check_range([360.0, 700.0])


conc = st.floats(min_value=0.0, max_value=200.0, allow_nan=False)


@settings(max_examples=60, deadline=None)
@given(chl=conc, cdom=st.floats(0.0, 20.0), small=st.floats(0.0, 50.0), large=st.floats(0.0, 50.0),
       wl=st.floats(400.0, 700.0))
def test_property_outputs_finite_nonnegative(chl, cdom, small, large, wl):
    w = ConstituentWater(chl_mg_per_m3=chl, cdom_a440_per_m=cdom, small_particles_ppm=small,
                         large_particles_ppm=large)
    t = w.iop_table(np.array([400.0, wl, 700.0]))
    for k, v in t.items():
        assert np.all(np.isfinite(v)) and np.all(v >= 0), k
    assert np.all(t["albedo"] <= 1.0)
    assert np.all(t["bb_per_m"] <= t["b_per_m"])
    mu = w.phase.sample(np.linspace(0, 1, 101), wl)
    assert np.all(np.isfinite(mu))


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "rigsim.cli", *args], capture_output=True, text=True, timeout=120)


def test_cli_show_json_consistent_with_published_kopelevich():
    r = run_cli("water", "show", "coastal", "--json")
    assert r.returncode == 0, r.stderr
    d = json.loads(r.stdout)
    assert set(d) == {"wavelength_nm", "a_per_m", "b_per_m", "c_per_m", "bb_per_m", "albedo", "kd_per_m"}
    assert len({len(v) for v in d.values()}) == 1 and len(d["wavelength_nm"]) == 31
    wl = np.array(d["wavelength_nm"])
    x = 550.0 / wl
    published = 0.0017 * x**4.3 + 1.34 * 0.1 * x**1.7 + 0.312 * 0.1 * x**0.3  # the write-up's coastal: 0.1 / 0.1 ppm
    np.testing.assert_allclose(d["b_per_m"], published, rtol=0.04)
    np.testing.assert_allclose(np.array(d["a_per_m"]) + d["b_per_m"], d["c_per_m"], rtol=1e-12)


def test_cli_errors_are_one_line():
    r = run_cli("water", "show", "coastl")
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "did you mean 'coastal'" in r.stderr
    r = run_cli("water", "show", "coastal", "--chl", "-2")
    assert r.returncode == 2 and "chl_mg_per_m3" in r.stderr and ">= 0" in r.stderr


def test_cli_plot(tmp_path):
    out = tmp_path / "w.png"
    r = run_cli("water", "plot", "clear", "coastal", "jerlov-II", "--out", str(out))
    assert r.returncode == 0, r.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and out.stat().st_size > 20_000


def test_cli_version():
    r = run_cli("--version")
    assert r.returncode == 0 and r.stdout.startswith("rigsim ")
