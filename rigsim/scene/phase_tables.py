"""The water's phase function as every engine uses it: component cell tables and wavelength weights.

Any :class:`~rigsim.water.phase.PhaseFunction` is written as

    p(ψ; λ) = Σ_k w_k(λ) p_k(ψ),

wavelength-independent components ``p_k`` held as cell masses on the angular grid
:data:`rigsim.water.phase.DEFAULT_GRID` and weights ``w_k(λ)`` (rows sum to one) tabulated
every :data:`WEIGHT_STEP_NM` over Mitsuba's 360–830 nm and read by linear interpolation:

* a :class:`~rigsim.water.phase.MixturePhase` of wavelength-independent components (the
  Kopelevich and Jerlov waters): its components and weights ``b_k(λ)/b(λ)``;
* a wavelength-independent phase function (Petzold, HG, Fournier–Forand): one component,
  weight 1;
* anything else: the function's cell masses at nodes every :data:`GENERIC_NODE_STEP_NM`,
  with linear (hat-function) weights in wavelength.

Outside the water's wavelength range the weights are held at the end values (those
wavelengths are never rendered).  Values (1/sr) are the cell densities ``mass / solid
angle``: the piecewise-constant function that the Monte Carlo renderer's phase plugin
(:mod:`rigsim.render.phase_plugin`, which only converts these tables to Dr.Jit alias
tables), the fast engine (:mod:`rigsim.preview`) and the daylight meter
(:mod:`rigsim.daylight.meter`) all evaluate and sample, so that none of them can disagree
about the phase function.

Examples
--------
>>> from rigsim.water import preset
>>> t = phase_tables(preset("coastal").phase, preset("coastal").wavelength_range_nm)
>>> t.n_components, round(float(t.weights_at([550.0]).sum()), 12)
(3, 1.0)
"""

from __future__ import annotations

import functools
import weakref
import dataclasses
from dataclasses import dataclass

import numpy as np

from rigsim.spectrum import MITSUBA_WAVELENGTH_RANGE_NM
from rigsim.water.phase import DEFAULT_GRID, LogAngleGrid, MixturePhase, PhaseFunction

__all__ = ["PhaseTables", "phase_tables", "WEIGHT_STEP_NM", "GENERIC_NODE_STEP_NM"]

#: Spacing of the wavelength table of the component weights (nm).
WEIGHT_STEP_NM = 1.0
#: Node spacing for phase functions that depend on wavelength other than as a mixture (nm).
GENERIC_NODE_STEP_NM = 10.0


