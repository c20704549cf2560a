"""Named light spectra: coverage of 360–830 nm, non-negativity, documented edges, errors."""

import numpy as np
import pytest

from rigsim.errors import ConfigError
from rigsim.light.spectra import LIGHT_WAVELENGTHS_NM, light_spectrum, spectrum_names

NAMED = ["xenon-strobe", "xenon-vivitar283", "daylight-led", "warm-led", "daylight-d65",
         "blackbody:3000", "blackbody:5600"]


@pytest.mark.parametrize("name", NAMED)
def test_spectra_cover_mitsuba_range_and_are_non_negative(name):
    wl = LIGHT_WAVELENGTHS_NM
    assert wl[0] == 360.0 and wl[-1] == 830.0
    s = light_spectrum(name, wl)
    assert s.shape == wl.shape
    assert np.all(np.isfinite(s)) and np.all(s >= 0)
    assert s.max() == pytest.approx(1.0)
    visible = (wl >= 400) & (wl <= 700)
    assert np.all(s[visible] > 0), "every light must emit across the rendered bands"


def test_xenon_edges_are_as_documented():
    s = light_spectrum("xenon-strobe", np.array([380.0, 399.0, 400.0, 700.0, 750.0, 830.0]))
    assert s[0] == 0 and s[1] == 0 and s[2] > 0          # UV cut below 400 nm
    assert s[4] == s[3] and s[5] == s[3]                # 700 nm value held


def test_led_ccts_are_daylight_and_warm():
    import colour

    def cct(name):
        sd = colour.SpectralDistribution(dict(zip(LIGHT_WAVELENGTHS_NM, light_spectrum(name))))
        xyz = colour.sd_to_XYZ(sd)
        return colour.uv_to_CCT(colour.UCS_to_uv(colour.XYZ_to_UCS(xyz)), method="Ohno 2013")[0]

    assert 5600 <= cct("daylight-led") <= 6700
    assert 2800 <= cct("warm-led") <= 3200
    assert cct("daylight-d65") == pytest.approx(6504, abs=30)


def test_blackbody_peak_follows_wien():
    wl = np.arange(360.0, 831.0, 0.5)
    s = light_spectrum("blackbody:5000", wl)
    assert wl[np.argmax(s)] == pytest.approx(2.897771955e6 / 5000, abs=1.0)


def test_unknown_spectrum_suggests_names():
    with pytest.raises(ConfigError) as e:
        light_spectrum("xenon-strob")
    assert "xenon-strobe" in str(e.value) and "\n" not in str(e.value)
    assert "blackbody:T" in spectrum_names()


def test_bad_blackbody_temperature():
    with pytest.raises(ConfigError, match="500–100000"):
        light_spectrum("blackbody:20")
    with pytest.raises(ConfigError, match="temperature"):
        light_spectrum("blackbody:hot")


def test_user_csv_spectrum_edge_held(tmp_path):
    p = tmp_path / "my_led.csv"
    p.write_text("# source: test\n# units: relative\nwavelength_nm,relative\n390,0.5\n550,1.0\n710,0.25\n")
    s = light_spectrum("my_led.csv", np.array([360.0, 390.0, 550.0, 710.0, 830.0]), base_dir=tmp_path)
    assert s.tolist() == pytest.approx([0.5, 0.5, 1.0, 0.25, 0.25])


def test_user_csv_spectrum_must_cover_visible(tmp_path):
    p = tmp_path / "short.csv"
    p.write_text("wavelength_nm,relative\n450,1\n650,1\n")
    with pytest.raises(ConfigError, match="400–700"):
        light_spectrum(str(p))
    with pytest.raises(ConfigError, match="not found"):
        light_spectrum("nowhere.csv", base_dir=tmp_path)
