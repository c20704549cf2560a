"""Wavy sea surfaces for caustics: a sum of sines, from explicit waves or a Pierson–Moskowitz wind sea.

A :class:`WaveField` is ``h(x, z) = Σ_i A_i sin(k_i (x sin α_i + z cos α_i) + φ_i)``
— heights in metres, up (+y in the scene frame), over the horizontal scene
coordinates x (right) and z (forward); α_i is the direction of travel measured
from +z towards +x, like the sun's azimuth.  Normals are analytic.

:func:`waves_PiersonMoskowitz1964` draws the components from the fully developed
wind-sea spectrum ``S(ω) = α g² ω⁻⁵ exp(−β (ω₀/ω)⁴)``, α = 8.1e−3, β = 0.74,
ω₀ = g/U₁₉.₅, with a cos² directional spread about the wind and deep-water
dispersion ``k = ω²/g``; each component's amplitude is ``√(2 S(ω) Δω D(α) Δα)``.
Its significant wave height is ``H_s ≈ 0.21 U²/g``.

:func:`caustic_pattern` traces the sun's rays refracted by the wavy surface down
to a horizontal plane and bins them: the relative irradiance pattern (mean 1) on
the bottom or a target — the "light patterns on the bottom in shallow water".

References
----------
.. [PM64] W.J. Pierson, L. Moskowitz, "A proposed spectral form for fully developed
   wind seas based on the similarity theory of S.A. Kitaigorodskii",
   J. Geophys. Res. 69(24):5181–5190 (1964).
.. [Te01] J. Tessendorf, "Simulating ocean water", SIGGRAPH course notes (2001).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigsim.daylight.surface import WATER_INDEX
from rigsim.errors import ConfigError

__all__ = ["WaveField", "sine_waves", "waves_PiersonMoskowitz1964", "caustic_pattern", "G_M_S2"]

#: Gravitational acceleration, m/s².
G_M_S2 = 9.81


@dataclass(frozen=True, eq=False)
class WaveField:
    """A sum of sinusoidal waves (see module docstring).

    Attributes
    ----------
    amplitude_m, wavelength_m, direction_deg, phase_rad
        One entry per component.
    """

    amplitude_m: np.ndarray
    wavelength_m: np.ndarray
    direction_deg: np.ndarray
    phase_rad: np.ndarray

    def __post_init__(self):
        arrs = [np.atleast_1d(np.asarray(getattr(self, f), float)) for f in
                ("amplitude_m", "wavelength_m", "direction_deg", "phase_rad")]
        if len({a.size for a in arrs}) != 1:
            raise ConfigError("wave components need equal-length amplitude, wavelength, direction and phase",
                              field="waves")
        if np.any(arrs[0] < 0) or np.any(arrs[1] <= 0) or not all(np.all(np.isfinite(a)) for a in arrs):
            raise ConfigError("wave amplitudes must be >= 0 m and wavelengths > 0 m", field="waves")
        for f, a in zip(("amplitude_m", "wavelength_m", "direction_deg", "phase_rad"), arrs):
            object.__setattr__(self, f, a)

    def _k(self):
        k = 2.0 * np.pi / self.wavelength_m
        al = np.radians(self.direction_deg)
        return k * np.sin(al), k * np.cos(al)

    def height(self, x, z) -> np.ndarray:
        """Surface elevation h(x, z), m."""
        x, z = np.asarray(x, float), np.asarray(z, float)
        kx, kz = self._k()
        arg = x[..., None] * kx + z[..., None] * kz + self.phase_rad
        return np.sum(self.amplitude_m * np.sin(arg), axis=-1)

    def slopes(self, x, z) -> tuple[np.ndarray, np.ndarray]:
        """(∂h/∂x, ∂h/∂z)."""
        x, z = np.asarray(x, float), np.asarray(z, float)
        kx, kz = self._k()
        arg = x[..., None] * kx + z[..., None] * kz + self.phase_rad
        c = self.amplitude_m * np.cos(arg)
        return np.sum(c * kx, axis=-1), np.sum(c * kz, axis=-1)

    def normal(self, x, z) -> np.ndarray:
        """Upward unit normals in the scene frame (x, y up, z): ``(−h_x, 1, −h_z)/|…|``."""
        hx, hz = self.slopes(x, z)
        n = np.stack([-hx, np.ones_like(hx), -hz], axis=-1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)


def sine_waves(amplitude_m, wavelength_m, direction_deg=0.0, phase_rad=0.0) -> WaveField:
    """Explicit waves (scalars or equal-length lists)."""
    a = np.atleast_1d(np.asarray(amplitude_m, float))
    return WaveField(a, np.broadcast_to(np.asarray(wavelength_m, float), a.shape).copy(),
                     np.broadcast_to(np.asarray(direction_deg, float), a.shape).copy(),
                     np.broadcast_to(np.asarray(phase_rad, float), a.shape).copy())


def waves_PiersonMoskowitz1964(wind_speed_m_s: float, *, wind_direction_deg: float = 0.0, n_frequencies: int = 32,
                               n_directions: int = 8, seed: int = 0,
                               min_wavelength_m: float = 0.05) -> WaveField:
    """A random sum of sines from the Pierson–Moskowitz (1964) spectrum with cos² spreading [PM64, Te01].

    Frequencies are spaced geometrically from 0.5 ω_peak to the capillary cut-off
    set by ``min_wavelength_m``; phases are uniform random (``seed``).
    """
    u = float(wind_speed_m_s)
    if not np.isfinite(u) or u <= 0:
        raise ConfigError(f"wind speed must be > 0 m/s, got {wind_speed_m_s}", field="wind_speed_m_s")
    g = G_M_S2
    w0 = g / u
    w_peak = 0.877 * w0  # (4β/5)^(1/4) ω0
    w_max = np.sqrt(g * 2.0 * np.pi / float(min_wavelength_m))
    if w_max <= 0.5 * w_peak:
        raise ConfigError("minimum wavelength too long for this wind", field="min_wavelength_m")
    edges = np.geomspace(0.5 * w_peak, w_max, n_frequencies + 1)
    w = np.sqrt(edges[:-1] * edges[1:])
    dw = np.diff(edges)
    s = 8.1e-3 * g * g * w ** -5 * np.exp(-0.74 * (w0 / w) ** 4)
    al = np.linspace(-np.pi / 2, np.pi / 2, n_directions + 1)
    al_c = 0.5 * (al[:-1] + al[1:])
    dal = np.diff(al)
    spread = (2.0 / np.pi) * np.cos(al_c) ** 2
    amp = np.sqrt(2.0 * s[:, None] * dw[:, None] * spread[None, :] * dal[None, :])
    k = w ** 2 / g
    rng = np.random.default_rng(seed)
    n = amp.size
    return WaveField(amp.ravel(), np.repeat(2 * np.pi / k, n_directions),
                     np.tile(np.degrees(al_c), n_frequencies) + float(wind_direction_deg),
                     rng.uniform(0, 2 * np.pi, n))


def caustic_pattern(waves: WaveField, *, sun_zenith_deg: float, sun_azimuth_deg: float = 0.0, depth_m: float,
                    extent_m: float = 2.0, resolution: int = 64, rays_per_cell: int = 16,
                    n_water: float = WATER_INDEX, seed: int = 0) -> np.ndarray:
    """Relative irradiance (mean ≈ 1) on a horizontal plane ``depth_m`` below the mean surface.

    Sun rays hit the wavy surface on a jittered grid that covers the window
    ``[−extent/2, extent/2]²`` (x, z) plus a margin for the refraction offset, are
    refracted by the local facet (Snell; Fresnel transmittance weights each ray),
    travel straight to the plane (no scattering: this is the *pattern*, multiply
    by the ambient meter's Ed at that depth for absolute values) and are binned on
    a ``resolution²`` grid.  Rows index z, columns x.  The surface height is
    neglected in the ray's start point (small amplitude); absorption along the
    slightly different path lengths is ignored.
    """
    from rigsim.daylight.surface import fresnel_reflectance_unpolarised

    if depth_m <= 0:
        raise ConfigError(f"depth must be > 0 m, got {depth_m}", field="depth_m")
    rng = np.random.default_rng(seed)
    ts, ps = np.radians(sun_zenith_deg), np.radians(sun_azimuth_deg)
    d_in = np.array([-np.sin(ts) * np.sin(ps), -np.cos(ts), -np.sin(ts) * np.cos(ps)])
    mu_w = np.sqrt(1 - (np.sin(ts) / n_water) ** 2)
    shift = depth_m * np.sin(ts) / n_water / mu_w
    margin = shift + 0.5 * depth_m + 0.1 * extent_m
    half = extent_m / 2 + margin
    cell = extent_m / resolution
    n_side = int(np.ceil(2 * half / cell)) * int(np.sqrt(rays_per_cell))
    g = (np.arange(n_side) + rng.random((n_side, n_side))) / n_side * 2 * half - half
    x0 = g
    z0 = ((np.arange(n_side)[:, None] + rng.random((n_side, n_side))) / n_side * 2 * half - half)
    x0, z0 = x0.ravel(), z0.ravel()
    # centre the launch window on the refracted footprint
    x0 = x0 + shift * np.sin(ps)
    z0 = z0 + shift * np.cos(ps)
    nrm = waves.normal(x0, z0)
    cos_i = np.clip(-(nrm @ d_in), 0.0, 1.0)
    eta = 1.0 / n_water
    k = 1.0 - eta * eta * (1.0 - cos_i ** 2)
    t = eta * d_in[None, :] + (eta * cos_i - np.sqrt(np.clip(k, 0, None)))[:, None] * nrm
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    w = (1.0 - fresnel_reflectance_unpolarised(cos_i, 1.0, n_water)) * cos_i / np.maximum(nrm[:, 1], 1e-9)
    down = t[:, 1] < -1e-6
    s = depth_m / -t[down, 1]
    x1 = x0[down] + s * t[down, 0]
    z1 = z0[down] + s * t[down, 2]
    h, _, _ = np.histogram2d(z1, x1, bins=resolution, range=[[-extent_m / 2, extent_m / 2]] * 2,
                             weights=w[down])
    # the same count for a flat surface: launch density times flat transmittance
    density = (n_side / (2 * half)) ** 2
    flat = density * cell * cell * (1.0 - float(fresnel_reflectance_unpolarised(np.cos(ts), 1.0, n_water))) \
        * np.cos(ts)
    return h / flat
