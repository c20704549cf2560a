"""Phase functions of sea water: normalised, sampled exactly, wavelength-dependent where needed.

Every phase function ``p(ψ; λ)`` here is in 1/sr and integrates to one over the
sphere, ``2π ∫ p(ψ) sin ψ dψ = 1``.  Each offers

* ``eval(cos_psi, wavelength_nm)`` — value in 1/sr,
* ``sample(u, wavelength_nm)`` — ``cos ψ`` drawn with density ``pdf`` (azimuth is
  uniform and left to the caller),
* ``pdf(cos_psi, wavelength_nm)`` — the sampling density per solid angle (equal to
  ``eval`` for every class here: all samplers are exact),
* ``mean_cosine(wavelength_nm)`` and ``backscatter_fraction(wavelength_nm)``,
* ``cell_masses(grid)`` — probability of each cell of a :class:`LogAngleGrid`, the
  representation the renderer's Mitsuba plugin uses.

Peaked, tabulated phase functions are represented on a grid that is logarithmic
in the scattering angle ψ (1e-4 rad … π/2) and uniform in ψ over the back
hemisphere; inside a cell the density per solid angle is constant (the exact cell
average of the continuous function), so the inverse-CDF sampler follows the
forward peak and is exact for the density it reports.

References
----------
.. [Mo94] C.D. Mobley, *Light and Water: Radiative Transfer in Natural Waters*,
   Academic Press (1994), §3.8 (Kopelevich model), Table 3.10 (Petzold).
.. [Ko83] O.V. Kopelevich, "Small-parameter model of optical properties of sea
   water", in *Ocean Optics* vol. 1 (A.S. Monin, ed.), Nauka (1983).
.. [Mo93] C.D. Mobley et al., "Comparison of numerical models for computing
   underwater light fields", Appl. Opt. 32(36):7484–7504 (1993), Table 2.
.. [FF99] G.R. Fournier, M. Jonasz, "Computer-based underwater imaging analysis",
   Proc. SPIE 3761 (1999); C.D. Mobley, L.K. Sundman, E. Boss, "Phase function
   effects on oceanic light fields", Appl. Opt. 41(6):1035–1050 (2002).
.. [HG41] L.G. Henyey, J.L. Greenstein, Astrophys. J. 93:70–83 (1941).
.. [Mo74] A. Morel, "Optical properties of pure water and pure sea water", in
   *Optical Aspects of Oceanography* (Jerlov & Steemann Nielsen, eds.), 1974.
"""

from __future__ import annotations

import functools
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import PchipInterpolator
from scipy.optimize import brentq

from rigsim.data import load_table, read_csv_table
from rigsim.errors import ConfigError

__all__ = [
    "LogAngleGrid",
    "DEFAULT_GRID",
    "PhaseFunction",
    "HenyeyGreenstein",
    "RayleighWater",
    "TabulatedPhase",
    "MixturePhase",
    "FournierForand",
    "phase_FournierForand1999",
    "petzold_average_particle",
    "kopelevich_small_particle",
    "kopelevich_large_particle",
    "tabulated_from_csv",
    "loglog_interpolant",
]

_FOUR_PI = 4.0 * np.pi


