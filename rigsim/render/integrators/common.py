"""What rigsim's two integrators share: MIS weights, light connections, roulette, sampling tables.

* :func:`mis_weight`, :func:`mis_weight_over_pdf` — the power (β = 2) or balance heuristic of
  Veach & Guibas (1995), the second in the form ``w/p`` that stays finite for tiny ``p``;
* :func:`russian_roulette` — survive with ``q = min(max_i β_i / threshold, 0.95)``;
* :func:`medium_interaction`, :func:`connect_light` — a vertex in the water, and the unoccluded,
  attenuated light of a point emitter there (analytic transmittance ``exp(−σ_t r)``);
* :func:`equiangular_sample` / :class:`Segment` — Kulla & Fajardo (2012) distances toward a light,
  optionally phase-weighted (:class:`PhaseAngleTable`); :class:`AureoleTable`, :func:`cone_sample`
  — directions around a light; :func:`target_table`, :func:`sample_target_point` — points on the
  targets;
* :func:`water_phase` — the medium's phase function as the rigsim plugin
  (:class:`~rigsim.render.phase_plugin.WaterPhaseFunction`), whose tables the sampling tables read
  through its public interface.

References
----------
Kulla, C. & Fajardo, M. (2012). Importance sampling techniques for path tracing in participating
media. *Computer Graphics Forum* 31(4), 1519–1528.

Veach, E. & Guibas, L. J. (1995). Optimally combining sampling techniques for Monte Carlo
rendering. *SIGGRAPH '95*, 419–428.
"""

from __future__ import annotations

import weakref

import numpy as np

from rigsim.errors import ConfigError
from rigsim.render.phase_plugin import WaterPhaseFunction
from rigsim.render.variant import mitsuba

__all__ = ["mis_weight", "mis_weight_over_pdf", "russian_roulette", "medium_interaction", "connect_light",
           "equiangular_sample", "equiangular_pdf", "Segment", "PhaseAngleTable", "AureoleTable", "cone_sample",
           "cone_pdf", "target_table", "sample_target_point", "reflects", "dot4", "channel", "water_phase",
           "phase_angle_table", "aureole_table", "MIS_HEURISTICS", "T_CAP_OPTICAL_DEPTH"]

mi, dr = mitsuba()

#: Equiangular samples stop at this optical depth of the least attenuated wavelength.
T_CAP_OPTICAL_DEPTH = 30.0
#: The multiple-importance-sampling heuristics (Veach & Guibas 1995).
MIS_HEURISTICS = ("power", "balance")
#: Smallest distance of a light from a ray line used by equiangular sampling (m).
_D_MIN = 1e-6


# ---------------------------------------------------------------------------------------
# MIS, roulette, vertices, light connections
# ---------------------------------------------------------------------------------------
def mis_weight(pdf_a, pdf_b, heuristic: str = "power"):
    """Weight of technique a against b: ``p_a²/(p_a² + p_b²)`` (power) or ``p_a/(p_a + p_b)`` (balance)."""
    if heuristic == "power":
        a2, b2 = pdf_a * pdf_a, pdf_b * pdf_b
        w = a2 / (a2 + b2)
    else:
        w = pdf_a / (pdf_a + pdf_b)
    return dr.select(dr.isfinite(w), w, 0.0)


def mis_weight_over_pdf(pdf_a, pdf_b, heuristic: str = "power"):
    """``mis_weight(p_a, p_b) / p_a`` in a form that stays finite for tiny ``p_a``:
    ``p_a/(p_a² + p_b²)`` (power) or ``1/(p_a + p_b)`` (balance); 0 where not finite."""
    if heuristic == "power":
        w = pdf_a / (pdf_a * pdf_a + pdf_b * pdf_b)
    else:
        w = 1.0 / (pdf_a + pdf_b)
    return dr.select(dr.isfinite(w), w, 0.0)


def russian_roulette(sampler, beta, depth, start_depth, threshold: float, active):
    """From ``depth > start_depth`` on, survive with ``q = min(max_i β_i / threshold, 0.95)``.

    Returns ``(active, beta)``: the survivors and their weights divided by ``q``.  A threshold
    below 1 lifts a path whose weight fell low only to ``threshold``, not to a full-weight path.
    """
    q = dr.minimum(dr.max(beta) * (1.0 / threshold), 0.95)
    rr = depth > start_depth
    active = active & ((sampler.next_1d(active) < q) | ~rr)
    beta = dr.select(rr & active, beta / q, beta)
    return active, beta


