"""The spectral phase-function plugin: tables, evaluation, χ² of the sampler, unbiasedness
for every wavelength of a path (hero-wavelength sampling)."""

from __future__ import annotations

import numpy as np
import pytest

from rigsim.render.phase_plugin import DEFENSIVE_FRACTION, make_phase
from rigsim.scene.phase_tables import phase_tables
from rigsim.render.variant import mitsuba
from rigsim.water import preset
from rigsim.water.phase import (
    DEFAULT_GRID,
    HenyeyGreenstein,
    MixturePhase,
    RayleighWater,
)
from tests.stats import chi2_gof

pytestmark = pytest.mark.render
mi, dr = mitsuba()

QUADS = [(420.0, 430.0, 440.0, 450.0), (400.0, 500.0, 600.0, 700.0), (690.0, 450.0, 560.0, 410.0)]


def _v3(v):
    return mi.Vector3f(*[float(x) for x in v])


def _mei(n, lams, wi=(0.2, -0.3, 0.9)):
    mei = dr.zeros(mi.MediumInteraction3f, n)
    w = np.asarray(wi, float) / np.linalg.norm(wi)
    mei.wi = _v3(w)
    mei.sh_frame = mi.Frame3f(mei.wi)
    mei.wavelengths = mi.Spectrum(*[float(x) for x in lams])
    return mei, w


def _sample(ph, lams, n, seed=0):
    rng = np.random.default_rng(seed)
    mei, wi = _mei(n, lams)
    wo, weight, pdf = ph.sample(mi.PhaseFunctionContext(), mei, mi.Float(rng.random(n)),
                                mi.Point2f(rng.random(n), rng.random(n)))
    wo = np.array(wo, float).T
    return wo, np.array(weight, float), np.array(pdf, float), wi


def _smooth_mixture():
    """Rayleigh + HG(0.6) with weights that swing with wavelength (χ²-friendly: no sharp peak)."""
    def weights(wl):
        s = np.clip((np.asarray(wl, float) - 360.0) / 470.0, 0, 1)
        return np.stack([0.9 - 0.8 * s, 0.1 + 0.8 * s], axis=-1)
    return MixturePhase([RayleighWater(), HenyeyGreenstein(0.6)], weights, name="test-mixture")


@pytest.mark.parametrize("name", ["coastal", "jerlov-IB", "clear"])
def test_tables_normalised_and_weight_nodes_exact(name):
    w = preset(name)
    t = phase_tables(w.phase, w.wavelength_range_nm)
    assert np.allclose(t.masses.sum(axis=1), 1.0, atol=1e-12)
    assert np.allclose(t.weights.sum(axis=1), 1.0, atol=1e-12)
    # node j sits at 360 + j nm (no half-bin offset): weights equal the model's at integer nm
    j = np.array([40, 140, 240, 340])
    assert np.allclose(t.weight_wavelength_nm[j], 360.0 + j)
    assert np.allclose(t.weights[j], w.phase.weights(360.0 + j), atol=1e-12)
    mu = np.cos(np.radians([0.5, 5.0, 30.0, 90.5, 150.0]))
    for lam in (412.0, 555.5, 680.0):
        assert np.allclose(t.eval(mu, lam), w.phase.eval(mu, lam), rtol=2e-3)


@pytest.mark.parametrize("lams", QUADS)
def test_eval_matches_model_per_wavelength_and_forward_is_forward(lams):
    w = preset("coastal")
    ph = make_phase(w.phase, w.wavelength_range_nm)
    wo, _, _, wi = _sample(ph, lams, 20000, seed=1)
    mei, _ = _mei(len(wo), lams)
    val, pdf = ph.eval_pdf(mi.PhaseFunctionContext(), mei, mi.Vector3f(*wo.T))
    val = np.array(val, float)
    cos = -(wo @ wi)
    for j, lam in enumerate(lams):
        ref = w.phase.eval(cos, lam)
        r = val[j] / ref
        assert np.median(np.abs(r - 1)) < 1e-4 and np.mean(np.abs(r - 1) < 0.01) > 0.99
    # straight on (wo = −wi: ψ = 0) is the forward peak, back along wi (ψ = π) is small
    n = 1
    mei1, wi1 = _mei(n, lams)
    fwd = np.array(ph.eval_pdf(mi.PhaseFunctionContext(), mei1, _v3(-wi1))[0])
    back = np.array(ph.eval_pdf(mi.PhaseFunctionContext(), mei1, _v3(wi1))[0])
    assert np.all(fwd > 1e3 * back)


@pytest.mark.parametrize("lams", QUADS)
def test_mitsuba_chi2_smooth_spectral_mixture(lams):
    """Mitsuba's own χ² test of the sampler against the plugin's pdf (smooth mixture)."""
    ph = make_phase(_smooth_mixture())

    def sample_functor(sample, *args):
        mei, _ = _mei(dr.width(sample), lams, wi=(0, 0, 1))
        wo, weight, pdf = ph.sample(mi.PhaseFunctionContext(), mei, sample[0], mi.Point2f(sample[1], sample[2]))
        return wo, dr.select(pdf > 0, 1.0, 0.0)

    def pdf_functor(wo, *args):
        mei, _ = _mei(dr.width(wo), lams, wi=(0, 0, 1))
        return ph.eval_pdf(mi.PhaseFunctionContext(), mei, wo)[1]

    chi2 = mi.chi2.ChiSquareTest(domain=mi.chi2.SphericalDomain(), sample_func=sample_functor,
                                 pdf_func=pdf_functor, sample_dim=3, sample_count=400_000, res=61, ires=8)
    assert chi2.run(), chi2.messages