# --------------------------------------------------------------------------------------
# The angular grid
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class LogAngleGrid:
    """Cells in scattering angle ψ: ``[0, ψ_min)``, ``n_log`` log-spaced cells up to π/2,
    then ``n_back`` equal cells up to π.  The cell index of an angle is analytic.

    Attributes
    ----------
    psi_min_rad
        Upper edge of the first cell (rad).
    n_log, n_back
        Number of log-spaced forward cells and of uniform backward cells.
    """

    psi_min_rad: float = 1e-4
    n_log: int = 1200
    n_back: int = 180

    @functools.cached_property
    def psi_edges(self) -> np.ndarray:
        """Cell edges in ψ (rad), ascending from 0 to π; π/2 is an edge."""
        fwd = np.geomspace(self.psi_min_rad, np.pi / 2, self.n_log + 1)
        back = np.linspace(np.pi / 2, np.pi, self.n_back + 1)[1:]
        return np.concatenate([[0.0], fwd, back])

    @functools.cached_property
    def mu_edges(self) -> np.ndarray:
        """Cell edges in cos ψ, descending from 1 to −1."""
        mu = np.cos(self.psi_edges)
        mu[0], mu[-1] = 1.0, -1.0
        mu[1 + self.n_log] = 0.0
        return mu

    @property
    def n_cells(self) -> int:
        return 1 + self.n_log + self.n_back

    @functools.cached_property
    def solid_angles(self) -> np.ndarray:
        """Solid angle of each cell (sr)."""
        return 2.0 * np.pi * (self.mu_edges[:-1] - self.mu_edges[1:])

    @functools.cached_property
    def backward(self) -> np.ndarray:
        """Mask of cells with ψ ≥ π/2."""
        idx = np.arange(self.n_cells)
        return idx >= 1 + self.n_log

    def cell_index(self, cos_psi) -> np.ndarray:
        """Index of the cell holding each ``cos ψ`` (analytic; clamps to the valid range)."""
        psi = np.arccos(np.clip(np.asarray(cos_psi, float), -1.0, 1.0))
        dlog = np.log(np.pi / 2 / self.psi_min_rad) / self.n_log
        with np.errstate(divide="ignore"):
            i_log = 1 + np.floor(np.log(np.maximum(psi, 1e-300) / self.psi_min_rad) / dlog)
        i_back = 1 + self.n_log + np.floor((psi - np.pi / 2) / (np.pi / 2 / self.n_back))
        idx = np.where(psi < self.psi_min_rad, 0, np.where(psi < np.pi / 2, i_log, i_back))
        idx = np.clip(idx, 0, self.n_cells - 1).astype(np.int64)
        # Correct round-off at edges so that mu_edges[i] >= mu > mu_edges[i+1].
        mu = np.cos(psi)
        idx = np.where((mu > self.mu_edges[idx]) & (idx > 0), idx - 1, idx)
        idx = np.where((mu <= self.mu_edges[np.minimum(idx + 1, self.n_cells)]) & (idx < self.n_cells - 1),
                       idx + 1, idx)
        return idx

    def integrate(self, fn: Callable[[np.ndarray], np.ndarray], order: int = 8) -> np.ndarray:
        """Mass per cell of a function of ψ: ``2π ∫_cell fn(ψ) sin ψ dψ`` (Gauss–Legendre).

        The first cell is integrated in ln ψ from 1e-12 rad so that integrable
        forward singularities (power laws) are handled.
        """
        x, w = np.polynomial.legendre.leggauss(order)
        a, b = self.psi_edges[1:-1], self.psi_edges[2:]
        psi = 0.5 * (b - a)[:, None] * x[None, :] + 0.5 * (a + b)[:, None]
        vals = fn(psi) * np.sin(psi)
        rest = 2.0 * np.pi * 0.5 * (b - a) * (vals @ w)
        la, lb = np.log(1e-12), np.log(self.psi_min_rad)
        t = 0.5 * (lb - la) * x + 0.5 * (la + lb)
        psi0 = np.exp(t)
        first = 2.0 * np.pi * 0.5 * (lb - la) * np.sum(w * fn(psi0) * np.sin(psi0) * psi0)
        return np.concatenate([[first], rest])


DEFAULT_GRID = LogAngleGrid()


