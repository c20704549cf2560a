"""Forward scattering in the small-angle approximation (SAA): the blur kernels of the preview.

Light that is scattered by less than a cut-off angle ψ_c (default 90°) is not taken
out of a beam but only turned a little: over a path of length r the angular
spread it acquires has, in the small-angle approximation (Wells 1973; Zege,
Ivanov & Katsev 1991), the 2-D Fourier transform (spatial frequency ν in cycles
per radian of angle)

``H(ν; r) = exp(−c r + b r Q(ν))``,  ``Q(ν) = ∫₀¹ P̂(ν t) dt``,

where ``P̂`` is the Fourier (Hankel) transform of the small-angle part of the phase
function laid out on the plane of angles and ``t`` the fraction of the path still
to go (scattering near the eye blurs most, near the object not at all).  ``H(0) =
exp(−(c − bF) r)`` with ``F = P̂(0)`` the probability of scattering by less than
ψ_c.  The unscattered part ``exp(−c r)`` is the direct (Beer–Lambert) component; the
rest, ``exp(−c r)(exp(b r Q(ν)) − 1)``, is the forward-scattered component, which the
preview writes as an amplitude ``exp(−c r)(exp(bFr) − 1)`` times a unit-mass
kernel

``K(ν; τ) = (exp(τ Q(ν)) − 1) / (exp(τ F) − 1)``,  τ = b r,

evaluated (:func:`unit_kernel`) as ``(exp(−τ(F − Q)) − exp(−τF)) / (1 − exp(−τF))``: since
``0 ≤ Q ≤ F`` every exponent is ≤ 0, so it cannot overflow however thick the water (the
quotient of two ``expm1`` overflows beyond τF ≈ 709 and gave NaN blur kernels, hence NaN
images, in strongly scattering water at tens of metres).

This includes multiple small-angle scattering (all orders) — the part of multiple
scattering that matters most for images — and is the spread function of
McGlamery (1980) and Jaffe (1990) with its constants taken from the phase
function instead of fitted.

It is used twice:

* **camera leg** — the image of the target (direct component times ``exp(bFr)−1``)
  is convolved with ``K`` by FFT, on the azimuthal equidistant grid about the image
  centre (the angular pitch at the centre; resampled from and to the pixels), the
  kernel of each range bin at the bin's water path (:class:`BlurPlan`:
  one band at a time — the bands in parallel threads — on a grid padded to at least twice
  the image, the zero rows of the padding skipped in the row transforms, the kernel, which
  depends on |ν| only, computed on half of the frequency rows);
* **light leg** — each light's beam pattern, laid out on a plane of angles around
  its axis (azimuthal equidistant, 2π/128 rad cells), is convolved with ``K`` at a
  few distances; the blurred pattern lights the target and the water with the
  amplitude ``exp(−c r)(exp(bFr) − 1)``.

Limits: angles add as plane vectors (exact for small angles; for ψ of tens of
degrees only the energy and the rough extent of the halo are right); the path
lengthening of scattered light and the cosine of its incidence are ignored; the
kernel is shift-invariant in angle (convolved on the azimuthal equidistant grid
about the image centre, ranges in bins); light scattered by more than ψ_c is not in these terms (it is in the
single-scattering backscatter integral when it reaches the camera from the
water, and missing when it lights the target).  The camera leg starts at the port
(:meth:`SmallAngle.blur_plan`'s ``port_m``): no water, no blur inside the housing.

Measured against Mitsuba's camera leg alone (``benchmarks/bench_fast_engine_camera_leg.py``: a
ColorChecker 40 % of the field behind an 8-inch dome emitting the fast engine's own irradiance,
2026-12-05): laid out on the pixels with the centre's pitch the halo's far part was too weak (a
pinhole's pixels off the axis are cos² θ narrower along the radius): with the Petzold phase function
cut off at 30° (all its scattering this model's), a = 0.05, b = 0.3 /m, the chart 3 m away, the water
0.5–2 / 4–8 / 8–16 / 16–64 pixels (0.8° each) beside the chart got −8 / −17 / −31 / −63 % of Monte
Carlo's light; with b = 2.35 /m −2 / −11 / −23 / −51 %.  On the azimuthal equidistant grid
(:meth:`SmallAngle.blur_plan`'s ``warp``), b = 2.35 /m: −0.4 / −2.6 / −3.9 / −8.8 %, the chart +1.4 %.
With the full phase function (the wide-angle part by :mod:`rigsim.preview.multiple`), chart patches:
Jerlov 7C at 1 m mean −0.8 %, −3.2 … +1.5 % (± 0.8 %; −5.4 … +4.7 % on the pixels with the water from
the pupil); 7C at 3 m +3.1 ± 2.1 %; III at 1 m −0.4 ± 0.7 %.
"""

from __future__ import annotations

import threading
import weakref

import numpy as np
import scipy.fft as sfft
from scipy.special import itj0y0

from rigsim.scene.phase_tables import PhaseTables
from rigsim.scene.types import BeamPattern