def medium_interaction(p, d, t, wavelengths, time, medium_ptr):
    """A medium interaction at ``p`` on a ray travelling along ``d`` (``wi = −d``, Mitsuba's frame)."""
    mei = dr.zeros(mi.MediumInteraction3f)
    mei.p = p
    mei.t = t
    mei.wi = -d
    mei.sh_frame = mi.Frame3f(mei.wi)
    mei.wavelengths = wavelengths
    mei.time = time
    mei.medium = medium_ptr
    return mei


def connect_light(scene, it, emitter, sigma_t, active):
    """Unoccluded, attenuated light of ``emitter`` at interaction ``it``: (value, direction sample)."""
    ds, val = emitter.sample_direction(it, mi.Point2f(0.5), active)
    if sigma_t is not None:
        val = val * dr.exp(-sigma_t * ds.dist)
    occluded = scene.ray_test(it.spawn_ray_to(ds.p), active)
    return dr.select(active & ~occluded, val, 0.0), ds


def water_phase(phase) -> WaterPhaseFunction:
    """The medium's phase function, which must be the rigsim water plugin (its tables drive sampling)."""
    if not isinstance(phase, WaterPhaseFunction):
        raise ConfigError(f"the rigsim integrator needs the rigsim water phase function, got {type(phase).__name__}",
                          field="integrator", allowed="volpath for other phase functions")
    return phase


# ---------------------------------------------------------------------------------------
# Equiangular sampling (Kulla & Fajardo 2012), optionally phase-weighted
# ---------------------------------------------------------------------------------------
def _equiangular_frame(o, d, p_light, t_max):
    delta = dr.dot(p_light - o, d)
    D = dr.maximum(dr.norm(p_light - (o + d * delta)), _D_MIN)
    th_a = dr.atan2(-delta, D)
    th_b = dr.atan2(t_max - delta, D)
    return delta, D, th_a, th_b


def equiangular_sample(o, d, p_light, t_max, u):
    """Distance ``t ∈ [0, t_max]`` along ``o + t d`` with density ∝ 1/(distance to the light)².

    Parameters
    ----------
    o, d
        Ray origin and unit direction.
    p_light
        Light position.
    t_max
        End of the segment (finite, ≥ 0).
    u
        Uniform number in [0, 1).

    Returns
    -------
    (t, pdf)
        The distance (m) and its density (1/m), ``D / ((θ_b − θ_a)(D² + (t − Δ)²))``.
    """
    delta, D, th_a, th_b = _equiangular_frame(o, d, p_light, t_max)
    dth = th_b - th_a
    th = dr.fma(u, dth, th_a)
    s, c = dr.sincos(th)
    t = dr.clip(delta + D * s / c, 0.0, t_max)
    # D² + (t − Δ)² = D²/cos² θ
    pdf = dr.select(dth > 0, c * c / (D * dth), 0.0)
    return t, pdf


def equiangular_pdf(o, d, p_light, t_max, t):
    """Density of :func:`equiangular_sample` at ``t`` (0 outside [0, t_max])."""
    delta, D, th_a, th_b = _equiangular_frame(o, d, p_light, t_max)
    dth = th_b - th_a
    x = t - delta
    pdf = D / (dth * (D * D + x * x))
    return dr.select((dth > 0) & (t >= 0) & (t <= t_max), pdf, 0.0)


