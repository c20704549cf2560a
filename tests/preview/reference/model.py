"""``render_preview(scene) → SpectralImage``: the Jaffe–McGlamery image model, vectorised.

The image is the sum of three components (McGlamery 1980; Jaffe 1990):

1. **Direct** — light from each lamp to the target and from the target to the camera
   without scattering: for a Lambertian surface point at distance ``r`` from a light
   and ``s`` (water path) from the port,
   ``L_d = ρ/π Σ_l I_l(λ) f_l(θ) cos θ_i / r² · e^{−c r} · e^{−c s}``, with the beam
   pattern ``f`` and on-axis spectrum ``I`` of each light exactly as the renderer's
   emitter, optional shadows from the other surfaces.
2. **Forward-scattered** — the same light turned by small angles on either leg
   (small-angle approximation, all orders; see :mod:`rigsim.preview.forward`):
   the target is lit by the beam blurred by forward scattering with amplitude
   ``e^{−cr}(e^{bFr} − 1)`` as well, and its image is blurred on the way to the
   camera with amplitude ``e^{−cs}(e^{bFs} − 1)``.
3. **Backscatter** — light from the lamps scattered once, at a wide angle, by the
   water in front of the target, integrated along each pixel's ray with the
   water's own wavelength-dependent phase function (see
   :mod:`rigsim.preview.backscatter`), plus the path radiance of daylight.

Daylight (``scene.daylight``) is the scene's daylight field
(:func:`rigsim.scene.daylight_field.scene_daylight`: the Kd shortcut or the Monte Carlo meter,
with the Daylight's sky and photons) and its transport, the same tables and formulas as the
renderer's: the target is lit by the sun beam and the diffuse field integrated over the
hemisphere about its normal (each × its height factor; unoccluded), seen through ``e^{−c s}``
(no forward-scattered halo, as the renderer's daylight), and each line of sight collects
Duntley's path radiance ``L_amb(v)(1 − e^{−(c − K v_y) s})``, so a black target's contrast is
``−e^{−c s}`` along a horizontal line of sight, as in the renderer.

What is not in it: multiple wide-angle scattering (the "glow" of turbid water
beyond a few optical depths), light scattered by more than the forward cut-off
angle that then lights the target, interreflections, port optics (radiance is the
in-water radiance at the port, as the renderer's).  The validation in
``benchmarks/bench_preview.py`` shows where this matters.

Validation against the renderer (Mitsuba volpath, 96 × 96, 6 seeds × 512 spp; region
means over pixels wholly inside each region; ``benchmarks/bench_preview.py`` and
``tests/preview/test_preview_vs_render.py``): ``clear`` water, ColorChecker at 2 m —
every region within 2 %; ``coastal`` at 2, 5 and 8 m (up to ~3 attenuation lengths
per leg) — mean patch radiance within ~6 % (Monte Carlo errors 2–8 %), open-water
veil within 3 %, backscatter in front of the chart −5…+5 % (+7…+12 % in front of a
large bright disk), the dark chart body up to +15 % (its forward-scattered halo is
too strong); classical single scattering without the forward term is 30–50 % low
there.  Beyond the single-scattering regime (Jerlov 3C at 2 m, b·r ≈ 2 per leg) the
backscatter in front of the target is 25–40 % high and patch radiances differ by
tens of per cent (the renderer's own noise is as large there).

Conventions are the renderer's (:func:`rigsim.render.render`): bands are averages
over ``[centre ± width/2]`` (the direct component by ``sub_bands``-point
Gauss–Legendre quadrature in each band; the water, blur kernels and backscatter at
band centres), strobes go to the ``flash`` layers in J/(m² sr nm) and continuous
light to ``radiance``, object ids and ``range_m`` from the pixel-centre ray.

References
----------
.. [McG80] B.L. McGlamery, "A computer model for underwater camera systems",
   Proc. SPIE 208, Ocean Optics VI, 221–231 (1980).
.. [Ja90] J.S. Jaffe, "Computer modeling and the design of optimal underwater
   imaging systems", IEEE J. Oceanic Eng. 15(2):101–111 (1990).
.. [We73] W.H. Wells, "Theory of small angle scattering", AGARD Lecture Series
   61 (1973).
.. [Ze91] E.P. Zege, A.P. Ivanov, I.L. Katsev, *Image Transfer Through a Scattering
   Medium*, Springer (1991).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import time
from collections.abc import Callable, Sequence

import numpy as np

from rigsim.errors import ConfigError
from tests.preview.reference.backscatter import (
    LightTables,
    beam_angle,
    cumulative_backscatter,
    interpolate_cumulative,
    s_nodes,
)
from tests.preview.reference.forward import SmallAngle
from tests.preview.reference.geometry import cast_rays, occluded, scene_surfaces
from rigsim.scene.daylight_field import height_factor, path_radiance, scene_daylight
from rigsim.scene.phase_tables import phase_tables
from rigsim.scene.types import Scene, unit
from rigsim.spectral_image import RenderInfo, SpectralImage
from rigsim.spectrum import DEFAULT_WAVELENGTHS_NM, band_average, band_edges
from rigsim.scene.imaging import IMAGE_LAYERS, check_int, check_scene_for_bands, image_request
from rigsim.scene.optics import angular_pitch_rad, camera_rays, fov_water_deg, outside_index, pixel_rays, world_radius_m

__all__ = ["render_preview", "PREVIEW_LAYERS", "band_edges"]

#: Ground-truth layers ``render_preview`` can make (as the renderer's).
PREVIEW_LAYERS = IMAGE_LAYERS
RENDERER_NAME = "rigsim.preview (Jaffe-McGlamery)"  # as the engine's

ProgressCallback = Callable[[float, str], None]


@dataclasses.dataclass
class _Water:
    """IOPs at the direct component's sub-band wavelengths (B, S) and at band centres (B,)."""

    c_sub: np.ndarray
    b_sub: np.ndarray
    F_sub: np.ndarray
    c: np.ndarray
    b: np.ndarray
    F: np.ndarray
    bw: np.ndarray  # (K, B) b_k at band centres
    components: object
    small_angle: SmallAngle | None