def _expected_cell_probs(ph, lams):
    """Probability per grid cell of the plugin's sampling strategy: the masses its float32
    alias tables realise, mixed by the wavelength-averaged weights, plus the uniform share."""
    t = ph.tables
    m = ph.realised_masses  # (K + 1, n): components, then the uniform one
    assert np.allclose(m[:-1], t.masses, rtol=1e-5, atol=1e-12)  # float32 tables barely move them
    wbar = np.mean([[np.interp(l, t.weight_wavelength_nm, t.weights[:, k]) for k in range(t.n_components)]
                    for l in lams], axis=0)
    return DEFENSIVE_FRACTION * m[-1] + (1 - DEFENSIVE_FRACTION) * (wbar @ m[:-1])


@pytest.mark.parametrize("name", ["coastal", "jerlov-IB"])
@pytest.mark.parametrize("lams", QUADS[:2])
def test_exact_bin_chi2_peaked_water_phase(name, lams):
    """χ² over groups of the log-angle cells (exact expected masses) and over azimuth,
    for the strongly peaked sea-water mixtures that Mitsuba's numeric χ² cannot integrate."""
    w = preset(name)
    ph = make_phase(w.phase, w.wavelength_range_nm)
    n = 400_000
    wo, weight, pdf, wi = _sample(ph, lams, n, seed=11)
    assert np.all(np.isfinite(wo)) and np.all(np.isfinite(weight)) and np.all(pdf > 0)
    h = np.linalg.norm(wo + wi, axis=1) / 2  # sin(ψ/2), accurate at small ψ
    psi = 2 * np.arcsin(np.clip(h, 0, 1))
    cell = DEFAULT_GRID.cell_index(np.cos(psi))
    small = psi < 0.05  # cos loses the small angles: index those by ψ directly
    dlog = np.log(np.pi / 2 / DEFAULT_GRID.psi_min_rad) / DEFAULT_GRID.n_log
    cell[small] = np.where(psi[small] < DEFAULT_GRID.psi_min_rad, 0,
                           1 + np.floor(np.log(np.maximum(psi[small], 1e-300) / DEFAULT_GRID.psi_min_rad) / dlog))
    p_cell = _expected_cell_probs(ph, lams)
    group = 15
    edges_cells = np.arange(0, DEFAULT_GRID.n_cells + group, group)
    edges_cells[-1] = DEFAULT_GRID.n_cells
    edges_cells = np.unique(np.minimum(edges_cells, DEFAULT_GRID.n_cells))
    expected = np.add.reduceat(p_cell, edges_cells[:-1])
    stat, p = chi2_gof(cell.astype(float) + 0.5, edges_cells.astype(float), expected / expected.sum())
    assert p > 1e-3, (stat, p)
    # azimuth about the propagation direction is uniform
    f = mi.Frame3f(_v3(-wi))
    s, t = np.array(f.s, float).ravel(), np.array(f.t, float).ravel()
    phi = np.arctan2(wo @ t, wo @ s)
    stat, p = chi2_gof(phi, np.linspace(-np.pi, np.pi, 37), np.full(36, 1 / 36))
    assert p > 1e-3, (stat, p)


@pytest.mark.parametrize("name", ["coastal", "jerlov-IB"])
def test_hero_sampling_unbiased_for_every_wavelength(name):
    """E[weight_i] = 1, E[weight_i cos ψ] = g(λ_i), E[weight_i 1{ψ>90°}] = b_b/b(λ_i) for all
    four wavelengths of a path, though directions are drawn from their average mixture."""
    w = preset(name)
    ph = make_phase(w.phase, w.wavelength_range_nm)
    lams = (400.0, 500.0, 600.0, 700.0)
    n = 1_000_000
    wo, weight, _, wi = _sample(ph, lams, n, seed=3)
    cos = -(wo @ wi)
    for j, lam in enumerate(lams):
        for fn, exact in ((np.ones_like(cos), 1.0),
                          (cos, float(w.phase.mean_cosine(lam))),
                          ((cos < 0).astype(float), float(w.phase.backscatter_fraction(lam)))):
            x = weight[j] * fn
            se = x.std() / np.sqrt(n)
            assert abs(x.mean() - exact) < 4 * se + 2e-4, (lam, x.mean(), exact, se)
    # the wavelengths really differ (else the test would be vacuous)
    r = w.phase.backscatter_fraction(400.0) / w.phase.backscatter_fraction(700.0)
    assert r > 1.3 or r < 1 / 1.3


def test_registered_plugin_loads_by_name():
    ph = mi.load_dict({"type": "rigsim_water_phase", "water": "coastal"})
    assert "kopelevich" in str(ph)
    mei, _ = _mei(1, QUADS[0])
    val, pdf = ph.eval_pdf(mi.PhaseFunctionContext(), mei, mi.Vector3f(0, 0, -1))
    assert np.all(np.array(val) > 0) and float(np.array(pdf)[0]) > 0
