"""The one phase-function decomposition: normalised, reproduces the water's phase function, and its
sampler follows its own cell masses (χ²), as the renderer's plugin and the daylight meter use it."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from rigsim.scene.phase_tables import phase_tables
from rigsim.water import preset
from rigsim.water.phase import HenyeyGreenstein


@pytest.mark.parametrize("name", ["coastal", "jerlov-IB", "clear"])
def test_tables_are_normalised_and_reproduce_the_phase_function(name):
    w = preset(name)
    t = phase_tables(w.phase, w.wavelength_range_nm)
    np.testing.assert_allclose(t.masses.sum(axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(t.weights.sum(axis=1), 1.0, atol=1e-12)
    mu = np.cos(np.radians([0.05, 1.0, 10.0, 60.0, 120.0, 175.0]))
    for lam in (412.0, 555.5, 680.0):  # cell averages against point values: the cells' curvature, < 0.3 %
        np.testing.assert_allclose(t.eval(mu, lam), w.phase.eval(mu, lam), rtol=3e-3)
    # mean cosine from the tables against the model's (cell midpoints: to 0.1 %)
    g_model = float(w.phase.mean_cosine(550.0))
    mu_mid = 0.5 * (t.grid.mu_edges[:-1] + t.grid.mu_edges[1:])
    g_tab = float((t.weights_at([550.0])[0] @ t.masses) @ mu_mid)
    assert g_tab == pytest.approx(g_model, rel=1e-3)


@pytest.mark.parametrize("name, lam", [("coastal", 450.0), ("jerlov-7C", 600.0)])
def test_sampler_follows_the_cell_masses_chi2(name, lam):
    w = preset(name)
    t = phase_tables(w.phase, w.wavelength_range_nm)
    rng = np.random.default_rng(7)
    n = 200_000
    mu = t.sample_cos(lam, rng.random(n), rng.random(n), rng.random(n))
    p = t.weights_at([lam])[0] @ t.masses
    # bins of ~equal probability (cells grouped), expected counts ≥ 100
    edges = np.searchsorted(np.cumsum(p), np.linspace(0, 1, 61)[1:-1])
    groups = np.concatenate([[0], np.unique(edges), [t.grid.n_cells]])
    counts = np.add.reduceat(np.bincount(t.grid.cell_index(mu), minlength=t.grid.n_cells), groups[:-1])
    expect = np.add.reduceat(p, groups[:-1]) * n
    keep = expect > 0
    res = stats.chisquare(counts[keep], expect[keep] * counts[keep].sum() / expect[keep].sum())
    assert res.pvalue > 1e-3, res
    # inside a cell, cos ψ is uniform: the first moment of the sample matches the cells'
    mu_mid = 0.5 * (t.grid.mu_edges[:-1] + t.grid.mu_edges[1:])
    assert mu.mean() == pytest.approx(p @ mu_mid, abs=4 * mu.std() / np.sqrt(n))


def test_one_wavelength_independent_function_is_one_component():
    t = phase_tables(HenyeyGreenstein(0.8))
    assert t.n_components == 1 and np.all(t.weights == 1.0)
    assert phase_tables(HenyeyGreenstein(0.8)) is not t  # another object, its own tables


def test_rms_angle_between_two_angles_is_the_phase_functions():
    """Henyey–Greenstein g = 0.8 between 1° and 30°: the RMS angle of the tables' cells against the
    quadrature of the exact phase function over the same cells' span (their log-midpoints: within 1 %)."""
    from scipy import integrate

    g = 0.8
    t = phase_tables(HenyeyGreenstein(g))
    lo, hi = np.radians(1.0), np.radians(30.0)
    e = t.grid.psi_edges
    cells = t.forward_cells(hi) & ~t.forward_cells(lo)
    a, b = e[:-1][cells][0], e[1:][cells][-1]  # the cells' span
    hg = lambda psi: (1 - g * g) / (1 + g * g - 2 * g * np.cos(psi)) ** 1.5 * np.sin(psi)  # noqa: E731
    m2 = integrate.quad(lambda psi: psi ** 2 * hg(psi), a, b, limit=200)[0] / integrate.quad(hg, a, b, limit=200)[0]
    assert t.rms_angle_rad(lo, hi, 550.0) == pytest.approx(np.sqrt(m2), rel=0.01)
    assert t.rms_angle_rad(hi, hi, 550.0) == 0.0  # no cells between
