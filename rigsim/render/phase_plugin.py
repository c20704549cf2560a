"""A Mitsuba phase-function plugin for wavelength-dependent sea-water phase functions.

Sea water scatters light with a mixture ``p(ψ; λ) = Σ_k w_k(λ) p_k(ψ)`` of
wavelength-independent shapes (pure water, small and large particles) whose
weights ``w_k(λ) = b_k(λ)/b(λ)`` change with wavelength.  Mitsuba's spectral
variants carry four wavelengths per path (hero-wavelength sampling), so the
plugin

* **evaluates** the phase function per wavelength of the path:
  ``value_i = Σ_k w_k(λ_i) p_k(cos ψ)``;
* **samples** the mixture averaged over the path's wavelengths,
  ``q(ψ) = ε/4π + (1 − ε) Σ_k w̄_k p̃_k(ψ)`` with ``w̄_k = mean_i w_k(λ_i)``
  (component by ``sample1``, cell by inverse CDF, ``cos ψ`` uniform in the cell,
  azimuth uniform), and returns ``weight_i = value_i / q`` — an unbiased estimator for
  *every* wavelength of the path, not only the hero one.  A small defensive
  uniform share ``ε`` = 1e-3 keeps ``q > 0`` wherever any ``p_k > 0``, whatever float32
  does to the tables.

Each component is held on the :class:`~rigsim.water.phase.LogAngleGrid` as cell
densities (the exact cell averages, 1/sr) and a float32 CDF; the sampling density
``p̃_k`` of a cell is computed from the *float32* CDF differences, so the reported
pdf is exactly the density the sampler realises.  The weights are tabulated on a
1-nm grid over Mitsuba's 360–830 nm (node ``j`` at ``360 + j`` nm, linear
interpolation, ends held).  Angles are handled through ``v = 1 − cos ψ =
2 sin²(ψ/2)``, which float32 resolves down to the first cell (ψ < 1e-4 rad), unlike
``cos ψ``.

Direction convention (Mitsuba): ``mei.wi`` points *away* from the interaction
(back along the incoming ray), so the cosine between the propagation directions is
``cos ψ = −dot(wi, wo)`` and ``1 − cos ψ = |wo + wi|² / 2``.

Components that are themselves wavelength-dependent but not a
:class:`~rigsim.water.phase.MixturePhase` are tabulated at nodes every 10 nm and
interpolated linearly in wavelength (hat-function weights), the same machinery.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigsim.render.variant import mitsuba
from rigsim.spectrum import MITSUBA_WAVELENGTH_RANGE_NM
from rigsim.water.phase import DEFAULT_GRID, LogAngleGrid, MixturePhase, PhaseFunction

__all__ = ["PhaseTables", "phase_tables", "WaterPhaseFunction", "make_phase", "PLUGIN_NAME",
           "DEFENSIVE_FRACTION", "WEIGHT_STEP_NM"]

mi, dr = mitsuba()

#: Name under which the plugin is registered with Mitsuba.
PLUGIN_NAME = "rigsim_water_phase"
#: Share of directions drawn uniformly over the sphere (keeps the pdf positive).
DEFENSIVE_FRACTION = 1e-3
#: Spacing of the wavelength table of the component weights (nm).
WEIGHT_STEP_NM = 1.0
#: Node spacing for phase functions that depend on wavelength in another way (nm).
GENERIC_NODE_STEP_NM = 10.0


@dataclass(frozen=True, eq=False)
class PhaseTables:
    """A phase function as the plugin holds it (numpy, float64).

    Attributes
    ----------
    grid
        The angular grid.
    masses
        (K, n_cells) probability of each cell for each component (rows sum to 1).
    weight_wavelength_nm
        (M,) wavelength nodes of the weight table (nm), uniform.
    weights
        (M, K) component weights at the nodes (rows sum to 1).
    name
        Name of the phase function.
    """

    grid: LogAngleGrid
    masses: np.ndarray
    weight_wavelength_nm: np.ndarray
    weights: np.ndarray
    name: str

    @property
    def n_components(self) -> int:
        return self.masses.shape[0]

    def eval(self, cos_psi, wavelength_nm) -> np.ndarray:
        """Reference value (1/sr) of the tabulated function, numpy, for tests."""
        idx = self.grid.cell_index(cos_psi)
        dens = self.masses[:, idx] / self.grid.solid_angles[idx]  # (K, N)
        w = np.stack([np.interp(wavelength_nm, self.weight_wavelength_nm, self.weights[:, k])
                      for k in range(self.n_components)], axis=-1)
        return np.einsum("...k,k...->...", w, dens)


def _weight_nodes(lo: float, hi: float) -> np.ndarray:
    a, b = MITSUBA_WAVELENGTH_RANGE_NM
    n = int(round((b - a) / WEIGHT_STEP_NM)) + 1
    return np.linspace(a, b, n)


def phase_tables(phase: PhaseFunction, wavelength_range_nm: tuple[float, float] | None = None,
                 grid: LogAngleGrid = DEFAULT_GRID) -> PhaseTables:
    """Tabulate a rigsim phase function for the plugin.

    Parameters
    ----------
    phase
        Any :class:`~rigsim.water.phase.PhaseFunction`.
    wavelength_range_nm
        Where the phase function is defined (the water's range); weights outside it
        are held at the end values (those wavelengths are never rendered).
    grid
        Angular grid (the default grid of :mod:`rigsim.water.phase`).
    """
    nodes = _weight_nodes(*MITSUBA_WAVELENGTH_RANGE_NM)
    lo, hi = wavelength_range_nm or MITSUBA_WAVELENGTH_RANGE_NM
    lo, hi = max(lo, nodes[0]), min(hi, nodes[-1])
    wl_eval = np.clip(nodes, lo, hi)
    if isinstance(phase, MixturePhase) and not any(c.wavelength_dependent for c in phase.components):
        masses = np.stack([np.asarray(c.cell_masses(grid), float) for c in phase.components])
        weights = np.asarray(phase.weights(wl_eval), float).reshape(len(nodes), -1)
    elif not phase.wavelength_dependent:
        masses = np.asarray(phase.cell_masses(grid), float)[None, :]
        weights = np.ones((len(nodes), 1))
    else:
        n_nodes = max(2, int(np.ceil((hi - lo) / GENERIC_NODE_STEP_NM)) + 1)
        lam = np.linspace(lo, hi, n_nodes)
        masses = np.stack([np.asarray(phase.cell_masses(grid, w), float) for w in lam])
        weights = np.stack([np.interp(wl_eval, lam, np.eye(n_nodes)[k]) for k in range(n_nodes)], axis=-1)
    masses = np.clip(masses, 0.0, None)
    masses = masses / masses.sum(axis=1, keepdims=True)
    weights = np.clip(np.nan_to_num(weights, nan=0.0), 0.0, None)
    s = weights.sum(axis=1, keepdims=True)
    weights = np.where(s > 0, weights / np.where(s > 0, s, 1.0), 1.0 / weights.shape[1])
    return PhaseTables(grid=grid, masses=masses, weight_wavelength_nm=nodes, weights=weights,
                       name=getattr(phase, "name", "phase"))


class WaterPhaseFunction(mi.PhaseFunction):
    """Mitsuba phase function sampling a wavelength-dependent mixture (see module docstring).

    Create it with :func:`make_phase`, or through Mitsuba as
    ``{"type": "rigsim_water_phase", "water": "coastal"}`` (a water preset name).
    """

    def __init__(self, props=None):
        if props is None:
            props = mi.Properties(PLUGIN_NAME)
        mi.PhaseFunction.__init__(self, props)
        self.m_flags = mi.PhaseFunctionFlags.Anisotropic
        self.tables: PhaseTables | None = None
        if "water" in props:
            from rigsim.water import preset

            w = preset(str(props["water"]))
            self.set_tables(phase_tables(w.phase, w.wavelength_range_nm))

    # -- set-up ---------------------------------------------------------------------
    def set_tables(self, t: PhaseTables) -> "WaterPhaseFunction":
        """Load the tables into Dr.Jit arrays."""
        g = t.grid
        n = g.n_cells
        psi = g.psi_edges.astype(np.float64)
        v_edges = 2.0 * np.sin(psi / 2.0) ** 2
        v_edges[0], v_edges[-1] = 0.0, 2.0
        omega = 2.0 * np.pi * np.diff(v_edges)
        dens_true = t.masses / omega[None, :]
        cdf = np.concatenate([np.zeros((t.n_components, 1)), np.cumsum(t.masses, axis=1)], axis=1)
        cdf32 = cdf.astype(np.float32)
        cdf32[:, -1] = 1.0
        cdf32[:, 0] = 0.0
        cdf32 = np.maximum.accumulate(cdf32, axis=1)
        dens_sampled = np.diff(cdf32.astype(np.float64), axis=1) / omega[None, :]

        self.tables = t
        self.K = t.n_components
        self.n = n
        self.M = len(t.weight_wavelength_nm)
        self.wl0 = float(t.weight_wavelength_nm[0])
        self.wl_step = float(t.weight_wavelength_nm[1] - t.weight_wavelength_nm[0])
        self.psi_min = float(g.psi_min_rad)
        self.n_log = int(g.n_log)
        self.dlog = float(np.log(np.pi / 2 / g.psi_min_rad) / g.n_log)
        self.dback = float((np.pi / 2) / g.n_back)
        self.v_edges = mi.Float(v_edges.astype(np.float32))
        self.dens_true = mi.Float(dens_true.astype(np.float32).ravel())
        self.dens_sampled = mi.Float(dens_sampled.astype(np.float32).ravel())
        self.cdf = mi.Float(cdf32.ravel())
        self.weight_table = mi.Float(t.weights.astype(np.float32).ravel())  # [m*K + k]
        self.eps = DEFENSIVE_FRACTION
        return self

    # -- helpers (pure Dr.Jit: traced symbolically inside Mitsuba's loops) ------------
    def _weights(self, wavelengths):
        """w[k][j]: weight of component k at the path's wavelength j; and w̄[k]."""
        K = self.K
        if K == 1:
            one = mi.Float(1.0)
            return [[one] * 4], [one]
        w = [[None] * 4 for _ in range(K)]
        for j in range(4):
            x = dr.clip((wavelengths[j] - self.wl0) / self.wl_step, 0.0, float(self.M - 1))
            i0 = mi.UInt32(dr.minimum(dr.floor(x), float(self.M - 2)))
            t = x - mi.Float(i0)
            for k in range(K):
                a = dr.gather(mi.Float, self.weight_table, i0 * K + k)
                b = dr.gather(mi.Float, self.weight_table, (i0 + 1) * K + k)
                w[k][j] = dr.fma(t, b - a, a)
        wbar = [(w[k][0] + w[k][1] + w[k][2] + w[k][3]) * 0.25 for k in range(K)]
        return w, wbar

    def _cell_of(self, psi, v):
        """Cell index of scattering angle ψ (with v = 1 − cos ψ for the edge correction)."""
        i_log = 1.0 + dr.floor(dr.log(dr.maximum(psi, 1e-30) / self.psi_min) / self.dlog)
        i_back = 1.0 + self.n_log + dr.floor((psi - dr.pi / 2) / self.dback)
        fi = dr.select(psi < self.psi_min, 0.0, dr.select(psi < dr.pi / 2, i_log, i_back))
        idx = mi.UInt32(dr.clip(fi, 0.0, float(self.n - 1)))
        lo = dr.gather(mi.Float, self.v_edges, idx)
        idx = dr.select((v < lo) & (idx > 0), idx - 1, idx)
        hi = dr.gather(mi.Float, self.v_edges, idx + 1)
        idx = dr.select((v >= hi) & (idx < self.n - 1), idx + 1, idx)
        return idx

    def _value_pdf(self, idx, w, wbar):
        val = [mi.Float(0.0)] * 4
        pdf = mi.Float(0.0)
        for k in range(self.K):
            d_true = dr.gather(mi.Float, self.dens_true, k * self.n + idx)
            d_samp = dr.gather(mi.Float, self.dens_sampled, k * self.n + idx)
            for j in range(4):
                val[j] = dr.fma(w[k][j], d_true, val[j])
            pdf = dr.fma(wbar[k], d_samp, pdf)
        pdf = dr.fma(1.0 - self.eps, pdf, self.eps / (4.0 * dr.pi))
        return mi.Spectrum(val[0], val[1], val[2], val[3]), pdf

    # -- Mitsuba interface ----------------------------------------------------------
    def eval_pdf(self, ctx, mei, wo, active=True):
        h = dr.minimum(dr.norm(wo + mei.wi) * 0.5, 1.0)  # sin(ψ/2)
        psi = 2.0 * dr.safe_asin(h)
        v = 2.0 * h * h
        w, wbar = self._weights(mei.wavelengths)
        val, pdf = self._value_pdf(self._cell_of(psi, v), w, wbar)
        return val, pdf

    def sample(self, ctx, mei, sample1, sample2, active=True):
        w, wbar = self._weights(mei.wavelengths)
        K, n = self.K, self.n
        uniform = sample1 < self.eps
        u1 = dr.clip((sample1 - self.eps) / (1.0 - self.eps), 0.0, 1.0)
        # component from the wavelength-averaged weights
        k = mi.UInt32(0)
        acc = mi.Float(0.0)
        for c in range(K - 1):
            acc = acc + wbar[c]
            k = dr.select(u1 >= acc, mi.UInt32(c + 1), k)
        base = k * (n + 1)
        u = sample2.x
        i1 = dr.binary_search(1, n, lambda i: dr.gather(mi.Float, self.cdf, base + i) <= u)
        cell = mi.UInt32(dr.clip(mi.Int32(i1) - 1, 0, n - 1))
        c0 = dr.gather(mi.Float, self.cdf, base + cell)
        c1 = dr.gather(mi.Float, self.cdf, base + cell + 1)
        width = c1 - c0
        frac = dr.clip(dr.select(width > 0.0, (u - c0) / width, 0.5), 0.0, 1.0)
        va = dr.gather(mi.Float, self.v_edges, cell)
        vb = dr.gather(mi.Float, self.v_edges, cell + 1)
        v_tab = dr.fma(frac, vb - va, va)
        v_uni = 2.0 * u
        v = dr.select(uniform, v_uni, v_tab)
        sin_half = dr.sqrt(dr.clip(0.5 * v, 0.0, 1.0))
        psi = 2.0 * dr.safe_asin(sin_half)
        cell = dr.select(uniform, self._cell_of(psi, v), cell)
        sin_psi = dr.safe_sqrt(v * (2.0 - v))
        cos_psi = 1.0 - v
        sp, cp = dr.sincos(2.0 * dr.pi * sample2.y)
        frame = mi.Frame3f(-mei.wi)
        wo = frame.to_world(mi.Vector3f(sin_psi * cp, sin_psi * sp, cos_psi))
        val, pdf = self._value_pdf(cell, w, wbar)
        weight = dr.select(pdf > 0.0, val / pdf, 0.0)
        return wo, weight, pdf

    def traverse(self, callback):
        pass

    def to_string(self):
        name = self.tables.name if self.tables is not None else "(no tables)"
        return f"WaterPhaseFunction[{name}, components={getattr(self, 'K', 0)}]"


def make_phase(phase: PhaseFunction, wavelength_range_nm=None) -> WaterPhaseFunction:
    """A plugin instance for a rigsim phase function."""
    return WaterPhaseFunction().set_tables(phase_tables(phase, wavelength_range_nm))


mi.register_phase(PLUGIN_NAME, lambda props: WaterPhaseFunction(props))