# --------------------------------------------------------------------------------------
# Base class
# --------------------------------------------------------------------------------------
class PhaseFunction(ABC):
    """A normalised phase function p(ψ; λ) in 1/sr (see module docstring)."""

    #: Whether the function changes with wavelength.
    wavelength_dependent: bool = False
    #: Short name for reports and metadata.
    name: str = "phase"

    @abstractmethod
    def eval(self, cos_psi, wavelength_nm=550.0) -> np.ndarray:
        """Value p(ψ; λ) in 1/sr at ``cos ψ`` (broadcast against ``wavelength_nm``)."""

    @abstractmethod
    def sample(self, u, wavelength_nm=550.0) -> np.ndarray:
        """Draw ``cos ψ`` from uniform numbers ``u`` in [0, 1) with density :meth:`pdf`."""

    def pdf(self, cos_psi, wavelength_nm=550.0) -> np.ndarray:
        """Sampling density per solid angle (1/sr); equals :meth:`eval` (exact samplers)."""
        return self.eval(cos_psi, wavelength_nm)

    @abstractmethod
    def cell_masses(self, grid: LogAngleGrid = DEFAULT_GRID, wavelength_nm=550.0) -> np.ndarray:
        """Probability mass of each grid cell (sums to 1)."""

    def mean_cosine(self, wavelength_nm=550.0) -> np.ndarray:
        """Asymmetry parameter g = ⟨cos ψ⟩."""
        wl = np.atleast_1d(np.asarray(wavelength_nm, float))
        g = DEFAULT_GRID
        mid = 0.5 * (g.mu_edges[:-1] + g.mu_edges[1:])
        out = np.array([self.cell_masses(g, w) @ mid for w in wl])
        return out if np.ndim(wavelength_nm) else out[0]

    def backscatter_fraction(self, wavelength_nm=550.0) -> np.ndarray:
        """b_b/b: probability of scattering by more than 90°."""
        wl = np.atleast_1d(np.asarray(wavelength_nm, float))
        g = DEFAULT_GRID
        out = np.array([self.cell_masses(g, w)[g.backward].sum() for w in wl])
        return out if np.ndim(wavelength_nm) else out[0]

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name}>"


def _check_u(u) -> np.ndarray:
    return np.clip(np.asarray(u, float), 0.0, np.nextafter(1.0, 0.0))


# --------------------------------------------------------------------------------------
# Analytic phase functions
# --------------------------------------------------------------------------------------
class HenyeyGreenstein(PhaseFunction):
    """Henyey–Greenstein phase function [HG41] with asymmetry ``g`` in (−1, 1).

    ``p(ψ) = (1 − g²) / (4π (1 + g² − 2g cos ψ)^{3/2})``
    """

    def __init__(self, g: float):
        if not -1.0 < float(g) < 1.0:
            raise ConfigError(f"HG asymmetry g must be in (-1, 1), got {g}", field="phase", allowed="-1 < g < 1")
        self.g = float(g)
        self.name = f"hg:{self.g:g}"

    def eval(self, cos_psi, wavelength_nm=550.0):
        mu = np.asarray(cos_psi, float)
        g = self.g
        val = (1 - g * g) / (_FOUR_PI * (1 + g * g - 2 * g * mu) ** 1.5)
        return np.broadcast_to(val, np.broadcast(mu, np.asarray(wavelength_nm)).shape).copy()

    def sample(self, u, wavelength_nm=550.0):
        u = _check_u(u)
        g = self.g
        if abs(g) < 1e-4:
            mu = 1 - 2 * u
        else:
            s = (1 - g * g) / (1 - g + 2 * g * u)
            mu = (1 + g * g - s * s) / (2 * g)
        mu = np.clip(mu, -1.0, 1.0)
        return np.broadcast_to(mu, np.broadcast(mu, np.asarray(wavelength_nm)).shape).copy()

    def _cdf_le(self, mu):
        """P(cos ψ <= mu)."""
        g = self.g
        if abs(g) < 1e-6:
            return (1 + np.asarray(mu, float)) / 2
        return (1 - g * g) / (2 * g) * (1 / np.sqrt(1 + g * g - 2 * g * np.asarray(mu, float)) - 1 / (1 + g))

    def cell_masses(self, grid=DEFAULT_GRID, wavelength_nm=550.0):
        return -np.diff(self._cdf_le(grid.mu_edges))

    def mean_cosine(self, wavelength_nm=550.0):
        return np.full(np.shape(wavelength_nm), self.g) if np.ndim(wavelength_nm) else self.g

    def backscatter_fraction(self, wavelength_nm=550.0):
        b = self._cdf_le(0.0)
        return np.full(np.shape(wavelength_nm), b) if np.ndim(wavelength_nm) else float(b)


