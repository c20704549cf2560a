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

``K(ν; τ) = (exp(τ Q(ν)) − 1) / (exp(τ F) − 1)``,  τ = b r.

This includes multiple small-angle scattering (all orders) — the part of multiple
scattering that matters most for images — and is the spread function of
McGlamery (1980) and Jaffe (1990) with its constants taken from the phase
function instead of fitted.

It is used twice:

* **camera leg** — the image of the target (direct component times ``exp(bFr)−1``)
  is convolved with ``K`` by FFT, in pixels through the angular pitch at the image
  centre, the kernel of each range bin at the bin's range;
* **light leg** — each light's beam pattern, laid out on a plane of angles around
  its axis (azimuthal equidistant, 2π/128 rad cells), is convolved with ``K`` at a
  few distances; the blurred pattern lights the target and the water with the
  amplitude ``exp(−c r)(exp(bFr) − 1)``.

Limits: angles add as plane vectors (exact for small angles; for ψ of tens of
degrees only the energy and the rough extent of the halo are right); the path
lengthening of scattered light and the cosine of its incidence are ignored; the
kernel in the image is shift-invariant (the pixel pitch at the centre, ranges in
bins); light scattered by more than ψ_c is not in these terms (it is in the
single-scattering backscatter integral when it reaches the camera from the
water, and missing when it lights the target).
"""

from __future__ import annotations

import weakref

import numpy as np
import scipy.fft as sfft
from scipy.special import itj0y0

from rigsim.scene.phase_tables import PhaseTables
from rigsim.scene.types import BeamPattern

__all__ = ["SmallAngle", "BEAM_GRID_N", "saa_transform"]

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



def _log_abs_expm1(x: np.ndarray) -> np.ndarray:
    """``log|exp(x) − 1|`` without overflow for large ``x`` (−inf at 0)."""
    x = np.asarray(x, float)
    big = x > 30.0
    with np.errstate(divide="ignore", invalid="ignore", under="ignore"):
        return np.where(big, x + np.log1p(-np.exp(-np.where(big, x, 30.0))), np.log(np.abs(np.expm1(np.where(big, 0.0, x)))))

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

    def q(self, nu: np.ndarray) -> np.ndarray:
        """Q(ν) per band, shape ``shape(nu) + (B,)``."""
        x = np.log1p(np.asarray(nu, float) / _NU0)
        qk = np.stack([np.interp(x, self._x, self._Qk[k]) for k in range(self._Qk.shape[0])], axis=-1)
        return qk @ self.w.T

    def kernel(self, nu: np.ndarray, tau: np.ndarray, q: np.ndarray | None = None) -> np.ndarray:
        """Unit-mass kernel transform ``K(ν; τ)`` per band, ``shape(nu) + (B,)``; τ (B,) = b r.

        ``q`` is :meth:`q` at ``nu`` if already known.
        """
        tau = np.asarray(tau, float)
        q = self.q(nu) if q is None else q
        tf = tau * self.F
        small = tf < 1e-9
        # expm1(qτ) / expm1(τF), in logs so that turbid water (τF of hundreds) gives no inf/inf
        qt = q * tau
        with np.errstate(divide="ignore", over="ignore", invalid="ignore", under="ignore"):
            k = np.sign(qt) * np.exp(_log_abs_expm1(qt) - _log_abs_expm1(np.where(small, 1.0, tf)))
        k = np.where(small, 0.0, np.nan_to_num(k, nan=0.0))
        if np.any(small):  # τ → 0: K → Q/F (and 1 where there is no forward scattering at all)
            lim = np.where(self.F > 0, 1.0 / np.where(self.F > 0, self.F, 1.0), 0.0)
            k = np.where(small, np.where(self.F > 0, q * lim, 1.0), k)
        return k

    # -- camera leg --------------------------------------------------------------------
    def blur_image(self, source: np.ndarray, range_m: np.ndarray, pitch_rad: tuple[float, float], *,
                   max_bins: int = 6, bin_ratio: float = 1.3) -> np.ndarray:
        """Convolve ``source`` (H, W, B) with the kernel of each pixel's range (bins in log r)."""
        H, W, B = source.shape
        finite = np.isfinite(range_m) & np.any(source != 0, axis=2)
        if not finite.any() or not np.any(self.F > 0):
            return source.copy()
        r = np.where(finite, range_m, np.nan)
        lo, hi = np.nanmin(r), np.nanmax(r)
        n_bins = int(min(max_bins, max(1, np.ceil(np.log(hi / lo) / np.log(bin_ratio)))))
        edges = np.geomspace(lo, hi * (1 + 1e-9), n_bins + 1)
        Hp, Wp = sfft.next_fast_len(2 * H, real=True), sfft.next_fast_len(2 * W, real=True)
        fy = np.fft.fftfreq(Hp, d=pitch_rad[1])[:, None]
        fx = np.fft.rfftfreq(Wp, d=pitch_rad[0])[None, :]
        nu = np.hypot(fx, fy)
        q = self.q(nu)
        out = np.zeros(source.shape, np.float64)
        for i in range(n_bins):
            m = finite & (r >= edges[i]) & (r < edges[i + 1])
            if not m.any():
                continue
            r_bin = float(np.sqrt(edges[i] * edges[i + 1])) if n_bins > 1 else float(np.nanmedian(r[m]))
            src = np.where(m[..., None], source, 0.0).astype(np.float32)
            spec = sfft.rfft2(src, s=(Hp, Wp), axes=(0, 1), workers=-1)
            spec *= self.kernel(nu, self.b * r_bin, q).astype(np.complex64)
            out += sfft.irfft2(spec, s=(Hp, Wp), axes=(0, 1), workers=-1)[:H, :W]
        return out

    # -- light leg ---------------------------------------------------------------------
    def blurred_beam(self, beam: BeamPattern, r_nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The beam pattern convolved with the kernel at distances ``r_nodes``.

        Returns
        -------
        (theta, table)
            θ nodes (rad, 0…π) and the blurred relative intensity, (n_r, n_θ, B).
        """
        N = BEAM_GRID_N
        pitch = 2 * np.pi / N
        i = np.fft.fftfreq(N, d=1.0 / N)  # 0, 1, ..., N/2-1, -N/2, ..., -1
        tx, ty = np.meshgrid(i * pitch, i * pitch)
        th = np.hypot(tx, ty)
        f = np.where(th < np.pi, beam.relative_intensity(np.minimum(th, np.pi)), 0.0)
        spec = np.fft.rfft2(f)
        nu = np.hypot(np.fft.fftfreq(N, d=pitch)[:, None], np.fft.rfftfreq(N, d=pitch)[None, :])
        q = self.q(nu)
        r_nodes = np.atleast_1d(np.asarray(r_nodes, float))
        k = np.stack([self.kernel(nu, self.b * r, q) for r in r_nodes])  # (n_r, N, N/2+1, B)
        # only row 0 (θ_y = 0) of the result is needed: inverse FFT along y is a sum over rows
        row = np.fft.irfft(np.sum(spec[None, :, :, None] * k, axis=1) / N, n=N, axis=1)  # (n_r, N, B)
        table = np.clip(row[:, :N // 2 + 1, :], 0.0, None)
        theta = np.arange(N // 2 + 1) * pitch
        return theta, table
