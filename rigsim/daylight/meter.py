"""The ambient light meter: Monte Carlo radiative transfer in a plane-parallel water column.

:func:`ambient_light_monte_carlo` answers "how much daylight, of what colour,
reaches depth z": per wavelength and depth it returns the plane irradiances Ed,
Eu, the scalar irradiances Eo, Eod, Eou (W·m⁻²·nm⁻¹), the nadir-viewing upwelling
radiance Lu (W·m⁻²·sr⁻¹·nm⁻¹) and Kd (1/m), each with a Monte Carlo standard
error.  :func:`ambient_light_kd` gives the same quantities from the fast Kd
shortcut (:mod:`rigsim.daylight.shortcut`).

The model (the classic "backward-free" photon Monte Carlo of ocean optics, e.g.
[Mo94 §6], [KW78]):

* **Sources** — the direct sun (a collimated beam of plane irradiance
  ``E_sun(0+)``) and the sky (radiance shaped by a :class:`~rigsim.daylight.sky.SkyModel`,
  plane irradiance ``E_sky(0+)``).  Photons are split between them in proportion
  to their irradiance (stratified); each carries ``E(0+)/N`` of plane irradiance.
* **Surface** — flat or Cox–Munk facets (:class:`~rigsim.daylight.surface.Surface`).
  From the air a photon's weight is multiplied by the Fresnel transmittance
  ``1 − R(θ)`` and it is refracted (the reflected part is tallied as
  ``reflected``).  From the water it is reflected with probability ``R`` (1 beyond
  the critical angle 48.3°: total internal reflection) and otherwise leaves
  (tallied as ``water_leaving``).
* **Water** — homogeneous IOPs: free paths with density ``c e^{−c s}``; at each
  collision the weight is multiplied by the albedo ``b/c`` (absorption as
  weight) and the direction is turned by ``cos ψ`` from the water's phase
  function (``phase.sample``) and a uniform azimuth, rotated about the old
  direction in 3-D.  Russian roulette below a weight of 1e−3 (unbiased).
* **Bottom** — none (infinitely deep), black, or Lambertian of reflectance R
  (weight × R, cosine-distributed upward direction).
* **Tallies** at each requested depth plane (just below the surface for z = 0):
  every crossing adds its weight to Ed (downward) or Eu (upward), and
  ``weight/|μ|`` to Eod/Eou (Eo = Eod + Eou); |μ| is floored at 1e−3 (bias < 0.1 %).
  **Lu** (radiance travelling straight up, i.e. seen by a nadir-viewing
  radiometer) uses a *point (next-event) estimator*: every collision at depth z′ > z
  adds ``w · (b/c) · p(ψ_up) · e^{−c (z′ − z)}`` and every bottom hit
  ``w · R/π · e^{−c (H − z)}``, the exact expected in-scattered radiance along
  the vertical ray — unbiased and of low variance.  (A cone estimator, counting
  upward crossings within 10° of the vertical, is available as ``lu_method="cone"``
  for checking; it is biased by the radiance's curvature over the cone.)
* **Errors** — photons are dealt into ``batches`` interleaved batches; each
  quantity's standard error is the standard deviation of the batch means over
  √batches.  **Kd** at depth z > 0 is the layer mean ``−ln(Ed(z)/Ed(0−))/z``; at
  z = 0 it is that of the top 0.5 m (or of the whole column if shallower).

Randomness: one ``numpy.random.Generator`` per wavelength seeded by
``SeedSequence([seed, round(1000 λ)])`` — the same inputs give the same numbers,
and a wavelength's result does not depend on which other wavelengths are asked.

References
----------
.. [Mo94] C.D. Mobley, *Light and Water*, Academic Press (1994): §1.3 (Ed, Eu, Eo,
   Lu definitions), §5.10 (Gershun's law), §6 (Monte Carlo), §4 (surface).
.. [KW78] G.W. Kattawar, C.N. Adams, "Radiative transfer in spherical shell
   atmospheres", and H.R. Gordon, O.B. Brown, M.M. Jacobs, "Computed relationships
   between the inherent and apparent optical properties of a flat homogeneous
   ocean", Appl. Opt. 14(2):417–427 (1975) (the ocean Monte Carlo this follows).
.. [Sp69] J. Spanier, E.M. Gelbard, *Monte Carlo Principles and Neutron Transport
   Problems*, Addison-Wesley (1969): point (next-event) estimators.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from rigsim.daylight.sky import BlackSky, SkyModel, sky_model
from rigsim.daylight.solar import SurfaceIrradiance, surface_irradiance
from rigsim.daylight.surface import Surface, fresnel_reflectance_unpolarised, refract
from rigsim.errors import ConfigError
from rigsim.spectrum import as_wavelengths
from rigsim.water.model import Water
from rigsim.scene.phase_tables import PhaseTables, phase_tables
from rigsim.water.phase import TabulatedPhase

__all__ = [
    "Bottom",
    "AmbientResult",
    "QUANTITIES",
    "UNITS",
    "DEFAULT_PHOTONS",
    "ambient_light_monte_carlo",
    "check_depths",
]

#: The reported quantities, in order.
QUANTITIES = ("Ed", "Eu", "Eo", "Eod", "Eou", "Lu", "Kd")
#: Their units.
UNITS = {"Ed": "W/(m2 nm)", "Eu": "W/(m2 nm)", "Eo": "W/(m2 nm)", "Eod": "W/(m2 nm)", "Eou": "W/(m2 nm)",
         "Lu": "W/(m2 sr nm)", "Kd": "1/m"}
#: Default photons per wavelength (a few seconds per wavelength on one core).
DEFAULT_PHOTONS = 100_000

_MU_FLOOR = 1e-3
_ROULETTE_WEIGHT = 1e-3
_ROULETTE_SURVIVAL = 0.1
_MAX_EVENTS = 20_000
_KD0_LAYER_M = 0.5
#: Lines of sight with |cos θ| below this use the equilibrium layer estimate in the angular tally.
_HORIZON_VZ = 0.1
#: Half-thickness of that layer (m; at most half the depth and one attenuation length).
_HORIZON_LAYER_M = 0.5


@dataclass(frozen=True)
class Bottom:
    """The sea floor.

    Attributes
    ----------
    depth_m
        Depth of the bottom (m, > 0); None for infinitely deep water.
    reflectance
        Lambertian (diffuse) reflectance in [0, 1]; 0 is a black bottom.
    """

    depth_m: float | None = None
    reflectance: float = 0.0

    def __post_init__(self):
        if self.depth_m is not None:
            d = float(self.depth_m)
            if not np.isfinite(d) or d <= 0:
                raise ConfigError(f"bottom depth must be > 0 m, got {self.depth_m}", field="bottom_depth_m",
                                  allowed="> 0 m, or none for infinitely deep water")
        r = float(self.reflectance)
        if not np.isfinite(r) or not 0.0 <= r <= 1.0:
            raise ConfigError(f"bottom reflectance must be in [0, 1], got {self.reflectance}",
                              field="bottom_reflectance", allowed="0 ≤ R ≤ 1")
        if self.depth_m is None and r != 0.0:
            raise ConfigError("a bottom reflectance needs a bottom depth", field="bottom_reflectance")

    def describe(self) -> str:
        if self.depth_m is None:
            return "infinitely deep"
        kind = "black" if self.reflectance == 0 else f"Lambertian R={self.reflectance:g}"
        return f"{kind} at {self.depth_m:g} m"


def check_depths(depth_m, bottom: Bottom = Bottom()) -> np.ndarray:
    """Validate tally depths (m): finite, >= 0, not below the bottom; returns a 1-D array."""
    try:
        d = np.atleast_1d(np.asarray(depth_m, float))
    except (TypeError, ValueError):
        raise ConfigError(f"cannot read depths {depth_m!r}", field="depths", allowed="numbers >= 0 (m)") from None
    if d.ndim != 1 or d.size == 0:
        raise ConfigError("need at least one depth", field="depths", allowed="numbers >= 0 (m)")
    if not np.all(np.isfinite(d)) or np.any(d < 0):
        raise ConfigError(f"depths must be finite and >= 0 m, got {d.tolist()}", field="depths",
                          allowed="numbers >= 0 (m)")
    if bottom.depth_m is not None and np.any(d > bottom.depth_m + 1e-12):
        raise ConfigError(f"depth {d.max():g} m is below the bottom at {bottom.depth_m:g} m", field="depths",
                          allowed=f"0 … {bottom.depth_m:g} m")
    return d


@dataclass(frozen=True, eq=False)
class AmbientResult:
    """Ambient light at depth: values and standard errors per depth and wavelength.

    Attributes
    ----------
    wavelength_nm, depth_m
        The axes (nm, m).
    values, stderr
        Quantity name (:data:`QUANTITIES`) → array (n_depth, n_wavelength) in
        :data:`UNITS`; ``stderr`` is the Monte Carlo standard error (zero for the Kd
        shortcut, which has a model error instead).
    above
        The plane irradiance just above the surface (sun + sky) that was used.
    budget
        Fractions of Ed(0+) per wavelength: ``reflected`` (by the surface),
        ``water_leaving``, ``absorbed_water``, ``absorbed_bottom`` (incl. a black
        bottom), ``lost`` (photons cut off after the event limit or, with no bottom,
        below the depth where they can no longer return).
    meta
        JSON-serialisable description of the run.
    """

    wavelength_nm: np.ndarray
    depth_m: np.ndarray
    values: dict[str, np.ndarray]
    stderr: dict[str, np.ndarray]
    above: SurfaceIrradiance
    budget: dict[str, np.ndarray] = field(default_factory=dict)
    meta: dict = field(default_factory=dict)
    #: The angular radiance tally (``angular_depth_m`` given): see :func:`ambient_light_monte_carlo`.
    angular: dict = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.values[name]

    def to_json(self) -> dict:
        """One JSON-ready object: ``wavelength_nm``, ``depth_m``, then per quantity a list (per depth)
        of lists (per wavelength), the same with ``_stderr``, the units and the run description."""
        out: dict = {"wavelength_nm": self.wavelength_nm.tolist(), "depth_m": self.depth_m.tolist()}
        for q in QUANTITIES:
            out[q] = _nan_to_none(self.values[q])
        for q in QUANTITIES:
            out[f"{q}_stderr"] = _nan_to_none(self.stderr[q])
        out["units"] = dict(UNITS)
        out["Ed_above_surface"] = self.above.total.tolist()
        out["Ed_above_surface_sky_fraction"] = self.above.sky_fraction.tolist()
        out["budget"] = {k: v.tolist() for k, v in self.budget.items()}
        out["meta"] = self.meta
        return out


def _nan_to_none(a: np.ndarray) -> list:
    return [[None if not np.isfinite(x) else float(x) for x in row] for row in np.asarray(a)]


class _PhaseAt:
    """The water's phase function at one wavelength, from the shared tables.

    :func:`rigsim.scene.phase_tables.phase_tables` (the decomposition the renderer and the fast
    engine use): the components' cell masses mixed with their weights at ``wl``, sampled and
    evaluated as a :class:`~rigsim.water.phase.TabulatedPhase` (cell by inverse CDF, uniform in
    cos ψ inside the cell; the value is the cell's density).
    """

    def __init__(self, tables: PhaseTables, wl: float):
        self.wl = float(wl)
        w = tables.weights_at([self.wl])[0]
        self.cells = TabulatedPhase(w @ tables.masses, tables.grid, name=tables.name)

    def sample(self, u: np.ndarray) -> np.ndarray:
        return np.asarray(self.cells.sample(u), float)

    def eval_fast(self, mu: np.ndarray, n: int = 4096) -> np.ndarray:
        """:meth:`eval` by linear interpolation in x = sin(ψ/2) on ``n`` nodes (for the local estimate)."""
        if getattr(self, "_lut", None) is None:
            x = np.linspace(0.0, 1.0, n)
            self._lut = np.asarray(self.eval(1.0 - 2.0 * x * x), float)
        lut = self._lut
        x = np.sqrt(np.clip(0.5 * (1.0 - mu), 0.0, 1.0)) * (lut.size - 1)
        i = np.minimum(x.astype(np.int64), lut.size - 2)
        f = x - i
        return lut[i] * (1.0 - f) + lut[i + 1] * f

    def eval(self, mu: np.ndarray) -> np.ndarray:
        return np.asarray(self.cells.eval(mu), float)


def _rotate(d: np.ndarray, cos_t: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Turn unit directions ``d`` by polar angle acos(cos_t) and azimuth ``phi`` about themselves."""
    sin_t = np.sqrt(np.clip(1.0 - cos_t * cos_t, 0.0, 1.0))
    cp, sp = np.cos(phi), np.sin(phi)
    ux, uy, uz = d[:, 0], d[:, 1], d[:, 2]
    out = np.empty_like(d)
    vert = np.abs(uz) > 0.99999
    den = np.sqrt(np.clip(1.0 - uz * uz, 1e-300, None))
    out[:, 0] = np.where(vert, sin_t * cp, sin_t * (ux * uz * cp - uy * sp) / den + ux * cos_t)
    out[:, 1] = np.where(vert, sin_t * sp, sin_t * (uy * uz * cp + ux * sp) / den + uy * cos_t)
    out[:, 2] = np.where(vert, np.sign(uz) * cos_t, -sin_t * cp * den + uz * cos_t)
    return out / np.linalg.norm(out, axis=1, keepdims=True)


@dataclass
class _Tally:
    batches: int
    depths: np.ndarray
    lu_cone_cos: float
    lu_cone_sr: float

    def __post_init__(self):
        shape = (self.batches, self.depths.size)
        for k in ("Ed", "Eu", "Eod", "Eou", "Lu_point", "Lu_cone"):
            setattr(self, k, np.zeros(shape))
        for k in ("reflected", "water_leaving", "absorbed_water", "absorbed_bottom", "lost"):
            setattr(self, k, np.zeros(self.batches))

    def setup_angular(self, depth_m: float, n_theta: int, n_phi: int):
        """Also tally the scattered radiance at ``depth_m`` in (θ, φ) bins of the *viewing* direction."""
        self.ang_depth = float(depth_m)
        self.n_theta, self.n_phi = int(n_theta), int(n_phi)
        self.L_ang = np.zeros((self.batches, self.n_theta * self.n_phi))
        self.beam_ang = np.zeros(self.batches)
        # bin-centre viewing directions (meter frame: z down, the sun towards −x; the +φ half — the
        # expected field is symmetric about the sun's plane, so one half is an unbiased estimate)
        th = (np.arange(self.n_theta) + 0.5) * np.pi / self.n_theta
        ph = (np.arange(self.n_phi) + 0.5) * np.pi / self.n_phi
        T, P = np.meshgrid(th, ph, indexing="ij")
        T, P = T.ravel(), P.ravel()
        self.view = np.stack([-np.sin(T) * np.cos(P), -np.sin(T) * np.sin(P), -np.cos(T)], axis=-1)
        self.L_local = np.zeros((self.batches, self.n_theta * self.n_phi))

    def sun_phase(self, pf, d_sun, sub: int = 8):
        """Bin-averaged phase function for light scattered out of the unscattered sun beam (per view bin)."""
        nt, nph = self.n_theta, self.n_phi
        g = (np.arange(sub) + 0.5) / sub
        te = np.linspace(0, np.pi, nt + 1)
        pe = np.linspace(0, np.pi, nph + 1)
        mu = np.cos(te[:-1])[:, None] + (np.cos(te[1:]) - np.cos(te[:-1]))[:, None] * g[None, :]
        ph = pe[:-1][:, None] + np.diff(pe)[:, None] * g[None, :]
        MU = mu[:, None, :, None]
        PH = ph[None, :, None, :]
        st = np.sqrt(np.clip(1 - MU * MU, 0, 1))
        # viewing direction v (meter frame) and propagation towards the detector −v
        vx, vy, vz = -st * np.cos(PH), -st * np.sin(PH), -MU * np.ones_like(PH)
        cos_psi = -(d_sun[0] * vx + d_sun[1] * vy + d_sun[2] * vz)
        self.p_sun = pf.eval(np.clip(cos_psi, -1, 1)).mean(axis=(2, 3)).ravel()

    def local_estimate(self, zc, d_in, wc, albedo, pf, c, nw, batch, unscattered_sun=None):
        """Point (local) estimate of the scattered radiance seen from the angular plane along each bin centre.

        A collision at depth z′ with weight w (before the albedo) adds
        ``w (b/c) p(ψ) e^{−c s}/|v_z|`` to the radiance seen looking along v if z′ lies
        on that line of sight, ``s = (z′ − z)/v_z``; lines of sight looking up are
        continued by their mirror image in the surface (Fresnel reflectance, 1 beyond
        the critical angle), ``s = (z + z′)/|v_z|``.
        """
        from rigsim.daylight.surface import fresnel_reflectance_unpolarised

        za = self.ang_depth
        V = self.view
        nb = V.shape[0]
        hor = np.abs(V[:, 2]) < _HORIZON_VZ
        iu = np.flatnonzero((V[:, 2] < 0) & ~hor)  # looking up
        idn = np.flatnonzero((V[:, 2] > 0) & ~hor)  # looking down
        ih = np.flatnonzero(hor)  # lines of sight within a few degrees of the horizon
        Vh = V[ih]
        dl = min(_HORIZON_LAYER_M, 0.5 * za, 1.0 / max(c, 1e-9))
        Vu, Vd = V[iu], V[idn]
        inv_u = 1.0 / np.abs(Vu[:, 2])
        inv_d = 1.0 / np.abs(Vd[:, 2])
        Vm = Vu * np.array([1.0, 1.0, -1.0])  # mirror image of an upward line of sight
        R = fresnel_reflectance_unpolarised(np.abs(Vu[:, 2]), nw, 1.0)
        cut = 30.0
        w_all = wc * albedo
        out = np.zeros((self.batches, nb))

        def add(rows, vals, cols):
            out[:, cols] += np.stack([vals[batch[rows] == k].sum(axis=0) for k in range(self.batches)])

        above = np.flatnonzero((zc < za) & (c * (za - zc) < cut))
        below = np.flatnonzero((zc > za) & (c * (zc - za) < cut))
        mir = np.flatnonzero(c * (za + zc) < cut)
        layer = np.flatnonzero(np.abs(zc - za) < dl)
        if ih.size and layer.size:
            # near the horizon the line-of-sight estimate's 1/|v_z| weights are wild; there the radiance is
            # the in-scattered source over c (equilibrium: L(h) does not change along a horizontal line),
            # J = Σ w (b/c) p(ψ) / (layer thickness), from the collisions in a thin layer around the plane
            for s0 in range(0, layer.size, 4096):
                r = layer[s0:s0 + 4096]
                vals = pf.eval_fast(np.clip(-(d_in[r] @ Vh.T), -1.0, 1.0))
                if unscattered_sun is not None:
                    us = unscattered_sun[r]
                    if np.any(us):
                        vals[us] = self.p_sun[ih][None, :]
                vals *= (w_all[r] / (2.0 * dl * max(c, 1e-12)))[:, None]
                add(r, vals, ih)
        for rows, VV, inv, dist_sign, cols, extra in (
                (above, Vu, inv_u, -1.0, iu, None),
                (below, Vd, inv_d, 1.0, idn, None),
                (mir, Vm, inv_u, None, iu, R)):
            for s0 in range(0, rows.size, 4096):
                r = rows[s0:s0 + 4096]
                zr = zc[r]
                if extra is None:
                    dist = dist_sign * (zr - za)  # ≥ 0 vertical distance
                else:
                    dist = za + zr
                vals = pf.eval_fast(np.clip(-(d_in[r] @ VV.T), -1.0, 1.0))
                if unscattered_sun is not None and extra is None:
                    # first scattering out of the sun beam: the bin-averaged phase function (keeps the forward peak)
                    us = unscattered_sun[r]
                    if np.any(us):
                        vals[us] = self.p_sun[cols][None, :]
                vals *= np.exp(-c * dist[:, None] * inv[None, :]) * inv[None, :]
                if extra is not None:
                    vals *= extra[None, :]
                vals *= w_all[r][:, None]
                add(r, vals, cols)
        self.L_local += out

    def local_bottom(self, H, wb, R_b, c, batch):
        """Bottom hits: ``w R/π e^{−c (H − z)/|v_z|}`` for lines of sight looking down."""
        vz = self.view[:, 2]
        att = np.where(vz > 0, np.exp(-c * (H - self.ang_depth) / np.maximum(np.abs(vz), 1e-6)), 0.0)
        per_b = np.bincount(batch, weights=wb * R_b / np.pi, minlength=self.batches)
        self.L_local += per_b[:, None] * att[None, :]

    def angular_crossings(self, z0, z1, d, w, batch, scattered):
        """Crossings of the angular plane: scattered photons → Σ w/|μ| per bin, unscattered → the beam."""
        za = self.ang_depth
        moved = z1 != z0
        hit = moved & (np.minimum(z0, z1) <= za) & (za <= np.maximum(z0, z1))
        if not np.any(hit):
            return
        i = np.flatnonzero(hit)
        di = d[i]
        inv_mu = 1.0 / np.maximum(np.abs(di[:, 2]), _MU_FLOOR)
        sc = scattered[i]
        if np.any(~sc):
            self.beam_ang += np.bincount(batch[i][~sc], weights=(w[i] * inv_mu)[~sc], minlength=self.batches)
        if np.any(sc):
            dd = di[sc]
            # viewing direction v = −d; its zenith angle from the scene's up: cos θ_v = d_z (z points down)
            th = np.arccos(np.clip(dd[:, 2], -1.0, 1.0))
            # azimuth of v from the direction towards the sun (−x), folded to [0, π]
            ph = np.arctan2(np.abs(dd[:, 1]), dd[:, 0])
            it = np.minimum((th / np.pi * self.n_theta).astype(np.int64), self.n_theta - 1)
            ip = np.minimum((ph / np.pi * self.n_phi).astype(np.int64), self.n_phi - 1)
            nb = self.n_theta * self.n_phi
            self.L_ang += np.bincount(batch[i][sc] * nb + it * self.n_phi + ip, weights=(w[i] * inv_mu)[sc],
                                      minlength=self.batches * nb).reshape(self.L_ang.shape)

    def add(self, name: str, batch: np.ndarray, cols: np.ndarray | None, w: np.ndarray):
        arr = getattr(self, name)
        nd = self.depths.size
        if cols is None:
            arr += np.bincount(batch, weights=w, minlength=self.batches)
        else:
            arr += np.bincount(batch * nd + cols, weights=w, minlength=self.batches * nd).reshape(arr.shape)

    def crossings(self, z0, z1, dz, w, batch):
        D = self.depths
        moved = z1 != z0
        down = (dz > 0) & moved
        up = (dz < 0) & moved
        lo, hi = np.minimum(z0, z1), np.maximum(z0, z1)
        hit = (lo[:, None] <= D[None, :]) & (D[None, :] <= hi[:, None])
        inv_mu = 1.0 / np.maximum(np.abs(dz), _MU_FLOOR)
        for mask, plane, scalar in ((down, "Ed", "Eod"), (up, "Eu", "Eou")):
            r, c = np.nonzero(hit & mask[:, None])
            if r.size:
                self.add(plane, batch[r], c, w[r])
                self.add(scalar, batch[r], c, w[r] * inv_mu[r])
                if plane == "Eu":
                    cone = -dz[r] >= self.lu_cone_cos
                    if np.any(cone):
                        self.add("Lu_cone", batch[r][cone], c[cone], w[r][cone] * inv_mu[r][cone] / self.lu_cone_sr)


def _one_wavelength(wl: float, a: float, b: float, phase: PhaseTables, e_sun: float, e_sky: float,
                    sky: SkyModel, sun_zenith_deg: float, surface: Surface, bottom: Bottom,
                    depths: np.ndarray, photons: int, batches: int, rng: np.random.Generator,
                    lu_cone_half_angle_deg: float, angular: tuple | None = None) -> tuple[_Tally, np.ndarray]:
    """Run one wavelength; tallies are in units of E(0+) per photon of each batch."""
    c = a + b
    albedo = b / c if c > 0 else 0.0
    nw = surface.n_water
    H = np.inf if bottom.depth_m is None else float(bottom.depth_m)
    R_b = float(bottom.reflectance)
    cone_cos = float(np.cos(np.radians(lu_cone_half_angle_deg)))
    tally = _Tally(batches, depths, cone_cos, 2.0 * np.pi * (1.0 - cone_cos))
    if angular is not None:
        tally.setup_angular(*angular)
    e0 = e_sun + e_sky
    n_batch = np.zeros(batches)
    if e0 <= 0 or photons <= 0:
        return tally, np.maximum(n_batch, 1)
    if not np.isfinite(H) and a <= 0:
        raise ConfigError("non-absorbing, infinitely deep water returns all light; give a bottom depth",
                          field="bottom_depth_m")
    pf = _PhaseAt(phase, wl)

    # ---- sources: sun and sky, stratified --------------------------------------------------------
    n_sky = int(round(photons * e_sky / e0)) if sky.emits else 0
    n_sky = min(max(n_sky, 1 if e_sky > 0 and sky.emits else 0), photons)
    n_sun = photons - n_sky
    if n_sun == 0 and e_sun > 0:
        n_sun, n_sky = 1, photons - 1
    ts = np.radians(sun_zenith_deg)
    d_sun = np.tile([np.sin(ts), 0.0, np.cos(ts)], (n_sun, 1))
    dirs = [d_sun]
    weights = [np.full(n_sun, (e_sun / e0) * photons / max(n_sun, 1))]
    if n_sky:
        mu, phi = sky.sample(n_sky, rng)
        st = np.sqrt(np.clip(1.0 - mu * mu, 0.0, 1.0))
        # φ is measured from the sun's azimuth; the sun's photons travel along +x (the sun lies towards
        # −x), so a sky element at φ sends photons along +(cos φ, sin φ) horizontally
        dirs.append(np.stack([st * np.cos(phi), st * np.sin(phi), mu], axis=-1))
        weights.append(np.full(n_sky, (e_sky / e0) * photons / n_sky))
    d = np.concatenate(dirs)
    w = np.concatenate(weights)
    if e_sky > 0 and not sky.emits:
        raise ConfigError("sky irradiance given for a black sky", field="sky")
    batch = np.arange(photons) % batches
    n_batch = np.bincount(batch, minlength=batches).astype(float)

    # ---- entry through the surface ------------------------------------------------------------
    nrm, fw = surface.sample_normals(d, rng)
    cos_i = np.clip(-np.sum(d * nrm, axis=1), 0.0, 1.0)
    R = fresnel_reflectance_unpolarised(cos_i, 1.0, nw)
    w = w * fw
    tally.add("reflected", batch, None, w * R)
    w = w * (1.0 - R)
    d, _ = refract(d, nrm, 1.0 / nw)
    d[:, 2] = np.maximum(np.abs(d[:, 2]), 1e-9)  # a steep facet's transmitted ray mirrored back down
    z = np.zeros(photons)
    # photons that met a facet of a rough surface count as scattered (they left the beam direction)
    scat = np.zeros(photons, bool) if surface.flat else np.ones(photons, bool)
    sky_ph = np.zeros(photons, bool)
    sky_ph[n_sun:] = True
    scat[n_sun:] = True  # sky photons are diffuse light from the start
    if angular is not None and n_sun:
        tally.sun_phase(pf, d[0] if surface.flat else np.array([np.sin(np.arcsin(np.sin(ts) / nw)), 0.0,
                                                                  np.cos(np.arcsin(np.sin(ts) / nw))]))
    keep = w > 0
    z, d, w, batch, scat, sky_ph = z[keep], d[keep], w[keep], batch[keep], scat[keep], sky_ph[keep]

    z_cut = np.inf
    if not np.isfinite(H):
        z_cut = float(depths.max()) + 25.0 / a  # below: return weight < e^-25

    events = 0
    while w.size and events < _MAX_EVENTS:
        events += 1
        n = w.size
        s = -np.log1p(-rng.random(n)) / c if c > 0 else np.full(n, np.inf)
        dz = d[:, 2]
        with np.errstate(invalid="ignore"):
            z1 = z + s * dz
        z1 = np.where(np.isnan(z1), z, z1)
        to_surf = z1 <= 0.0
        to_bot = z1 >= H
        z1 = np.where(to_surf, 0.0, np.where(to_bot, H, z1))
        tally.crossings(z, z1, dz, w, batch)
        if angular is not None:
            tally.angular_crossings(z, z1, d, w, batch, scat)
        z = z1
        coll = ~(to_surf | to_bot)

        # -- collisions in the water
        if np.any(coll) and c > 0:
            ic = np.flatnonzero(coll)
            wc, zc = w[ic], z[ic]
            above = depths[None, :] < zc[:, None]
            r, col = np.nonzero(above)
            if r.size:
                p_up = pf.eval(-d[ic, 2])
                contrib = wc[r] * albedo * p_up[r] * np.exp(-c * (zc[r] - depths[col]))
                tally.add("Lu_point", batch[ic][r], col, contrib)
            if angular is not None:
                tally.local_estimate(zc, d[ic], wc, albedo, pf, c, nw, batch[ic], ~scat[ic] & ~sky_ph[ic])
            tally.add("absorbed_water", batch[ic], None, wc * (1.0 - albedo))
            w[ic] = wc * albedo
            scat[ic] = True
            cos_t = pf.sample(rng.random(ic.size))
            d[ic] = _rotate(d[ic], cos_t, 2.0 * np.pi * rng.random(ic.size))

        # -- the surface from below
        if np.any(to_surf):
            i_s = np.flatnonzero(to_surf)
            ds = d[i_s]
            nrm, fw = surface.sample_normals(ds, rng)
            cos_i = np.clip(-np.sum(ds * nrm, axis=1), 0.0, 1.0)
            Rs = fresnel_reflectance_unpolarised(cos_i, nw, 1.0)
            w[i_s] *= fw
            refl = rng.random(i_s.size) < Rs
            out = i_s[~refl]
            tally.add("water_leaving", batch[out], None, w[out])
            w[out] = 0.0
            ir = i_s[refl]
            if ir.size:
                scat[ir] = True
                d[ir] = ds[refl] - 2.0 * np.sum(ds[refl] * nrm[refl], axis=1, keepdims=True) * nrm[refl]

        # -- the bottom
        if np.any(to_bot):
            ib = np.flatnonzero(to_bot)
            wb = w[ib]
            if R_b > 0:
                r, col = np.nonzero(np.ones((ib.size, depths.size), bool))
                contrib = wb[r] * R_b / np.pi * np.exp(-c * (H - depths[col]))
                tally.add("Lu_point", batch[ib][r], col, contrib)
            if angular is not None and R_b > 0:
                tally.local_bottom(H, wb, R_b, c, batch[ib])
            tally.add("absorbed_bottom", batch[ib], None, wb * (1.0 - R_b))
            w[ib] = wb * R_b
            scat[ib] = True
            mu = np.sqrt(rng.random(ib.size))
            phi = 2.0 * np.pi * rng.random(ib.size)
            st = np.sqrt(1.0 - mu * mu)
            d[ib] = np.stack([st * np.cos(phi), st * np.sin(phi), -mu], axis=-1)

        # -- too deep to matter (infinitely deep water only)
        deep = z > z_cut
        if np.any(deep):
            tally.add("lost", batch[deep], None, w[deep])
            w[deep] = 0.0

        # -- Russian roulette
        low = (w > 0) & (w < _ROULETTE_WEIGHT)
        if np.any(low):
            il = np.flatnonzero(low)
            survive = rng.random(il.size) < _ROULETTE_SURVIVAL
            w[il[survive]] /= _ROULETTE_SURVIVAL
            w[il[~survive]] = 0.0

        alive = w > 0
        if not np.all(alive):
            z, d, w, batch, scat, sky_ph = z[alive], d[alive], w[alive], batch[alive], scat[alive], sky_ph[alive]
    if w.size:
        tally.add("lost", batch, None, w)
    return tally, n_batch


def ambient_light_monte_carlo(water: Water, wavelength_nm, depth_m, *, sun_zenith_deg: float = 30.0,
                              sky: str | SkyModel = "cie", above: SurfaceIrradiance | None = None,
                              surface: Surface | None = None, bottom: Bottom | None = None,
                              photons: int = DEFAULT_PHOTONS, batches: int = 10, seed: int = 0,
                              lu_method: str = "point", lu_cone_half_angle_deg: float = 10.0,
                              angular_depth_m: float | None = None, n_theta: int = 36,
                              n_phi: int = 6) -> AmbientResult:
    """Ambient daylight at depth by Monte Carlo through the water column (see module docstring).

    Parameters
    ----------
    water
        The water (its a, b and phase function at each wavelength).
    wavelength_nm
        Wavelengths, nm (each is run separately).
    depth_m
        Depths of the tally planes, m (>= 0; 0 means just below the surface).
    sun_zenith_deg
        Sun zenith above the surface, deg in [0, 90).
    sky
        A :class:`~rigsim.daylight.sky.SkyModel` or a name (``black``, ``uniform``,
        ``cie``, ``cie:N``).
    above
        Plane irradiance just above the surface split into sun and sky
        (:func:`~rigsim.daylight.solar.surface_irradiance`); default the ASTM G173
        clear-sky model for this sun (with no sky light for a black sky).
    surface
        Flat (default) or Cox–Munk :class:`~rigsim.daylight.surface.Surface`.
    bottom
        :class:`Bottom` (default: infinitely deep).
    photons
        Photons per wavelength (>= batches).
    batches
        Number of batches for the standard errors (>= 2).
    seed
        Random seed.
    lu_method
        ``"point"`` (next-event estimator, default) or ``"cone"``.
    lu_cone_half_angle_deg
        Half-angle of the cone estimator, deg.
    angular_depth_m
        Also tally the angular radiance distribution at this depth (m, > 0): the
        result's ``angular`` dict holds ``radiance`` (n_wavelength, n_theta, n_phi),
        W·m⁻²·sr⁻¹·nm⁻¹, the radiance *seen looking* in bins of the viewing
        direction's zenith angle θ (from straight up, ``theta_edges_rad``, uniform in
        θ) and of its azimuth from the direction towards the sun (``phi_edges_rad``,
        uniform on [0, π], the field being symmetric about the sun's vertical plane);
        only photons that were scattered (by the water, the bottom, a rough surface or
        an internal reflection) count — the unscattered sun beam is a delta, tallied
        as ``beam_normal`` (irradiance normal to the beam).  Estimator: every
        crossing of the plane adds ``w/|μ|`` to its bin, divided by the bin's solid
        angle, so ``Σ L ΔΩ + beam_normal`` is exactly the scalar irradiance Eo
        (unscattered sky light counts as diffuse here).  ``radiance_scattered``:
        the light scattered at least once (by the water or the bottom) seen along
        each bin's centre directions, by a point (local) estimate — every collision
        adds its expected in-scattered radiance along the line of sight (continued
        by its mirror image in the surface), every bottom hit its Lambertian
        radiance — smooth and of low variance even at the horizon, where plane
        crossings are rare; it excludes the unscattered sky seen through Snell's
        window (:func:`rigsim.daylight.field.angular_field_monte_carlo` adds it).
        Standard errors (``*_stderr``) as for the other quantities.
    n_theta, n_phi
        Bins of the angular tally.
    """
    wl = np.atleast_1d(water.check_range(as_wavelengths(wavelength_nm)))
    bottom = bottom or Bottom()
    surface = surface or Surface()
    depths = check_depths(depth_m, bottom)
    if isinstance(sky, str):
        sky = sky_model(sky, sun_zenith_deg)
    photons, batches = int(photons), int(batches)
    if batches < 2:
        raise ConfigError(f"need at least 2 batches, got {batches}", field="batches", allowed=">= 2")
    if photons < batches:
        raise ConfigError(f"need at least as many photons as batches ({batches}), got {photons}",
                          field="photons", allowed=f">= {batches}")
    from rigsim.resources import check_memory

    # every photon of a wavelength is traced at once: ~360 B of state plus a tally per depth (measured)
    check_memory(photons * (360 + 40 * (depths.size + 2)), f"{photons:g} photons at {depths.size} depths",
                 field="photons")
    if lu_method not in ("point", "cone"):
        raise ConfigError(f"unknown Lu estimator {lu_method!r}", field="lu_method", allowed="point, cone")
    if not 0.0 < float(lu_cone_half_angle_deg) <= 30.0:
        raise ConfigError("Lu cone half-angle must be in (0, 30] deg", field="lu_cone_half_angle_deg")
    if above is None:
        above = surface_irradiance(wl, sun_zenith_deg, black_sky=isinstance(sky, BlackSky))
    elif not np.allclose(above.wavelength_nm, wl):
        raise ConfigError("surface irradiance was given at other wavelengths", field="above")
    if isinstance(sky, BlackSky) and np.any(above.sky > 0):
        raise ConfigError("a black sky cannot carry sky irradiance; use --sky uniform or cie", field="sky")

    angular = None
    if angular_depth_m is not None:
        za = float(angular_depth_m)
        if not np.isfinite(za) or za <= 0 or (bottom.depth_m is not None and za >= bottom.depth_m):
            raise ConfigError(f"angular tally depth must be > 0 m and above the bottom, got {angular_depth_m}",
                              field="angular_depth_m")
        if int(n_theta) < 2 or int(n_theta) % 2 or int(n_phi) < 1:
            raise ConfigError("need an even n_theta >= 2 (a bin edge at the horizon) and n_phi >= 1",
                              field="n_theta")
        angular = (za, int(n_theta), int(n_phi))
        ang_b = np.zeros((batches, wl.size, int(n_theta) * int(n_phi)))
        loc_b = np.zeros((batches, wl.size, int(n_theta) * int(n_phi)))
        beam_b = np.zeros((batches, wl.size))
    kd0_depth = _KD0_LAYER_M if bottom.depth_m is None else min(_KD0_LAYER_M, float(bottom.depth_m))
    all_depths = np.concatenate([depths, [0.0, kd0_depth]])
    n_d = depths.size
    a_all, b_all = water.a_per_m(wl), water.b_per_m(wl)
    per_batch = {k: np.zeros((batches, n_d + 2, wl.size)) for k in ("Ed", "Eu", "Eod", "Eou", "Lu")}
    budget_b = {k: np.zeros((batches, wl.size)) for k in
                ("reflected", "water_leaving", "absorbed_water", "absorbed_bottom", "lost")}
    t0 = time.perf_counter()
    tables = phase_tables(water.phase, water.wavelength_range_nm)
    for j, lam in enumerate(wl):
        rng = np.random.default_rng(np.random.SeedSequence([int(seed), int(round(1000 * lam))]))
        tally, nb = _one_wavelength(float(lam), float(a_all[j]), float(b_all[j]), tables,
                                    float(above.sun[j]), float(above.sky[j]), sky, float(sun_zenith_deg),
                                    surface, bottom, all_depths, photons, batches, rng,
                                    float(lu_cone_half_angle_deg), angular)
        e0 = float(above.total[j])
        scale = e0 / nb[:, None]
        per_batch["Ed"][:, :, j] = tally.Ed * scale
        per_batch["Eu"][:, :, j] = tally.Eu * scale
        per_batch["Eod"][:, :, j] = tally.Eod * scale
        per_batch["Eou"][:, :, j] = tally.Eou * scale
        per_batch["Lu"][:, :, j] = (tally.Lu_point if lu_method == "point" else tally.Lu_cone) * scale
        for k in budget_b:
            budget_b[k][:, j] = getattr(tally, k) / nb
        if angular is not None:
            ang_b[:, j, :] = tally.L_ang * scale
            loc_b[:, j, :] = tally.L_local * scale
            beam_b[:, j] = tally.beam_ang * scale[:, 0]
    elapsed = time.perf_counter() - t0
    ang_out: dict = {}
    if angular is not None:
        za, nt, nph = angular
        te = np.linspace(0.0, np.pi, nt + 1)
        pe = np.linspace(0.0, np.pi, nph + 1)
        # solid angle of a bin: both halves φ ∈ ±[φ0, φ1] (the field is folded about the sun's plane)
        d_omega = (2.0 * np.diff(pe))[None, :] * (np.cos(te[:-1]) - np.cos(te[1:]))[:, None]
        rad_b = ang_b.reshape(batches, wl.size, nt, nph) / d_omega
        loc = loc_b.reshape(batches, wl.size, nt, nph)
        ang_out = {"depth_m": za, "theta_edges_rad": te, "phi_edges_rad": pe, "solid_angle_sr": d_omega,
                   "radiance": rad_b.mean(axis=0),
                   "radiance_stderr": rad_b.std(axis=0, ddof=1) / np.sqrt(batches),
                   "radiance_scattered": loc.mean(axis=0),
                   "radiance_scattered_stderr": loc.std(axis=0, ddof=1) / np.sqrt(batches),
                   "beam_normal": beam_b.mean(axis=0),
                   "beam_normal_stderr": beam_b.std(axis=0, ddof=1) / np.sqrt(batches)}

    per_batch["Eo"] = per_batch["Eod"] + per_batch["Eou"]
    values, stderr = {}, {}
    for q in ("Ed", "Eu", "Eo", "Eod", "Eou", "Lu"):
        pb = per_batch[q]
        values[q] = pb.mean(axis=0)[:n_d]
        stderr[q] = (pb.std(axis=0, ddof=1) / np.sqrt(batches))[:n_d]
    # Kd: layer mean from 0- to z (z = 0: the top kd0_depth metres), per batch for the error
    ed = per_batch["Ed"]
    ed0 = ed[:, n_d, :]
    zz = np.where(depths > 0, depths, kd0_depth)
    ed_z = np.where((depths > 0)[None, :, None], ed[:, :n_d, :], ed[:, n_d + 1: n_d + 2, :])
    with np.errstate(divide="ignore", invalid="ignore"):
        ed_mean = ed.mean(axis=0)
        ed_z_mean = np.where((depths > 0)[:, None], ed_mean[:n_d], ed_mean[n_d + 1][None, :])
        values["Kd"] = -np.log(ed_z_mean / ed_mean[n_d][None, :]) / zz[:, None]
        # delta method with the batch covariance of Ed(z) and Ed(0-) (always finite when Ed(z) > 0)
        dz_ = ed_z - ed_z.mean(axis=0)
        d0_ = (ed0 - ed0.mean(axis=0))[:, None, :]
        var_z = np.sum(dz_ ** 2, axis=0) / (batches - 1) / batches
        var_0 = np.sum(d0_ ** 2, axis=0) / (batches - 1) / batches
        cov = np.sum(dz_ * d0_, axis=0) / (batches - 1) / batches
        var_ln = var_z / ed_z_mean ** 2 + var_0 / ed_mean[n_d][None, :] ** 2 \
            - 2 * cov / (ed_z_mean * ed_mean[n_d][None, :])
        stderr["Kd"] = np.sqrt(np.maximum(var_ln, 0.0)) / zz[:, None]
    budget = {k: v.mean(axis=0) for k, v in budget_b.items()}
    meta = {
        "model": "monte-carlo",
        "water": water.describe(),
        "sun_zenith_deg": float(sun_zenith_deg),
        "sky": sky.describe(),
        "surface": surface.describe(),
        "bottom": bottom.describe(),
        "above_surface_spectrum": above.spectrum,
        "photons_per_wavelength": photons,
        "batches": batches,
        "seed": int(seed),
        "lu_method": lu_method,
        "kd": "layer mean -ln(Ed(z)/Ed(0-))/z; at z=0 over the top %g m" % kd0_depth,
        "seconds": round(elapsed, 3),
    }
    if angular is not None:
        meta["angular"] = {"depth_m": angular[0], "n_theta": angular[1], "n_phi": angular[2]}
    return AmbientResult(wl, depths, values, stderr, above, budget, meta, ang_out)