class RayleighWater(PhaseFunction):
    """Pure-water scattering phase function ``∝ 1 + γ cos²ψ`` with γ = 0.835 [Mo74].

    ``p(ψ) = (1 + γ cos²ψ) / (4π (1 + γ/3))``; mean cosine 0, b_b/b = 0.5.
    """

    def __init__(self, gamma: float = 0.835):
        self.gamma = float(gamma)
        self.name = "rayleigh"
        self._norm = _FOUR_PI * (1 + self.gamma / 3)

    def eval(self, cos_psi, wavelength_nm=550.0):
        mu = np.asarray(cos_psi, float)
        val = (1 + self.gamma * mu * mu) / self._norm
        return np.broadcast_to(val, np.broadcast(mu, np.asarray(wavelength_nm)).shape).copy()

    def _cdf_from_minus1(self, mu):
        """P(cos ψ <= mu)."""
        k = self.gamma / 3
        return ((mu + 1) + k * (mu**3 + 1)) / (2 * (1 + k))

    def sample(self, u, wavelength_nm=550.0):
        # Solve k μ³ + μ + (1 + k − 2(1+k)u) = 0: one real root (monotone cubic), Cardano.
        u = _check_u(u)
        k = self.gamma / 3
        p = 1.0 / k
        q = (1 + k - 2 * (1 + k) * u) / k
        disc = np.sqrt(q * q / 4 + p**3 / 27)
        mu = np.cbrt(-q / 2 + disc) + np.cbrt(-q / 2 - disc)
        mu = np.clip(mu, -1.0, 1.0)
        return np.broadcast_to(mu, np.broadcast(mu, np.asarray(wavelength_nm)).shape).copy()

    def cell_masses(self, grid=DEFAULT_GRID, wavelength_nm=550.0):
        return -np.diff(self._cdf_from_minus1(grid.mu_edges))

    def mean_cosine(self, wavelength_nm=550.0):
        return np.zeros(np.shape(wavelength_nm)) if np.ndim(wavelength_nm) else 0.0

    def backscatter_fraction(self, wavelength_nm=550.0):
        return np.full(np.shape(wavelength_nm), 0.5) if np.ndim(wavelength_nm) else 0.5


