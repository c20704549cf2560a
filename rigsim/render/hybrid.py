"""A second Monte Carlo reference for a chart lit by the rig's lights in turbid water: light tracing + a camera pass.

Why
---
In water that scatters much and absorbs little (Jerlov III, 5C–9C) the renderer's camera paths find the
strobe light on a chart patch by rebuilding, from the patch, a chain of many nearly collinear small-angle
scatterings back to a point light: the estimate is heavy-tailed (one render of a chart case up to 1 733×
the median), and a patch's mean over tens of renders is often tens of per cent off with a standard error
that does not show it (``benchmarks/bench_reference_convergence.py``).  Traced the other way the same light
is easy.  The reference here splits every path at its last surface interaction:

1. **the targets' irradiance by light tracing** (:func:`rigsim.render.light_trace.trace_target_irradiance`:
   photons from the strobes — or the continuous lights, :func:`hybrid_group` — through the renderer's own
   Mitsuba scene; bounded weights, no tail), on the chart fitted by a quadratic in its plane
   (:func:`smooth_chart_irradiance`: the light on a chart a metre or more into turbid water changes over
   decimetres, a patch is 4 cm; the fit pools the 24 patches' photons);
2. **the camera leg**: Mitsuba's ``volpath`` through the same water with the targets black and *emitting*
   ``ρ/π E`` (:func:`emissive_camera_pass`, one render per band);
3. **the veil**: the renderer's own ``backscatter`` layer (light of paths that never meet a surface) — of
   the Monte Carlo renders each hybrid image is built on (:func:`hybrid_image`).  Over open water it has no
   tail (largest of 32 renders 1.1–1.3× the median in Jerlov 7C and 9C); over the chart's patches, in front
   of which the edge-lit rig's beams cross, it can have one (9C at 1 m: one render 15× the median over the
   moderate red patch's blue, the veil's SE there 19 % of the patch's light): the hybrid does not remove
   that part of the renders' tail.  It pools it: the veil does not depend on the patches, so over the chart it is
   replaced by a local quadratic of the pixels around (:func:`smooth_chart_veil`, ``hybrid_image(...,
   veil_sigma_px=4)``: a patch's noise 1.6–1.9× lower in Jerlov 7C, a bright path spread over its neighbours).

Each hybrid image is an independent estimate (its own photons, camera paths and render), so the agreement
check (:func:`rigsim.metrics.agreement.compare_renders`) takes their mean and spread as it takes renders'.

Measured (``benchmarks/bench_reference_hybrid.py``): where Monte Carlo converges (coastal water, chart at
1 m) hybrid / Monte Carlo − 1 has median −0.1 % over the 72 patch cells, within the renders' 1–3 %; in Jerlov
7C with the edge-lit rig at 1 m no cell of the fast engine is beyond tolerance + t·SE from it where 16 renders of
Monte Carlo scatter by ±40 % (and in 9C at 1 m none either, with the veil's noise above).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from rigsim.errors import ConfigError
from rigsim.render.light_trace import TargetIrradiance, trace_target_irradiance
from rigsim.render.variant import mitsuba
from rigsim.scene.surfaces import target_surfaces
from rigsim.scene.types import Scene
from rigsim.spectrum import band_average, band_edges

__all__ = ["CELLS", "CAMERA_CELLS", "DEFAULT_FIT_ORDER", "PASS_RENDER_COST_RATIO", "HybridSettings",
           "emissive_camera_pass", "hybrid_group", "hybrid_image", "hybrid_reflected", "smooth_chart_irradiance",
           "smooth_chart_veil", "supports_hybrid", "veil_renders_for"]

mi, dr = mitsuba()

#: Texture cells per side of each target piece in the light tracer.
CELLS = 8
#: Emitters per side of each piece in the camera pass (the tracer's cells averaged): ``volpath`` picks one
#: emitter at random for each next-event estimate, and with 64 per patch (1 600 in all) the camera leg's
#: forward-scattered light was 20–30 % noisy per patch at 8 spp (2026-12-04).
CAMERA_CELLS = 2
#: Order of the polynomial :func:`smooth_chart_irradiance` fits to the chart's light-traced irradiance.  Checked
#: against the exact direct irradiance of every shipped rig's lights on a ColorChecker 40 % of the field at
#: 0.5–6 m (``I f(θ) cos θᵢ e^{−c r}/r²`` per texture cell; ``tests/render/test_hybrid.py``): the largest error of
#: a patch mean is 4.1 % at order 2 (twin-strobes-45-wide at 0.5 m; 3.3 % at 6 m, 2.4 % single strobe at 1 m),
#: 2.4 % at 3 and 0.19 % at 4.  Where the direct beam lights the chart in clear water (Jerlov II, 45-wide, 3 and
#: 6 m, 4 000 000 photons in 8 batches) the raw patch means scattered about an order-2 fit by rms z = 2.4 (7.3 at
#: most, 72 patch × colour-group values) and about an order-4 fit by 1.1–1.4 (Student's t with 7 degrees of
#: freedom: 1.18); the fit's own noise per patch grows from 0.31 to 0.40 %.  (Until 2026-12-06: 2.)
DEFAULT_FIT_ORDER = 4


#: Time of one hybrid image's light trace and camera pass over that of one render, where neither was timed (kept
#: before their times were): 2 000 000 photons and 128 paths per pixel and band against a render of 32 paths per
#: pixel, 96×64, 31 bands, Jerlov III, ~170 s against ~3.4 s on 2 cores (2026-12-06).
PASS_RENDER_COST_RATIO = 50.0


def veil_renders_for(veil_var, pass_var, *, render_s: float, pass_s: float, k_min: int, k_max: int) -> int:
    """How many renders' veil each hybrid image should average, from a pilot's noise and costs.

    A hybrid image is one camera pass (and light trace: ``pass_s`` seconds) plus ``k`` renders (``render_s``
    each) whose veil it averages; over a judged region its variance is ``veil_var/k + pass_var`` (``veil_var``:
    one render's veil, ``pass_var``: one pass's light, each region's relative variance).  The time to bring the
    regions' summed variance to any given level is ∝ ``(pass_s + k render_s)(V/k + P)`` (``V``, ``P`` the sums),
    least at ``k* = √(pass_s V / (render_s P))``; returned is the better of the integers either side, within
    [``k_min``, ``k_max``].  Where the chart is near (0.5–1 m in Jerlov II/III) the pass's light is most of a
    patch and ``k*`` is small; where it is far (3–6 m) the veil is 75–99 % of a patch's light, one render's
    veil varies 100–10⁵ times as much as one pass's (``benchmarks/results/fast-engine-log.md``, 2026-12-07),
    and ``k*`` is in the hundreds."""
    if not (1 <= k_min <= k_max):
        raise ValueError(f"need 1 <= k_min <= k_max, got {k_min}, {k_max}")
    if not (render_s > 0 and pass_s > 0):
        raise ValueError(f"costs must be positive, got render {render_s} s, pass {pass_s} s")
    v = np.asarray(veil_var, float)
    p = np.asarray(pass_var, float)
    ok = np.isfinite(v) & np.isfinite(p)
    V, P = float(v[ok].sum()), float(p[ok].sum())
    if V <= 0:
        return k_min
    if P <= 0:
        return k_max

    def cost(k: int) -> float:
        return (pass_s + k * render_s) * (V / k + P)

    k_star = math.sqrt(pass_s * V / (render_s * P))
    lo = int(min(max(math.floor(k_star), k_min), k_max))
    hi = int(min(max(math.ceil(k_star), k_min), k_max))
    return lo if cost(lo) <= cost(hi) else hi


@dataclass(frozen=True)
class HybridSettings:
    """Work per hybrid image: light-tracer photons, camera-pass paths per pixel and band, the fit's order."""

    photons: int = 1_000_000
    spp: int = 64
    order: int = DEFAULT_FIT_ORDER

    def key(self) -> str:
        return f"hybrid-{self.photons}ph-{self.spp}spp-o{self.order}"


def hybrid_group(scene: Scene) -> str | None:
    """The light group the hybrid reference replaces — ``"strobe"`` (the ``flash`` layer, J per flash) or
    ``"continuous"`` (``radiance``, W) — or None where it does not apply: it needs one ColorChecker in water,
    lit by lights of one kind and no daylight (the light tracer starts photons at the rig's lights only)."""
    if scene.water is None or len(scene.targets) != 1 or scene.targets[0].kind != "colorchecker":
        return None
    kinds = {l.kind for l in scene.lights}
    if len(kinds) != 1 or (kinds == {"continuous"} and scene.daylight is not None):
        return None
    kind = kinds.pop()
    return kind if kind in ("strobe", "continuous") else None


def supports_hybrid(scene: Scene) -> bool:
    """Whether the hybrid reference applies (:func:`hybrid_group`)."""
    return hybrid_group(scene) is not None


def smooth_chart_irradiance(pieces, labels, E: np.ndarray, cell_area_m2: np.ndarray,
                            order: int = DEFAULT_FIT_ORDER) -> np.ndarray:
    """The light-traced irradiance ``E`` (S, T, T, B) of a ColorChecker's patches replaced by a polynomial of
    ``order`` in the chart's plane (u, v about the chart body's centre), fitted per band to the texture cells of
    all 24 patches (their areas as weights) and evaluated on the patches and on the body (whose own cells mix
    the lit gaps with the dark under the patches: emitting that mean, the gaps shone at about a third of
    their light and their glow over the dark patches was missing, −13 … −17 % on the black patch in coastal
    water at 1 m).  Checked in ``benchmarks/bench_reference_hybrid.py``: each patch's raw mean scatters about
    the fit as its noise says (rms of (raw − fit)/SE ≈ 1 in coastal water at 1 m, Jerlov III at 3 m, 7C and 9C
    at 1 m)."""
    body = [k for k, lab in enumerate(labels) if lab.endswith("chart")]
    patches = [k for k, lab in enumerate(labels) if not lab.endswith("chart")]
    if len(body) != 1 or not patches:
        raise ValueError("the fit needs a ColorChecker")
    k0 = body[0]
    T = E.shape[1]
    g = (np.arange(T) + 0.5) / T * 2 - 1
    c0 = np.asarray(pieces[k0].center_m, float)
    u0, v0 = np.asarray(pieces[k0].u_axis, float), np.asarray(pieces[k0].v_axis, float)

    def plane_uv(k):
        p = pieces[k]
        hw, hh = p.size_m[0] / 2, p.size_m[1] / 2
        cen = (np.asarray(p.center_m, float)[None, None, :] + hw * g[:, None, None] * np.asarray(p.u_axis, float)
               + hh * g[None, :, None] * np.asarray(p.v_axis, float))
        rel = cen - c0
        return np.stack([rel @ u0, rel @ v0], axis=-1).reshape(-1, 2)

    uv = np.concatenate([plane_uv(k) for k in patches])
    scale = np.abs(uv).max()

    def design(xy):
        x, y = xy[:, 0] / scale, xy[:, 1] / scale
        return np.stack([x ** i * y ** j for i in range(order + 1) for j in range(order + 1 - i)], axis=1)

    A = design(uv)
    wsq = np.sqrt(np.concatenate([cell_area_m2[k].reshape(-1) for k in patches]))[:, None]
    raw = np.concatenate([E[k].reshape(-1, E.shape[-1]) for k in patches])
    coef, *_ = np.linalg.lstsq(A * wsq, raw * wsq, rcond=None)
    out = E.copy()
    n = T * T
    fit = A @ coef
    for j, k in enumerate(patches):
        out[k] = fit[j * n:(j + 1) * n].reshape(T, T, -1)
    out[k0] = (design(plane_uv(k0)) @ coef).reshape(T, T, -1)
    return np.maximum(out, 0.0)


def smooth_chart_veil(veil: np.ndarray, chart: np.ndarray, sigma_px: float, degree: int = 2) -> np.ndarray:
    """The veil ``veil`` (H, W, B) over the chart's pixels (``chart``, a boolean (H, W) mask; its outer ring of
    pixels, which mix the chart with the water behind it, excepted) replaced by a local polynomial regression of
    ``degree`` over them with a Gaussian kernel of ``sigma_px`` pixels (Fan & Gijbels 1996, *Local Polynomial
    Modelling and Its Applications*, ch. 3); elsewhere unchanged.

    Why: the veil is the light of paths that never meet a surface, so in front of the chart it does not depend on
    the patches (the same water up to the same plane; the renders' ``backscatter`` layer of a white and a black
    disk with the same seeds is identical), and it varies over decimetres of water, not over a patch.  Pooled
    over neighbouring patches and the gaps between them its noise falls 1.6–1.9× (Jerlov 7C, edge-lit rig, 32
    renders, 4 px: a patch's relative SE 3.6 → 1.9 % at 1 m, 4.2 → 2.7 % at 3 m, median; for independent pixels
    the variance of a patch mean falls to 0.17×) and a rare bright path spreads over the kernel instead of landing
    on one patch (one pixel weighs at most 0.32 of its weight in a plain patch mean; unbiased either way).  A local polynomial follows the veil's gradient and curvature across
    the chart (it rises steeply towards an edge-lit chart's sides); what it smooths away is measured on the fast
    engine's noise-free veil in ``tests/render/test_hybrid.py``."""
    from scipy import ndimage

    chart = np.asarray(chart, bool)
    inner = ndimage.binary_erosion(chart, iterations=1)
    v = np.asarray(veil, float)
    if not inner.any() or sigma_px <= 0:
        return v.copy()
    H, W = chart.shape
    py, px = np.nonzero(inner)
    terms = [(i, j) for i in range(degree + 1) for j in range(degree + 1 - i)]
    K = len(terms)
    M = np.zeros((py.size, K, K))
    r = np.zeros((py.size, K, v.shape[-1]))
    reach = int(np.ceil(3.0 * sigma_px))
    for dy in range(-reach, reach + 1):
        for dx in range(-reach, reach + 1):
            w = np.exp(-0.5 * (dx * dx + dy * dy) / (sigma_px * sigma_px))
            qy, qx = py + dy, px + dx
            ok = (qy >= 0) & (qy < H) & (qx >= 0) & (qx < W)
            ok[ok] = inner[qy[ok], qx[ok]]
            if not ok.any():
                continue
            a = np.array([float(dx) ** i * float(dy) ** j for i, j in terms])
            M[ok] += w * np.outer(a, a)
            r[ok] += w * a[:, None] * v[qy[ok], qx[ok]][:, None, :]
    out = v.copy()
    # a pixel whose neighbourhood cannot hold the polynomial (a thin strip of the mask) keeps its value
    good = np.linalg.matrix_rank(M) == K
    beta = np.linalg.solve(M[good], r[good])
    out[py[good], px[good]] = beta[:, 0, :]
    return out


def emissive_camera_pass(scene: Scene, E: np.ndarray, wavelength_nm, bandwidth_nm, *, width: int, height: int,
                         spp: int, seed: int, cells_per_side: int = CAMERA_CELLS) -> np.ndarray:
    """Radiance (H, W, B) at the camera of the targets emitting ``ρ/π E`` (black otherwise), through the water:
    Mitsuba ``volpath``, one render per band, ``spp`` paths per pixel each.  ``E`` (S, T, T, B) on the pieces
    of :func:`rigsim.scene.surfaces.target_surfaces` (object-id order) is averaged to ``cells_per_side``²
    emitters per piece; ``ρ`` is each piece's reflectance averaged over the band.

    One band per render: with four neighbouring bands in one render (a path's four wavelengths in different
    bands) a pass took a third of the time but its noise per patch doubled (coastal water, chart at 1 m,
    32 spp: 1.8 % → 3.4 % rms over the patches) — ``volpath`` draws distances for the path's first
    wavelength, the other bands' weights are ratios of transmittances."""
    from rigsim.render.mitsuba_scene import WATER_KEY, MitsubaScene, water_medium_dict
    from rigsim.render.renderer import render_pass
    from rigsim.scene.optics import outside_index, world_radius_m

    wl, bw = band_edges(np.asarray(wavelength_nm, float), bandwidth_nm)
    pieces = [p for t in scene.targets for p in target_surfaces(t, scene.camera)]
    traced = E.shape[1]
    if traced % cells_per_side:
        raise ValueError(f"cells_per_side must divide the tracer's {traced} cells")
    f = traced // cells_per_side
    E = E.reshape(E.shape[0], cells_per_side, f, cells_per_side, f, E.shape[-1]).mean(axis=(2, 4))
    T = cells_per_side
    rho = np.stack([band_average(np.asarray(p.wavelength_nm, float), np.asarray(p.reflectance, float),
                                 wl - bw / 2, wl + bw / 2) for p in pieces])
    cam = np.asarray(scene.camera.position_m, float)
    cells = []
    for k, p in enumerate(pieces):
        if p.shape != "rectangle":
            raise ConfigError("the hybrid reference handles flat rectangles only (the colorchecker)",
                              field="targets", allowed="colorchecker")
        c, u, v, n = (np.asarray(x, float) for x in (p.center_m, p.u_axis, p.v_axis, p.normal))
        n = n if np.dot(n, cam - c) > 0 else -n
        hw, hh = p.size_m[0] / 2, p.size_m[1] / 2
        for iu in range(T):
            for iv in range(T):
                cen = c + u * hw * ((iu + 0.5) / T * 2 - 1) + v * hh * ((iv + 0.5) / T * 2 - 1)
                m = np.eye(4)
                m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = u * hw / T, v * hh / T, n, cen
                cells.append((k, iu, iv, mi.ScalarTransform4f(m.tolist())))
    medium = mi.load_dict(water_medium_dict(scene.water))
    out = np.zeros((height, width, len(wl)))
    black = {"type": "diffuse", "reflectance": {"type": "uniform", "value": 0.0}}
    for bi in range(len(wl)):
        d = {"type": "scene", "integrator": {"type": "volpath", "max_depth": -1},
             WATER_KEY: {"type": "sphere", "center": cam.tolist(), "radius": world_radius_m(scene),
                         "bsdf": {"type": "null"}, "interior": medium}}
        for j, (k, iu, iv, tw) in enumerate(cells):
            radiance = max(float(rho[k, bi] / np.pi * E[k, iu, iv, bi]), 0.0)
            d[f"cell{j}"] = {"type": "rectangle", "to_world": tw, "bsdf": black, "exterior": medium,
                             "emitter": {"type": "area", "radiance": {"type": "uniform", "value": radiance}}}
        ms = MitsubaScene(scene=mi.load_dict(d, optimize=False), medium=medium, surfaces=[], mode="full",
                          n_outside=outside_index(scene))
        img, _ = render_pass(ms, scene.camera, width=width, height=height, spp=spp, seed=seed + 7 * bi,
                             band_lo=np.array([wl[bi] - bw[bi] / 2]), band_w=np.array([bw[bi]]))
        out[..., bi] = img[..., 0]
    return out


def hybrid_reflected(scene: Scene, *, width: int, height: int, wavelength_nm, bandwidth_nm=None,
                     settings: HybridSettings = HybridSettings(), seed: int = 0) -> tuple[np.ndarray, TargetIrradiance]:
    """One independent estimate (H, W, B) of the light whose last surface interaction is the chart, at the
    camera (J/(m² sr nm) per flash from strobes, W/(m² sr nm) from continuous lights: :func:`hybrid_group`):
    the lights' irradiance on it by light tracing (``settings.photons``), fitted (``settings.order``; < 0: the
    traced cells as they are), seen through the water by a camera pass (``settings.spp`` per band).  Returns it
    and the traced irradiance."""
    group = hybrid_group(scene)
    if group is None:
        raise ValueError("the hybrid reference needs one colorchecker lit by lights of one kind (strobes, or "
                         "continuous lights without daylight), in water")
    wl, bw = band_edges(np.asarray(wavelength_nm, float), bandwidth_nm)
    lt = trace_target_irradiance(scene, wavelength_nm=wl, bandwidth_nm=bw, photons=settings.photons,
                                 seed=int(seed) & 0xFFFF, batches=4, cells=CELLS,
                                 lights=[l for l in scene.lights if l.kind == group])
    pieces = [p for t in scene.targets for p in target_surfaces(t, scene.camera)]
    E = lt.irradiance
    if settings.order >= 0:
        E = smooth_chart_irradiance(pieces, [p.name for p in pieces], E, lt.cell_area_m2, settings.order)
    refl = emissive_camera_pass(scene, E, wl, bw, width=width, height=height, spp=settings.spp,
                                seed=(int(seed) * 104_729 + 17) % 2**31)
    return refl, lt


def hybrid_image(render, reflected: np.ndarray, *, group: str = "strobe", veil_sigma_px: float = 0.0):
    """A Monte Carlo render (:class:`~rigsim.spectral_image.SpectralImage` with the group's backscatter layer
    and ``object_id``) whose light from ``group`` (:func:`hybrid_group`: ``"strobe"`` — ``flash``, veil
    ``flash_backscatter``; ``"continuous"`` — ``radiance``, veil ``backscatter``) is replaced by its veil (the
    paths that met no surface) plus ``reflected`` (:func:`hybrid_reflected`: the paths whose last surface is
    the chart).  With ``veil_sigma_px`` > 0 the veil over the chart is pooled by :func:`smooth_chart_veil` (in
    the image and in the backscatter layer)."""
    if group not in ("strobe", "continuous"):
        raise ValueError(f"group must be 'strobe' or 'continuous', not {group!r}")
    veil_key = "flash_backscatter" if group == "strobe" else "backscatter"
    veil = render.layers.get(veil_key)
    if veil is None:
        raise ValueError(f"the render has no {veil_key} layer")
    veil = np.asarray(veil, float)
    layers = dict(render.layers)
    if veil_sigma_px > 0:
        oid = render.layers.get("object_id")
        if oid is None:
            raise ValueError("pooling the veil over the chart needs the render's object_id layer")
        veil = smooth_chart_veil(veil, np.asarray(oid) > 0, veil_sigma_px)
        layers[veil_key] = veil.astype(np.asarray(render.layers[veil_key]).dtype)
    if veil.shape != reflected.shape:
        raise ValueError(f"shapes differ: {veil.shape} vs {reflected.shape}")
    meta = {**render.meta, "reference": "hybrid", "veil_sigma_px": float(veil_sigma_px)}
    if group == "strobe":
        flash = (veil + reflected).astype(np.asarray(render.layers["flash"]).dtype)
        return dataclasses.replace(render, layers={**layers, "flash": flash}, meta=meta)
    radiance = (veil + reflected).astype(np.asarray(render.radiance).dtype)
    return dataclasses.replace(render, radiance=radiance, layers=layers, meta=meta)
