"""Single-scattering backscatter of the rig's lights: the integral along each camera ray.

For a camera ray from the port, ``x(s) = o + s d``, the radiance scattered towards
the camera by the water between the port and the first surface (at ``s_hit``) is

``L_b(λ) = ∫₀^{s_hit} T_cam(s) Σ_lights β(ψ, λ) I_eff(θ, r, λ) / r² ds``

with ``r`` the light–point distance, ``θ`` the angle from the light's axis, ``ψ`` the
scattering angle (``cos ψ = −d·(x − l)/r``), ``β = b p(ψ; λ)`` the volume scattering
function from the water's own (wavelength-dependent) phase function, and

* without forward scattering: ``I_eff = I(λ) f(θ) e^{−c r}``, ``T_cam = e^{−c s}``
  (classical single scattering, McGlamery 1980 eq. for the backscatter component);
* with forward scattering (default): ``I_eff = I(λ)[f(θ) e^{−c r} + f̃(θ; r)(e^{−(c−bF) r} − e^{−c r})]``
  with the SAA-blurred beam ``f̃`` and ``T_cam = e^{−(c − bF) s}`` — one wide-angle
  scattering with any number of small-angle ones before and after it (the
  small-angle/single-backscatter approximation; the veiling light is smooth, so
  small-angle scattering on the way back only redistributes it).  The forward-scattered part
  meets the wide-angle β not at ψ but averaged over the directions its small-angle turns gave
  it (``spread``: :meth:`rigsim.preview.forward.SmallAngle.spread_beta`, the addition theorem of
  Legendre polynomials; in Jerlov 9C after 1 m of water the turned light's β is 5–30 % higher
  at 60–130° and 5–15 % lower near 180° than the straight light's).  The camera's line of sight is
  turned the same way on its ``s`` of water (``two_leg``:
  :meth:`rigsim.preview.forward.SmallAngle.two_leg_beta`): ``T_cam β`` keeps the light that small-angle
  scatterings bring into the line of sight, but that light left the wide-angle scattering along
  directions spread about the line, so it met β averaged over them too.

Quadrature: the integrand has a 1/r² peak where the ray passes a light and decays
like e^{−κs}/s² far away, so it is integrated with the trapezoidal rule in
``u = ln(s + s_a)`` (``s_a`` = 2 cm) on ``n_nodes`` nodes up to a cut-off ``S``
where ``e^{−κ S}`` < e^{−50} (or the renderer's world radius, ≥ 1 km).  The
cumulative integral is stored at the nodes, so the value at any ``s_hit`` is read by
linear interpolation.  The backscatter varies slowly across the image (except very
near a light in view), so the integral is computed on a coarse grid of rays and
interpolated bilinearly in the image — at each pixel's own ``s_hit``, which keeps
target edges sharp.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigsim.preview.geometry import SceneSurfaces, cast_rays, occluded

__all__ = ["LightTables", "s_nodes", "cumulative_backscatter", "interpolate_cumulative", "beam_angle"]

S_A_M = 0.02  #: Offset of the logarithmic variable u = ln(s + s_a), m.


@dataclass(frozen=True, eq=False)
class LightTables:
    """What the integrals need to know about one light, per band.

    Attributes
    ----------
    position, axis
        (3,) position (m) and unit beam axis.
    beam_fn
        θ (rad) → f(θ).
    intensity
        (Λ,) on-axis intensity at the wavelengths of the integral.
    theta_nodes, r_nodes, blurred
        The SAA-blurred beam ``f̃``: θ nodes (rad), r nodes (m), table (n_r, n_θ, Λ);
        None without forward scattering.
    """

    position: np.ndarray
    axis: np.ndarray
    beam_fn: object
    intensity: np.ndarray
    theta_nodes: np.ndarray | None = None
    r_nodes: np.ndarray | None = None
    blurred: np.ndarray | None = None

    def blurred_at(self, theta: np.ndarray, r: np.ndarray) -> np.ndarray:
        """f̃(θ; r) per band, shape ``shape(theta) + (Λ,)`` (linear in θ and in ln r, clamped), in the
        table's dtype."""
        tn, rn, tab = self.theta_nodes, self.r_nodes, self.blurred
        x = np.clip(theta / (tn[1] - tn[0]), 0.0, len(tn) - 1.000001)
        i = x.astype(np.int64)
        fx = (x - i)[..., None].astype(tab.dtype)
        if len(rn) > 1:
            lr = np.log(rn)
            y = np.clip((np.log(np.maximum(r, 1e-9)) - lr[0]) / (lr[1] - lr[0]), 0.0, len(rn) - 1.000001)
        else:
            y = np.zeros_like(r)
        j = y.astype(np.int64)
        fy = (y - j)[..., None].astype(tab.dtype)
        j1 = np.minimum(j + 1, len(rn) - 1)
        nt = len(tn)
        flat = tab.reshape(-1, tab.shape[-1])
        a0, a1 = j * nt + i, j1 * nt + i
        a = np.take(flat, a0, axis=0) * (1 - fx) + np.take(flat, a0 + 1, axis=0) * fx
        b = np.take(flat, a1, axis=0) * (1 - fx) + np.take(flat, a1 + 1, axis=0) * fx
        return a * (1 - fy) + b * fy