# --------------------------------------------------------------------------------------
# Tabulated (cell) phase functions
# --------------------------------------------------------------------------------------
class TabulatedPhase(PhaseFunction):
    """A wavelength-independent phase function held as cell masses on a :class:`LogAngleGrid`.

    Build it with :meth:`from_function` from a continuous function of ψ (it is
    integrated over each cell and normalised).  Within a cell the density per
    solid angle is constant, so ``eval == pdf`` and sampling is exact.

    Attributes
    ----------
    norm
        The integral ``2π ∫ f(ψ) sin ψ dψ`` of the function before normalisation
        (e.g. the scattering coefficient b when ``f`` is a VSF in 1/(m sr)).
    """

    def __init__(self, masses: np.ndarray, grid: LogAngleGrid = DEFAULT_GRID, *,
                 name: str = "tabulated", norm: float = 1.0):
        masses = np.asarray(masses, float)
        if masses.shape != (grid.n_cells,) or np.any(masses < 0) or not np.all(np.isfinite(masses)):
            raise ConfigError("phase function table must be finite and >= 0 on every cell", field="phase")
        total = masses.sum()
        if total <= 0:
            raise ConfigError("phase function table integrates to zero", field="phase")
        self.grid = grid
        self.masses = masses / total
        self.cdf = np.concatenate([[0.0], np.cumsum(self.masses)])
        self.cdf[-1] = 1.0
        self.density = self.masses / grid.solid_angles  # 1/sr per cell
        self.name = name
        self.norm = float(norm * total)

    @classmethod
    def from_function(cls, fn: Callable[[np.ndarray], np.ndarray], *, name: str,
                      grid: LogAngleGrid = DEFAULT_GRID) -> "TabulatedPhase":
        """Tabulate a non-negative function of ψ (rad); its integral is kept as ``norm``."""
        m = grid.integrate(fn)
        return cls(m, grid, name=name, norm=1.0)

    def eval(self, cos_psi, wavelength_nm=550.0):
        mu = np.asarray(cos_psi, float)
        val = self.density[self.grid.cell_index(mu)]
        return np.broadcast_to(val, np.broadcast(mu, np.asarray(wavelength_nm)).shape).copy()

    def sample(self, u, wavelength_nm=550.0):
        u = _check_u(u)
        i = np.clip(np.searchsorted(self.cdf, u, side="right") - 1, 0, self.grid.n_cells - 1)
        # skip empty cells (cannot be selected: u in [cdf[i], cdf[i+1]) has zero width there)
        frac = (u - self.cdf[i]) / np.where(self.masses[i] > 0, self.masses[i], 1.0)
        frac = np.clip(frac, 0.0, 1.0)
        e = self.grid.mu_edges
        mu = e[i] + frac * (e[i + 1] - e[i])
        return np.broadcast_to(mu, np.broadcast(mu, np.asarray(wavelength_nm)).shape).copy()

    def cell_masses(self, grid=DEFAULT_GRID, wavelength_nm=550.0):
        if grid != self.grid:
            raise ValueError("TabulatedPhase can only report masses on its own grid")
        return self.masses


class MixturePhase(PhaseFunction):
    """Mixture ``p(ψ; λ) = Σ_k w_k(λ) p_k(ψ)`` with wavelength-dependent weights.

    Parameters
    ----------
    components
        Wavelength-independent phase functions.
    weights
        Function of wavelength (nm, array of shape S) returning weights of shape
        S + (K,) that sum to one (each component's share of the scattering
        coefficient, ``b_k(λ)/b(λ)``).
    name
        Name for reports.
    """

    wavelength_dependent = True

    def __init__(self, components: Sequence[PhaseFunction],
                 weights: Callable[[np.ndarray], np.ndarray], *, name: str):
        self.components = list(components)
        self._weights = weights
        self.name = name

    def weights(self, wavelength_nm) -> np.ndarray:
        """Component weights at ``wavelength_nm``, shape ``shape(wl) + (K,)``."""
        w = np.asarray(self._weights(np.asarray(wavelength_nm, float)), float)
        return w

    def eval(self, cos_psi, wavelength_nm=550.0):
        mu = np.asarray(cos_psi, float)
        w = self.weights(wavelength_nm)
        vals = np.stack([c.eval(mu) for c in self.components], axis=-1)
        return np.sum(vals * w, axis=-1)

    def sample(self, u, wavelength_nm=550.0):
        u = _check_u(u)
        shape = np.broadcast(u, np.asarray(wavelength_nm)).shape
        u = np.broadcast_to(u, shape)
        w = np.broadcast_to(self.weights(wavelength_nm), shape + (len(self.components),))
        cw = np.cumsum(w, axis=-1)
        cw[..., -1] = 1.0
        k = np.minimum((u[..., None] >= cw).sum(axis=-1), len(self.components) - 1)
        lo = np.where(k > 0, np.take_along_axis(cw, np.maximum(k - 1, 0)[..., None], -1)[..., 0], 0.0)
        wk = np.take_along_axis(w, k[..., None], -1)[..., 0]
        u2 = np.clip((u - lo) / np.where(wk > 0, wk, 1.0), 0.0, np.nextafter(1.0, 0.0))
        out = np.empty(shape)
        for j, comp in enumerate(self.components):
            m = k == j
            if np.any(m):
                out[m] = comp.sample(u2[m])
        return out

    def cell_masses(self, grid=DEFAULT_GRID, wavelength_nm=550.0):
        w = self.weights(float(wavelength_nm))
        return sum(wk * c.cell_masses(grid) for wk, c in zip(w, self.components))


