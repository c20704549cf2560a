"""The air–water interface: Fresnel reflectance, Snell refraction, Cox–Munk wind-roughened facets.

Conventions of this module: directions are unit 3-vectors in a frame whose third
axis points **down** (into the water, along depth), so a photon heading down has
``d[..., 2] > 0``.  The mean sea surface is the plane ``z = 0``; air is above
(``z < 0``), water below.

References
----------
.. [BW99] M. Born, E. Wolf, *Principles of Optics*, 7th ed., Cambridge (1999), §1.5.
.. [CM54] C. Cox, W. Munk, "Measurement of the roughness of the sea surface from
   photographs of the sun's glitter", J. Opt. Soc. Am. 44(11):838–850 (1954).
.. [Mo94] C.D. Mobley, *Light and Water*, Academic Press (1994), §4.3 (Fresnel
   reflectance of a level surface, R(0) = 0.0211 for n = 1.34) and §4.6 (Cox–Munk
   capillary-wave slopes; the random-facet ray tracing used here).
.. [PM86] R.W. Preisendorfer, C.D. Mobley, "Albedos and glitter patterns of a
   wind-roughened sea surface", J. Phys. Oceanogr. 16:1293–1316 (1986).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr

from rigsim.errors import ConfigError
from rigsim.water.refraction import WATER_INDEX, fresnel_reflectance_unpolarised, snell_cos_transmitted

__all__ = [
    "WATER_INDEX",
    "fresnel_reflectance_unpolarised",
    "snell_cos_transmitted",
    "critical_angle_deg",
    "refract",
    "reflect",
    "slope_variance_CoxMunk1954",
    "Surface",
    "flat_surface",
    "cox_munk_surface",
]


def critical_angle_deg(n_water: float = WATER_INDEX) -> float:
    """Critical angle of total internal reflection, water → air (deg): asin(1/n) = 48.27° for n = 1.34."""
    return float(np.degrees(np.arcsin(1.0 / n_water)))


def reflect(d: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Mirror direction of ``d`` about the unit normal ``n`` (any orientation)."""
    return d - 2.0 * np.sum(d * n, axis=-1, keepdims=True) * n


def refract(d: np.ndarray, n: np.ndarray, eta: float) -> tuple[np.ndarray, np.ndarray]:
    """Snell refraction of unit directions ``d`` through a facet of unit normal ``n``.

    Parameters
    ----------
    d
        Incident directions (..., 3).
    n
        Facet normals (..., 3) pointing to the incident side (``d·n < 0``).
    eta
        Ratio ``n_incident / n_transmitted``.

    Returns
    -------
    t, ok
        Transmitted unit directions and a mask that is False where total internal
        reflection occurs (there ``t`` is the mirror direction).
    """
    cos_i = -np.sum(d * n, axis=-1, keepdims=True)
    sin2_t = eta * eta * (1.0 - cos_i * cos_i)
    ok = sin2_t[..., 0] <= 1.0
    cos_t = np.sqrt(np.clip(1.0 - sin2_t, 0.0, 1.0))
    t = eta * d + (eta * cos_i - cos_t) * n
    t = np.where(ok[..., None], t, d + 2.0 * cos_i * n)
    return t / np.linalg.norm(t, axis=-1, keepdims=True), ok


def slope_variance_CoxMunk1954(wind_speed_m_s) -> np.ndarray:
    """Mean square slope of the sea surface, isotropic Cox–Munk (1954) clean-surface fit [CM54].

    ``σ² = 0.003 + 0.00512 U`` with U the wind speed at 12.5 m above the sea (m/s),
    fitted for 1 < U < 14 m/s.  Each slope component has variance σ²/2.

    Examples
    --------
    >>> round(float(slope_variance_CoxMunk1954(5.0)), 4)
    0.0286
    """
    u = np.asarray(wind_speed_m_s, float)
    if np.any(u < 0) or not np.all(np.isfinite(u)):
        raise ConfigError(f"wind speed must be >= 0 m/s, got {wind_speed_m_s}", field="wind_speed_m_s",
                          allowed=">= 0 m/s (fit valid to about 14 m/s)")
    return 0.003 + 0.00512 * u


