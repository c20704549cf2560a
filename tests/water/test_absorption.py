"""Absorption against the published tables (exact at tabulated wavelengths) and formulas."""

from pathlib import Path

import numpy as np
import pytest

from rigsim.data import load_table, read_csv_table
from rigsim.errors import ConfigError, SpectrumRangeError
from rigsim.water import absorption as ab

REFERENCE = Path(__file__).resolve().parents[3] / "shared" / "reference"

TABLES = [
    ("smith-baker-1981", "pure_water_absorption_smith_baker_1981.csv"),
    ("pope-fry-1997", "pure_water_absorption_pope_fry_1997.csv"),
    ("buiteveld-1994", "pure_water_absorption_buiteveld_1994.csv"),
]


@pytest.mark.parametrize("method,fname", TABLES)
def test_pure_water_exact_at_tabulated_wavelengths(method, fname):
    t = load_table(f"water/{fname}")
    got = ab.absorption_pure_water(t["wavelength_nm"], method)
    np.testing.assert_array_equal(got, t["a_w_per_m"])


@pytest.mark.parametrize("method,fname", TABLES)
def test_data_copy_matches_shared_reference(method, fname):
    ref = REFERENCE / fname
    if not ref.is_file():
        pytest.skip("shared/reference not beside this checkout")
    a, b = read_csv_table(ref), load_table(f"water/{fname}")
    assert a.header == b.header  # provenance kept
    np.testing.assert_array_equal(a["a_w_per_m"], b["a_w_per_m"])


def test_published_spot_values():
    # Smith & Baker 1981 Table 1 at 440 nm; Pope & Fry 1997 at 600 nm; Buiteveld 1994 at 440 nm.
    assert ab.absorption_pure_water_SmithBaker1981(440.0) == pytest.approx(0.0145, abs=1e-12)
    assert ab.absorption_pure_water_PopeFry1997(600.0) == pytest.approx(0.2224, abs=1e-12)
    assert ab.absorption_pure_water_Buiteveld1994(440.0) == pytest.approx(0.0104, abs=1e-12)


def test_interpolation_is_not_shifted_by_half_a_bin():
    # midway between two table points is the mean of the two (pbrt-v3 looked up the wrong bin)
    a = ab.absorption_pure_water_SmithBaker1981([440.0, 445.0, 450.0])
    assert a[1] == pytest.approx(0.5 * (a[0] + a[2]), rel=1e-12)


def test_detritus_cdom_formulas():
    wl = np.array([400.0, 440.0, 550.0, 700.0])
    det = ab.absorption_detritus_Bricaud1998(wl, 2.0)
    np.testing.assert_allclose(det, 0.0124 * 2.0**0.702 * np.exp(-0.011 * (wl - 440)), rtol=1e-14)
    det_code = ab.absorption_detritus_Bricaud1998(wl, 2.0, exponent=ab.DETRITUS_EXPONENT_ORIGINAL_CODE)
    np.testing.assert_allclose(det_code, 0.0124 * 2.0**0.724 * np.exp(-0.011 * (wl - 440)), rtol=1e-14)
    y = ab.absorption_cdom_Bricaud1981(wl, 0.3)
    np.testing.assert_allclose(y, 0.3 * np.exp(-0.014 * (wl - 440)), rtol=1e-14)


def test_phytoplankton_matches_original_code_scaling():
    for chl in (0.1, 1.0, 10.0):
        assert ab.absorption_phytoplankton_Bricaud1995(440.0, chl) == pytest.approx(0.0378 * chl**0.627)
    with pytest.raises(SpectrumRangeError, match="400–700 nm"):
        ab.absorption_phytoplankton_Bricaud1995(380.0, 1.0)


def test_out_of_range_and_negative_inputs():
    with pytest.raises(SpectrumRangeError, match="Pope & Fry 1997 .* covers 380–727.5 nm"):
        ab.absorption_pure_water_PopeFry1997([370.0, 500.0])
    with pytest.raises(ConfigError, match="chl_mg_per_m3.*>= 0"):
        ab.absorption_detritus_Bricaud1998(500.0, -1.0)
    with pytest.raises(ConfigError, match="did you mean 'pope-fry-1997'"):
        ab.absorption_pure_water(500.0, "pope-fry")