# --------------------------------------------------------------------------------------
# Fournier–Forand
# --------------------------------------------------------------------------------------
def phase_FournierForand1999(psi_rad, n: float, mu_slope: float) -> np.ndarray:
    """Fournier–Forand phase function [FF99] in the form of Mobley et al. (2002), 1/sr.

    Parameters
    ----------
    psi_rad
        Scattering angle (rad).
    n
        Real index of refraction of the particles relative to water (> 1).
    mu_slope
        Slope of the hyperbolic (Junge) particle size distribution (3 < μ ≤ 5).
    """
    psi = np.asarray(psi_rad, float)
    nu = (3.0 - mu_slope) / 2.0
    k = 4.0 / (3.0 * (n - 1.0) ** 2)
    s2 = np.sin(psi / 2.0) ** 2
    d = k * s2
    d180 = k
    dnu = d**nu
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (nu * (1 - d) - (1 - dnu) + (d * (1 - dnu) - nu * (1 - d)) / s2) / (
            _FOUR_PI * (1 - d) ** 2 * dnu)
    t2 = (1 - d180**nu) / (16 * np.pi * (d180 - 1) * d180**nu) * (3 * np.cos(psi) ** 2 - 1)
    return t1 + t2


def _ff_backscatter(n: float, mu_slope: float) -> float:
    nu = (3.0 - mu_slope) / 2.0
    d90 = 4.0 / (3.0 * (n - 1.0) ** 2) * np.sin(np.pi / 4) ** 2
    return 1.0 - (1.0 - d90 ** (nu + 1) - 0.5 * (1.0 - d90**nu)) / ((1.0 - d90) * d90**nu)


class FournierForand(TabulatedPhase):
    """Fournier–Forand phase function [FF99], tabulated on the log-angle grid.

    Use :meth:`from_backscatter_fraction` to choose it by b_b/b, as in
    Mobley et al. (2002): n = 1.10 fixed, μ solved for.
    """

    def __init__(self, n: float, mu_slope: float, grid: LogAngleGrid = DEFAULT_GRID):
        self.n, self.mu_slope = float(n), float(mu_slope)
        masses = grid.integrate(lambda p: phase_FournierForand1999(p, self.n, self.mu_slope))
        super().__init__(masses, grid, name=f"ff:n={self.n:g},mu={self.mu_slope:.4f}")

    @classmethod
    @functools.lru_cache(maxsize=64)
    def from_backscatter_fraction(cls, bb_over_b: float, n: float = 1.10) -> "FournierForand":
        """FF phase function with the given backscatter fraction (0.0001 ≤ b_b/b ≤ 0.5)."""
        B = float(bb_over_b)
        lo, hi = 3.0001, 5.0
        blo, bhi = _ff_backscatter(n, lo), _ff_backscatter(n, hi)
        if not (min(blo, bhi) <= B <= max(blo, bhi)):
            raise ConfigError(f"Fournier–Forand backscatter fraction {B:g} is out of reach for n={n:g}",
                              field="phase", allowed=f"{min(blo, bhi):.4g} ≤ b_b/b ≤ {max(blo, bhi):.4g}")
        mu = brentq(lambda m: _ff_backscatter(n, m) - B, lo, hi, xtol=1e-12)
        ff = cls(n, mu)
        ff.name = f"ff:{B:g}"
        return ff