class PhaseAngleTable:
    """The water phase function as a density in the scattering angle ψ (per radian).

    Along a ray passing a point light at distance ``D``, the equiangular angle θ
    (``t = Δ + D tan θ``) and the single-scattering angle ψ toward the ray's origin
    are related by ``ψ = θ + π/2``; the light scattered at ``x(t)`` is
    ``∝ p(ψ)/r²`` and ``dt = r²/D dθ``, so in θ the integrand is the phase function
    itself, ``p(θ + π/2)/D`` (times transmittance and the beam pattern).  Sampling θ
    ∝ ``p̄(ψ)``, the phase function averaged over the path's wavelengths, removes the
    forward peak's variance (double scattering near a strobe: the fireflies left by
    plain equiangular sampling).

    Built from a :class:`~rigsim.render.phase_plugin.WaterPhaseFunction`: the
    plugin's realised per-cell densities (constant in each cell of its ψ grid), so
    ``p̄`` is exactly the plugin's ``eval`` averaged over wavelengths (without its
    defensive uniform share).
    """

    def __init__(self, phase):


        psi, dens = phase.cell_edges_rad, phase.cell_densities  # (n + 1,), (K, n) 1/sr
        K = phase.n_components
        cdf = np.concatenate([np.zeros((K, 1)), np.cumsum(dens * np.diff(psi)[None, :], axis=1)], axis=1)
        self.phase = phase
        self.K, self.n = K, dens.shape[1]
        self.psi_lo = mi.Float(psi[:-1].astype(np.float32))
        self.dens = mi.Float(dens.astype(np.float32).ravel())
        self.cdf = mi.Float(cdf.astype(np.float32).ravel())

    def weights(self, wavelengths):
        """w̄_k: component weights averaged over the path's wavelengths."""
        return self.phase.component_weights(wavelengths)[1]

    def _cdf_at(self, k, psi):
        j = self.phase.cell_of(psi)
        c = dr.gather(mi.Float, self.cdf, k * (self.n + 1) + j)
        p = dr.gather(mi.Float, self.dens, k * self.n + j)
        return c + p * (psi - dr.gather(mi.Float, self.psi_lo, j))

    def masses(self, wbar, psi_a, psi_b):
        """(Z_k = w̄_k ∫_{ψa}^{ψb} p_k dψ for each k, Z = Σ Z_k)."""
        zk = [dr.maximum(wbar[k] * (self._cdf_at(k, psi_b) - self._cdf_at(k, psi_a)), 0.0) for k in range(self.K)]
        z = zk[0]
        for k in range(1, self.K):
            z = z + zk[k]
        return zk, z

    def density(self, wbar, psi):
        """p̄(ψ) = Σ_k w̄_k p_k(ψ) (1/sr, as a density per radian once divided by Z)."""
        j = self.phase.cell_of(psi)
        out = mi.Float(0.0)
        for k in range(self.K):
            out = dr.fma(wbar[k], dr.gather(mi.Float, self.dens, k * self.n + j), out)
        return out

    def sample(self, wbar, psi_a, psi_b, zk, z, u1, u2):
        """ψ ∈ [ψa, ψb] with density p̄(ψ)/Z."""
        k = mi.UInt32(self.K - 1)
        acc = mi.Float(0.0)
        target = u1 * z
        for c in range(self.K - 1):
            acc = acc + zk[c]
            k = dr.select((target < acc) & (k == self.K - 1), mi.UInt32(c), k)
        # inverse CDF inside component k, restricted to [ψa, ψb]
        ca = self._cdf_at(k, psi_a)
        cb = self._cdf_at(k, psi_b)
        c = dr.fma(u2, cb - ca, ca)
        base = k * (self.n + 1)
        j = dr.binary_search(0, self.n, lambda i: dr.gather(mi.Float, self.cdf, base + i) <= c)
        j = mi.UInt32(dr.clip(mi.Int32(j) - 1, 0, self.n - 1))
        c0 = dr.gather(mi.Float, self.cdf, base + j)
        p = dr.gather(mi.Float, self.dens, k * self.n + j)
        psi = dr.gather(mi.Float, self.psi_lo, j) + dr.select(p > 0, (c - c0) / p, 0.0)
        return dr.clip(psi, psi_a, psi_b)


def cone_sample(axis, u):
    """Direction at angle α = π u.x from ``axis``, azimuth 2π u.y: density 1/(2π² sin α) ∝ 1/α near the axis."""
    a = dr.pi * u.x
    sa, ca = dr.sincos(a)
    sp, cp = dr.sincos(2.0 * dr.pi * u.y)
    return mi.Frame3f(axis).to_world(mi.Vector3f(sa * cp, sa * sp, ca))


def cone_pdf(axis, w):
    """Solid-angle density of :func:`cone_sample` at unit direction ``w``."""
    sa = dr.norm(dr.cross(axis, w))
    return dr.select(sa > 0, 1.0 / (2.0 * dr.pi * dr.pi * sa), 0.0)


