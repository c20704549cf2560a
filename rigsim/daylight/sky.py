"""Sky radiance distributions above the sea: black, uniform, and the CIE Standard General Sky.

A sky model gives the *shape* of the sky radiance, normalised to unit horizontal
irradiance: ``ℓ(θ, φ)`` in 1/sr with ``∫ ℓ cos θ dΩ = 1`` over the upper
hemisphere.  The spectral sky radiance is ``L(θ, φ, λ) = E_sky(λ) · ℓ(θ, φ)``
with ``E_sky`` the sky's plane irradiance (:mod:`rigsim.daylight.solar`); the
angular shape is taken to be the same at all wavelengths (the CIE distributions
are luminance distributions).

Angles: θ is the zenith angle of the direction *towards* the sky element, φ its
azimuth measured from the sun's azimuth.

References
----------
.. [CIE03] CIE S 011/E:2003 / ISO 15469:2004, *Spatial distribution of daylight —
   CIE standard general sky*.
.. [DK02] S. Darula, R. Kittler, "CIE general sky standard defining luminance
   distributions", Proc. eSim 2002, Montréal, 11–13.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from rigsim.data import load_table
from rigsim.errors import ConfigError, unknown_name_error

__all__ = [
    "SkyModel",
    "BlackSky",
    "UniformSky",
    "CIEGeneralSky",
    "cie_sky_parameters",
    "radiance_CIE_general_sky",
    "SKY_MODELS",
    "sky_model",
]


class SkyModel:
    """Normalised sky radiance ``ℓ(θ, φ)`` (1/sr) and a sampler of directions with pdf ∝ ℓ cos θ."""

    name: str = "sky"
    #: False for the black sky (no light).
    emits: bool = True

    def radiance(self, cos_zenith, rel_azimuth_rad) -> np.ndarray:
        """ℓ(θ, φ) per unit horizontal sky irradiance, 1/sr."""
        raise NotImplementedError

    def sample(self, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """``n`` directions towards the sky, as (cos θ, φ) with density ℓ cos θ (per sr)."""
        raise NotImplementedError

    def describe(self) -> str:
        return self.name


class BlackSky(SkyModel):
    """No sky light (a sun in a black sky: the textbook collimated-beam problem)."""

    name = "black"
    emits = False

    def radiance(self, cos_zenith, rel_azimuth_rad):
        return np.zeros(np.broadcast(np.asarray(cos_zenith), np.asarray(rel_azimuth_rad)).shape)

    def sample(self, n, rng):
        raise ConfigError("a black sky emits no light", field="sky")


class UniformSky(SkyModel):
    """Isotropic sky radiance: ``ℓ = 1/π`` (Lambertian sky); sampled exactly, cos θ = √u."""

    name = "uniform"

    def radiance(self, cos_zenith, rel_azimuth_rad):
        mu = np.asarray(cos_zenith, float)
        return np.broadcast_to(np.where(mu > 0, 1.0 / np.pi, 0.0),
                               np.broadcast(mu, np.asarray(rel_azimuth_rad)).shape).copy()

    def sample(self, n, rng):
        return np.sqrt(rng.random(n)), 2.0 * np.pi * rng.random(n)


@functools.lru_cache(maxsize=None)
def _cie_table():
    return load_table("daylight/cie_standard_general_sky.csv")


def cie_sky_parameters(sky_type: int) -> tuple[float, float, float, float, float]:
    """(a, b, c, d, e) of CIE standard general sky type 1–15 [CIE03] (``data/daylight/cie_standard_general_sky.csv``).

    Examples
    --------
    >>> cie_sky_parameters(12)
    (-1.0, -0.32, 10.0, -3.0, 0.45)
    """
    t = _cie_table()
    types = t["type"].astype(int)
    if int(sky_type) not in types:
        raise ConfigError(f"unknown CIE sky type {sky_type!r}", field="sky", allowed="1–15 (12: standard clear sky)")
    i = int(np.flatnonzero(types == int(sky_type))[0])
    return tuple(float(t[k][i]) for k in ("a", "b", "c", "d", "e"))  # type: ignore[return-value]


def radiance_CIE_general_sky(cos_zenith, rel_azimuth_rad, sun_zenith_deg: float,
                             params: tuple[float, float, float, float, float]) -> np.ndarray:
    """Relative radiance L/L_zenith of the CIE Standard General Sky [CIE03, DK02].

    ``L(θ, φ)/L_z = f(χ) Φ(θ) / (f(θ_s) Φ(0))`` with gradation
    ``Φ(θ) = 1 + a exp(b / cos θ)`` (Φ = 1 at the horizon) and indicatrix
    ``f(χ) = 1 + c (exp(d χ) − exp(d π/2)) + e cos² χ``; χ is the angle between
    the sky element and the sun, ``cos χ = cos θ cos θ_s + sin θ sin θ_s cos φ``.

    Examples
    --------
    >>> round(float(radiance_CIE_general_sky(1.0, 0.0, 30.0, (-1, -0.32, 10, -3, 0.45))), 12)  # zenith
    1.0
    """
    a, b, c, d, e = params
    mu = np.clip(np.asarray(cos_zenith, float), 0.0, 1.0)
    phi = np.asarray(rel_azimuth_rad, float)
    zs = np.radians(float(sun_zenith_deg))
    sin_t = np.sqrt(1.0 - mu * mu)
    cos_chi = np.clip(mu * np.cos(zs) + sin_t * np.sin(zs) * np.cos(phi), -1.0, 1.0)
    chi = np.arccos(cos_chi)

    def f(x, cx):
        return 1.0 + c * (np.exp(d * x) - np.exp(d * np.pi / 2)) + e * cx * cx

    with np.errstate(divide="ignore", over="ignore"):
        grad = 1.0 + a * np.where(mu > 0, np.exp(b / np.maximum(mu, 1e-300)), 0.0)
    grad0 = 1.0 + a * np.exp(b)
    return f(chi, cos_chi) * grad / (f(zs, np.cos(zs)) * grad0)


@dataclass(frozen=True, eq=False)
class _Grid:
    mu_edges: np.ndarray     # ascending, uniform in mu^2 (equal cos-weighted solid angle)
    phi_edges: np.ndarray
    cdf: np.ndarray          # over flattened (mu, phi) cells
    norm: float              # ∫ L_rel cos θ dΩ


class CIEGeneralSky(SkyModel):
    """CIE Standard General Sky of a given type (default 12, the CIE standard clear sky).

    The shape is tabulated on a 90 × 180 grid (cells of equal cos-weighted solid
    angle in θ, 2° in φ); directions are sampled cell by cell (exactly ∝ cos θ
    inside a cell) and the normalisation uses the same grid, so each sampled
    photon carries exactly its share of the sky irradiance.
    """

    def __init__(self, sun_zenith_deg: float, sky_type: int = 12, n_mu: int = 90, n_phi: int = 180):
        self.sun_zenith_deg = float(sun_zenith_deg)
        self.sky_type = int(sky_type)
        self.params = cie_sky_parameters(self.sky_type)
        self.name = f"cie-{self.sky_type}"
        self._n_mu, self._n_phi = n_mu, n_phi

    @functools.cached_property
    def _grid(self) -> _Grid:
        mu_e = np.sqrt(np.linspace(0.0, 1.0, self._n_mu + 1))
        phi_e = np.linspace(-np.pi, np.pi, self._n_phi + 1)
        mu_c = np.sqrt(0.5 * (mu_e[:-1] ** 2 + mu_e[1:] ** 2))
        phi_c = 0.5 * (phi_e[:-1] + phi_e[1:])
        lrel = radiance_CIE_general_sky(mu_c[:, None], phi_c[None, :], self.sun_zenith_deg, self.params)
        cell = 0.5 * (mu_e[1:] ** 2 - mu_e[:-1] ** 2)[:, None] * np.diff(phi_e)[None, :]  # ∫cosθ dΩ
        mass = (lrel * cell).ravel()
        norm = float(mass.sum())
        return _Grid(mu_e, phi_e, np.cumsum(mass) / norm, norm)

    def radiance(self, cos_zenith, rel_azimuth_rad):
        mu = np.asarray(cos_zenith, float)
        val = radiance_CIE_general_sky(mu, rel_azimuth_rad, self.sun_zenith_deg, self.params) / self._grid.norm
        return np.where(mu > 0, val, 0.0)

    def sample(self, n, rng):
        g = self._grid
        k = np.minimum(np.searchsorted(g.cdf, rng.random(n), side="right"), g.cdf.size - 1)
        i, j = np.divmod(k, self._n_phi)
        m0, m1 = g.mu_edges[i] ** 2, g.mu_edges[i + 1] ** 2
        mu = np.sqrt(m0 + rng.random(n) * (m1 - m0))
        phi = g.phi_edges[j] + rng.random(n) * (g.phi_edges[j + 1] - g.phi_edges[j])
        return mu, phi

    def describe(self) -> str:
        return f"CIE standard general sky type {self.sky_type}"


#: Sky names accepted by :func:`sky_model`.
SKY_MODELS = ("black", "uniform", "cie", "cie:1..15")


def sky_model(name: str, sun_zenith_deg: float = 30.0) -> SkyModel:
    """A sky by name: ``black``, ``uniform``, ``cie`` (type 12, CIE standard clear sky) or ``cie:N``."""
    low = str(name).strip().lower()
    if low == "black":
        return BlackSky()
    if low == "uniform":
        return UniformSky()
    if low == "cie":
        return CIEGeneralSky(sun_zenith_deg, 12)
    if low.startswith("cie:"):
        try:
            t = int(low[4:])
        except ValueError:
            t = -1
        if not 1 <= t <= 15:
            raise ConfigError(f"unknown CIE sky type in {name!r}", field="sky", allowed="cie:1 … cie:15")
        return CIEGeneralSky(sun_zenith_deg, t)
    raise unknown_name_error("sky", str(name), ("black", "uniform", "cie"), field="sky")
