"""The one CMF integration (rigsim.colorimetry) against colour-science's tristimulus values."""

import numpy as np
import pytest

from rigsim.colorimetry import OBSERVER, XYZ_from_bands, cmf_band_matrix
from rigsim.errors import ConfigError
from rigsim.scene.reflectances import reflectance_colorchecker_Ohta
from rigsim.spectral_image import xyz_from_spectral

colour = pytest.importorskip("colour")
CMFS = colour.MSDS_CMFS[OBSERVER]


def _red_under_d65(wl):
    """A known spectrum: the ColorChecker 'red' patch under D65 (radiance-like, arbitrary unit)."""
    d65 = colour.SDS_ILLUMINANTS["D65"]
    return reflectance_colorchecker_Ohta(wl)["red"] * np.interp(wl, d65.wavelengths, d65.values)


def test_narrow_bands_equal_colours_integration():
    wl = np.arange(380.0, 781.0, 1.0)
    s = _red_under_d65(wl)
    sd = colour.SpectralDistribution(dict(zip(wl, s)))
    ref = colour.sd_to_XYZ(sd, CMFS, colour.sd_ones(), k=100, method="Integration")  # k given: colour divides by 100
    assert XYZ_from_bands(s, wl, 1.0) == pytest.approx(ref, rel=5e-4)


def test_band_means_give_the_integral_of_the_fine_spectrum():
    fine = np.arange(395.0, 705.0 + 1e-9, 0.5)
    s = _red_under_d65(fine)
    ref = colour.sd_to_XYZ(colour.SpectralDistribution(dict(zip(fine, s))), CMFS, colour.sd_ones(), k=100,
                           method="Integration")
    wl = np.arange(400.0, 701.0, 10.0)
    means = np.array([s[(fine >= c - 5) & (fine <= c + 5)].mean() for c in wl])  # what a band holds
    new = XYZ_from_bands(means, wl, 10.0)
    centre = means @ (np.stack([np.interp(wl, CMFS.wavelengths, CMFS.values[:, k]) for k in range(3)], -1) * 10)
    assert new == pytest.approx(ref, rel=4e-3)
    assert np.abs(new / ref - 1).max() < np.abs(centre / ref - 1).max()   # better than the band-centre rule


def test_white_point_of_d65_matches_colours_astm_e308():
    wl = np.arange(380.0, 781.0, 5.0)
    xyz = XYZ_from_bands(np.ones_like(wl), wl, illuminant=colour.SDS_ILLUMINANTS["D65"][wl])
    ref = colour.sd_to_XYZ(colour.sd_ones(), illuminant=colour.SDS_ILLUMINANTS["D65"]) / 100
    assert xyz[1] == pytest.approx(1.0, abs=1e-12)
    assert xyz == pytest.approx(ref, rel=3e-4)


def test_chart_under_d65_matches_colours_sd_to_XYZ():
    wl = np.arange(380.0, 781.0, 5.0)
    refl = reflectance_colorchecker_Ohta(wl)
    d65 = colour.SDS_ILLUMINANTS["D65"]
    new = XYZ_from_bands(np.array(list(refl.values())), wl, illuminant=d65[wl])
    ref = np.array([colour.sd_to_XYZ(colour.SpectralDistribution(dict(zip(wl, r))), CMFS, d65) / 100
                    for r in refl.values()])
    assert new == pytest.approx(ref, rel=2e-3, abs=1e-4)


def test_matrix_is_the_cmf_for_vanishing_widths_and_zero_outside():
    wl = np.array([380.0, 455.5, 550.0, 612.3, 700.0])
    m = cmf_band_matrix(wl, 0.01) / 0.01
    ref = np.stack([np.interp(wl, CMFS.wavelengths, CMFS.values[:, k]) for k in range(3)], -1)
    assert m == pytest.approx(ref, rel=1e-3, abs=1e-6)  # Sprague vs linear between 1 nm rows
    # a band half outside the CMF table (360–830 nm) gets only the inside half
    half = cmf_band_matrix([360.0], [20.0])[0]
    assert half == pytest.approx(cmf_band_matrix([365.0], [10.0])[0], rel=1e-12)
    assert not cmf_band_matrix(wl, 1.0).flags.writeable


def test_single_and_uneven_bands():
    one = XYZ_from_bands(np.array([2.0]), [550.0], [10.0])
    wl1 = np.arange(545.0, 555.0 + 1e-9, 0.1)
    ref = 2.0 * np.trapezoid(np.stack([np.interp(wl1, CMFS.wavelengths, CMFS.values[:, k])
                                       for k in range(3)], -1), wl1, axis=0)
    assert one == pytest.approx(ref, rel=1e-3)  # Sprague (ours) vs linear (here) between 1 nm rows
    uneven = cmf_band_matrix([450.0, 530.0, 640.0], [20.0, 5.0, 40.0])
    assert uneven.shape == (3, 3) and np.all(uneven[:, 1] > 0)
    assert cmf_band_matrix([400.0, 420.0, 450.0]) == pytest.approx(
        cmf_band_matrix([400.0, 420.0, 450.0], [20.0, 20.0, 30.0]))  # default: the smaller spacing


def test_image_shapes_and_spectral_image_uses_it():
    wl = np.arange(400.0, 701.0, 10.0)
    img = np.random.default_rng(1).random((40, 30, wl.size))
    xyz = XYZ_from_bands(img, wl, 10.0)
    assert xyz.shape == (40, 30, 3)
    assert np.array_equal(xyz_from_spectral(img, wl, np.full(wl.size, 10.0)), xyz)
    assert xyz[3, 4] == pytest.approx(img[3, 4] @ cmf_band_matrix(wl, 10.0))


def test_errors():
    with pytest.raises(ValueError, match="bands"):
        XYZ_from_bands(np.ones(3), [400.0, 410.0], 10.0)
    with pytest.raises(ConfigError, match="widths"):
        cmf_band_matrix([400.0], [0.0])
    with pytest.raises(ConfigError, match="observer"):
        cmf_band_matrix([400.0], [10.0], observer="CIE 1931 2 Degre Standard Observer")
