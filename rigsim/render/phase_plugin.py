"""A Mitsuba phase-function plugin for wavelength-dependent sea-water phase functions.

Sea water scatters light with a mixture ``p(ψ; λ) = Σ_k w_k(λ) p_k(ψ)`` of
wavelength-independent shapes (pure water, small and large particles) whose
weights ``w_k(λ) = b_k(λ)/b(λ)`` change with wavelength.  Mitsuba's spectral
variants carry four wavelengths per path (hero-wavelength sampling), so the
plugin

* **evaluates** the phase function per wavelength of the path:
  ``value_i = Σ_k w_k(λ_i) p_k(cos ψ)``;
* **samples** the mixture averaged over the path's wavelengths,
  ``q(ψ) = ε/4π + (1 − ε) Σ_k w̄_k p_k(ψ)`` with ``w̄_k = mean_i w_k(λ_i)``
  (component by ``sample1``, cell by the component's alias table — an exact
  discrete inverse of its cell masses in O(1) —, ``cos ψ`` uniform in the cell,
  azimuth uniform), and returns ``weight_i = value_i / q`` — an unbiased estimator
  for *every* wavelength of the path, not only the hero one.  A small defensive
  uniform share ``ε`` = 1e-3 keeps ``q > 0`` wherever any ``p_k > 0``.

The tables come from :func:`rigsim.scene.phase_tables.phase_tables` (the one
decomposition, shared with the fast engine and the daylight meter); this module only
converts them.  Each component is held on the :class:`~rigsim.water.phase.LogAngleGrid`
as cell densities (the exact cell averages, 1/sr) and a Walker alias table.  The densities
the plugin uses for both the value and the pdf are the masses its float32 alias
table *realises* (computed in float64; they differ from the model's by < 1e-5
relative), so value, pdf and sampler agree exactly and no cell the model gives
mass can have zero sampling probability.  The weights are tabulated on a 1-nm
grid over Mitsuba's 360–830 nm (node ``j`` at ``360 + j`` nm, ends held),
resampled linearly to 0.1 nm and read at the nearest node (error ≤ 0.05 nm × the
slope, ~1e-5; no offset).  Angles are handled through ``v = 1 − cos ψ =
2 sin²(ψ/2)``, which float32 resolves down to the first cell (ψ < 1e-4 rad),
unlike ``cos ψ``.  Tables are packed so that each lookup is one packet gather.

Direction convention (Mitsuba): ``mei.wi`` points *away* from the interaction
(back along the incoming ray), so the cosine between the propagation directions is
``cos ψ = −dot(wi, wo)`` and ``1 − cos ψ = |wo + wi|² / 2``; sampled directions are
built in ``mei.sh_frame`` (= ``Frame3f(wi)``, set by Mitsuba's media) with local
z = −cos ψ.

The integrator (:mod:`rigsim.render.integrators`) reads the same tables through the public
methods :meth:`WaterPhaseFunction.component_weights`, :meth:`~WaterPhaseFunction.cell_of`
and :attr:`~WaterPhaseFunction.cell_densities`.
"""

from __future__ import annotations

import numpy as np

from rigsim.render.variant import mitsuba
from rigsim.scene.phase_tables import PhaseTables, phase_tables
from rigsim.water.phase import PhaseFunction

__all__ = [
    "DEFENSIVE_FRACTION",
    "PLUGIN_NAME",
    "WaterPhaseFunction",
    "make_phase",
]

mi, dr = mitsuba()

