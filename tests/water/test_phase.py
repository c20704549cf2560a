"""Phase functions: normalisation, mean cosine, backscatter fraction, exact samplers (χ²)."""

import numpy as np
import pytest

from rigsim.water import preset
from rigsim.water.phase import (
    DEFAULT_GRID,
    FournierForand,
    HenyeyGreenstein,
    MixturePhase,
    RayleighWater,
    TabulatedPhase,
    kopelevich_large_particle,
    kopelevich_small_particle,
    petzold_average_particle,
    phase_FournierForand1999,
)
from tests.stats import chi2_gof

ALL = {
    "hg0.0": lambda: HenyeyGreenstein(0.0),
    "hg0.5": lambda: HenyeyGreenstein(0.5),
    "hg0.95": lambda: HenyeyGreenstein(0.95),
    "hg-0.3": lambda: HenyeyGreenstein(-0.3),
    "rayleigh": RayleighWater,
    "petzold": petzold_average_particle,
    "kop-small": kopelevich_small_particle,
    "kop-large": kopelevich_large_particle,
    "ff0.0183": lambda: FournierForand.from_backscatter_fraction(0.0183),
    "ff0.05": lambda: FournierForand.from_backscatter_fraction(0.05),
    "kopelevich-coastal": lambda: preset("coastal").phase,
    "jerlov-II": lambda: preset("jerlov-II").phase,
}


def _integral(p, wl):
    """2π ∫ p(ψ) sin ψ dψ by an independent quadrature (fine log grid in ψ + trapezoid)."""
    psi = np.concatenate([np.linspace(0, 1e-6, 50)[:-1], np.geomspace(1e-6, np.pi, 400_000)])
    v = p.eval(np.cos(psi), wl)
    return np.trapezoid(2 * np.pi * v * np.sin(psi), psi)


@pytest.mark.parametrize("name", ALL)
@pytest.mark.parametrize("wl", [400.0, 550.0, 700.0])
def test_integrates_to_one(name, wl):
    assert _integral(ALL[name](), wl) == pytest.approx(1.0, abs=1e-3)


@pytest.mark.parametrize("g", [-0.3, 0.0, 0.5, 0.95])
def test_hg_mean_cosine_and_backscatter(g):
    p = HenyeyGreenstein(g)
    assert p.mean_cosine() == g
    # cell representation used by the renderer has the same mean cosine
    mid = 0.5 * (DEFAULT_GRID.mu_edges[:-1] + DEFAULT_GRID.mu_edges[1:])
    assert p.cell_masses() @ mid == pytest.approx(g, abs=2e-4)
    # closed form b_b/b = (1-g)/(2g) ((1+g)/sqrt(1+g^2) - 1)
    expect = 0.5 if g == 0 else (1 - g) / (2 * g) * ((1 + g) / np.sqrt(1 + g * g) - 1)
    assert p.backscatter_fraction() == pytest.approx(expect, rel=1e-9)
    assert p.cell_masses()[DEFAULT_GRID.backward].sum() == pytest.approx(expect, rel=1e-9)


def test_rayleigh_water_moments():
    p = RayleighWater()
    assert p.mean_cosine() == 0.0 and p.backscatter_fraction() == 0.5
    mid = 0.5 * (DEFAULT_GRID.mu_edges[:-1] + DEFAULT_GRID.mu_edges[1:])
    assert abs(p.cell_masses() @ mid) < 1e-5  # cell representation, not exact
    # the form 1 + 0.835 cos^2: ratio forward/side
    assert p.eval(1.0) / p.eval(0.0) == pytest.approx(1.835)


def test_petzold_average_backscatter_fraction():
    # Mobley et al. (1993): b_b/b = 0.0183 for the Petzold average-particle phase function.
    # Our log-log interpolation of the 55 tabulated angles gives 0.01825; tolerance 1 %.
    assert petzold_average_particle().backscatter_fraction() == pytest.approx(0.0183, rel=0.01)


def test_fournier_forand_backscatter_by_definition():
    for B in (0.005, 0.0183, 0.05, 0.1):
        p = FournierForand.from_backscatter_fraction(B)
        assert p.backscatter_fraction() == pytest.approx(B, rel=2e-3)
    # Mobley et al. (2002): n = 1.10, mu = 3.5835 gives the Petzold value 0.0183
    p = FournierForand.from_backscatter_fraction(0.0183)
    assert p.mu_slope == pytest.approx(3.5835, abs=2e-3)


def test_fournier_forand_formula_matches_its_cell_average():
    p = FournierForand(1.10, 3.5835)
    for deg in (1.0, 10.0, 90.0, 170.0):
        psi = np.radians(deg)
        assert p.eval(np.cos(psi)) == pytest.approx(phase_FournierForand1999(psi, 1.10, 3.5835), rel=0.02)