class AureoleTable:
    """Directions around a light with the shape of its aureole in forward-scattering water.

    A ray that leaves ``x`` at angle α from the direction to a point light at distance
    ``r`` collects, by single scattering along it, ``≈ I σ_s/(r sin α) ∫_α^π p(ψ) dψ``
    (the equiangular integral: ``ψ`` runs from α at ``x`` to π far beyond the light).
    For a phase function with a forward peak steeper than ``1/ψ`` that falls off faster
    than the ``1/α`` of :func:`cone_sample` — the infinite-variance tail of double
    scattering near a strobe.  This table samples α with density per radian
    ``G(α)/N``, ``G(α) = ∫_α^π p̄(ψ) dψ``, ``N = ∫_0^π G dα = ∫_0^π ψ p̄(ψ) dψ``
    (``p̄``: the water's phase function averaged over its tabulated wavelengths), which
    makes that light constant per sample up to transmittance and the beam pattern.

    ``G`` is piecewise linear on the phase function's ψ cells; the table uses its cell
    averages (piecewise-constant density in α, uniform inside a cell), and the
    solid-angle density is ``g(α) / (2π sin α)``.
    """

    def __init__(self, phase):


        edges, dens_k = phase.cell_edges_rad, phase.cell_densities
        wbar = np.asarray(phase.tables.weights, np.float64).mean(axis=0)[:phase.n_components]
        dens = (wbar[:, None] * dens_k).sum(0)  # p̄ per cell, 1/sr
        dpsi = np.diff(edges)
        G = np.concatenate([np.cumsum((dens * dpsi)[::-1])[::-1], [0.0]])  # G at the cell edges
        mass = 0.5 * (G[:-1] + G[1:]) * dpsi
        mass = np.maximum(mass, 1e-12 * mass.sum())
        cdf = np.concatenate([[0.0], np.cumsum(mass)])
        cdf /= cdf[-1]
        self.phase = phase
        self.n = len(dpsi)
        self.edges = mi.Float(edges.astype(np.float32))
        self.cdf = mi.Float(cdf.astype(np.float32))
        self.g = mi.Float((np.diff(cdf) / dpsi).astype(np.float32))  # density per radian

    def sample(self, axis, u1, u2):
        j = dr.binary_search(0, self.n, lambda i: dr.gather(mi.Float, self.cdf, i) <= u1)
        j = mi.UInt32(dr.clip(mi.Int32(j) - 1, 0, self.n - 1))
        c0 = dr.gather(mi.Float, self.cdf, j)
        c1 = dr.gather(mi.Float, self.cdf, j + 1)
        a0 = dr.gather(mi.Float, self.edges, j)
        a1 = dr.gather(mi.Float, self.edges, j + 1)
        f = dr.select(c1 > c0, (u1 - c0) / (c1 - c0), 0.5)
        a = dr.clip(dr.fma(dr.clip(f, 0.0, 1.0), a1 - a0, a0), 0.0, dr.pi)
        sa, ca = dr.sincos(a)
        sp, cp = dr.sincos(2.0 * dr.pi * u2)
        return mi.Frame3f(axis).to_world(mi.Vector3f(sa * cp, sa * sp, ca))

    def pdf(self, axis, w):
        sa = dr.norm(dr.cross(axis, w))
        a = dr.atan2(sa, dr.dot(axis, w))
        g = dr.gather(mi.Float, self.g, self.phase.cell_of(a))
        return dr.select(sa > 0, g / (2.0 * dr.pi * sa), 0.0)


def target_table(scene):
    """``(ShapePtr array, DiscreteDistribution over areas, 1/total area)`` of the scene's opaque
    shapes (the targets), or None if it has none.  The discrete particles (the shape with id
    ``"particles"``, :mod:`rigsim.render.mitsuba_scene`) are not targets: the light they reflect
    is reached by the paths' own continuations, not by this next-event estimate."""
    shapes = [sh for sh in scene.shapes() if not mi.has_flag(sh.bsdf().flags(), mi.BSDFFlags.Null)
              and sh.id() != "particles"]
    if not shapes:
        return None
    areas = np.array([float(np.asarray(sh.surface_area()).ravel()[0]) for sh in shapes])
    if not (np.all(np.isfinite(areas)) and areas.sum() > 0):
        return None
    return (mi.ShapePtr(shapes), mi.DiscreteDistribution(mi.Float(areas.astype(np.float32))),
            dr.opaque(mi.Float, 1.0 / float(areas.sum())))


