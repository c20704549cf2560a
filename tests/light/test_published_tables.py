"""Published tables come from one place: colour-science's copies (D65, LED-B2/B5, V(λ), Planck)."""

import numpy as np
import pytest

from rigsim.light.photometry import photopic_V_CIE1924
from rigsim.light.spectra import LIGHT_WAVELENGTHS_NM, light_spectrum, spectrum_d65_CIE

colour = pytest.importorskip("colour")


def test_d65_is_colours_table_and_d_series_tail():
    table = colour.SDS_ILLUMINANTS["D65"]
    wl = np.arange(360.0, 781.0, 5.0)
    rel = spectrum_d65_CIE(wl)
    ref = table[wl]
    assert rel / rel[wl == 560.0] == pytest.approx(ref / ref[wl == 560.0], rel=1e-12)
    # 785–830 nm: the D series at 6504 K, continuous with the table at 780 nm (within 2 %)
    tail = spectrum_d65_CIE(np.array([780.0, 785.0, 830.0]))
    assert np.all(tail > 0) and tail[1] == pytest.approx(tail[0], rel=0.02)
    assert spectrum_d65_CIE(np.array([835.0]))[0] == 0.0


@pytest.mark.parametrize("name,cie", [("daylight-led", "LED-B5"), ("warm-led", "LED-B2")])
def test_led_spectra_are_colours_tables(name, cie):
    sd = colour.SDS_ILLUMINANTS[cie]
    s = light_spectrum(name, sd.wavelengths)
    assert s == pytest.approx(sd.values / sd.values.max(), rel=1e-12)


def test_vlambda_is_colours_table():
    v = colour.colorimetry.SDS_LEFS_PHOTOPIC["CIE 1924 Photopic Standard Observer"]
    assert photopic_V_CIE1924(v.wavelengths) == pytest.approx(v.values, abs=1e-15)
    assert photopic_V_CIE1924(np.array([359.0, 831.0])).tolist() == [0.0, 0.0]


@pytest.mark.parametrize("temperature_K", [1000.0, 3000.0, 5600.0, 20000.0])
def test_blackbody_is_colours_planck_law(temperature_K):
    sd = colour.sd_blackbody(temperature_K, colour.SpectralShape(360, 830, 1))
    s = light_spectrum(f"blackbody:{temperature_K:g}", LIGHT_WAVELENGTHS_NM)
    assert s == pytest.approx(sd.values / sd.values.max(), rel=1e-12)
