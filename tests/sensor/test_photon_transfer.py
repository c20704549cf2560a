"""Photon transfer (EMVA 1288): the simulated camera returns its own K, σ_d and SNR_max.

The flat-field stack goes through the full :func:`rigsim.sensor.capture` (develop=None).
Oracle 1 is the ``emva1288`` package (test-only dependency; its ``np.asfarray`` is
shimmed for NumPy 2); oracle 2 is a closed-form mean–variance fit written here.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigsim.sensor import Exposure, Lens, NoiseSwitches, capture, load_sensor
from rigsim.sensor.optics import electrons_per_radiance

from .conftest import BW, WL, flat_image

SHAPE = (256, 256)
T_EXP = 0.01


def _stack(sensor, iso, levels_e, seed0=0):
    """Pairs of green-site frames (DN) at mean green electrons ``levels_e`` (0 = dark)."""
    lens = Lens(f_number=4.0)
    m = electrons_per_radiance(WL, BW, sensor.qe_at(WL), lens=lens, pixel_area_m2=sensor.pixel_area_m2,
                               exposure_time_s=T_EXP)
    e_per_radiance_green = m[:, 1].sum()
    photons_per_radiance = electrons_per_radiance(WL, BW, np.ones((len(WL), 1)), lens=lens,
                                                  pixel_area_m2=sensor.pixel_area_m2,
                                                  exposure_time_s=T_EXP)[:, 0].sum()
    ex = Exposure(T_EXP, iso, lens)
    out = {}
    for i, lev in enumerate(levels_e):
        L = lev / e_per_radiance_green
        frames = []
        for k in range(2):
            cap = capture(flat_image(L, SHAPE), sensor, ex, seed=seed0 + 10 * i + k, develop=None)
            frames.append(cap.raw[0::2, 1::2].astype(np.int64))  # G sites of RGGB
        out[L * photons_per_radiance] = frames
    return out


def _closed_form(stack, sat_fraction=0.7, max_dn=None):
    """K from the slope of σ²_y − σ²_dark vs μ_y − μ_dark; σ_d from the dark pair."""
    dark = stack[0.0]
    mu_d = np.mean(dark)
    var_d = np.var(dark[0] - dark[1]) / 2
    xs, ys = [], []
    for p, (a, b) in stack.items():
        if p == 0:
            continue
        mu = (a.mean() + b.mean()) / 2
        if max_dn is not None and mu - mu_d > sat_fraction * max_dn:
            continue
        xs.append(mu - mu_d)
        ys.append(np.var(a - b) / 2 - var_d)
    xs, ys = np.array(xs), np.array(ys)
    k = (xs @ ys) / (xs @ xs)
    sigma_d = np.sqrt(var_d - 1 / 12) / k
    return k, sigma_d


@pytest.mark.parametrize("iso", [100, 800])
def test_photon_transfer_closed_form(iso):
    s = load_sensor("sony_ilce-7rm2")
    st = s.iso_setting(iso)
    sat = s.saturation_e(iso)
    stack = _stack(s, iso, [0] + list(np.linspace(0.05, 0.65, 8) * sat))
    k, sigma_d = _closed_form(stack)
    assert k == pytest.approx(st.gain_dn_per_e, rel=0.02)
    assert sigma_d == pytest.approx(st.read_noise_e, rel=0.02)


def test_photon_transfer_emva1288_oracle():
    pytest.importorskip("emva1288")
    if not hasattr(np, "asfarray"):  # NumPy 2 removed it; emva1288 1.0.2 still calls it
        np.asfarray = lambda a, dtype=float: np.asarray(a, dtype=dtype)
    from emva1288.process.data import Data1288
    from emva1288.process.results import Results1288
    from emva1288.process.routines import get_int_imgs

    s = load_sensor("sony_ilce-7rm2")
    iso = 100
    st = s.iso_setting(iso)
    sat = s.saturation_e(iso)
    # up to saturation, not beyond: emva1288 1.0.2 takes a trailing run of fully clipped
    # (zero-variance) points for the saturation point
    levels = [0] + list(np.r_[np.linspace(0.04, 0.96, 20), 0.99, 1.0] * sat)
    stack = _stack(s, iso, levels, seed0=1000)
    rows, cols = next(iter(stack.values()))[0].shape
    def temporal_sums(frames):  # as emva1288.process.loader does for temporal data
        d = get_int_imgs(frames)
        return {"sum": np.sum(d["sum"]), "pvar": np.sum(d["pvar"]), "dmean": d["dmean"]}

    temporal = {T_EXP: {p: temporal_sums(frames) for p, frames in stack.items()}}
    p_mid = sorted(stack)[len(stack) // 2]
    spatial = {T_EXP: {0.0: get_int_imgs(stack[0.0]), p_mid: get_int_imgs(stack[p_mid])}}
    data = Data1288({"width": cols, "height": rows, "temporal": temporal, "spatial": spatial})
    res = Results1288(data.data, pixel_area=s.pixel_pitch_um ** 2, loglevel=40)
    assert res.K == pytest.approx(st.gain_dn_per_e, rel=0.02)
    assert res.sigma_d == pytest.approx(st.read_noise_e, rel=0.02)
    # QE at the green channel: R/K = electrons per photon of the (spectrally flat) field
    qe_flat = (s.qe_at(WL)[:, 1] * WL * BW).sum() / (WL * BW).sum()
    assert res.QE / 100 == pytest.approx(qe_flat, rel=0.03)
    # SNR at saturation ≈ √(full well): photon-noise limited; the saturation point is the
    # max-variance point, 1–4 % below the clip level on this grid
    assert res.SNR_max == pytest.approx(np.sqrt(sat), rel=0.025)
    assert res.SNR_max <= np.sqrt(sat)


def test_snr_at_saturation_is_sqrt_full_well():
    s = load_sensor("sony_ilce-7sm2")  # full well 128k e- < ADC limit at ISO 100
    sat = s.saturation_e(100)
    st = _stack(s, 100, [0, 0.97 * sat])
    (a, b) = st[max(st)]
    k = s.iso_setting(100).gain_dn_per_e
    mu_e = ((a.mean() + b.mean()) / 2 - s.black_level_dn) / k
    sigma_e = np.sqrt(np.var(a - b) / 2) / k
    assert mu_e / sigma_e == pytest.approx(np.sqrt(mu_e), rel=0.02)
    assert mu_e / sigma_e >= 0.97 * np.sqrt(sat)


def test_prnu_and_dsnu_are_fixed_pattern():
    s = load_sensor("sony_ilce-7rm2")
    ex = Exposure(T_EXP, 100, Lens(4.0))
    m = electrons_per_radiance(WL, BW, s.qe_at(WL), lens=ex.lens, pixel_area_m2=s.pixel_area_m2,
                               exposure_time_s=T_EXP)
    img = flat_image(20000.0 / m[:, 1].sum(), (128, 128))  # 20 000 e- at green sites
    only_fpn = NoiseSwitches(shot=False, read=False, dark_current=False, prnu=True, dsnu=True)
    a = capture(img, s, ex, seed=1, noise=only_fpn, develop=None).electrons
    b = capture(img, s, ex, seed=2, noise=only_fpn, develop=None).electrons
    c = capture(img, s, ex, seed=1, fpn_seed=7, noise=only_fpn, develop=None).electrons
    np.testing.assert_array_equal(a, b)          # same body, other frame: same pattern
    assert not np.array_equal(a, c)              # other body
    g = a[0::2, 1::2]
    mu = g.mean()
    expected = np.sqrt((s.prnu_percent / 100 * mu) ** 2 + s.dsnu_e ** 2)
    assert g.std() == pytest.approx(expected, rel=0.05)
