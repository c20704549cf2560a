"""The water's phase function as the preview uses it: component cell tables and wavelength weights.

Any :class:`~rigsim.water.phase.PhaseFunction` is written as
``p(ψ; λ) = Σ_k w_k(λ) p_k(ψ)`` with wavelength-independent components ``p_k`` held
as cell masses on :data:`rigsim.water.phase.DEFAULT_GRID` (the representation the
renderer's phase plugin samples) — the same three cases as
:func:`rigsim.render.phase_plugin.phase_tables`:

* a :class:`~rigsim.water.phase.MixturePhase` of wavelength-independent components:
  its components and weights ``b_k(λ)/b(λ)``;
* a wavelength-independent phase function: one component, weight 1;
* anything else: the function's cell masses at nodes every 10 nm, with linear
  (hat-function) weights in wavelength.

Values (1/sr) are the cell densities ``mass / solid angle``, i.e. exactly the
piecewise-constant function the renderer samples and evaluates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import itj0y0

from rigsim.water.phase import DEFAULT_GRID, LogAngleGrid, MixturePhase, PhaseFunction

__all__ = ["PhaseComponents", "phase_components"]

#: Node spacing for phase functions that depend on wavelength other than as a mixture (nm).
GENERIC_NODE_STEP_NM = 10.0


@dataclass(frozen=True, eq=False)
class PhaseComponents:
    """Cell tables of the components and a weight function (see module docstring).

    Attributes
    ----------
    grid
        The angular grid.
    masses
        (K, n_cells) probability of each cell per component (rows sum to 1).
    weight_fn
        Wavelengths (nm, shape S) → weights of shape S + (K,) (rows sum to 1).
    """

    grid: LogAngleGrid
    masses: np.ndarray
    weight_fn: object

    @property
    def n_components(self) -> int:
        return self.masses.shape[0]

    def weights(self, wavelength_nm) -> np.ndarray:
        """(n_wl, K) weights, clipped ≥ 0 and normalised."""
        wl = np.atleast_1d(np.asarray(wavelength_nm, float))
        w = np.clip(np.nan_to_num(np.asarray(self.weight_fn(wl), float).reshape(wl.size, -1)), 0.0, None)
        s = w.sum(axis=1, keepdims=True)
        return np.where(s > 0, w / np.where(s > 0, s, 1.0), 1.0 / w.shape[1])

    def eval_components(self, cos_psi) -> np.ndarray:
        """Component densities (1/sr), shape ``shape(cos_psi) + (K,)``."""
        idx = self.grid.cell_index(cos_psi)
        dens = self.masses / self.grid.solid_angles[None, :]  # (K, n_cells)
        return np.moveaxis(dens[:, idx], 0, -1)

    def forward_fraction(self, cutoff_rad: float) -> np.ndarray:
        """(K,) probability of scattering by less than ``cutoff_rad`` (cells wholly below it)."""
        return self.masses[:, self._forward_cells(cutoff_rad)].sum(axis=1)

    def _forward_cells(self, cutoff_rad: float) -> np.ndarray:
        upper = self.grid.psi_edges[1:]
        return upper <= cutoff_rad * (1 + 1e-12)

    def saa_transform(self, nu_per_rad: np.ndarray, cutoff_rad: float) -> np.ndarray:
        """Path-averaged Hankel transform of the small-angle part, per component: (K, n_nu).

        ``Q_k(ν) = ∫₀¹ P̂_k(ν t) dt`` with ``P̂_k(ν) = Σ_{cells ψ<cutoff} m_kj J₀(2πνψ_j)``
        (the 2-D Fourier transform of the component's small-angle part treated as a
        density on the plane of angles; ψ_j the cell's log-midpoint), so
        ``∫₀¹ J₀(x t) dt = (1/x) ∫₀ˣ J₀`` (:func:`scipy.special.itj0y0`).
        ``Q_k(0)`` is the forward fraction.
        """
        cells = self._forward_cells(cutoff_rad)
        e = self.grid.psi_edges
        lo, hi = e[:-1][cells], e[1:][cells]
        psi = np.where(lo > 0, np.sqrt(np.maximum(lo, 1e-300) * hi), hi / 2)
        m = self.masses[:, cells]  # (K, J)
        nu = np.asarray(nu_per_rad, float)
        out = np.empty((self.n_components, nu.size))
        chunk = max(1, 2_000_000 // max(psi.size, 1))
        for i0 in range(0, nu.size, chunk):
            x = 2 * np.pi * nu[i0:i0 + chunk, None] * psi[None, :]  # (n, J)
            with np.errstate(divide="ignore", invalid="ignore"):
                g = np.where(x > 1e-8, itj0y0(x)[0] / np.where(x > 1e-8, x, 1.0), 1.0 - x * x / 12)
            out[:, i0:i0 + chunk] = m @ g.T
        return out


_CACHE: dict = {}


def phase_components(phase: PhaseFunction, wavelength_range_nm: tuple[float, float] | None = None,
                     grid: LogAngleGrid = DEFAULT_GRID) -> PhaseComponents:
    """Write a phase function as weighted wavelength-independent components (see module docstring).

    Cached per phase-function object (the same water gives the same tables).
    """
    key = (id(phase), wavelength_range_nm, grid)
    hit = _CACHE.get(key)
    if hit is not None and hit[0] is phase:
        return hit[1]
    out = _phase_components(phase, wavelength_range_nm, grid)
    if len(_CACHE) > 32:
        _CACHE.clear()
    _CACHE[key] = (phase, out)
    return out


def _phase_components(phase, wavelength_range_nm, grid) -> PhaseComponents:
    if isinstance(phase, MixturePhase) and not any(c.wavelength_dependent for c in phase.components):
        masses = np.stack([np.asarray(c.cell_masses(grid), float) for c in phase.components])
        lo, hi = wavelength_range_nm or (-np.inf, np.inf)

        def weight_fn(wl, _p=phase, _lo=lo, _hi=hi):
            return _p.weights(np.clip(wl, _lo, _hi))
    elif not phase.wavelength_dependent:
        masses = np.asarray(phase.cell_masses(grid), float)[None, :]

        def weight_fn(wl):
            return np.ones((np.size(wl), 1))
    else:
        lo, hi = wavelength_range_nm or (360.0, 830.0)
        n = max(2, int(np.ceil((hi - lo) / GENERIC_NODE_STEP_NM)) + 1)
        lam = np.linspace(lo, hi, n)
        masses = np.stack([np.asarray(phase.cell_masses(grid, w), float) for w in lam])
        eye = np.eye(n)

        def weight_fn(wl, _lam=lam, _eye=eye, _lo=lo, _hi=hi):
            w = np.clip(np.asarray(wl, float), _lo, _hi)
            return np.stack([np.interp(w, _lam, _eye[k]) for k in range(len(_lam))], axis=-1)
    masses = np.clip(masses, 0.0, None)
    masses = masses / masses.sum(axis=1, keepdims=True)
    return PhaseComponents(grid, masses, weight_fn)