@dataclass(frozen=True, eq=False)
class PhaseTables:
    """A phase function as weighted, wavelength-independent cell tables (see module docstring).

    Attributes
    ----------
    grid
        The angular grid.
    masses
        (K, n_cells) probability of each cell for each component (rows sum to 1).
    weight_wavelength_nm
        (M,) uniform wavelength nodes of the weight table (nm).
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

    @property
    def densities(self) -> np.ndarray:
        """(K, n_cells) component densities (1/sr), constant inside each cell."""
        return self.masses / self.grid.solid_angles[None, :]

    def weights_at(self, wavelength_nm) -> np.ndarray:
        """(n_wl, K) weights at the wavelengths (linear in the 1-nm table, ends held)."""
        wl = np.atleast_1d(np.asarray(wavelength_nm, float)).ravel()
        return np.stack([np.interp(wl, self.weight_wavelength_nm, self.weights[:, k])
                         for k in range(self.n_components)], axis=-1)

    def eval_components(self, cos_psi) -> np.ndarray:
        """Component densities (1/sr), shape ``shape(cos_psi) + (K,)``."""
        idx = self.grid.cell_index(cos_psi)
        return np.moveaxis(self.densities[:, idx], 0, -1)

    def eval(self, cos_psi, wavelength_nm) -> np.ndarray:
        """Phase function (1/sr) at ``cos_psi`` and ``wavelength_nm`` (nm), broadcast together."""
        wl = np.asarray(wavelength_nm, float)
        w = self.weights_at(wl).reshape(wl.shape + (self.n_components,))
        return np.sum(self.eval_components(cos_psi) * w, axis=-1)

    def forward_fraction(self, cutoff_rad: float) -> np.ndarray:
        """(K,) probability of scattering by less than ``cutoff_rad`` (cells wholly below it)."""
        return self.masses[:, self.forward_cells(cutoff_rad)].sum(axis=1)

    def rms_angle_rad(self, lo_rad: float, hi_rad: float, wavelength_nm: float) -> float:
        """RMS scattering angle (rad) of the phase function at ``wavelength_nm`` (nm) over the cells below
        ``hi_rad`` that are not below ``lo_rad`` (:meth:`forward_cells`: the mass ``forward_fraction(hi_rad)
        − forward_fraction(lo_rad)``), each at its log-midpoint angle; 0 where they hold no mass."""
        e = self.grid.psi_edges
        cells = self.forward_cells(hi_rad) & ~self.forward_cells(lo_rad)
        mass = self.masses[:, cells].T @ self.weights_at([wavelength_nm])[0]
        if not mass.sum() > 0:
            return 0.0
        mid = np.sqrt(e[:-1][cells] * e[1:][cells])
        return float(np.sqrt(np.sum(mass * mid ** 2) / mass.sum()))

    def without_forward(self, cutoff_rad: float) -> tuple["PhaseTables", np.ndarray]:
        """The tables without the scatterings by less than ``cutoff_rad`` (δ-truncation: Wiscombe 1977): each
        component's :meth:`forward_cells` emptied and the rest renormalised, the weight table scaled by what each
        component keeps (``w_k (1 − F_k)``, renormalised); and the (K,) :meth:`forward_fraction` ``F_k`` removed
        (the scattering coefficient that goes with the new tables is ``b (1 − Σ_k w_k F_k)``)."""
        cone = self.forward_cells(cutoff_rad)
        Fk = self.forward_fraction(cutoff_rad)
        keep = np.maximum(1.0 - Fk, 1e-300)
        w = self.weights * (1.0 - Fk)[None, :]
        return dataclasses.replace(self, masses=np.where(cone[None, :], 0.0, self.masses) / keep[:, None],
                                   weights=w / np.maximum(w.sum(axis=1, keepdims=True), 1e-300),
                                   name=f"{self.name} without < {np.degrees(cutoff_rad):g} deg"), Fk

    def forward_only(self, cutoff_rad: float) -> tuple["PhaseTables", np.ndarray]:
        """The tables of the scatterings by less than ``cutoff_rad`` alone (what :meth:`without_forward` drops):
        each component's :meth:`forward_cells`, renormalised (a component with no mass there keeps its table,
        at weight 0), the weight table scaled by ``F_k`` and renormalised; and the (K,) ``F_k``."""
        cone = self.forward_cells(cutoff_rad)
        Fk = self.forward_fraction(cutoff_rad)
        has = Fk > 0
        masses = np.where(has[:, None], np.where(cone[None, :], self.masses, 0.0) / np.where(has, Fk, 1.0)[:, None],
                          self.masses)
        w = self.weights * Fk[None, :]
        return dataclasses.replace(self, masses=masses, weights=w / np.maximum(w.sum(axis=1, keepdims=True), 1e-300),
                                   name=f"{self.name} below {np.degrees(cutoff_rad):g} deg"), Fk

    def forward_cells(self, cutoff_rad: float) -> np.ndarray:
        """Mask of the cells that lie wholly below the angle ``cutoff_rad``."""
        return self.grid.psi_edges[1:] <= cutoff_rad * (1 + 1e-12)

    def sample_cos(self, wavelength_nm: float, u_component, u_cell, u_position) -> np.ndarray:
        """cos ψ drawn from the tables at one wavelength: component by weight, cell by mass,
        uniform in ``v = 1 − cos ψ`` inside the cell (the renderer's plugin does the same)."""
        w = self.weights_at([wavelength_nm])[0]
        cw = np.cumsum(w)
        cw[-1] = 1.0
        k = np.minimum(np.searchsorted(cw, np.asarray(u_component, float), side="right"), self.n_components - 1)
        cdf = self.cdfs
        uc = np.asarray(u_cell, float)
        cell = np.empty(uc.shape, np.int64)
        for j in range(self.n_components):
            m = k == j
            if np.any(m):
                cell[m] = np.minimum(np.searchsorted(cdf[j], uc[m], side="right") - 1, self.grid.n_cells - 1)
        v0, v1 = self.v_edges[cell], self.v_edges[cell + 1]
        return 1.0 - (v0 + np.asarray(u_position, float) * (v1 - v0))

    @functools.cached_property
    def v_edges(self) -> np.ndarray:
        """Cell edges in ``v = 1 − cos ψ = 2 sin²(ψ/2)`` (0 … 2), which resolves the smallest cells."""
        v = 2.0 * np.sin(np.asarray(self.grid.psi_edges, float) / 2.0) ** 2
        v[0], v[-1] = 0.0, 2.0
        return v

    @functools.cached_property
    def cdfs(self) -> np.ndarray:
        """(K, n_cells + 1) cumulative cell masses of each component."""
        c = np.concatenate([np.zeros((self.n_components, 1)), np.cumsum(self.masses, axis=1)], axis=1)
        c[:, -1] = 1.0
        return c


_TABLES: "weakref.WeakKeyDictionary[PhaseFunction, dict]" = weakref.WeakKeyDictionary()


def _nodes() -> np.ndarray:
    a, b = MITSUBA_WAVELENGTH_RANGE_NM
    return np.linspace(a, b, int(round((b - a) / WEIGHT_STEP_NM)) + 1)


def phase_tables(phase: PhaseFunction, wavelength_range_nm: tuple[float, float] | None = None,
                 grid: LogAngleGrid = DEFAULT_GRID) -> PhaseTables:
    """Write a phase function as weighted wavelength-independent components (see module docstring).

    Parameters
    ----------
    phase
        Any :class:`~rigsim.water.phase.PhaseFunction`.
    wavelength_range_nm
        Where the phase function is defined (the water's range, nm); weights outside it are
        held at the end values.
    grid
        Angular grid.

    Returns
    -------
    PhaseTables
        Kept while ``phase`` lives (the same water gives the same tables).
    """
    key = (None if wavelength_range_nm is None else tuple(float(x) for x in wavelength_range_nm), grid)
    per_phase = _TABLES.get(phase)
    if per_phase is not None and key in per_phase:
        return per_phase[key]
    out = _build(phase, key[0], grid)
    _TABLES.setdefault(phase, {})[key] = out
    return out


def _build(phase, wavelength_range_nm, grid) -> PhaseTables:
    nodes = _nodes()
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