def _water_at(scene: Scene, wl: np.ndarray, lam: np.ndarray, cutoff_rad: float, forward: bool) -> _Water | None:
    water = scene.water
    if water is None:
        return None
    lo, hi = water.wavelength_range_nm

    def iops(x):
        x = np.clip(x, lo, hi)
        return water.c_per_m(x), water.b_per_m(x)

    comps = phase_tables(water.phase, water.wavelength_range_nm)
    F_k = comps.forward_fraction(cutoff_rad) if forward else np.zeros(comps.n_components)
    c_sub, b_sub = iops(lam)
    c, b = iops(wl)
    w_sub = comps.weights_at(lam.ravel())
    w = comps.weights_at(wl)
    F_sub = (w_sub @ F_k).reshape(lam.shape)
    sa = SmallAngle(comps, cutoff_rad, b, w) if forward else None
    return _Water(c_sub, b_sub, F_sub, c, b, w @ F_k, (b[:, None] * w).T, comps, sa)


def _sub_band_wavelengths(wl: np.ndarray, bw: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(B, n) Gauss–Legendre nodes inside each band and their weights (summing to 1)."""
    x, w = np.polynomial.legendre.leggauss(n)
    return wl[:, None] + 0.5 * bw[:, None] * x[None, :], w / 2.0


def render_preview(scene: Scene, *, width: int = 320, height: int = 240,
                   wavelengths_nm: Sequence[float] = DEFAULT_WAVELENGTHS_NM, bandwidth_nm=None,
                   layers: Sequence[str] = ("range_m", "clear", "object_id"), split: bool = False,
                   shadows: bool = False, forward_scatter: bool = True, forward_cutoff_deg: float = 90.0,
                   sub_bands: int = 3, pixel_samples: int = 1, backscatter_grid: int | None = 32,
                   backscatter_nodes: int = 64, multiple: bool = False, photons: int | None = None,
                   ms_grid: int | None = None, spp: int | None = None, seed: int | None = None,
                   max_depth: int | None = None, progress: ProgressCallback | None = None) -> SpectralImage:
    """Fast semi-analytic image of a :class:`~rigsim.scene.types.Scene` (see module docstring).

    Parameters
    ----------
    scene
        Camera, lights, targets, water (``None``: no water) and optional daylight.
    width, height
        Image size (pixels).
    wavelengths_nm, bandwidth_nm
        Band centres and widths (nm), as :func:`rigsim.render.render`.
    layers, split
        Ground-truth layers from :data:`PREVIEW_LAYERS`; ``split`` adds ``direct`` and
        ``backscatter``.
    shadows
        Let target surfaces shadow the lights (on surfaces and in the water).
    forward_scatter
        Include the small-angle forward-scattered component (False: the classical
        direct + single-backscatter model with ``e^{−c·}`` on every leg).
    forward_cutoff_deg
        Scattering by less than this angle is treated as forward scattering (deg, 0–90).
    sub_bands
        Gauss–Legendre points per band for the direct component (1: band centres).
    pixel_samples
        The direct component is averaged over ``pixel_samples²`` points per pixel
        (1: the pixel centre; the renderer box-filters over the pixel).
    backscatter_grid
        Rays along the longer image side on which the backscatter integral is
        computed and then interpolated (None: every pixel).
    backscatter_nodes
        Quadrature nodes along each ray.
    spp, seed, max_depth
        Accepted for call compatibility with :func:`rigsim.render.render` and ignored
        (the preview is deterministic and has no sampling).
    progress
        Called as ``progress(fraction_done, message)``.

    Returns
    -------
    SpectralImage
        As :func:`rigsim.render.render`: ``radiance`` (continuous light and daylight,
        W·m⁻²·sr⁻¹·nm⁻¹), ``flash``/``flash_*`` for strobes (J·m⁻²·sr⁻¹·nm⁻¹),
        ``meta["renderer"] = "rigsim.preview (Jaffe-McGlamery)"``.

    Examples
    --------
    >>> from rigsim.config.rig import load_rig
    >>> from rigsim.scene.build import build_scene
    >>> sc = build_scene(load_rig("rigs/twin-strobes-45-wide.toml"), "coastal", "colorchecker", 2.0)
    >>> img = render_preview(sc, width=48, height=32)
    >>> img.radiance.shape, sorted(img.layers)
    ((32, 48, 31), ['flash', 'flash_clear', 'object_id', 'range_m'])
    """
    t_start = time.perf_counter()
    req = image_request(width=width, height=height, wavelengths_nm=wavelengths_nm, bandwidth_nm=bandwidth_nm,
                        layers=layers, split=split)
    width, height, layers = req.width, req.height, req.layers
    sub_bands = check_int("sub_bands", sub_bands, 1, 16)
    pixel_samples = check_int("pixel_samples", pixel_samples, 1, 16)
    backscatter_nodes = check_int("backscatter_nodes", backscatter_nodes, 8, 4096)
    if not 0.0 < float(forward_cutoff_deg) <= 90.0:
        raise ConfigError(f"forward cut-off must be in (0, 90] deg, got {forward_cutoff_deg}",
                          field="forward_cutoff_deg", allowed="0 < angle <= 90")
    wl, bw = req.wavelength_nm, req.bandwidth_nm
    check_scene_for_bands(scene, req)

    def tick(frac, msg):
        if progress is not None:
            progress(frac, msg)

    B = len(wl)
    lam, lam_w = _sub_band_wavelengths(wl, bw, sub_bands)  # (B, S), (S,)
    cutoff = np.radians(float(forward_cutoff_deg))
    has_water = scene.water is not None
    forward = bool(forward_scatter) and has_water
    water = _water_at(scene, wl, lam, cutoff, forward)
    surf = scene_surfaces(scene)
    cam = scene.camera
    pupil = np.asarray(cam.position_m, float)

    # --- pixel-centre rays: geometry layers ----------------------------------------------
    n_out = outside_index(scene)
    o_c, d_c, cols, rows = pixel_rays(cam, width, height, n_outside=n_out)
    t_c, oid_c = cast_rays(surf, o_c, d_c)
    p_c = o_c + np.where(np.isfinite(t_c), t_c, 0.0)[..., None] * d_c
    range_m = np.where(oid_c > 0, np.linalg.norm(p_c - pupil, axis=-1), np.inf).astype(np.float32)

    # --- surface samples (pixel_samples² per pixel) ------------------------------------
    n = pixel_samples
    g = (np.arange(n) + 0.5) / n
    PX = ((np.arange(width)[:, None] + g[None, :]).ravel() / width)
    PY = ((np.arange(height)[:, None] + g[None, :]).ravel() / height)
    if n == 1:
        o_s, d_s, t_s, oid_s = o_c, d_c, t_c, oid_c
    else:
        PXg, PYg = np.meshgrid(PX, PY)  # (H n, W n)
        o_s, d_s = camera_rays(cam, PXg, PYg, n_outside=n_out)
        t_s, oid_s = cast_rays(surf, o_s, d_s)
    hit = oid_s > 0
    ts = np.where(hit, t_s, 0.0)
    p_s = o_s + ts[..., None] * d_s
    normals = surf.normal if len(surf) else np.zeros((1, 3))  # a scene of open water only
    nrm = np.where(hit[..., None], normals[np.maximum(oid_s - 1, 0)], 0.0)
    nrm = np.where((np.sum(nrm * d_s, axis=-1) > 0)[..., None], -nrm, nrm)  # two-sided: face the camera
    # work on the samples that hit a surface only
    sample_shape = hit.shape
    hidx = np.flatnonzero(hit)
    p_s, nrm = p_s.reshape(-1, 3)[hidx], nrm.reshape(-1, 3)[hidx]
    oid_s, ts = oid_s.ravel()[hidx], ts.ravel()[hidx]
    hit = np.ones(len(hidx), bool)
    rho_sub = surf.reflectance(lam.ravel()).reshape(len(surf) + 1, B, sub_bands)  # (S+1, B, n_sub)
    rho_c = surf.reflectance(wl)  # (S+1, B)
    tick(0.1, "geometry")

    groups = {"continuous": [l for l in scene.lights if l.kind == "continuous"],
              "strobe": [l for l in scene.lights if l.kind == "strobe"]}
    shape = (height, width, B)
    sshape = p_s.shape[:-1] + (B,)
    results: dict[tuple[str, str], np.ndarray] = {}
    pitch = angular_pitch_rad(cam, width, height, n_outside=n_out)
    world_r = world_radius_m(scene)
    r_nodes = np.geomspace(0.05, world_r, 16)  # distances of the blurred-beam tables (m)
    beam_cache: dict = {}

    for gi, (gname, lights) in enumerate(groups.items()):
        has_day = gname == "continuous" and scene.daylight is not None and has_water
        if not lights and not has_day:
            continue
        lights = [l for l in lights if np.any(np.asarray(l.axial_intensity, float) > 0)]
        clear = np.zeros(sshape)
        direct = np.zeros(sshape)
        scattered = np.zeros(sshape)  # target lit by forward-scattered light, unscattered to the camera
        tables = []
        for light in lights:
            lpos = np.asarray(light.position_m, float)
            axis = unit(light.aim)
            lwl, lval = np.asarray(light.wavelength_nm, float), np.asarray(light.axial_intensity, float)
            v = p_s - lpos
            r = np.linalg.norm(v, axis=-1)
            vh = v / np.maximum(r, 1e-12)[..., None]
            cos_i = np.clip(-np.sum(vh * nrm, axis=-1), 0.0, None) * hit
            if shadows:
                cos_i = cos_i * ~occluded(surf, p_s, lpos, exclude=oid_s)
            theta = beam_angle(vh, axis)
            f = light.beam.relative_intensity(theta)
            geo = cos_i / (np.pi * np.maximum(r, 1e-9) ** 2)  # (h, w)
            # changed after the freeze, as in the model: the light's exact band averages
            I_c = band_average(lwl, lval, wl - bw / 2, wl + bw / 2)
            I_sub = np.interp(lam, lwl, lval, left=0.0, right=0.0)  # (B, n_sub)
            quad = I_sub @ lam_w
            I_sub = np.where(quad[:, None] > 0, I_sub * (I_c / np.where(quad > 0, quad, 1.0))[:, None], I_c[:, None])
            # band averages of ρ I (clear) and of ρ I e^{−c L} on a table of path lengths L = r + s
            clear += (geo * f)[..., None] * ((rho_sub * I_sub) @ lam_w)[oid_s]
            if not has_water:
                continue
            path = r + ts
            L_nodes = np.linspace(0.0, max(float(np.max(path[hit])) if hit.any() else 1.0, 1e-3) * 1.0001, 513)
            tab = np.einsum("kbs,lbs->klb", rho_sub * (I_sub * lam_w),
                            np.exp(-water.c_sub[None] * L_nodes[:, None, None]), optimize=True)  # (S+1, nL, B)
            direct += (geo * f)[..., None] * _interp_table(tab, oid_s, path, L_nodes)
            lt = LightTables(lpos, axis, light.beam.relative_intensity, I_c)
            if forward:
                if light.beam not in beam_cache:
                    beam_cache[light.beam] = water.small_angle.blurred_beam(light.beam, r_nodes)
                th_n, btab = beam_cache[light.beam]
                lt = dataclasses.replace(lt, theta_nodes=th_n, r_nodes=r_nodes, blurred=btab)
                fb = lt.blurred_at(theta, r)  # (h, w, B)
                rr = r[..., None]
                amp = np.exp(-water.c * rr) * np.expm1(water.b * water.F * rr)
                scattered += geo[..., None] * fb * amp * (rho_c[oid_s] * I_c)
            tables.append(lt)
        ms = None
        if multiple:  # the reference is the analytic model only
            raise NotImplementedError("the reference model has no multiple scattering")
        if has_day:
            # the target lit by the scene's daylight field (as the renderer: sun beam and diffuse
            # field; no forward-scattered halo of it, the renderer's daylight transport has none)
            # the daylight tables' band means (SceneDaylight.band_means: a physics fix made after this
            # copy was frozen, applied here too so that the comparison stays one of speed-ups)
            day = scene_daylight(scene, req.band_lo_nm, req.band_hi_nm).band_means(wl, bw)
            day_lit = rho_c[oid_s] / np.pi * _daylight_irradiance(day, p_s, nrm, wl)
            clear += day_lit
        clear = _pixel_mean(_expand(clear, sample_shape, hidx), n)
        if not has_water:
            results[(gname, "full")] = clear
            results[(gname, "clear")] = clear
            results[(gname, "direct")] = clear
            results[(gname, "backscatter")] = np.zeros(shape)
            continue
        T = np.exp(-water.c * ts[..., None])
        scattered *= T
        fwd = np.zeros(shape)
        if forward:
            src = _pixel_mean(_expand((direct + scattered) * np.expm1(water.b * water.F * ts[..., None]),
                                      sample_shape, hidx), n)
            fwd = water.small_angle.blur_image(src, range_m.astype(float), pitch)
        if has_day:
            # seen through the daylight tables' band-mean c, as the renderer's daylight transport (a
            # physics fix of 2026-12-03, applied here too; the sub-bands of that fix are off in the comparison)
            direct += day_lit * np.exp(-day.c[day.band_index(wl)] * ts[..., None])
        direct = _pixel_mean(_expand(direct, sample_shape, hidx), n)
        scattered = _pixel_mean(_expand(scattered, sample_shape, hidx), n)
        tick(0.3 + 0.3 * gi, f"{gname}: direct and forward")
        back = np.zeros(shape)
        if tables:
            back += _backscatter(scene, surf, tables, water, forward, cam, width, height, t_c, cols, rows,
                                 world_r, backscatter_grid, backscatter_nodes, shadows)
        if ms is not None:
            C_, R_ = np.meshgrid(cols, rows)
            back += ms.veil_at(C_, R_, range_m.astype(float))
        if has_day:
            back += _daylight_path_radiance(day, o_c, d_c, t_c, wl)
        tick(0.5 + 0.3 * gi, f"{gname}: backscatter")
        results[(gname, "full")] = direct + scattered + fwd + back
        results[(gname, "clear")] = clear
        results[(gname, "direct")] = direct
        results[(gname, "backscatter")] = back
    zeros = np.zeros(shape, np.float32)
    out_layers: dict[str, np.ndarray] = {}
    radiance = results.get(("continuous", "full"), zeros).astype(np.float32)
    for gname, prefix in (("continuous", ""), ("strobe", "flash_")):
        if (gname, "full") not in results:
            continue
        if gname == "strobe":
            out_layers["flash"] = results[(gname, "full")].astype(np.float32)
        for k in ("clear", "direct", "backscatter"):
            if k in layers:
                out_layers[f"{prefix}{k}"] = results[(gname, k)].astype(np.float32)
    if "range_m" in layers:
        out_layers["range_m"] = range_m
    if "object_id" in layers:
        out_layers["object_id"] = oid_c.astype(np.int32)

    meta = {
        "renderer": RENDERER_NAME,
        "engine": "preview",
        "wavelength_nm": wl.tolist(),
        "bandwidth_nm": bw.tolist(),
        "width": width, "height": height, "spp": None, "seed": None,
        "layers": list(out_layers),
        "passes": [f"{g}:full" for g in ("continuous", "strobe") if (g, "full") in results],
        "water": scene.water.describe() if has_water else None,
        "camera": dataclasses.asdict(cam),
        "fov_water_x_deg": fov_water_deg(cam, n_out),
        "lights": [l.describe() for l in scene.lights],
        "targets": [dataclasses.asdict(t) for t in scene.targets],
        "object_ids": {str(i + 1): lab for i, lab in enumerate(surf.labels)},
        "world_radius_m": world_r,
        "radiance_reference": "in-water radiance arriving at the port, band-averaged (no port "
                              "transmission or n^2 factor)",
        "daylight_rendered": bool(scene.daylight is not None and has_water) if scene.daylight is not None else None,
        "preview": {"forward_scatter": forward, "forward_cutoff_deg": float(forward_cutoff_deg),
                    "shadows": bool(shadows), "sub_bands": sub_bands, "pixel_samples": pixel_samples,
                    "backscatter_grid": backscatter_grid, "backscatter_nodes": backscatter_nodes,
                    "ignored": {"spp": spp, "seed": seed, "max_depth": max_depth}},
    }
    meta["scene_hash"] = hashlib.sha256(json.dumps(
        {k: meta[k] for k in ("water", "camera", "lights", "targets")}, sort_keys=True,
        default=str).encode()).hexdigest()[:16]
    meta["wall_time_s"] = time.perf_counter() - t_start
    tick(1.0, "done")
    return SpectralImage(radiance=radiance, wavelength_nm=wl, bandwidth_nm=bw, layers=out_layers, meta=meta,
                         scene=scene, render=RenderInfo("preview"))


# ---------------------------------------------------------------------------------------
def _expand(a: np.ndarray, sample_shape: tuple, idx: np.ndarray) -> np.ndarray:
    """Scatter per-hit values (N, B) into an image of ``sample_shape + (B,)`` (zeros elsewhere)."""
    out = np.zeros((int(np.prod(sample_shape)), a.shape[-1]), a.dtype)
    out[idx] = a
    return out.reshape(*sample_shape, a.shape[-1])


def _interp_table(tab: np.ndarray, oid: np.ndarray, x: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """``tab[oid, ·, :]`` read at ``x`` on the uniform ``nodes`` (linear): shape ``x.shape + (B,)``."""
    u = np.clip((x - nodes[0]) / (nodes[1] - nodes[0]), 0.0, len(nodes) - 1.000001)
    j = u.astype(np.int64)
    fr = (u - j)[..., None]
    return tab[oid, j] * (1 - fr) + tab[oid, j + 1] * fr


def _pixel_mean(a: np.ndarray, n: int) -> np.ndarray:
    if n == 1:
        return a
    H, W = a.shape[0] // n, a.shape[1] // n
    return a.reshape(H, n, W, n, *a.shape[2:]).mean(axis=(1, 3))


def _backscatter(scene, surf, tables, water, forward, cam, width, height, t_c, cols, rows, world_r,
                 grid, n_nodes, shadows) -> np.ndarray:
    kappa_cam = water.c - water.b * water.F if forward else water.c
    kappa_light = water.c - water.b * water.F if forward else water.c
    k_min = float(np.min(kappa_cam + kappa_light))
    s_max = world_r if k_min <= 0 else min(world_r, 50.0 / k_min)
    s, _ = s_nodes(s_max, n_nodes)
    if grid is None:
        o, d, gcol, grow = pixel_rays(cam, width, height, n_outside=outside_index(scene))
    else:
        step = max(width, height) / float(grid)
        o, d, gcol, grow = pixel_rays(cam, width, height, n_outside=outside_index(scene), step=max(step, 1e-9))
    cum = cumulative_backscatter(o.reshape(-1, 3), d.reshape(-1, 3), s, tables, bw=water.bw, c=water.c,
                                 kappa_light=kappa_light, kappa_cam=kappa_cam,
                                 components=water.components, forward=forward,
                                 surfaces=surf if shadows else None)
    C, R = np.meshgrid(cols, rows)
    return interpolate_cumulative(cum, (len(grow), len(gcol)), gcol, grow, s, C, R, t_c)


# --- daylight ------------------------------------------------------------------------------
def _daylight_irradiance(day, p, nrm, wl) -> np.ndarray:
    """Daylight irradiance (N, B) on surface samples at ``p`` with normals ``nrm`` (facing the camera).

    Sun beam × cos × the beam's height factor × caustics, plus the diffuse field integrated over
    the hemisphere about the normal × its height factor (:mod:`rigsim.scene.daylight_field`;
    unoccluded: no shadows or light from other targets).
    """
    idx = day.band_index(wl)
    if p.shape[0] == 0:  # no surface in view
        return np.zeros((0, len(idx)))
    dy = (p[..., 1] - day.y0)[..., None]
    sun = np.asarray(day.sun_direction, float)
    cos_sun = np.clip(-(nrm @ sun), 0.0, None)
    e_sun = (cos_sun * day.caustic(p))[..., None] * day.beam[idx] * height_factor(day.k_beam[idx], dy, np.exp)
    # the diffuse field's irradiance per distinct normal (targets are flat pieces: few normals)
    fld = day.field
    dirs, dw = fld.bin_directions(4)
    uniq, inv = np.unique(np.round(nrm, 9), axis=0, return_inverse=True)
    cosw = np.stack([np.clip(dirs @ n, 0.0, None).sum(axis=-1) * dw for n in uniq])  # (U, nθ, nφ)
    e_dif_u = np.einsum("btp,utp->ub", day.diffuse[idx], cosw)
    e_dif = e_dif_u[np.asarray(inv).ravel()] * height_factor(day.k_diffuse[idx], dy, np.exp)
    return e_sun + e_dif


def _daylight_path_radiance(day, o, d, t_hit, wl) -> np.ndarray:
    """Duntley's path radiance of the daylight field along each pixel ray (H, W, B), as the renderer's."""
    idx = day.band_index(wl)
    t = np.where(np.isfinite(t_hit), t_hit, np.inf)[..., None]
    with np.errstate(over="ignore"):
        return path_radiance(day.radiance(d, wl), day.c[idx], day.k_diffuse[idx], d[..., 1:2],
                             (o[..., 1] - day.y0)[..., None], t, np.exp)