__all__ = ["SmallAngle", "BlurPlan", "BEAM_GRID_N", "saa_transform", "unit_kernel"]

#: Cells per side of the angular grid of beam patterns (covering −π…π).
BEAM_GRID_N = 128
_NU0 = 1e-2  # cycles/rad: scale of the ν interpolation variable


def saa_transform(tables: PhaseTables, nu_per_rad: np.ndarray, cutoff_rad: float) -> np.ndarray:
    """Path-averaged Hankel transform of the small-angle part, per component: (K, n_nu).

    ``Q_k(ν) = ∫₀¹ P̂_k(ν t) dt`` with ``P̂_k(ν) = Σ_{cells ψ<cutoff} m_kj J₀(2πνψ_j)``
    (the 2-D Fourier transform of the component's small-angle part treated as a
    density on the plane of angles; ψ_j the cell's log-midpoint), so
    ``∫₀¹ J₀(x t) dt = (1/x) ∫₀ˣ J₀`` (:func:`scipy.special.itj0y0`).
    ``Q_k(0)`` is the forward fraction.
    """
    cells = tables.forward_cells(cutoff_rad)
    e = tables.grid.psi_edges
    lo, hi = e[:-1][cells], e[1:][cells]
    psi = np.where(lo > 0, np.sqrt(np.maximum(lo, 1e-300) * hi), hi / 2)
    m = tables.masses[:, cells]  # (K, J)
    nu = np.asarray(nu_per_rad, float)
    out = np.empty((tables.n_components, nu.size))
    chunk = max(1, 2_000_000 // max(psi.size, 1))
    for i0 in range(0, nu.size, chunk):
        x = 2 * np.pi * nu[i0:i0 + chunk, None] * psi[None, :]  # (n, J)
        with np.errstate(divide="ignore", invalid="ignore"):
            g = np.where(x > 1e-8, itj0y0(x)[0] / np.where(x > 1e-8, x, 1.0), 1.0 - x * x / 12)
        out[:, i0:i0 + chunk] = m @ g.T
    return out


_Q_CACHE: "weakref.WeakKeyDictionary[PhaseTables, dict]" = weakref.WeakKeyDictionary()


def _q_table(components: PhaseTables, cutoff_rad: float) -> tuple[np.ndarray, np.ndarray]:
    """(x, Q_k) on ν = 0 and 240 log-spaced frequencies 10⁻²…2·10⁵ cycles/rad, x = ln(1 + ν/ν₀);
    kept while the tables live."""
    per = _Q_CACHE.setdefault(components, {})
    key = float(cutoff_rad)
    if key not in per:
        nu = np.concatenate([[0.0], np.geomspace(1e-2, 2e5, 240)])
        per[key] = (np.log1p(nu / _NU0), saa_transform(components, nu, cutoff_rad))
    return per[key]


def unit_kernel(q: np.ndarray | None, tau, F, *, q_minus_F: np.ndarray | None = None) -> np.ndarray:
    """The unit-mass kernel ``K = (e^{τq} − 1)/(e^{τF} − 1)`` from ``q = Q(ν)`` (see module docstring).

    Parameters
    ----------
    q
        Q(ν) per band, shape ``(…, B)`` (or ``(…)`` with scalar ``tau``, ``F``); float64 or
        float32 (the result has its dtype).  May be None if ``q_minus_F`` is given and τF > 1/2 in
        every band.
    tau, F
        (B,) optical path b·r and forward fraction Q(0).
    q_minus_F
        ``Q(ν) − F``, if known more accurately than ``q − F`` (summed from the components'
        ``Q_k − F_k``: relative to itself, not to F, which matters in float32 at large τ).

    Notes
    -----
    Where τF > 1/2 it is written ``(e^{τ(Q−F)} − e^{−τF}) / (1 − e^{−τF})``: the exponents are
    ≤ 0 (``Q ≤ F``), so nothing overflows however large τ is, and the absolute error is that of
    ``e^x`` times ``1/(1 − e^{−τF}) < 2.6`` (~1e-7 in float32).  Where τF ≤ 1/2 (nothing can overflow)
    it is the quotient of ``expm1``, accurate as τF → 0, whose limit ``q/F`` is taken below τF = 1e-9
    (1 where there is no forward scattering).
    """
    a = q if q is not None else q_minus_F
    dt = np.float32 if np.asarray(a).dtype == np.float32 else np.float64
    q = None if q is None else np.asarray(q, dt)
    qmf = None if q_minus_F is None else np.asarray(q_minus_F, dt)
    tau = np.asarray(tau, np.float64)
    F = np.asarray(F, np.float64)
    if tau.ndim == 0:
        def band(x):
            return None if x is None else x[..., None]
        return _unit_kernel_bands(band(q), band(qmf), tau[None], np.atleast_1d(F))[..., 0]
    return _unit_kernel_bands(q, qmf, tau, F)


def _thick_kernel(q_minus_F, tau, tf, out):
    """``(e^{τ(Q−F)} − e^{−τF}) / (1 − e^{−τF})`` into ``out`` (may be ``q_minus_F``): :func:`unit_kernel` where τF > 1/2."""
    dt = out.dtype
    np.multiply(q_minus_F, np.asarray(tau).astype(dt), out=out)
    np.exp(out, out=out)
    out -= np.exp(-tf).astype(dt)
    out *= (1.0 / -np.expm1(-tf)).astype(dt)
    return out


def _unit_kernel_bands(q, qmf, tau, F):
    tf = tau * F
    a = q if q is not None else qmf
    dt = a.dtype
    k = np.empty(np.broadcast_shapes(a.shape, tf.shape), dt)
    thick = tf > 0.5
    if np.any(thick):
        t, f, x = tau[thick], F[thick], tf[thick]
        arg = qmf[..., thick] if qmf is not None else q[..., thick] - f.astype(dt)
        k[..., thick] = _thick_kernel(arg, t, x, np.empty(arg.shape, dt))
    thin = ~thick
    if np.any(thin):
        t, f, x = tau[thin], F[thin], tf[thin]
        small = x < 1e-9
        with np.errstate(divide="ignore", invalid="ignore"):
            kt = np.expm1(q[..., thin] * t.astype(dt)) / np.expm1(x).astype(dt)
        if np.any(small):  # τ → 0: K → Q/F (and 1 where there is no forward scattering at all)
            lim = np.where(f > 0, 1.0 / np.where(f > 0, f, 1.0), 0.0).astype(dt)
            kt = np.where(small, np.where(f > 0, q[..., thin] * lim, 1.0), kt)
        k[..., thin] = kt
    return k


#: phase tables → {(cut-off, b, weights, beam, r nodes): blurred beam}, kept while the tables live.
_BEAM_CACHE: "weakref.WeakKeyDictionary[PhaseTables, dict]" = weakref.WeakKeyDictionary()
_BEAM_CACHE_SIZE = 16
_KERNEL_F32_MIN_TF = 0.5  # bands with τF above this get their blur kernel in float32 (unit_kernel's two forms)


#: Legendre terms of the spread phase function (:func:`_spread_moments`): resolves ~180°/L of angle; a Lanczos
#: σ-window damps the series' ringing at the phase function's cell edges (and at ψ_c, where its wide part starts).
_SPREAD_L = 720
#: ψ nodes (0…π, 1° apart) and μ = bF r nodes (log-spaced, clamped) of the spread phase function's tables.
_SPREAD_PSI_NODES = 181
_SPREAD_MU_NODES = np.geomspace(1e-3, 300.0, 56)
_SPREAD_CACHE: "weakref.WeakKeyDictionary[PhaseTables, dict]" = weakref.WeakKeyDictionary()


def _legendre_table(x: np.ndarray, L: int) -> np.ndarray:
    """(L + 2, len(x)) Legendre polynomials P_0 … P_{L+1} at ``x`` (Bonnet's recurrence)."""
    P = np.empty((L + 2, len(x)))
    P[0] = 1.0
    P[1] = x
    for l in range(1, L + 1):
        P[l + 1] = ((2 * l + 1) * x * P[l] - l * P[l - 1]) / (l + 1)
    return P


def _spread_moments(components: PhaseTables, cutoff_rad: float):
    """``(wide_l, small_l, P_psi)``: each component's Legendre moments ``∫ p P_l dΩ`` (K, L + 1) of its cells by
    more than ``cutoff_rad`` and of its cells below it (the latter's l = 0 term is the forward fraction F_k),
    exact for the piecewise-constant densities (``∫ P_l dμ = (P_{l+1} − P_{l−1}) / (2l + 1)``); and P_l at the ψ
    nodes (L + 1, n_ψ) times ``(2l + 1)/(4π)`` and the Lanczos window.  Kept per phase function."""
    per = _SPREAD_CACHE.setdefault(components, {})
    key = ("moments", float(cutoff_rad))
    hit = per.get(key)
    if hit is not None:
        return hit
    L = _SPREAD_L
    mu_e = components.grid.mu_edges  # descending 1 … −1
    Pe = _legendre_table(mu_e, L)
    l = np.arange(L + 1)
    prim = np.empty((L + 1, len(mu_e)))  # ∫_{-1}^{μ} P_l
    prim[0] = mu_e + 1.0
    prim[1:] = (Pe[2:L + 2] - Pe[0:L]) / (2 * l[1:, None] + 1)
    width = mu_e[:-1] - mu_e[1:]
    cell = (prim[:, :-1] - prim[:, 1:]) / np.maximum(width, 1e-300)  # (L+1, cells): mean P_l
    # cells narrower than this in μ (the forward peak's, down to 1e-4 rad): the difference of primitives cancels
    # catastrophically; P_l at the cell's middle instead (P_l varies by ~l² δμ across it)
    tiny = width < 1e-6
    if np.any(tiny):
        cell[:, tiny] = _legendre_table(0.5 * (mu_e[:-1] + mu_e[1:])[tiny], L)[:L + 1]
    fwd = components.forward_cells(cutoff_rad)
    m = components.masses
    wide_l = np.where(fwd[None, :], 0.0, m) @ cell.T
    small_l = np.where(fwd[None, :], m, 0.0) @ cell.T
    psi = np.linspace(0.0, np.pi, _SPREAD_PSI_NODES)
    x = np.pi * l / (L + 1)
    window = np.where(l == 0, 1.0, np.sin(x) / np.where(l == 0, 1.0, x))
    P_psi = _legendre_table(np.cos(psi), L)[:L + 1] * ((2 * l + 1) / (4 * np.pi) * window)[:, None]
    hit = (wide_l, small_l, P_psi)
    per[key] = hit
    return hit


class SmallAngle:
    """Small-angle forward scattering for a set of bands (see module docstring).

    Parameters
    ----------
    components
        The phase function's components.
    cutoff_rad
        ψ_c: scattering by less than this is forward scattering.
    b_per_m
        (B,) scattering coefficient at the band centres (1/m).
    weights
        (B, K) component weights at the band centres.
    """

    def __init__(self, components: PhaseTables, cutoff_rad: float, b_per_m: np.ndarray,
                 weights: np.ndarray):
        self.components = components
        self.cutoff_rad = float(cutoff_rad)
        self.b = np.asarray(b_per_m, float)
        self.w = np.asarray(weights, float)
        self.F_k = components.forward_fraction(self.cutoff_rad)  # (K,)
        self.F = self.w @ self.F_k  # (B,)
        self._x, self._Qk = _q_table(components, self.cutoff_rad)

    def q_components(self, nu: np.ndarray) -> np.ndarray:
        """Q_k(ν) of each phase component, shape ``(K,) + shape(nu)``."""
        x = np.log1p(np.asarray(nu, float) / _NU0)
        return np.stack([np.interp(x, self._x, self._Qk[k]) for k in range(self._Qk.shape[0])])

    def q(self, nu: np.ndarray) -> np.ndarray:
        """Q(ν) per band, shape ``shape(nu) + (B,)``."""
        return np.moveaxis(self.q_components(nu), 0, -1) @ self.w.T

    def q_minus_F(self, nu: np.ndarray) -> np.ndarray:
        """Q(ν) − F per band, ``shape(nu) + (B,)``, summed from the components' ``Q_k(ν) − Q_k(0)`` (``Q_k(0)`` is
        the forward fraction ``F_k`` to rounding; the difference is exactly 0 at ν = 0)."""
        qk = self.q_components(nu)
        return np.moveaxis(qk - self._Qk[:, :1].reshape((-1,) + (1,) * (qk.ndim - 1)), 0, -1) @ self.w.T

    def kernel(self, nu: np.ndarray, tau: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
        """Unit-mass kernel transform ``K(ν; τ)`` per band, ``shape(nu) + (B,)``; τ (B,) = b r.

        ``q`` is :meth:`q` at ``nu`` if already known.  Float64 (:func:`unit_kernel`).
        """
        q = self.q(nu) if q is None else np.asarray(q, float)
        return unit_kernel(q, tau, self.F, q_minus_F=self.q_minus_F(nu))

    # -- camera leg --------------------------------------------------------------------
    def blur_image(self, source: np.ndarray, range_m: np.ndarray, pitch_rad: tuple[float, float], *,
                   max_bins: int = 6, bin_ratio: float = 1.3) -> np.ndarray:
        """Convolve ``source`` (H, W, B) with the kernel of each pixel's range (bins in log r): float64 (H, W, B).

        :meth:`blur_bands` on the bands laid out first.
        """
        src = np.ascontiguousarray(np.moveaxis(np.asarray(source), -1, 0), dtype=np.float32)
        out = self.blur_bands(src, np.asarray(range_m, float), pitch_rad, max_bins=max_bins, bin_ratio=bin_ratio,
                              out=src)
        if out is None:
            return np.array(source, dtype=np.float64)
        return np.moveaxis(out, 0, -1).astype(np.float64)

    def blur_bands(self, source: np.ndarray, range_m: np.ndarray, pitch_rad: tuple[float, float], *,
                   max_bins: int = 6, bin_ratio: float = 1.3, nonzero: np.ndarray | None = None,
                   out: np.ndarray | None = None, map_bands=map) -> np.ndarray | None:
        """Convolve each band of ``source`` (B, H, W) with the kernel of each pixel's range (:class:`BlurPlan`).

        Parameters
        ----------
        source
            (B, H, W), zero where there is nothing to blur.
        range_m, pitch_rad, max_bins, bin_ratio, nonzero
            As :meth:`blur_plan` (``nonzero`` is computed from ``source`` if None).
        out
            (B, H, W) float32 array for the result; may be ``source`` (each band is read
            before it is written).
        map_bands
            ``map``-like callable over band indices (e.g. a thread pool's ``map``: every step
            of a band releases the GIL).

        Returns
        -------
        (B, H, W) float32, or None if nothing is blurred (see :meth:`blur_plan`): the result is
        then the source itself.
        """
        B = source.shape[0]
        if nonzero is None:
            nonzero = np.any(source != 0, axis=0)
        plan = self.blur_plan(range_m, pitch_rad, nonzero, max_bins=max_bins, bin_ratio=bin_ratio)
        if plan is None:
            return None
        out = np.empty(source.shape, np.float32) if out is None else out

        def band(b):
            out[b] = plan.blur(b, source[b])

        for _ in map_bands(band, range(B)):
            pass
        return out

    def blur_plan(self, range_m: np.ndarray, pitch_rad: tuple[float, float], nonzero: np.ndarray, *,
                  max_bins: int = 6, bin_ratio: float = 1.3, port_m: float = 0.0,
                  viewpoint_m: float | None = None, warp=None) -> "BlurPlan | None":
        """What the camera-leg blur of an image needs, band by band (see :class:`BlurPlan`).

        Pixels are put in at most ``max_bins`` bins of range (``bin_ratio`` apart in log r);
        those of each bin are convolved with the kernel at the bin's range (the geometric
        centre of its edges, or the median range with one bin) and the results added.  The
        FFT grid is padded to at least twice the image in each direction (the kernel is
        periodic over the padded grid).

        Parameters
        ----------
        range_m
            (H, W) range of each pixel (m, inf where nothing is hit: not blurred).
        pitch_rad
            Angle between neighbouring pixels (x, y) at the image centre.
        nonzero
            (H, W) whether any band of the source is non-zero.
        port_m, viewpoint_m
            The housing's part of each line of sight: the distance (m) from the entrance pupil to the port's
            outer surface (no water there, no scattering), and the distance behind that surface of the point
            the rays in the water appear to come from (default ``port_m``: a dome centred on the pupil).  A
            line of sight of range ``r`` then crosses ``s = r − port_m`` of water, and light scattered by ψ at
            ``u`` before the target is seen ``ψ u / D`` off it, ``D = s + viewpoint_m``: the kernel's optical
            path is ``τ = b s`` and its angles are those of ``Q(a ν)``, ``a = s / D`` (``Q(ν) = ∫₀¹ P̂(ν t)
            dt`` over the scattering points spread evenly over the water, ``t = u / D ∈ [0, a]``).  0 and
            None: the water starts at the pupil (``a = 1``, ``τ = b r``).  Measured (2026-12-05, a
            ColorChecker at 1 m in Jerlov 7C behind an 8-inch dome, 550 nm: ``a`` = 0.89 and τ 11 % smaller
            than the range's): the fast engine's light of each patch against Mitsuba's camera leg (the
            chart emitting the fast engine's own irradiance, ``rigsim.render.hybrid.emissive_camera_pass``)
            spread −5.4 … +4.7 % (the bright patches low, the dark ones high: too much light exchanged
            between neighbours) without this, −0.6 … +3.7 % (mean +1.8 %) with it on the pixel grid, −3.2 …
            +1.5 % (mean −0.8 %) with ``warp`` too (``benchmarks/bench_fast_engine_camera_leg.py``).
        warp
            ``(to_x, to_y, from_x, from_y)`` of :func:`rigsim.scene.optics.equidistant_maps`: the blur is done on
            the azimuthal equidistant grid about the image centre (where a distance is an angle at every
            azimuth) and sampled back at the pixels; None: on the pixel grid with the centre's pitch (a
            pinhole's pixels off the axis are narrower than that along the radius — ``cos² θ``, 0.55 at a
            24 mm lens's corner — so the kernel laid out in pixels put the halo too near its source there).

        Returns
        -------
        BlurPlan, or None if there is nothing to blur: no pixel with a finite range and a non-zero
        source, or no forward scattering in any band.
        """
        finite = np.isfinite(range_m) & nonzero
        if not finite.any() or not np.any(self.F > 0):
            return None
        return BlurPlan(self, np.where(finite, range_m, np.nan), finite, pitch_rad, max_bins, bin_ratio,
                        port_m=port_m, viewpoint_m=viewpoint_m, warp=warp)

    # -- the direction of forward-scattered light ---------------------------------------
    def spread_table(self, bw: np.ndarray) -> np.ndarray:
        """(B, n_μ, n_ψ) :meth:`spread_beta` on its nodes (ψ 0…π, μ = bF r :data:`_SPREAD_MU_NODES`); kept per
        phase function and set of bands."""
        bw = np.asarray(bw, float)
        per = _SPREAD_CACHE.setdefault(self.components, {})
        key = ("table", self.cutoff_rad, self.w.tobytes(), bw.tobytes())
        hit = per.get(key)
        if hit is None:
            wide_l, small_l, P_psi = _spread_moments(self.components, self.cutoff_rad)
            one = (self.w @ small_l) / np.maximum(self.F, 1e-300)[:, None]  # (B, L+1): one small-angle turn
            mu = _SPREAD_MU_NODES[None, :, None]
            # N ≥ 1 turns, N Poisson of mean μ: Σ_N μ^N e^{−μ}/N! p̂^N / (1 − e^{−μ})
            d = (np.exp(mu * (one[:, None, :] - 1.0)) - np.exp(-mu)) / -np.expm1(-mu)
            beta_l = bw.T @ wide_l  # (B, L+1)
            hit = np.einsum("bml,lp->bmp", d * beta_l[:, None, :], P_psi, optimize=True)
            per[key] = hit
        return hit

    def spread_beta(self, cos_psi: np.ndarray, r_m: np.ndarray, bw: np.ndarray) -> np.ndarray:
        """Volume scattering function by more than ψ_c (1/(m sr), ``shape(cos_psi) + (B,)``) of the beam's
        forward-scattered light at angle ψ from the straight line from the light, after ``r_m`` of water; ``bw``
        (K, B) ``b w_k`` per band.

        The quasi-single backscatter took that light as going straight on.  Its direction has been turned by
        N ≥ 1 scatterings by less than ψ_c (N Poisson of mean μ = bF r, each turn drawn from the phase
        function's cells below ψ_c about a random axis), so the wide-angle phase function it meets is averaged
        over those directions: on the sphere, exactly, a product of Legendre moments (the addition theorem),
        ``β̄(ψ) = Σ_l (2l+1)/(4π) β_l d_l P_l(cos ψ)``, ``β_l`` the moments of ``Σ_k bw_k p_k`` over its cells
        by more than ψ_c, ``d_l = (e^{μ(p̂_l − 1)} − e^{−μ}) / (1 − e^{−μ})``, ``p̂_l`` the mean of P_l(cos ψ) over
        one small-angle turn (:func:`_spread_moments`; :data:`_SPREAD_L` terms).  The light's direction is taken
        to be spread about the line from the light as in a broad beam (at a beam's edge it is also tilted
        outwards, which this leaves out).  Linear in ψ and in ln μ between the table's nodes
        (:meth:`spread_table`).
        """
        table = self.spread_table(bw)
        B, n_m, n_p = table.shape
        cos_psi = np.asarray(cos_psi, float)
        x = np.clip(np.arccos(np.clip(cos_psi, -1.0, 1.0)) * ((n_p - 1) / np.pi), 0.0, n_p - 1.000001)
        i = x.astype(np.int64)[..., None]
        fx = (x - i[..., 0])[..., None]
        mu = np.maximum(self.b * self.F * np.asarray(r_m, float)[..., None], _SPREAD_MU_NODES[0])
        lm = np.log(_SPREAD_MU_NODES)
        y = np.clip((np.log(mu) - lm[0]) / (lm[1] - lm[0]), 0.0, n_m - 1.000001)
        j = y.astype(np.int64)
        fy = y - j
        flat = table.reshape(-1)
        a0 = ((np.arange(B) * n_m) + j) * n_p + i  # (…, B)
        a1 = a0 + n_p
        lo = flat[a0] * (1 - fx) + flat[a0 + 1] * fx
        hi = flat[a1] * (1 - fx) + flat[a1 + 1] * fx
        return lo * (1 - fy) + hi * fy

    def two_leg_beta(self, cos_psi: np.ndarray, beta: np.ndarray, r_m: np.ndarray, s_m: np.ndarray,
                     bw: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The volume scattering function the quasi-single veil meets with small-angle turns on both legs:
        ``r_m`` of water from the light, ``s_m`` on to the camera (both ``shape(cos_psi)``); ``beta``
        (``shape(cos_psi) + (B,)``) the straight lines' ``β(ψ)``, ``bw`` as :meth:`spread_beta`'s.

        The camera's line of sight is turned on its way as the light's is (reciprocity): the light that
        reaches the pupil along it left the wide-angle scattering along a direction spread about it by
        ``N_s`` turns (Poisson of mean ``μ_s = bF s``).  Both spreads are symmetric about their own lines,
        so on the sphere their Legendre factors multiply (:meth:`spread_beta`): with
        ``B̄(μ) = Σ_l (2l+1)/(4π) β_l e^{μ (p̂_l − 1)} P_l(cos ψ) = e^{−μ} β + (1 − e^{−μ}) β̄(μ)`` (any number of
        turns, ``β̄`` :meth:`spread_beta`) and ``μ_r = bF r``, returns

        * ``beta_s = B̄(μ_s)``: what the light not turned on the light leg (``f e^{−c r}``) meets;
        * ``delta = B̄(μ_r + μ_s) − e^{−μ_r} B̄(μ_s)``: times ``f̃ e^{−(c − bF) r}``, the light turned on the
          light leg (``delta / (1 − e^{−μ_r})`` is the mean it meets; this form has no quotient).

        With ``s_m = 0`` they are ``β`` and ``(1 − e^{−μ_r}) β̄(μ_r)``, the light leg's spread alone.
        """
        bf = self.b * self.F
        r_m = np.asarray(r_m, float)
        s_m = np.asarray(s_m, float)
        e_r = np.exp(-r_m[..., None] * bf)
        e_s = np.exp(-s_m[..., None] * bf)
        beta_s = e_s * beta + (1.0 - e_s) * self.spread_beta(cos_psi, s_m, bw)
        e_rs = e_r * e_s
        beta_rs = e_rs * beta + (1.0 - e_rs) * self.spread_beta(cos_psi, r_m + s_m, bw)
        return beta_s, beta_rs - e_r * beta_s

    # -- light leg ---------------------------------------------------------------------
    def blurred_beam(self, beam: BeamPattern, r_nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The beam pattern convolved with the kernel at distances ``r_nodes``.

        Returns
        -------
        (theta, table)
            θ nodes (rad, 0…π) and the blurred relative intensity, (n_r, n_θ, B).  Kept (a
            few per phase function, while its tables live): do not modify.
        """
        r_nodes = np.atleast_1d(np.asarray(r_nodes, float))
        key = (self.cutoff_rad, self.b.tobytes(), self.w.tobytes(), beam, r_nodes.tobytes())
        per = _BEAM_CACHE.setdefault(self.components, {})
        hit = per.get(key)
        if hit is None:
            hit = self._blurred_beam(beam, r_nodes)
            if len(per) >= _BEAM_CACHE_SIZE:
                per.pop(next(iter(per)))
            per[key] = hit
        return hit

    def _blurred_beam(self, beam: BeamPattern, r_nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        N = BEAM_GRID_N
        pitch = 2 * np.pi / N
        i = np.fft.fftfreq(N, d=1.0 / N)  # 0, 1, ..., N/2-1, -N/2, ..., -1
        tx, ty = np.meshgrid(i * pitch, i * pitch)
        th = np.hypot(tx, ty)
        f = np.where(th < np.pi, beam.relative_intensity(np.minimum(th, np.pi)), 0.0)
        spec = np.fft.rfft2(f)
        nu = np.hypot(np.fft.fftfreq(N, d=pitch)[:, None], np.fft.rfftfreq(N, d=pitch)[None, :])
        q, qmf = self.q(nu), self.q_minus_F(nu)
        k = np.stack([unit_kernel(q, self.b * r, self.F, q_minus_F=qmf) for r in r_nodes])  # (n_r, N, N/2+1, B)
        # only row 0 (θ_y = 0) of the result is needed: inverse FFT along y is a sum over rows
        row = np.fft.irfft(np.sum(spec[None, :, :, None] * k, axis=1) / N, n=N, axis=1)  # (n_r, N, B)
        table = np.ascontiguousarray(np.clip(row[:, :N // 2 + 1, :], 0.0, None))
        theta = np.arange(N // 2 + 1) * pitch
        table.setflags(write=False)
        theta.setflags(write=False)
        return theta, table


class BlurPlan:
    """The camera-leg blur of one image, band by band (:meth:`SmallAngle.blur_plan`).

    Each band is convolved by FFT on a grid padded to at least twice the image: the rows of the
    source (only those holding a non-zero pixel) transformed, then the columns; the spectrum times
    the kernel of each range bin — which depends on |ν| only, so it is computed on the rows of
    non-negative frequency and mirrored — summed over the bins; back by columns, then by the rows of
    the image only.  :meth:`blur` releases the GIL in every step: bands can run in threads.
    """

    def __init__(self, sa: SmallAngle, r: np.ndarray, finite: np.ndarray, pitch_rad, max_bins: int,
                 bin_ratio: float, *, port_m: float = 0.0, viewpoint_m: float | None = None, warp=None):
        self.sa = sa
        H, W = finite.shape
        self.shape = (H, W)
        lo, hi = np.nanmin(r), np.nanmax(r)
        n_bins = int(min(max_bins, max(1, np.ceil(np.log(hi / lo) / np.log(bin_ratio)))))
        edges = np.geomspace(lo, hi * (1 + 1e-9), n_bins + 1)
        port_m = max(float(port_m), 0.0)
        view_m = port_m if viewpoint_m is None else max(float(viewpoint_m), 0.0)
        self.bins = []  # (pixels or None, water path s (m), angle scale a)
        for i in range(n_bins):
            m = finite & (r >= edges[i]) & (r < edges[i + 1])
            if m.any():
                r_bin = float(np.sqrt(edges[i] * edges[i + 1])) if n_bins > 1 else float(np.nanmedian(r[m]))
                s_w = max(r_bin - port_m, 1e-6)
                a = round(s_w / (s_w + view_m), 4)  # 1 without a port
                self.bins.append((None if n_bins == 1 else m, s_w, a))
        self.finite = finite
        self.Hp, self.Wp = sfft.next_fast_len(2 * H, real=True), sfft.next_fast_len(2 * W, real=True)
        self.h = self.Hp // 2  # |ν| of row i and of row Hp − i are equal: the kernel on rows 0 … h only
        fy = np.fft.fftfreq(self.Hp, d=pitch_rad[1])[:self.h + 1, None]
        fx = np.fft.rfftfreq(self.Wp, d=pitch_rad[0])[None, :]
        nu = np.hypot(fx, fy)
        # Q_k(a ν) − Q_k(0) per angle scale a, float32 (see q_minus_F): (K, h + 1, Wp/2 + 1) each
        self.dk32 = {a: (sa.q_components(a * nu) - sa._Qk[:, :1, None]).astype(np.float32)
                     for a in sorted({a for _, _, a in self.bins})}
        self.warp = None if warp is None else tuple(np.ascontiguousarray(m, np.float32) for m in warp)
        seen = finite if self.warp is None else self._to_grid(finite.astype(np.float32)) > 0
        rows = np.flatnonzero(seen.any(axis=1))
        self.r0, self.r1 = int(rows[0]), int(rows[-1]) + 1  # only these rows of the source are non-zero
        self._local = threading.local()

    def _workspace(self) -> dict:
        """This thread's buffers, reused band after band (fresh memory is slow to touch)."""
        ws = getattr(self._local, "ws", None)
        if ws is None:
            spec = (self.Hp, self.Wp // 2 + 1)
            ws = self._local.ws = {
                "spec": np.empty(spec, np.complex64),
                "sum": np.empty(spec, np.complex64) if len(self.bins) > 1 else None,
                "q": np.empty((self.h + 1, spec[1]), np.float32),
                "tmp": np.empty((self.h + 1, spec[1]), np.float32),
                "x": np.empty((self.r1 - self.r0, self.shape[1]), np.float32)}
        return ws

    def _to_grid(self, image: np.ndarray) -> np.ndarray:
        """A (H, W) float32 image of pixels on the grid the blur is done on (the equidistant one, if warped)."""
        if self.warp is None:
            return image
        import cv2

        return cv2.remap(image, self.warp[2], self.warp[3], cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                         borderValue=0.0)

    def _to_pixels(self, grid: np.ndarray) -> np.ndarray:
        if self.warp is None:
            return grid
        import cv2

        return cv2.remap(np.ascontiguousarray(grid, np.float32), self.warp[0], self.warp[1], cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=0.0)

    def kernel(self, b: int, water_m: float, a: float = 1.0) -> np.ndarray:
        """Band ``b``'s unit kernel after ``water_m`` of water, its angles scaled by ``a`` (a scale of this
        plan's bins: see :meth:`SmallAngle.blur_plan`), on rows 0 … h of the frequency grid, float32 (from
        the components' ``Q_k − F_k`` in float32; where τF ≤ 1/2 from ``Q = (Q − F) + F``: see
        :func:`unit_kernel`)."""
        sa = self.sa
        tau = sa.b[b] * water_m
        w = sa.w[b]
        dk = self.dk32[a]
        ws = self._workspace()  # in this thread's buffers
        qmf, tmp = ws["q"], ws["tmp"]
        np.multiply(dk[0], np.float32(w[0]), out=qmf)
        for k in range(1, len(w)):
            qmf += np.multiply(dk[k], np.float32(w[k]), out=tmp)
        if tau * sa.F[b] > _KERNEL_F32_MIN_TF:
            return _thick_kernel(qmf, tau, tau * sa.F[b], qmf)
        qmf += np.float32(sa.F[b])
        return unit_kernel(qmf, tau, sa.F[b])

    def blur(self, b: int, image: np.ndarray) -> np.ndarray:
        """Band ``b`` of the source, (H, W), blurred: (H, W) float32 (pixels outside the plan's pixels —
        not hit, or with a zero source — are taken as zero)."""
        H, W = self.shape
        Hp, Wp, h, r0, r1 = self.Hp, self.Wp, self.h, self.r0, self.r1
        ws = self._workspace()
        spec_sum = None
        for i, (m, water_m, a) in enumerate(self.bins):
            mask = self.finite if m is None else m
            if self.warp is None:
                x = np.multiply(image[r0:r1], mask[r0:r1], out=ws["x"])
            else:
                x = self._to_grid(np.multiply(image, mask, dtype=np.float32))[r0:r1]
            spec = ws["spec"]
            spec[:r0] = 0
            spec[r1:] = 0
            spec[r0:r1] = sfft.rfft(x, n=Wp, axis=1)
            spec = sfft.fft(spec, axis=0, overwrite_x=True)
            kern = self.kernel(b, water_m, a)
            spec[:h + 1] *= kern
            spec[h + 1:] *= kern[Hp - h - 1:0:-1]
            if ws["sum"] is None:  # one bin
                spec_sum = spec
            elif i == 0:
                spec_sum = ws["sum"]
                spec_sum[...] = spec
            else:
                spec_sum += spec
        cols = sfft.ifft(spec_sum, axis=0, overwrite_x=True)[:H]
        return self._to_pixels(sfft.irfft(cols, n=Wp, axis=1)[:, :W])