def test_forward_is_forward():
    # pbrt-v3 swapped forward and backward in direct lighting; cos ψ = +1 is forward here.
    for name in ("petzold", "kop-large", "kopelevich-coastal", "hg0.5"):
        p = ALL[name]()
        assert p.eval(0.999, 550.0) > 20 * p.eval(-0.999, 550.0)


def test_kopelevich_mixture_weights_follow_b_components():
    w = preset("coastal")
    p = w.phase
    wl = np.array([400.0, 550.0, 700.0])
    comps = w._b_components(wl)
    np.testing.assert_allclose(p.weights(wl), comps / comps.sum(-1, keepdims=True))
    # phase depends on wavelength: more forward-peaked in the red (large particles ~ λ^-0.3)
    g = p.mean_cosine(wl)
    assert g[2] > g[1] > g[0]
    # eval is the weighted sum of the components
    mu = np.array([0.99, 0.5, -0.5])
    direct = sum(comps[1, k] / comps[1].sum() * c.eval(mu) for k, c in enumerate(p.components))
    np.testing.assert_allclose(p.eval(mu, 550.0), direct, rtol=1e-12)


def _chi2_edges():
    # bins in ψ: log-spaced through the forward peak, uniform behind; expressed in μ ascending
    psi = np.concatenate([[0.0], np.geomspace(1e-3, np.pi / 2, 60), np.linspace(np.pi / 2, np.pi, 31)[1:]])
    mu = np.cos(psi)[::-1].copy()
    mu[0], mu[-1] = -1.0, 1.0
    return mu


def _expected(p, edges, wl):
    # independent of the sampler: integrate eval over each bin numerically
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        plo, phi = np.arccos(hi), np.arccos(lo)
        psi = np.geomspace(max(plo, 1e-9), phi, 4001) if plo < 1e-6 else np.linspace(plo, phi, 4001)
        v = 2 * np.pi * p.eval(np.cos(psi), wl) * np.sin(psi)
        out.append(np.trapezoid(v, psi))
    out = np.array(out)
    return out / out.sum()


@pytest.mark.parametrize("name", ALL)
def test_sampler_chi2(name):
    p = ALL[name]()
    rng = np.random.default_rng(1234)
    edges = _chi2_edges()
    for wl in ((450.0, 650.0) if p.wavelength_dependent else (550.0,)):
        mu = p.sample(rng.random(200_000), wl)
        assert np.all(np.isfinite(mu)) and np.all(np.abs(mu) <= 1)
        _, pval = chi2_gof(mu, edges, _expected(p, edges, wl))
        assert pval > 1e-3, f"{name} at {wl} nm: p = {pval:.2e}"


def test_sampler_chi2_detects_a_wrong_sampler():
    # the test has power: HG(0.5) samples checked against HG(0.55) must fail
    rng = np.random.default_rng(7)
    edges = _chi2_edges()
    mu = HenyeyGreenstein(0.5).sample(rng.random(200_000))
    _, pval = chi2_gof(mu, edges, _expected(HenyeyGreenstein(0.55), edges, 550.0))
    assert pval < 1e-6


def test_mixture_sampler_per_sample_wavelengths():
    p = preset("coastal").phase
    rng = np.random.default_rng(3)
    wl = np.where(rng.random(100_000) < 0.5, 400.0, 700.0)
    mu = p.sample(rng.random(wl.size), wl)
    edges = _chi2_edges()
    for w in (400.0, 700.0):
        _, pval = chi2_gof(mu[wl == w], edges, _expected(p, edges, w))
        assert pval > 1e-3


def test_no_nan_from_flat_cdf_segments():
    # cells with zero mass (flat CDF) must never produce NaN directions (a pbrt-v3 defect)
    m = np.zeros(DEFAULT_GRID.n_cells)
    m[10:20] = 1.0
    m[-5:] = 2.0
    p = TabulatedPhase(m)
    u = np.concatenate([np.linspace(0, 1, 10001), [np.nextafter(1.0, 0.0)]])
    mu = p.sample(u)
    assert np.all(np.isfinite(mu))
    idx = DEFAULT_GRID.cell_index(mu)
    assert np.all(m[idx] > 0)


def test_mixture_with_zero_weight_component():
    p = MixturePhase([HenyeyGreenstein(0.9), RayleighWater()], lambda wl: np.stack(
        [np.ones_like(wl), np.zeros_like(wl)], -1), name="t")
    mu = p.sample(np.linspace(0, 1, 1001))
    assert np.all(np.isfinite(mu))
    assert p.eval(0.3) == pytest.approx(HenyeyGreenstein(0.9).eval(0.3))