def sample_target_point(targets, time, u_shape, u_pos, active):
    """A point uniform by area on the scene's opaque shapes (density ``targets[2]`` = 1/total area).

    ``targets`` is ``(ShapePtr array, DiscreteDistribution over their areas, 1/total area)``
    as built by :class:`RigsimVolIntegrator`'s scene check; a shape is chosen with
    probability ∝ its area, then Mitsuba's ``sample_position`` (uniform on the shape).
    """
    shapes, distr, _ = targets
    idx = distr.sample(u_shape, active)
    sh = dr.gather(mi.ShapePtr, shapes, idx, active)
    return sh.sample_position(time, u_pos, active)


class Segment:
    """Equiangular geometry of one ray segment and one light, with the θ density

    ``q(θ) = (1 − α)/(θ_b − θ_a) + α p̄(θ + π/2)/Z`` (α = 0 without a phase table);
    the distance density is ``q(θ) cos² θ / D``.
    """

    def __init__(self, o, d, p_light, t_max, table, wbar, alpha):
        self.o, self.d = o, d
        self.delta, self.D, self.th_a, self.th_b = _equiangular_frame(o, d, p_light, t_max)
        self.dth = self.th_b - self.th_a
        self.t_max = t_max
        self.table, self.wbar, self.alpha = table, wbar, alpha
        if table is not None:
            self.psi_a = self.th_a + dr.pi / 2
            self.psi_b = self.th_b + dr.pi / 2
            self.zk, self.z = table.masses(wbar, self.psi_a, self.psi_b)

    def _q(self, th):
        q = dr.select(self.dth > 0, 1.0 / self.dth, 0.0)
        if self.table is None:
            return q
        ph = dr.select(self.z > 0, self.table.density(self.wbar, th + dr.pi / 2) / self.z, 0.0)
        a = dr.select(self.z > 0, self.alpha, 0.0)
        return (1.0 - a) * q + a * ph

    def sample(self, u_sel, u1, u2):
        th = dr.fma(u_sel, self.dth, self.th_a)  # uniform in θ
        if self.table is not None:
            use_phase = (u_sel < self.alpha) & (self.z > 0)
            psi = self.table.sample(self.wbar, self.psi_a, self.psi_b, self.zk, self.z, u1, u2)
            th = dr.select(use_phase, psi - dr.pi / 2, dr.fma(u1, self.dth, self.th_a))
        th = dr.clip(th, self.th_a, self.th_b)
        s, c = dr.sincos(th)
        t = dr.clip(self.delta + self.D * s / c, 0.0, self.t_max)
        pdf = self._q(th) * c * c / self.D
        return t, dr.select(self.dth > 0, pdf, 0.0)

    def pdf(self, t):
        x = t - self.delta
        th = dr.atan2(x, self.D)
        pdf = self._q(th) * self.D / (self.D * self.D + x * x)
        return dr.select((self.dth > 0) & (t >= 0) & (t <= self.t_max), pdf, 0.0)


def reflects(bsdf, ctx, si, active):
    """Whether the surface reflects any light back on the side it is seen from (a black target
    does not: its halo next-event estimation would cost rays for nothing)."""
    wo = mi.Vector3f(0.0, 0.0, dr.select(si.wi.z < 0, -1.0, 1.0))
    return dr.any(bsdf.eval(ctx, si, wo, active) > 0.0)


def dot4(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]


def channel(s, j):
    return dr.select(j == 0, s[0], dr.select(j == 1, s[1], dr.select(j == 2, s[2], s[3])))


_PHASE_ANGLE: "weakref.WeakKeyDictionary[WaterPhaseFunction, PhaseAngleTable]" = weakref.WeakKeyDictionary()
_AUREOLE: "weakref.WeakKeyDictionary[WaterPhaseFunction, AureoleTable]" = weakref.WeakKeyDictionary()


def phase_angle_table(phase: WaterPhaseFunction) -> PhaseAngleTable:
    """The :class:`PhaseAngleTable` of a water phase plugin (kept while the plugin lives)."""
    t = _PHASE_ANGLE.get(phase)
    if t is None:
        t = _PHASE_ANGLE[phase] = PhaseAngleTable(phase)
    return t


def aureole_table(phase: WaterPhaseFunction) -> AureoleTable:
    """The :class:`AureoleTable` of a water phase plugin (kept while the plugin lives)."""
    t = _AUREOLE.get(phase)
    if t is None:
        t = _AUREOLE[phase] = AureoleTable(phase)
    return t
