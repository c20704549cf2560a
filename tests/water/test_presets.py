"""Presets: the original's parameters, the Jerlov IOP tables, Kd."""

import numpy as np
import pytest

from rigsim.data import load_table
from rigsim.errors import ConfigError
from rigsim.water import JERLOV_TYPES, ORIGINAL_PRESETS, preset, preset_names
from rigsim.water.presets import CODE_PRESETS
from rigsim.water.scattering import (
    scattering_large_particles_Kopelevich1983,
    scattering_pure_water,
    scattering_small_particles_Kopelevich1983,
)

# (chl mg/m3, a_y(440) 1/m, small ppm, large ppm): the write-up's table (Lian & Jobalia, "Underwater
# Rendering with Realistic Water Properties", section "Example Images"), typed here from the write-up
# itself, not read from the data file
EXPECTED = {
    "pure-sea": (0, 0, 0.001, 0.001),
    "clear": (0, 0, 0.05, 0.05),
    "coastal": (0, 0, 0.1, 0.1),
    "oceanic": (0.01, 0.01, 0.01, 0.01),
    "coastal-regions": (5, 0.25, 0.01, 0.01),
    "lakes-and-rivers": (15, 1, 0.01, 0.01),
}
# the six waters rigsim shipped under those names before, from the original code's comments
EXPECTED_CODE = {
    "pure-water": (0, 0, 0, 0),
    "uwsim-clear-ocean": (0.01, 0.01, 0.01, 0.01),
    "uwsim-ocean": (0.2, 0.02, 0.01, 0.01),
    "coastal-petzold": (1, 0.1, 0.1, 0.3),
    "turbid-coastal": (10, 0.5, 0.2, 0.4),
    "turbid-lake": (50, 1.0, 0.2, 0.4),
}


def test_public_names():
    names = preset_names()
    for n in ["pure-sea", "clear", "coastal", "oceanic", "coastal-regions", "lakes-and-rivers",
              "jerlov-I", "jerlov-IA", "jerlov-IB", "jerlov-II", "jerlov-III", "jerlov-1C", "jerlov-3C",
              "jerlov-5C", "jerlov-7C", "jerlov-9C"]:
        assert n in names
        preset(n)


@pytest.mark.parametrize("name", ORIGINAL_PRESETS + CODE_PRESETS)
def test_constituent_presets_parameters(name):
    w = preset(name)
    got = (w.chl_mg_per_m3, w.cdom_a440_per_m, w.small_particles_ppm, w.large_particles_ppm)
    assert got == pytest.approx({**EXPECTED, **EXPECTED_CODE}[name])
    assert w.detritus_exponent == 0.702 and w.pure_water == "smith-baker-1981"


def test_write_up_coastal_scatters_as_kopelevich_says():
    """b(550) of the write-up's coastal water: b_w + b_s*·0.1 + b_l*·0.1 with rigsim's own
    integration of Kopelevich's specific VSFs (1.300 and 0.3156 1/(m ppm), within 3 % of the
    published 1.34 and 0.312), i.e. ≈ 0.0017 + 1.34·0.1 + 0.312·0.1 = 0.167 1/m."""
    b = float(preset("coastal").b_per_m(550.0))
    b_s = float(scattering_small_particles_Kopelevich1983(550.0, 1.0))
    b_l = float(scattering_large_particles_Kopelevich1983(550.0, 1.0))
    assert b == pytest.approx(float(scattering_pure_water(550.0)) + 0.1 * b_s + 0.1 * b_l, rel=1e-12)
    assert b == pytest.approx(0.0017 + 1.34 * 0.1 + 0.312 * 0.1, rel=0.03)
    # the write-up's strongly absorbing waters scatter weakly: 0.01 ppm of each particle class
    for name in ("coastal-regions", "lakes-and-rivers"):
        assert float(preset(name).b_per_m(550.0)) == pytest.approx(0.0179, abs=5e-4)
        assert float(preset(name).a_per_m(440.0)) > 10 * float(preset(name).b_per_m(440.0))