@dataclass(frozen=True)
class Surface:
    """An air–water interface: flat, or random Cox–Munk facets.

    Attributes
    ----------
    wind_speed_m_s
        None for a flat (level) surface, else the wind speed of the Cox–Munk slope
        distribution (a wind of 0 m/s still has σ² = 0.003).
    n_water
        Refractive index of the water (1.34).

    Notes
    -----
    The rough surface is modelled as in [PM86]/[Mo94 §4.6]: each ray meets one
    facet whose slopes ``(z_x, z_y)`` are Gaussian with variance σ²/2 each; a facet
    is met with probability proportional to its projected area seen along the ray,
    ``f = max(0, cos i) / (cos θ_n |μ|) = max(0, 1 + s tan θ)`` (s the slope along
    the ray's horizontal direction).  Facets are drawn from the slope distribution
    and the ray's weight is multiplied by ``f / E[f]``, with ``E[f]`` in closed form
    — energy is conserved exactly.  Shadowing and multiple hits of the same ray
    are not modelled; a ray that a steep facet would send back across the mean
    surface is mirrored in the horizontal plane (rare below ~15 m/s).
    """

    wind_speed_m_s: float | None = None
    n_water: float = WATER_INDEX

    def __post_init__(self):
        if self.wind_speed_m_s is not None:
            slope_variance_CoxMunk1954(self.wind_speed_m_s)
        if not 1.0 < float(self.n_water) < 2.0:
            raise ConfigError(f"water index must be in (1, 2), got {self.n_water}", field="n_water")

    @property
    def flat(self) -> bool:
        return self.wind_speed_m_s is None

    @property
    def slope_variance(self) -> float:
        """σ² (0 for the flat surface)."""
        return 0.0 if self.flat else float(slope_variance_CoxMunk1954(self.wind_speed_m_s))

    def describe(self) -> str:
        return "flat" if self.flat else f"cox-munk U={self.wind_speed_m_s:g} m/s (sigma^2={self.slope_variance:.4f})"

    # ---------------------------------------------------------------------------------
    def sample_normals(self, d: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Facet normals met by rays ``d`` (pointing to the rays' incident side) and the weights ``f/E[f]``.

        Parameters
        ----------
        d
            Unit ray directions (n, 3), down-positive third axis; rays from the air
            have ``d_z > 0``, rays from the water ``d_z < 0``.
        rng
            Random generator.

        Returns
        -------
        normals, weight
            (n, 3) unit normals with ``d·n < 0`` wherever ``weight > 0``; (n,) weights
            with mean one.
        """
        n = d.shape[0]
        side = -np.sign(d[:, 2])  # normal's z sign: towards the incident side
        side = np.where(side == 0, -1.0, side)
        if self.flat:
            nrm = np.zeros((n, 3))
            nrm[:, 2] = side
            return nrm, np.ones(n)
        s1 = np.sqrt(self.slope_variance / 2.0)
        zx, zy = rng.normal(0.0, s1, n), rng.normal(0.0, s1, n)
        # facet normal towards the air is (-z_x, -z_y, -1)/N in this z-down frame, towards
        # the water (z_x, z_y, 1)/N: both are side * (z_x, z_y, 1)/N up to the slopes' sign.
        nrm = side[:, None] * np.stack([zx, zy, np.ones(n)], axis=-1)
        nrm /= np.linalg.norm(nrm, axis=-1, keepdims=True)
        cos_i = -np.sum(d * nrm, axis=-1)
        f = np.maximum(cos_i, 0.0) / (np.abs(nrm[:, 2]) * np.maximum(np.abs(d[:, 2]), 1e-12))
        mu = np.clip(np.abs(d[:, 2]), 1e-12, 1.0)
        tan_t = np.sqrt(1.0 - mu * mu) / mu
        norm = _mean_positive_linear(tan_t * s1)
        return nrm, f / norm


def _mean_positive_linear(ts: np.ndarray) -> np.ndarray:
    """E[max(0, 1 + ts·x)] for x standard normal: Φ(1/ts) + ts·φ(1/ts) (→ 1 as ts → 0)."""
    ts = np.asarray(ts, float)
    with np.errstate(divide="ignore"):
        x0 = np.where(ts > 0, 1.0 / np.maximum(ts, 1e-300), np.inf)
    phi = np.exp(-0.5 * np.minimum(x0, 40.0) ** 2) / np.sqrt(2.0 * np.pi)
    phi = np.where(np.isinf(x0), 0.0, phi)
    return ndtr(x0) + ts * phi


def flat_surface(n_water: float = WATER_INDEX) -> Surface:
    """A level sea surface."""
    return Surface(None, n_water)


def cox_munk_surface(wind_speed_m_s: float, n_water: float = WATER_INDEX) -> Surface:
    """A wind-roughened surface with Cox–Munk (1954) isotropic slopes."""
    return Surface(float(wind_speed_m_s), n_water)