#: Name under which the plugin is registered with Mitsuba.
PLUGIN_NAME = "rigsim_water_phase"
#: Share of directions drawn uniformly over the sphere (keeps the pdf positive).
DEFENSIVE_FRACTION = 1e-3
#: Spacing of the table the plugin reads the weights from (nearest node), nm.
WEIGHT_FINE_STEP_NM = 0.1


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
    def set_tables(self, t: PhaseTables) -> WaterPhaseFunction:
        """Load :class:`~rigsim.scene.phase_tables.PhaseTables` into Dr.Jit arrays (alias tables,
        realised cell densities, weights)."""
        g = t.grid
        n = g.n_cells
        psi = g.psi_edges.astype(np.float64)
        v_edges = 2.0 * np.sin(psi / 2.0) ** 2
        v_edges[0], v_edges[-1] = 0.0, 2.0
        omega = 2.0 * np.pi * np.diff(v_edges)
        # components 0..K-1 from the tables, component K: uniform over the sphere (defensive)
        masses = np.vstack([t.masses, (omega / (4.0 * np.pi))[None, :]])
        probs, aliases, realised = zip(*(_alias_table(m) for m in masses))
        dens = np.stack(realised) / omega[None, :]  # 1/sr: value == sampling density, per component

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
        # Packed layouts, so that one packet gather fetches what a lookup needs:
        #   v_pairs[2 cell + (0, 1)]          = cell edges in v = 1 − cos ψ
        #   dens[P cell + k], k = 0..K        = density of component k (K: uniform), P = 2^⌈log2(K+1)⌉
        #   alias[2 (k n + j) + (0, 1)]       = (probability, alias cell) of component k
        #   weights[Q m + (0..K-2, K-1..)]    = first K−1 weights at nodes m and m+1
        self.v_pairs = mi.Float(np.stack([v_edges[:-1], v_edges[1:]], axis=1).astype(np.float32).ravel())
        self.P = _packet(self.K + 1)
        dens_p = np.zeros((n, self.P), np.float32)
        dens_p[:, :self.K + 1] = dens.T
        self.dens = mi.Float(dens_p.ravel())
        alias = np.stack([np.concatenate(probs).astype(np.float32),
                          np.concatenate(aliases).astype(np.float32)], axis=1)
        self.alias = mi.Float(alias.ravel())
        self.Kw = max(self.K - 1, 0)
        if self.Kw:
            # resampled (linearly, exact at the 1-nm nodes) to WEIGHT_FINE_STEP_NM and read at
            # the nearest node: |error| ≤ step/2 · |dw/dλ| (~1e-5), no systematic offset
            n_fine = int(round((t.weight_wavelength_nm[-1] - t.weight_wavelength_nm[0]) / WEIGHT_FINE_STEP_NM)) + 1
            lam = np.linspace(t.weight_wavelength_nm[0], t.weight_wavelength_nm[-1], n_fine)
            wk = np.stack([np.interp(lam, t.weight_wavelength_nm, t.weights[:, k]) for k in range(self.Kw)], axis=1)
            self.Q = _packet(self.Kw)
            wq = np.zeros((n_fine, self.Q), np.float32)
            wq[:, :self.Kw] = wk
            self.weight_table = mi.Float(wq.ravel())
            self.M_fine = n_fine
            self.fine_step = float(lam[1] - lam[0])
        self.eps = DEFENSIVE_FRACTION
        self.realised_masses = np.stack(realised)
        self._omega = omega
        return self

    # -- the tables as the integrator reads them ----------------------------------------
    @property
    def n_components(self) -> int:
        """K, the number of wavelength-independent components."""
        return self.K

    @property
    def cell_edges_rad(self) -> np.ndarray:
        """ψ edges (rad) of the cells, 0 … π (float64)."""
        psi = np.asarray(self.tables.grid.psi_edges, np.float64).copy()
        psi[0], psi[-1] = 0.0, np.pi
        return psi

    @property
    def cell_densities(self) -> np.ndarray:
        """(K, cells) density per steradian of each component in each cell, as sampled (float64)."""
        return np.asarray(self.realised_masses, np.float64)[:self.K] / self._omega[None, :]

    def component_weights(self, wavelengths):
        """``(w, w̄)``: ``w[k][j]`` the weight of component k at the path's wavelength j, ``w̄[k]``
        their mean over the path's four wavelengths (Dr.Jit)."""
        return self._weights(wavelengths)

    def cell_of(self, psi):
        """Cell index (Dr.Jit UInt32) of scattering angles ``psi`` (rad)."""
        return self._cell_of(psi)

    # -- helpers (pure Dr.Jit: traced symbolically inside Mitsuba's loops) ------------
    def _weights(self, wavelengths):
        """w[k][j]: weight of component k at the path's wavelength j; and w̄[k] (their mean)."""
        K, Kw = self.K, self.Kw
        if K == 1:
            one = mi.Float(1.0)
            return [[one] * 4], [one]
        w = [[None] * 4 for _ in range(K)]
        for j in range(4):
            x = dr.clip((wavelengths[j] - self.wl0) * (1.0 / self.fine_step) + 0.5, 0.0, float(self.M_fine - 1))
            row = _gather_row(self.weight_table, mi.UInt32(x), self.Q, Kw)
            rest = mi.Float(1.0)
            for k in range(Kw):
                w[k][j] = row[k]
                rest = rest - row[k]
            w[K - 1][j] = dr.maximum(rest, 0.0)
        wbar = [(w[k][0] + w[k][1] + w[k][2] + w[k][3]) * 0.25 for k in range(K)]
        return w, wbar

    def _cell_of(self, psi):
        """Cell index of the scattering angle ψ (analytic)."""
        i_log = 1.0 + dr.floor(dr.log(dr.maximum(psi, 1e-30) * (1.0 / self.psi_min)) * (1.0 / self.dlog))
        i_back = 1.0 + self.n_log + dr.floor((psi - dr.pi / 2) * (1.0 / self.dback))
        fi = dr.select(psi < self.psi_min, 0.0, dr.select(psi < dr.pi / 2, i_log, i_back))
        return mi.UInt32(dr.clip(fi, 0.0, float(self.n - 1)))

    def _value_pdf(self, idx, w, wbar):
        row = _gather_row(self.dens, idx, self.P, self.K + 1)
        val = [mi.Float(0.0)] * 4
        pdf = mi.Float(0.0)
        for k in range(self.K):
            d = row[k]
            for j in range(4):
                val[j] = dr.fma(w[k][j], d, val[j])
            pdf = dr.fma(wbar[k], d, pdf)
        pdf = dr.fma(1.0 - self.eps, pdf, self.eps * row[self.K])
        return mi.Spectrum(val[0], val[1], val[2], val[3]), pdf

    # -- Mitsuba interface ----------------------------------------------------------
    def eval_pdf(self, ctx, mei, wo, active=True):
        h = dr.minimum(dr.norm(wo + mei.wi) * 0.5, 1.0)  # sin(ψ/2): exact at small ψ
        psi = 2.0 * dr.safe_asin(h)
        w, wbar = self._weights(mei.wavelengths)
        return self._value_pdf(self._cell_of(psi), w, wbar)

    def sample(self, ctx, mei, sample1, sample2, active=True):
        w, wbar = self._weights(mei.wavelengths)
        K, n = self.K, self.n
        # component: uniform (defensive) with probability ε, else by the wavelength-averaged weights
        k = mi.UInt32(K)
        u1 = (sample1 - self.eps) * (1.0 / (1.0 - self.eps))
        acc = mi.Float(0.0)
        for c in range(K):
            acc = acc + wbar[c]
            k = dr.select((u1 < acc) & (k == K) & (sample1 >= self.eps), mi.UInt32(c), k)
        k = dr.select((sample1 >= self.eps) & (k == K), mi.UInt32(K - 1), k)
        # cell by the alias method, position uniform in v = 1 − cos ψ inside it
        x = sample2.x * n
        j = mi.UInt32(dr.minimum(dr.floor(x), float(n - 1)))
        f = dr.clip(x - mi.Float(j), 0.0, 1.0)
        pa = dr.gather(mi.Vector2f, self.alias, k * n + j)
        prob = pa[0]
        take = f < prob
        cell = dr.select(take, j, mi.UInt32(pa[1]))
        frac = dr.select(take, f / dr.maximum(prob, 1e-30), (f - prob) / dr.maximum(1.0 - prob, 1e-30))
        frac = dr.clip(frac, 0.0, 1.0)
        vab = dr.gather(mi.Vector2f, self.v_pairs, cell)
        v = dr.fma(frac, vab[1] - vab[0], vab[0])
        sin_psi = dr.safe_sqrt(v * (2.0 - v))
        cos_psi = 1.0 - v
        sp, cp = dr.sincos(2.0 * dr.pi * sample2.y)
        # mei.sh_frame = Frame3f(wi) (Mitsuba's medium interactions): local −z is the propagation
        wo = mei.to_world(mi.Vector3f(sin_psi * cp, sin_psi * sp, -cos_psi))
        val, pdf = self._value_pdf(cell, w, wbar)
        weight = dr.select(pdf > 0.0, val / pdf, 0.0)
        return wo, weight, pdf

    def traverse(self, callback):
        pass

    def to_string(self):
        name = self.tables.name if self.tables is not None else "(no tables)"
        return f"WaterPhaseFunction[{name}, components={getattr(self, 'K', 0)}]"


