"""Metrics on synthetic images with known answers."""

import numpy as np
import pytest
from scipy.special import erf

from rigsim import metrics as M


def test_contrast_known_patches():
    assert M.contrast_michelson(0.8, 0.2) == pytest.approx(0.6)
    assert M.contrast_weber(0.8, 0.2) == pytest.approx(3.0)
    assert M.contrast_weber(0.0, 0.5) == pytest.approx(-1.0)
    np.testing.assert_allclose(M.contrast_michelson([1, 2, 3], [1, 1, 1]), [0, 1 / 3, 0.5])
    # a mean below the black level is noise: no contrast to measure (it read 7.2 from 0.0008 and -0.0006)
    assert np.isnan(M.contrast_michelson(0.0008, -0.0006)) and M.contrast_michelson(0.0, 0.0) == 0.0
    img = np.zeros((20, 20, 3))
    img[5:10, 5:10] = [0.5, 0.3, 0.1]
    img[img.sum(-1) == 0] = [0.1, 0.1, 0.1]
    t = np.zeros((20, 20), bool)
    t[5:10, 5:10] = True
    c = M.contrast_michelson(img[t].mean(0), img[~t].mean(0))
    np.testing.assert_allclose(c, [0.4 / 0.6, 0.2 / 0.4, 0.0], atol=1e-12)
    assert M.luminance(np.array([1.0, 1.0, 1.0])) == pytest.approx(1.0)


def test_patch_snr_poisson():
    rng = np.random.default_rng(0)
    img = rng.poisson(400.0, size=(200, 200)).astype(float)
    snr = M.patch_snr(img, np.ones((200, 200), bool))
    assert snr == pytest.approx(20.0, rel=0.02)
    assert M.patch_snr(np.ones((4, 4)), np.ones((4, 4), bool)) == np.inf


def test_backscatter_share():
    tot = np.full((4, 4, 2), 2.0)
    bs = np.full((4, 4, 2), 0.5)
    assert M.backscatter_share(bs, tot) == pytest.approx(0.25)


# CIEDE2000 test pairs from G. Sharma, W. Wu, E.N. Dalal, "The CIEDE2000 color-difference formula:
# implementation notes, supplementary test data, and mathematical observations", Color Res. Appl.
# 30(1):21-30 (2005), Table 1 (pairs 1, 7, 13, 17, 25, 34).
SHARMA = [
    ((50.0000, 2.6772, -79.7751), (50.0000, 0.0000, -82.7485), 2.0425),
    ((50.0000, 0.0000, 0.0000), (50.0000, -1.0000, 2.0000), 2.3669),
    ((50.0000, 2.4900, -0.0010), (50.0000, -2.4900, 0.0011), 7.2195),
    ((50.0000, 2.5000, 0.0000), (73.0000, 25.0000, -18.0000), 27.1492),
    ((60.2574, -34.0099, 36.2677), (60.4626, -34.1751, 39.4387), 1.2644),
    ((22.7233, 20.0904, -46.6940), (23.0331, 14.9730, -42.5619), 2.0373),
]


def test_delta_e_2000_published_pairs():
    a = np.array([p[0] for p in SHARMA])
    b = np.array([p[1] for p in SHARMA])
    np.testing.assert_allclose(M.delta_e_2000(a, b), [p[2] for p in SHARMA], atol=1e-4)


def test_chart_delta_e_zero_for_identical():
    xyz = np.random.default_rng(1).uniform(0.05, 0.9, (24, 3))
    mean, per = M.chart_delta_e(xyz, xyz)
    assert mean == 0.0 and per.shape == (24,)


def _gaussian_edge(sigma_px, angle_deg=5.0, size=100):
    y, x = np.mgrid[0:size, 0:size].astype(float)
    t = np.tan(np.radians(angle_deg))
    d = (x - size / 2 - (y - size / 2) * t) * np.cos(np.radians(angle_deg))
    return 0.1 + 0.8 * 0.5 * (1 + erf(d / (np.sqrt(2) * sigma_px)))


@pytest.mark.parametrize("sigma", [0.6, 1.0, 2.0])
def test_mtf_of_gaussian_edge(sigma):
    f, m = M.mtf_slanted_edge(_gaussian_edge(sigma))
    exact = np.exp(-2 * np.pi**2 * sigma**2 * f**2)
    sel = f <= 0.5
    np.testing.assert_allclose(m[sel], exact[sel], atol=0.03)
    f50 = np.sqrt(np.log(2) / (2 * np.pi**2 * sigma**2))
    assert M.mtf50(f, m) == pytest.approx(f50, rel=0.05)