def beam_angle(direction_out: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Angle (rad) between unit directions and the axis, accurate at all angles."""
    return 2.0 * np.arctan2(np.linalg.norm(direction_out - axis, axis=-1),
                            np.linalg.norm(direction_out + axis, axis=-1))


def s_nodes(s_max: float, n_nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes ``s`` (from 0 to ``s_max``) and trapezoid weights ``ds`` of the u = ln(s + s_a) rule."""
    u = np.linspace(np.log(S_A_M), np.log(s_max + S_A_M), n_nodes)
    s = np.exp(u) - S_A_M
    s[0] = 0.0
    du = u[1] - u[0]
    w = (s + S_A_M) * du
    return s, w


def cumulative_backscatter(origin: np.ndarray, direction: np.ndarray, s: np.ndarray, lights: list[LightTables],
                           *, bw: np.ndarray, c: np.ndarray, kappa_light: np.ndarray, kappa_cam: np.ndarray,
                           components, forward: bool, surfaces: SceneSurfaces | None = None,
                           chunk_elems: int = 4_000_000, spread=None, shade_beyond_hit: bool = False,
                           two_leg=None) -> np.ndarray:
    """Cumulative backscatter ``∫₀^{s_j}`` at the nodes for each ray: (N, n_nodes, Λ).

    Parameters
    ----------
    origin, direction
        (N, 3) ray origins (on the port) and unit directions.
    s
        (M,) nodes from :func:`s_nodes`.
    lights
        The lights of one group.
    bw
        (K, Λ) ``b(λ) w_k(λ)``: scattering coefficient of each phase component.
    c, kappa_light
        (Λ,) beam attenuation c and the attenuation of the SAA-blurred beam, c − bF.
    kappa_cam
        (Λ,) attenuation on the camera leg.
    components
        :class:`~rigsim.scene.phase_tables.PhaseTables`.
    forward
        Use the SAA illumination (see module docstring).
    surfaces
        If given, volume points in a surface's shadow get no light from that light (the points in front of
        the ray's own first surface: beyond it the ray sees nothing, and a shadow there would only bend the
        integral's last step towards the surface, −0.1 % at a disk's centre in coastal water at 3 m);
        ``shade_beyond_hit``: every point tested (as before 2026-12-05).
    spread
        With ``forward``: ``(cos_psi, r) → (…, Λ)`` the volume scattering function of the beam's
        forward-scattered light, whose directions have spread about the line from the light
        (:meth:`rigsim.preview.forward.SmallAngle.spread_beta`); None: ``β(ψ)`` as the unscattered light's.
    two_leg
        With ``forward``, instead of ``spread``: ``(cos_psi, beta, r, s) → (beta_s, delta)``, the volume
        scattering function with the turns of both legs (:meth:`rigsim.preview.forward.SmallAngle.two_leg_beta`;
        ``s`` the node's water path from the port).
    """
    N, M, L = len(origin), len(s), bw.shape[1]
    out = np.zeros((N, M, L))
    du = np.log(s[-1] + S_A_M) - np.log(S_A_M)
    du /= (M - 1)
    jac = (s + S_A_M) * du  # ds/du
    cam = np.exp(-np.outer(s, kappa_cam))  # (M, Λ)
    rows = max(1, chunk_elems // (M * L))
    for n0 in range(0, N, rows):
        o, d = origin[n0:n0 + rows], direction[n0:n0 + rows]
        p = o[:, None, :] + s[None, :, None] * d[:, None, :]  # (n, M, 3)
        g = np.zeros((len(o), M, L))
        if surfaces is not None and len(surfaces):
            t_hit = np.full(len(o), np.inf) if shade_beyond_hit else cast_rays(surfaces, o, d)[0]
            in_front = s[None, :] < t_hit[:, None]  # (n, M)
        for lt in lights:
            v = p - lt.position
            r = np.linalg.norm(v, axis=-1)
            vh = v / np.maximum(r, 1e-12)[..., None]
            cos_psi = -np.einsum("nmk,nk->nm", vh, d)
            theta = beam_angle(vh, lt.axis)
            beta = components.eval_components(cos_psi) @ bw  # (n, M, Λ)
            att = np.exp(-r[..., None] * c)
            illum = lt.beam_fn(theta)[..., None] * att
            if forward and lt.blurred is not None and two_leg is not None:
                beta_s, delta = two_leg(cos_psi, beta, r, np.broadcast_to(s[None, :], r.shape))
                illum = illum * beta_s + lt.blurred_at(theta, r) * np.exp(-r[..., None] * kappa_light) * delta
            elif forward and lt.blurred is not None:
                fs = lt.blurred_at(theta, r) * (np.exp(-r[..., None] * kappa_light) - att)
                if spread is not None:
                    illum = beta * illum + spread(cos_psi, r) * fs
                else:
                    illum = beta * (illum + fs)
            else:
                illum = beta * illum
            val = illum * (lt.intensity / np.maximum(r, 1e-9)[..., None] ** 2)
            if surfaces is not None and len(surfaces):
                shade = np.zeros(in_front.shape, bool)  # only the points in front of the ray's hit are tested
                shade[in_front] = occluded(surfaces, p[in_front], lt.position)
                val *= ~shade[..., None]
            g += val
        g *= cam[None] * jac[None, :, None]
        # trapezoid cumulative sum in u
        seg = 0.5 * (g[:, 1:] + g[:, :-1])
        out[n0:n0 + rows, 1:] = np.cumsum(seg, axis=1)
    return out


def interpolate_cumulative(cum: np.ndarray, grid_shape: tuple[int, int], grid_col: np.ndarray,
                           grid_row: np.ndarray, s: np.ndarray, col: np.ndarray, row: np.ndarray,
                           s_hit: np.ndarray, *, out: np.ndarray | None = None) -> np.ndarray:
    """Read the cumulative integral at pixel positions and path lengths.

    Bilinear in the image between the grid rays, linear in s between nodes.
    ``cum`` is (n_rows·n_cols, M, Λ) for a grid of ``grid_shape`` (rows, cols) at
    pixel coordinates ``grid_row`` × ``grid_col``; ``col``, ``row``, ``s_hit`` are
    arrays of one shape (``s_hit`` = inf reads the full integral).  The result has ``cum``'s dtype;
    with ``out`` (``shape(col) + (Λ,)``) it is added to ``out``.
    """
    nr, nc = grid_shape
    M = len(s)

    def idx(x, nodes):
        k = np.clip(np.searchsorted(nodes, x, side="right") - 1, 0, len(nodes) - 2)
        f = np.clip((x - nodes[k]) / (nodes[k + 1] - nodes[k]), 0.0, 1.0)
        return k, f.astype(cum.dtype)

    ic, fc = idx(col, grid_col)
    ir, fr = idx(row, grid_row)
    sh = np.minimum(np.where(np.isfinite(s_hit), s_hit, s[-1]), s[-1])
    js, fs = idx(sh, s)
    flat = cum.reshape(nr * nc * M, -1)
    fs = fs[..., None]
    if out is None:
        out = np.zeros(np.shape(col) + (flat.shape[1],), cum.dtype)
    whole = bool(np.all(sh >= s[-1]))  # every line of sight sees the whole integral (open water)
    for dr_, wr in ((0, 1 - fr), (1, fr)):
        for dc_, wc in ((0, 1 - fc), (1, fc)):
            base = ((ir + dr_) * nc + (ic + dc_)) * M
            if whole:
                b = np.take(flat, base + (M - 1), axis=0)
            else:
                a = np.take(flat, base + js, axis=0)
                b = np.take(flat, base + js + 1, axis=0)
                b -= a  # a + (b − a) fs, in place
                b *= fs
                b += a
            b *= (wr * wc)[..., None]
            out += b
    return out