def _packet(n: int) -> int:
    """Row width for packed tables: n rounded up to 2, 4 or 8 (wider rows: n)."""
    for p in (1, 2, 4, 8):
        if n <= p:
            return p
    return n


def _gather_row(table, row, width: int, n: int) -> list:
    """The first ``n`` entries of row ``row`` of a table with rows of ``width`` floats."""
    if width == 1:
        return [dr.gather(mi.Float, table, row)]
    if width in (2, 4):
        v = dr.gather(mi.Vector2f if width == 2 else mi.Vector4f, table, row)
        return [v[i] for i in range(n)]
    return [dr.gather(mi.Float, table, row * width + i) for i in range(n)]


def _alias_table(masses: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Walker/Vose alias table of cell masses: (prob float32, alias, realised masses).

    The realised masses are what the float32 table actually samples (computed in
    float64); the plugin reports those as its densities, so value, pdf and sampler agree.
    """
    m = np.asarray(masses, float)
    n = m.size
    scaled = m / m.sum() * n
    prob = np.ones(n)
    alias = np.arange(n)
    small = [i for i in range(n) if scaled[i] < 1.0]
    large = [i for i in range(n) if scaled[i] >= 1.0]
    while small and large:
        s_, l_ = small.pop(), large.pop()
        prob[s_] = scaled[s_]
        alias[s_] = l_
        scaled[l_] = scaled[l_] + scaled[s_] - 1.0
        (small if scaled[l_] < 1.0 else large).append(l_)
    for i in small + large:
        prob[i] = 1.0
    p32 = prob.astype(np.float32).astype(float)
    realised = p32.copy()
    np.add.at(realised, alias, 1.0 - p32)
    return p32.astype(np.float32), alias, realised / n


def make_phase(phase: PhaseFunction, wavelength_range_nm=None) -> WaterPhaseFunction:
    """A plugin instance for a rigsim phase function (its :func:`~rigsim.scene.phase_tables.phase_tables`)."""
    return WaterPhaseFunction().set_tables(phase_tables(phase, wavelength_range_nm))


mi.register_phase(PLUGIN_NAME, lambda props: WaterPhaseFunction(props))