# --------------------------------------------------------------------------------------
# Phase functions from tables in data/
# --------------------------------------------------------------------------------------
def loglog_interpolant(angle_deg: np.ndarray, values: np.ndarray, *, below: str = "linear"
                       ) -> Callable[[np.ndarray], np.ndarray]:
    """A continuous function of ψ (rad) through tabulated (angle, value) pairs.

    Shape-preserving cubic (PCHIP) interpolation of log(value) against log(ψ) —
    the forward peak is a power law there — for ψ ≥ the first non-zero angle.
    Below it: ``below="linear"`` joins linearly to a tabulated value at 0°, or
    ``below="power"`` continues the power law of the first two points.
    """
    ang = np.radians(np.asarray(angle_deg, float))
    val = np.asarray(values, float)
    if np.any(val <= 0):
        raise ConfigError("tabulated phase function values must be > 0 for log interpolation",
                          field="phase")
    pos = ang > 0
    la, lv = np.log(ang[pos]), np.log(val[pos])
    f = PchipInterpolator(la, lv, extrapolate=True)
    a1 = ang[pos][0]
    has_zero = np.any(ang == 0)
    v0 = val[ang == 0][0] if has_zero else None
    slope = (lv[1] - lv[0]) / (la[1] - la[0])
    amax = ang[-1]

    def fn(psi):
        psi = np.asarray(psi, float)
        out = np.exp(f(np.log(np.clip(psi, a1, amax))))
        small = psi < a1
        if np.any(small):
            if below == "linear" and has_zero:
                out = np.where(small, v0 + (val[pos][0] - v0) * psi / a1, out)
            else:
                out = np.where(small, val[pos][0] * (np.maximum(psi, 1e-300) / a1) ** slope, out)
        return out

    return fn


@functools.lru_cache(maxsize=None)
def petzold_average_particle() -> TabulatedPhase:
    """Petzold "average particle" phase function [Mo93], b_b/b = 0.0183.

    Log-log PCHIP through the 55 tabulated angles (0.1–180°), power law below
    0.1° (slope of the first two points, as in Mobley et al. 1993).
    """
    t = load_table("water/petzold_average_particle_phase_function.csv")
    fn = loglog_interpolant(t["angle_deg"], t["phase_function_per_sr"], below="power")
    return TabulatedPhase.from_function(fn, name="petzold-average")


def _kopelevich_component(column: str, name: str) -> TabulatedPhase:
    t = load_table("water/kopelevich_vsf_small_large_particles.csv")
    fn = loglog_interpolant(t["angle_deg"], t[column], below="linear")
    return TabulatedPhase.from_function(fn, name=name)


@functools.lru_cache(maxsize=None)
def kopelevich_small_particle() -> TabulatedPhase:
    """Kopelevich (1983) small-particle phase function; ``.norm`` is b_s* in 1/(m ppm) at 550 nm."""
    return _kopelevich_component("beta_s_star_per_m_sr_ppm", "kopelevich-small")


@functools.lru_cache(maxsize=None)
def kopelevich_large_particle() -> TabulatedPhase:
    """Kopelevich (1983) large-particle phase function; ``.norm`` is b_l* in 1/(m ppm) at 550 nm."""
    return _kopelevich_component("beta_l_star_per_m_sr_ppm", "kopelevich-large")


def tabulated_from_csv(path) -> TabulatedPhase:
    """A user phase function (or VSF shape) from a CSV of ``angle_deg`` and a value column.

    The values need not be normalised; they are interpolated in log-log space
    and normalised.  The table must start at 0° or use a power law below its
    first angle, and end at 180°.
    """
    t = read_csv_table(path)
    names = list(t.columns)
    if len(names) < 2 or names[0] != "angle_deg":
        raise ConfigError("phase CSV needs columns angle_deg,value", file=path, field="phase")
    ang, val = t[names[0]], t[names[1]]
    if ang[-1] != 180 or np.any(np.diff(ang) <= 0):
        raise ConfigError("phase CSV angles must increase and end at 180", file=path, field="angle_deg",
                          allowed="0 ≤ angle_deg ≤ 180, increasing, last = 180")
    fn = loglog_interpolant(ang, val, below="linear" if ang[0] == 0 else "power")
    return TabulatedPhase.from_function(fn, name=str(path))