def test_mtf_horizontal_edge_and_bad_angle():
    f, m = M.mtf_slanted_edge(_gaussian_edge(1.0).T)
    assert M.mtf50(f, m) == pytest.approx(np.sqrt(np.log(2) / (2 * np.pi**2)), rel=0.05)
    with pytest.raises(ValueError, match="edge angle"):
        M.mtf_slanted_edge(_gaussian_edge(1.0, angle_deg=0.0))


@pytest.mark.parametrize("c,c0,thr", [(0.3, 0.9, 0.02), (1.2, 0.5, 0.02), (0.5, 0.8, 0.05)])
def test_visibility_range_exponential(c, c0, thr):
    d = np.linspace(0.5, 20, 12)
    contrast = c0 * np.exp(-c * d)
    assert M.visibility_range(d, contrast, threshold=thr) == pytest.approx(np.log(c0 / thr) / c, rel=1e-9)


def test_visibility_range_edges():
    d = np.array([1.0, 2.0, 3.0])
    assert M.visibility_range(d, [0.5, 0.4, 0.3]) == np.inf
    r = M.visibility_range(d, [0.01, 0.005, 0.001])
    assert r < 1.0
    # below the threshold first and growing after: nothing to extrapolate back (it was 3.79 m, the
    # rising contrast's crossing, for an edge-lit black disk in Jerlov 3C at 3, 6, 9 m)
    assert np.isnan(M.visibility_range([3.0, 6.0, 9.0], [0.0149, 0.0451, 0.0421]))
    with pytest.raises(ValueError):
        M.visibility_range([2.0, 1.0], [0.5, 0.1])


def test_visibility_range_se_is_the_scatter_of_ranges_from_noisy_contrasts():
    """The first-order standard error against the spread of the ranges of 20 000 sweeps whose contrasts
    carry Gaussian noise of the stated standard errors (3 % and 5 % of each: small enough for first order)."""
    d = np.array([1.0, 2.0, 3.0, 4.5, 6.0])
    c = 0.3 * np.exp(-0.6 * d)  # crosses 2 % at 4.51 m: between 4.5 and 6 m
    se = c * np.array([0.03, 0.03, 0.03, 0.03, 0.05])
    rng = np.random.default_rng(7)
    ranges = np.array([M.visibility_range(d, c + se * rng.standard_normal(d.size)) for _ in range(20000)])
    predicted = M.visibility_range_se(d, c, se)
    assert predicted > 0
    # the sample s.d. of 20 000 has 0.5 % noise; first order is good to a few % at these noise levels
    assert ranges.std() == pytest.approx(predicted, rel=0.05)
    # only the two bracketing contrasts count: noise elsewhere changes nothing
    se2 = se.copy()
    se2[:2] = 1e-1
    assert M.visibility_range_se(d, c, se2) == pytest.approx(predicted, rel=1e-12)


def test_visibility_range_se_is_nan_where_the_range_is_no_crossing_or_an_error_is_missing():
    d = np.array([1.0, 2.0, 3.0])
    assert np.isnan(M.visibility_range_se(d, [0.5, 0.4, 0.3], [0.01] * 3))  # never below: inf range
    # the crossing lies between 1 and 2 m: a missing error at either makes it NaN, at 3 m it does not count
    assert np.isnan(M.visibility_range_se(d, [0.5, 0.01, 0.005], [0.01, np.nan, 0.001]))
    assert np.isnan(M.visibility_range_se(d, [0.5, 0.01, 0.005], [np.nan, 0.001, 0.001]))
    assert M.visibility_range_se(d, [0.5, 0.01, 0.005], [0.0, 0.0, np.nan]) == 0.0


def test_black_disk_range():
    assert M.black_disk_range_ZaneveldPegau2003(0.4) == pytest.approx(12.0)


def test_speck_numbers_count_and_light_share():
    """Two lit particles against a uniform subject and one dark particle hiding part of it: the count
    takes the particles at >= 5 % of the subject's luminance; the net share sums all three; the light
    share only what the lit ones add."""
    from rigsim.metrics.specks import speck_numbers

    lum = np.ones((6, 6))
    part = np.zeros((6, 6))
    ids = np.zeros((6, 6), int)
    part[1, 1], ids[1, 1] = 0.5, 1    # bright speck
    part[2, 2], ids[2, 2] = 0.02, 2   # below the 5 % threshold
    part[4, 4], ids[4, 4] = -0.3, 3   # a dark particle hiding the subject
    total = (lum + part).sum()
    m = speck_numbers(lum + part, part, ids)
    assert m["speck_count"] == 1
    assert m["speck_share"] == pytest.approx((0.5 + 0.02 - 0.3) / total)
    assert m["speck_light_share"] == pytest.approx((0.5 + 0.02) / total)
