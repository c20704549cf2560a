"""Photometric → radiometric conversions: lumens round trip, guide number worked example."""

import numpy as np
import pytest

from rigsim.errors import ConfigError
from rigsim.light import (
    K_M_LM_PER_W,
    LIGHT_WAVELENGTHS_NM,
    axial_intensity_from_lumens,
    axial_luminous_exposure_from_guide_number_ISO2720,
    beam_solid_angle_sr,
    guide_number_from_axial_luminous_exposure_ISO2720,
    light_spectrum,
    luminous_integral,
    photopic_V_CIE1924,
    soft_cone,
    strobe_light,
    video_light,
)


def test_vlambda_peak():
    assert photopic_V_CIE1924([555.0])[0] == pytest.approx(1.0, abs=1e-4)
    assert photopic_V_CIE1924([300.0, 900.0]).tolist() == [0.0, 0.0]


def test_monochromatic_555_gives_683_lm_per_w():
    # a narrow triangle around 555 nm carrying 1 W/sr·nm·nm = 1 W/sr: ~683 cd
    wl = np.array([554.0, 555.0, 556.0])
    assert K_M_LM_PER_W * luminous_integral(wl, [0.0, 1.0, 0.0]) == pytest.approx(683.0, rel=1e-3)


@pytest.mark.parametrize("spectrum", ["daylight-led", "warm-led", "xenon-strobe", "blackbody:4000"])
@pytest.mark.parametrize("angle", [60.0, 100.0, 120.0])
def test_lumens_round_trip(spectrum, angle):
    lumens = 3500.0
    beam = soft_cone(angle)
    light = video_light("v", (0.3, 0, 0), (0, 0, 1), beam, lumens=lumens, spectrum=spectrum)
    flux_lm = K_M_LM_PER_W * beam_solid_angle_sr(beam) * luminous_integral(light.wavelength_nm,
                                                                             light.axial_intensity)
    assert abs(flux_lm - lumens) / lumens < 1e-6


def test_video_light_magnitude_is_plausible():
    # 4000 lm white LED ≈ 12–14 W optical; on-axis a few mW/(sr·nm) per 100 lm
    beam = soft_cone(100.0)
    i = axial_intensity_from_lumens(4000.0, beam_solid_angle_sr(beam), LIGHT_WAVELENGTHS_NM,
                                    light_spectrum("daylight-led"))
    radiant_w = beam_solid_angle_sr(beam) * np.trapezoid(i, LIGHT_WAVELENGTHS_NM)
    assert 10.0 < radiant_w < 16.0   # ≈ 300 lm/W luminous efficacy of radiation for a white LED


def test_guide_number_worked_example():
    # ISO 2720: N²/t = E S / C, C = 250 lx·s. A flash with GN 24 m at ISO 100, subject at 3 m:
    # correct aperture N = 24/3 = 8, so the luminous exposure must be H = C N² / S = 250·64/100 = 160 lx·s,
    # i.e. I_v t = H d² = 160 · 9 = 1440 cd·s.
    assert axial_luminous_exposure_from_guide_number_ISO2720(24.0, 100.0) == pytest.approx(1440.0)
    h_at_3m = axial_luminous_exposure_from_guide_number_ISO2720(24.0) / 3.0 ** 2
    assert 250.0 * (24.0 / 3.0) ** 2 / 100.0 == pytest.approx(h_at_3m)
    # doubling ISO → GN × √2 for the same flash
    q = axial_luminous_exposure_from_guide_number_ISO2720(24.0, 100.0)
    assert guide_number_from_axial_luminous_exposure_ISO2720(q, 200.0) == pytest.approx(24.0 * 2 ** 0.5)


def test_strobe_from_guide_number_carries_the_luminous_exposure():
    beam = soft_cone(100.0)
    lt = strobe_light("s", (0.3, 0, 0), (0, 0, 1), beam, guide_number_m=24.0)
    assert lt.kind == "strobe"
    assert K_M_LM_PER_W * luminous_integral(lt.wavelength_nm, lt.axial_intensity) == pytest.approx(1440.0, rel=1e-9)
    quarter = strobe_light("s", (0.3, 0, 0), (0, 0, 1), beam, guide_number_m=24.0, power_fraction=0.25)
    assert np.asarray(quarter.axial_intensity) == pytest.approx(0.25 * np.asarray(lt.axial_intensity))


def test_strobe_from_flash_energy():
    beam = soft_cone(100.0)
    lt = strobe_light("s", (0.3, 0, 0), (0, 0, 1), beam, flash_energy_J=100.0, luminous_efficacy_lm_s_per_J=30.0)
    q_axis = K_M_LM_PER_W * luminous_integral(lt.wavelength_nm, lt.axial_intensity)
    assert q_axis * beam_solid_angle_sr(beam) == pytest.approx(3000.0, rel=1e-9)   # lm·s total


@pytest.mark.parametrize("kwargs", [dict(flash_energy_J=-5.0), dict(guide_number_m=0.0),
                                    dict(flash_energy_J=10.0, guide_number_m=20.0), dict()])
def test_strobe_bad_power(kwargs):
    with pytest.raises(ConfigError):
        strobe_light("s", (0.3, 0, 0), (0, 0, 1), soft_cone(100.0), **kwargs)


def test_negative_lumens():
    with pytest.raises(ConfigError, match="> 0"):
        video_light("v", (0.3, 0, 0), (0, 0, 1), soft_cone(100.0), lumens=-10.0)