def test_code_presets_are_ordered_by_turbidity():
    c = [float(preset(n).c_per_m(550.0)) for n in CODE_PRESETS]
    assert c == sorted(c)


@pytest.mark.parametrize("t", JERLOV_TYPES)
def test_jerlov_iops_exact_at_tabulated_wavelengths(t):
    tab = load_table("water/jerlov_iop_solonenko_mobley_2015.csv")
    m = (tab["water_type"] == t) & np.isfinite(tab["a_per_m"])
    w = preset(f"jerlov-{t}")
    np.testing.assert_array_equal(w.a_per_m(tab["wavelength_nm"][m]), tab["a_per_m"][m])
    np.testing.assert_array_equal(w.b_per_m(tab["wavelength_nm"][m]), tab["b_per_m"][m])


def test_jerlov_filled_rows_are_flagged_and_plausible():
    w5 = preset("jerlov-5C")
    assert w5.describe()["filled_wavelengths_nm"] == [600.0, 625.0, 650.0, 675.0, 700.0]
    assert preset("jerlov-3C").describe()["filled_wavelengths_nm"] == [675.0, 700.0]
    # filled absorption lies within the range of the neighbouring types (±10 %)
    wl = np.array([600.0, 650.0, 675.0, 700.0])
    a1, a3, a5, a7 = (preset(f"jerlov-{t}").a_per_m(wl) for t in ("1C", "3C", "5C", "7C"))
    for a in (a3, a5):
        assert np.all((a >= 0.9 * np.minimum(a1, a7)) & (a <= 1.1 * np.maximum(a1, a7)))
    b = w5.b_per_m(np.arange(400.0, 701.0, 25.0))
    assert np.all(np.diff(b) < 0)


def test_kd_vs_jerlov_tables():
    """Kd from the IOPs (Lee et al. 2005, sun at zenith) against Jerlov's measured Kd (1976).

    Tolerance: 30 % for oceanic types I–III and 50 % for coastal types.  Justification: Jerlov's
    Kd are type averages whose 1968 and 1976 editions differ by up to 35 %; Solonenko & Mobley's
    a, b were retrieved with a different bio-optical Kd model (their own Kd column differs from
    Jerlov's by up to 40 % in coastal types); the particle phase function (Petzold average,
    b_b/b = 0.0183) is a choice.  The test catches unit or factor errors, not 10 % effects.
    """
    t = load_table("water/jerlov_1976_kd.csv")
    wl = t["wavelength_nm"]
    m = wl >= 400
    for ty in JERLOV_TYPES:
        kd = preset(f"jerlov-{ty}").kd_per_m(wl[m])
        ref = t[f"Kd_{ty}_per_m"][m]
        tol = 0.30 if ty in ("I", "IA", "IB", "II", "III") else 0.50
        np.testing.assert_allclose(kd, ref, rtol=tol, err_msg=ty)


def test_kd_vs_solonenko_mobley_model_kd():
    """Against Solonenko & Mobley's own model Kd computed from the same a and b: 25 %
    (their Kd model differs from Lee et al. 2005 and their particle b_b/b from Petzold's)."""
    t = load_table("water/jerlov_iop_solonenko_mobley_2015.csv")
    for ty in JERLOV_TYPES:
        m = (t["water_type"] == ty) & (t["wavelength_nm"] >= 400) & np.isfinite(t["Kd_model_per_m"])
        kd = preset(f"jerlov-{ty}").kd_per_m(t["wavelength_nm"][m])
        np.testing.assert_allclose(kd, t["Kd_model_per_m"][m], rtol=0.25, err_msg=ty)


def test_unknown_preset_suggests_names():
    with pytest.raises(ConfigError, match=r"unknown water preset 'coastel'; did you mean 'coastal'"):
        preset("coastel")


def test_aliases():
    assert preset("jerlov-ii").name == "jerlov-II"
    assert preset("jerlov-c5").name == "jerlov-5C"
    assert preset("lakes").name == "lakes-and-rivers"
