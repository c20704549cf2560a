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
   :mod:`rigsim.preview.backscatter`), plus the path radiance of daylight.  The camera leg keeps the
   light it scatters by small angles where it was (``e^{−(c − bF) s}``), except at a target's silhouette:
   there the part ``1 − e^{−bF r}`` of the veil from the water behind the target (which the target blocks)
   is spread by the camera leg's kernel, so some of it reaches the target's pixels and the water beside
   the target lacks what came from behind it (:meth:`_Group._behind`; the demo's edge-lit black disk in
   Jerlov 3C at 1 m: the veil in front of it 7.6 % low without it, 2 % with it, against Monte Carlo).

Daylight (``scene.daylight``) is the scene's daylight field
(:func:`rigsim.scene.daylight_field.scene_daylight`: the Kd shortcut or the Monte Carlo meter,
with the Daylight's sky and photons) and its transport, the same tables and formulas as the
renderer's: the target is lit by the sun beam (stopped by other targets, and a mesh by itself, when
``shadows`` is on, as the renderer's shadow ray) and the diffuse field integrated over the
hemisphere about its normal (each × its height factor; with ``shadows``, less what targets hide of it
and plus what they reflect in its place, once: :meth:`_Daylight._hidden_diffuse`), seen through ``e^{−c s}``
(no forward-scattered halo, as the renderer's daylight), and each line of sight collects
Duntley's path radiance ``L_amb(v)(1 − e^{−(c − K v_y) s})``, so a black target's contrast is
``−e^{−c s}`` along a horizontal line of sight, as in the renderer.

Targets are flat pieces or triangle meshes (:mod:`rigsim.preview.geometry`): a mesh sample has its
own interpolated normal (smooth shading, as the renderer's), for the strobes' cos θ, their shadows
(a rock shadows itself) and the diffuse daylight, which for meshes is interpolated on a grid of
normals (:data:`_NORMAL_GRID`).  Checked in ``tests/preview/test_meshes.py``: a disk of 720
triangles images as the flat disk (every layer within 0.5 %), the shipped rock in coastal water
agrees with Monte Carlo (region means within 5 % + t·SE).  Measured once (48 × 48, 4 × 256 spp, before
shadows were on by default for meshes): in coastal water the rock's mean radiance within 0.6 %, in
Jerlov 3C within 3.6 % (blue) and its unscattered light per pixel within −0.7…+0.9 % (5th–95th
percentile).

What is not in it: multiple wide-angle scattering (the "glow" of turbid water
beyond a few optical depths), light scattered by more than the forward cut-off
angle that then lights the target, interreflections (but the daylight one target reflects onto
another in place of the diffuse field it hides, above), port optics (radiance is the
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

Computation: the image is shaded in tiles of rows (:data:`~rigsim.preview.tiles.TILE_SAMPLES` samples each, so that
every per-band array of a tile stays in the cache), the tiles in parallel threads (numpy releases
the GIL); per-band arithmetic is float32 where that keeps the result to ~1e-6 relative (exponents
within ±:data:`F32_EXP_MAX`; the daylight path radiance on lines of sight of optical depth above
:data:`F32_PATH_MIN`), float64 elsewhere; the forward blur is one FFT per band and range bin
(:meth:`~rigsim.preview.forward.SmallAngle.blur_bands`).  The backscatter integral is computed on
its coarse grid of rays only and interpolated.

Conventions are the renderer's (:func:`rigsim.render.render`): bands are averages
over ``[centre ± width/2]`` (the direct component by ``sub_bands``-point
Gauss–Legendre quadrature in each band; the daylight on as many equal sub-bands as the
field's and the water's fall across the band need, :func:`daylight_sub_bands`; the water, blur
kernels and backscatter at band centres), strobes go to the ``flash`` layers in J/(m² sr nm) and
continuous light to ``radiance``, object ids and ``range_m`` from the pixel-centre ray.  Pixels are
box-filtered as the renderer's: a pixel on an edge (:func:`_edge_pixels`) is the mean of
``edge_samples²`` rays jittered in their cells, for the surfaces' light and for the veil along each
(a ray past a target's rim sees the water to its end).

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
import threading
import time
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from rigsim.errors import ConfigError
from rigsim.preview.backscatter import (
    LightTables,
    beam_angle,
    cumulative_backscatter,
    interpolate_cumulative,
    s_nodes,
)
from rigsim.preview.forward import SmallAngle
from rigsim.preview.geometry import SceneSurfaces, cast_rays, occluded, scene_surfaces
from rigsim.preview.multiple import NOISE_TARGET, MultipleScattering, _cosine_about, photon_factor
from rigsim.preview.tiles import default_threads, no_hugepage_advice, row_tiles, run, thread_map
from rigsim.scene.daylight_field import SceneDaylight, height_factor, path_radiance, scene_daylight
from rigsim.scene.particles import scene_particles
from rigsim.scene.phase_tables import phase_tables
from rigsim.scene.types import Scene, unit
from rigsim.spectral_image import RenderInfo, SpectralImage
from rigsim.spectrum import DEFAULT_WAVELENGTHS_NM, band_average, band_edges
from rigsim.scene.imaging import IMAGE_LAYERS, check_int, check_scene_for_bands, image_request
from rigsim.scene.optics import (angular_pitch_rad, camera_rays, fov_water_deg, outside_index, port_reach_m,
                                 equidistant_maps, port_viewpoint_m, world_radius_m)

__all__ = ["render_preview", "render_photon_batches", "PREVIEW_LAYERS", "band_edges"]

#: Ground-truth layers ``render_preview`` can make (as the renderer's).
PREVIEW_LAYERS = IMAGE_LAYERS
RENDERER_NAME = "rigsim.preview (Jaffe-McGlamery)"
#: Per-band arithmetic of a surface sample is float32 while every exponent it takes is within ±this
#: (e^x then keeps ~5e-6 relative precision and its products stay far from float32's range); else float64.
F32_EXP_MAX = 60.0
#: The daylight path radiance ``∝ 1 − e^{−x}`` is float32 where the line of sight's optical depth x is at
#: least this for every band (relative error ≤ 6e-8/x), float64 where it is less.
F32_PATH_MIN = 1e-2

ProgressCallback = Callable[[float, str], None]
_F32, _F64 = np.dtype(np.float32), np.dtype(np.float64)


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


#: ψ_c with multiple scattering (deg): the analytic model carries the paths with no scattering by
#: more than 30° but one (direct and small-angle blurred light, quasi-single backscatter), the
#: tracer the rest.  Measured (``rigsim.preview.multiple`` docstring, ``classes="A"``): at 30° the
#: quasi-single-scattering veil equals the traced paths of its class to 0.8 %; at 90° it is 19 % high.
MS_CUTOFF_DEG = 30.0
#: The quasi-single backscatter of the beam's forward-scattered light with its directions spread about the line
#: from the light (:meth:`rigsim.preview.forward.SmallAngle.spread_beta`, checked against drawn turns in
#: ``tests/preview/test_preview_model.py``); False: as if it went straight on (before 2026-12-04; the frozen
#: reference of tests/preview/test_preview_speed.py).  Measured (2026-12-04): against the tracer's own class-A paths
#: (450 nm) Jerlov 9C 0.977 → 1.019, 3C 1.009 → 1.016 (the image's sides 0.95 → 1.00, its middle 1.02–1.05: the
#: path lengthening of the turned light is left out); in the agreement benchmark against 11–256 Monte Carlo renders
#: the open water of Jerlov 9C around a black disk at 1 m −7.0 ± 0.7 → −4.0 ± 0.7 % and of 7C around a chart at
#: 3 m −5.8 ± 0.4 → −3.7 ± 0.4 % (blue), the clear waters unchanged, the strobe cells beyond tolerance 4 → 2 of
#: 2 719 (both chart patches on heavy-tailed references).
SPREAD_PHASE = True
#: With :data:`SPREAD_PHASE`, the camera leg's small-angle turns too (the line of sight's directions spread on its
#: way back, :meth:`rigsim.preview.forward.SmallAngle.two_leg_beta`); False: β seen straight along the line of sight
#: (before 2026-12-06).  Measured (2026-12-06, ``benchmarks/bench_fast_engine_classes.py --size 48x32 --renders 48
#: --seeds 6 --photons 100000``, the same Monte Carlo renders, open water; analytic class A / Monte Carlo's, blue /
#: green / red, without → with): ``twin-strobes-45-wide`` Jerlov 9C at 1 m 0.984 / 0.990 / 0.992 → 1.002 / 1.003 /
#: 1.001, at 3 m 0.984 / 0.988 / 0.990 → 1.001 / 1.001 / 0.999, 3C at 1 m 0.996 / 0.998 / 0.999 → 1.000 / 0.999 /
#: 1.001 (the whole veil 9C at 1 m 0.976 / 0.979 / 0.988 → 0.988 / 0.988 / 0.994); ``twin-strobes-edge-lighting``
#: at 3 m 9C 0.976 / 0.978 / 0.983 → 0.993 / 0.991 / 0.992, 7C 0.983 / 0.982 / 0.985 → 0.996 / 0.991 / 0.991, 5C
#: 0.985 / 0.987 / 0.989 → 0.990 / 0.989 / 0.991; coastal, Jerlov III unchanged within 0.2 %.
SPREAD_CAMERA_LEG = True
#: The camera leg's small-angle blur with the housing's part of each line of sight left out (no water inside the
#: port; the kernel's optical path the water's, its angles scaled by the water's share of the distance to the
#: rays' viewpoint: :meth:`rigsim.preview.forward.SmallAngle.blur_plan`'s ``port_m``, ``viewpoint_m``); False:
#: the water taken to start at the pupil (before 2026-12-05; the frozen reference of
#: tests/preview/test_preview_speed.py).
BLUR_PORT = True
#: The camera leg's small-angle blur done on the azimuthal equidistant grid about the image centre, where its
#: kernel is the same at every pixel (:func:`rigsim.scene.optics.equidistant_maps`); False: on the pixels with the
#: centre's pitch (before 2026-12-05; the frozen reference of tests/preview/test_preview_speed.py).
BLUR_EQUIDISTANT = True
#: With ``shadows="auto"`` the water behind any target is in its shadow (the veil's points in front of each ray's
#: own first surface tested against every target, :func:`rigsim.preview.backscatter.cumulative_backscatter`); False:
#: only with meshes or several targets, and every point of the ray tested (before 2026-12-05; the frozen reference
#: of tests/preview/test_preview_speed.py).  Checked against Monte Carlo in tests/preview/test_preview_vs_render.py.
VEIL_SHADOWS = True
#: Wide-angle scattering ``b (1 − F(30°))`` at 550 nm (1/m) from which ``multiple="auto"`` adds the
#: multiply scattered light.  Set from the agreement benchmark without it
#: (``data/fast_engine/agreement.csv`` of 2026-12-01): the waters below it (pure-sea, oceanic, the
#: write-up's coastal regions and lakes, Jerlov I–IB: 0.002–0.008 /m) agreed with Monte Carlo
#: within 2.7 % without it; from clear (0.020 /m, −3.3 %) and coastal (0.039 /m, −5.4 %) up
#: (Jerlov II 0.044 … 9C 0.38 /m: −24 … −70 % at the worst cell) the missing light showed.
MS_AUTO_MIN_B_WIDE_PER_M = 0.01
#: A particle's light scattered by less than this (deg) on its way to the camera stays in its speck; the rest of
#: its forward-scattered light is a wide glow (:mod:`rigsim.preview.particles`).
PARTICLE_SPECK_DEG = 1.0


def wide_angle_scattering_per_m(water, wavelength_nm: float = 550.0, cutoff_deg: float = MS_CUTOFF_DEG) -> float:
    """``b (1 − F(ψ_c))`` (1/m): the water's scattering by more than ``cutoff_deg`` at ``wavelength_nm``."""
    lo, hi = water.wavelength_range_nm
    wl = float(np.clip(wavelength_nm, lo, hi))
    comps = phase_tables(water.phase, water.wavelength_range_nm)
    F = float(comps.weights_at([wl])[0] @ comps.forward_fraction(np.radians(cutoff_deg)))
    return float(water.b_per_m(wl)) * (1.0 - F)


def multiple_scattering_matters(scene: Scene) -> bool:
    """Whether ``multiple="auto"`` adds the multiply scattered light (:data:`MS_AUTO_MIN_B_WIDE_PER_M`)."""
    if scene.water is None or not scene.lights:
        return False
    return wide_angle_scattering_per_m(scene.water) >= MS_AUTO_MIN_B_WIDE_PER_M


def _sub_band_wavelengths(wl: np.ndarray, bw: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(B, n) Gauss–Legendre nodes inside each band and their weights (summing to 1)."""
    x, w = np.polynomial.legendre.leggauss(n)
    return wl[:, None] + 0.5 * bw[:, None] * x[None, :], w / 2.0


def render_preview(scene: Scene, *, width: int = 320, height: int = 240,
                   wavelengths_nm: Sequence[float] = DEFAULT_WAVELENGTHS_NM, bandwidth_nm=None,
                   layers: Sequence[str] = ("range_m", "clear", "object_id"), split: bool = False,
                   shadows: bool | str = "auto", forward_scatter: bool = True, forward_cutoff_deg: float | None = None,
                   sub_bands: int = 3, pixel_samples: int = 1, edge_samples: int = 4,
                   backscatter_grid: int | None = 32, backscatter_nodes: int = 64, multiple: bool | str = "auto",
                   photons: int | None = None, noise_target: float | None = NOISE_TARGET,
                   ms_grid: int | None = None, ms_truncate_deg: float | None = None, spp: int | None = None,
                   seed: int | None = None,
                   max_depth: int | None = None, progress: ProgressCallback | None = None,
                   threads: int | None = None, traced: Mapping[str, MultipleScattering] | None = None,
                   traced_out: dict | None = None, reuse: dict | None = None) -> SpectralImage:
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
        Let target surfaces shadow the lights and the sun (on surfaces; the lights also in the water):
        True, False, or ``"auto"`` (default: on surfaces where a shadow can fall — a mesh, or more than one
        target; a single flat target cannot shadow itself — and in the water behind any target).
    forward_scatter
        Include the small-angle forward-scattered component (False: the classical
        direct + single-backscatter model with ``e^{−c·}`` on every leg).
    forward_cutoff_deg
        Scattering by less than this angle is treated as forward scattering (deg, 0–90; None:
        :data:`MS_CUTOFF_DEG` with multiple scattering, 90 without).
    multiple, photons, ms_grid, ms_truncate_deg
        The multiply scattered light of the lights (:mod:`rigsim.preview.multiple`): True, False
        (single scattering only) or ``"auto"`` (default: on where the water's wide-angle scattering
        ``b (1 − F(ψ_c))`` at 550 nm is at least :data:`MS_AUTO_MIN_B_WIDE_PER_M`), photons per light
        group (default
        :func:`~rigsim.preview.multiple.default_photons`), its grid and δ-truncation angle.
    noise_target
        With the default photons: where the multiply scattered light's own noise (:func:`class_b_noise`, from the
        photons' batches) is above this fraction of the image's light, more photons are traced, of an independent
        stream of the same seed, up to :data:`~rigsim.preview.multiple.MAX_PHOTON_FACTOR` times as many
        (:func:`~rigsim.preview.multiple.photon_factor`; default
        :data:`~rigsim.preview.multiple.NOISE_TARGET`), and the group's image is made again with them all.  None,
        or ``photons`` given: the photons as given.  The image's ``meta["preview"]["multiple"]`` says the noise
        before (``noise``) and after (``noise_after``) and the photons traced.
    sub_bands
        Gauss–Legendre points per band for the direct component (1: band centres).
    pixel_samples, edge_samples
        The light of the surfaces is averaged over ``pixel_samples²`` points in every pixel, as the
        renderer box-filters each pixel; with ``pixel_samples = 1`` (default) over ``edge_samples²``
        points in the pixels on an edge (another object or a range step of more than
        :data:`EDGE_RANGE_STEP` at a neighbour's centre) and at the centre elsewhere, where it is smooth
        (``edge_samples = 1``: centres only; a ColorChecker filling 40 % of a 96×64 image was then
        5 % too dark in blue against Monte Carlo (its dark frame and the open water counted in or out
        whole), with 4 (the default) or 8 within 0.4 %; 3 and 5 alias its thin frame: −1 and −3 %).
    backscatter_grid
        Rays along the longer image side on which the backscatter integral is
        computed and then interpolated (None: every pixel).
    backscatter_nodes
        Quadrature nodes along each ray.
    spp, max_depth
        Accepted for call compatibility with :func:`rigsim.render.render` and ignored.
    seed
        Seed of the multiply scattered light's photons (None: 0); the image is deterministic, and
        without multiple scattering it has no sampling at all.
    progress
        Called as ``progress(fraction_done, message)``.
    threads
        Threads of the per-pixel passes and of the forward blur (None:
        :func:`~rigsim.preview.tiles.default_threads`, the cores this process may use; the image does not depend on it).
    traced, traced_out
        The multiply scattered light of a light group (``"strobe"``, ``"continuous"``) already traced for
        this scene and image size (:class:`~rigsim.preview.multiple.MultipleScattering`), used instead of
        tracing it again (``traced``); a dict that receives the groups' traced light (``traced_out``):
        :func:`render_photon_batches` makes an image with each batch of the photons from them.
    reuse
        A dict kept by the caller across renders of one scene at one size that differ in their multiply
        scattered light alone (another ``seed`` or ``traced``: :func:`render_photon_batches`, a check's fast
        side): the lights' single-scattering veil on its coarse grid, a pure function of the scene, the size and
        the settings and most of a small image's time (0.84 of 1 s at 96×64), is computed by the first and
        reused by the rest; a render with other settings computes its own.  The images are those without it.

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
    edge_samples = check_int("edge_samples", edge_samples, 1, 16)
    backscatter_nodes = check_int("backscatter_nodes", backscatter_nodes, 8, 4096)
    threads = default_threads() if threads is None else check_int("threads", threads, 1, 1024)
    if multiple == "auto":
        multiple = multiple_scattering_matters(scene)
    elif not isinstance(multiple, bool):
        raise ConfigError(f"multiple must be true, false or 'auto', got {multiple!r}", field="multiple",
                          allowed="true, false, auto")
    if noise_target is not None and not (np.isfinite(float(noise_target)) and 0.0 < float(noise_target) <= 1.0):
        raise ConfigError(f"noise target must be a fraction in (0, 1] of the image's light, got {noise_target}",
                          field="noise_target", allowed="0 < fraction <= 1, or None")
    if forward_cutoff_deg is None:
        forward_cutoff_deg = MS_CUTOFF_DEG if multiple else 90.0
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
    if shadows == "auto":
        shadows = bool(np.any(surf.is_mesh)) or len(scene.targets) > 1
        # the water behind a target is in its shadow whatever the target: near the camera the strobes light it
        # from the side and the open water around the target looks into that shadow (a black disk filling
        # 0.4 of the field at 0.5 m in pure sea: without, the open water's veil read +3.6 / +3.1 / +1.4 %
        # above Monte Carlo, blue / green / red; with, -0.3 / -0.2 / -0.1 %; a ColorChecker +2.7 -> -0.6 %)
        veil_shadows = len(surf) > 0 if VEIL_SHADOWS else shadows
    elif not isinstance(shadows, bool):
        raise ConfigError(f"shadows must be true, false or 'auto', got {shadows!r}", field="shadows",
                          allowed="true, false, auto")
    else:
        veil_shadows = shadows
    cam = scene.camera
    n_out = outside_index(scene)
    pitch = angular_pitch_rad(cam, width, height, n_outside=n_out)
    world_r = world_radius_m(scene)
    r_nodes = np.geomspace(0.05, world_r, 16)  # distances of the blurred-beam tables (m)
    rho_sub = surf.reflectance(lam.ravel()).reshape(len(surf) + 1, B, sub_bands)  # (S+1, B, n_sub)
    rho_c = surf.reflectance(wl)  # (S+1, B)
    groups = {"continuous": [l for l in scene.lights if l.kind == "continuous"],
              "strobe": [l for l in scene.lights if l.kind == "strobe"]}
    lit = [l for l in scene.lights if np.any(np.asarray(l.axial_intensity, float) > 0)]
    shape = (height, width, B)
    results: dict[tuple[str, str], np.ndarray] = {}
    ms_info: dict[str, dict] = {}
    ms_by_group: dict[str, object] = {}
    groups_done: dict[str, _Group] = {}

    with no_hugepage_advice(), thread_map(threads) as pmap:
        view = _view(scene, surf, width, height, pixel_samples, n_out, [l.position_m for l in lit], pmap,
                     edge_n=edge_samples)
        tick(0.1, "geometry")
        seen = view.range_m[np.isfinite(view.range_m)]
        reach = float(seen.max()) if seen.size else 0.0  # the longest line of sight to a surface (m)
        for gi, (gname, lights) in enumerate(groups.items()):
            has_day = gname == "continuous" and scene.daylight is not None and has_water
            if not lights and not has_day:
                continue
            lights = [l for l in lights if np.any(np.asarray(l.axial_intensity, float) > 0)]
            lamps, tables = [], []
            for light in lights:
                lamp = _lamp(light, lam, lam_w, wl - bw / 2, wl + bw / 2, rho_sub, rho_c, water, forward, r_nodes,
                             view.path_max[lit.index(light)])
                lamps.append(lamp)
                if lamp.light is not None:
                    tables.append(lamp.light)
            ms = None
            if multiple and has_water and lights and water.b.max() > 0 and traced and gname in traced:
                ms = traced[gname]
                ms_by_group[gname] = ms
            elif multiple and has_water and lights and water.b.max() > 0:
                from rigsim.preview.multiple import DEFAULT_GRID, default_photons, trace_multiple

                kap = water.c - water.b * water.F if forward else water.c
                ms_args = dict(scene=scene, surf=surf, lights=lights, wavelength_nm=wl, c=water.c, b=water.b,
                               kappa_cam=kap, tables=water.components, weights=water.components.weights_at(wl),
                               width=width, height=height, cutoff_rad=cutoff, grid=ms_grid or DEFAULT_GRID,
                               truncate_rad=None if ms_truncate_deg is None else np.radians(ms_truncate_deg),
                               seed=0 if seed is None else int(seed), bandwidth_nm=bw)
                ms = trace_multiple(**ms_args, photons=photons or default_photons(width, height))
                ms_info[gname] = {"photons": ms.photons, "seconds": round(ms.seconds, 3),
                                  "relative_noise": [float(x) for x in ms.relative_noise]}
                ms_by_group[gname] = ms
            # the target lit by the scene's daylight field (as the renderer: sun beam and diffuse field; no
            # forward-scattered halo of it, the renderer's daylight transport has none) and its path radiance
            day = _Daylight(scene_daylight(scene, req.band_lo_nm, req.band_hi_nm), wl, surf, bw,
                            shadows=shadows, reach_m=reach) if has_day else None
            grid = None
            if tables:
                key = ("backscatter_grid", id(scene), gname, width, height, tuple(np.asarray(wl, float)),
                       tuple(np.asarray(bw, float)), sub_bands, float(forward_cutoff_deg), forward, backscatter_grid,
                       backscatter_nodes, veil_shadows)
                kept = None if reuse is None else reuse.get(key)
                if kept is not None and kept[0] is scene:  # (the scene itself: an id can be another's later)
                    grid = kept[1]
                else:
                    grid = _backscatter_grid(scene, surf, tables, water, forward, cam, width, height, world_r,
                                             backscatter_grid, backscatter_nodes, veil_shadows, pmap)
                    if reuse is not None:
                        reuse[key] = (scene, grid)

            def image_of(ms):
                group = _Group(view, surf, water, lamps, rho_c, forward, shadows, day, grid, ms, want=set(layers))
                group.shade(pmap)
                tick(0.3 + 0.3 * gi, f"{gname}: direct and backscatter")
                if forward:
                    group.add_forward(water.small_angle, pitch, pmap)
                tick(0.5 + 0.3 * gi, f"{gname}: forward")
                return group

            group = image_of(ms)
            traced_here = gname in ms_info  # (not given by the caller: ``traced``)
            if traced_here and photons is None and noise_target is not None and ms.n_batches >= 2:
                # the photons' noise against the image's light: more photons where it is above the target
                noise = class_b_noise(group, ms, wl)
                f = photon_factor(noise, noise_target)
                ms_info[gname]["noise"] = round(noise, 5)
                if f > 1:
                    more = trace_multiple(**ms_args, photons=(f - 1) * ms.photons, stream=1)
                    ms = ms.merged(more)
                    ms_by_group[gname] = ms
                    group = image_of(ms)
                    ms_info[gname].update(photons=ms.photons, seconds=round(ms.seconds, 3),
                                          relative_noise=[float(x) for x in ms.relative_noise],
                                          noise_after=round(class_b_noise(group, ms, wl), 5))
            groups_done[gname] = group
            for k, a in group.layers().items():
                results[(gname, k)] = a
    zeros = np.zeros(shape, np.float32)
    out_layers: dict[str, np.ndarray] = {}
    used: set[int] = set()

    def own(a):  # one array per layer (the model gives no-water layers one array)
        if id(a) in used:
            a = a.copy()
        used.add(id(a))
        return a

    radiance = own(results.get(("continuous", "full"), zeros))
    for gname, prefix in (("continuous", ""), ("strobe", "flash_")):
        if (gname, "full") not in results:
            continue
        if gname == "strobe":
            out_layers["flash"] = own(results[(gname, "full")])
        for k in ("clear", "direct", "backscatter"):
            if k in layers:
                out_layers[f"{prefix}{k}"] = own(results[(gname, k)])
    if "range_m" in layers:
        out_layers["range_m"] = view.range_m
    if "object_id" in layers:
        out_layers["object_id"] = view.oid_c.astype(np.int32)
    particles_meta = None
    ps = scene_particles(scene) if has_water else None
    if ps is not None:  # the water's discrete particles: their light, their shadow on the rest, their ids
        from rigsim.preview.particles import particle_layers

        kap = water.c - water.b * water.F if forward else water.c
        day_b = (scene_daylight(scene, req.band_lo_nm, req.band_hi_nm).band_means(wl, bw)
                 if scene.daylight is not None else None)
        k_speck, glow = None, 0.0
        if forward:  # on the way to the camera: a speck of what stays within PARTICLE_SPECK_DEG, a glow of the rest
            comps = water.components
            w_c = comps.weights_at(wl)
            k_speck = water.c - water.b * (w_c @ comps.forward_fraction(np.radians(PARTICLE_SPECK_DEG)))
            glow = comps.rms_angle_rad(np.radians(PARTICLE_SPECK_DEG), cutoff, 550.0)
        pl = particle_layers(scene, ps, width=width, height=height, wl=wl, bw=bw, kappa=kap,
                             range_m=view.range_m, n_outside=n_out, daylight=day_b, multiple=ms_by_group,
                             kappa_speck=k_speck, glow_rad=glow)
        cov = pl.coverage[..., None]
        pix_h = pl.hiders[0].astype(np.int64)
        pl = dataclasses.replace(pl, hiders=(pix_h,) + tuple(pl.hiders[1:]))

        def hidden(image, gname):
            """What the particles take from the rest of the image: the light from behind each of them along
            the lines of sight they cover (not the veil in front of them, :func:`_veil_behind`), and their
            shadows in the lights' beams (:func:`_particle_shadows`)."""
            g = groups_done.get(gname)
            if g is None:
                return (cov * image).astype(np.float32)
            h = _veil_behind(g, image, pl.hiders) + _particle_shadows(g, image, ps, scene)
            return np.minimum(h, image).astype(np.float32)  # no more than all of it (near particles' discs overlap)

        net = pl.radiance - hidden(radiance, "continuous")  # what the particles change: their light less what they hide
        radiance = radiance + net
        if "particles" in layers:
            out_layers["particles"] = net
        if "flash" in out_layers:
            net_f = pl.flash - hidden(out_layers["flash"], "strobe")
            out_layers["flash"] = out_layers["flash"] + net_f
            if "particles" in layers:
                out_layers["flash_particles"] = net_f
        for k in ("direct", "backscatter"):
            for key in (k, f"flash_{k}"):
                if key in out_layers:
                    out_layers[key] = out_layers[key] * (1.0 - cov)
        if "particle_id" in layers:
            out_layers["particle_id"] = pl.particle_id
        particles_meta = {**ps.describe(), "visible": pl.visible}
    else:
        if "particle_id" in layers:
            out_layers["particle_id"] = np.zeros((height, width), np.int32)
        if "particles" in layers:
            out_layers["particles"] = np.zeros(shape, np.float32)
            if "flash" in out_layers:
                out_layers["flash_particles"] = np.zeros(shape, np.float32)

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
        "particles": particles_meta,
        "preview": {"forward_scatter": forward, "forward_cutoff_deg": float(forward_cutoff_deg),
                    "shadows": bool(shadows), "veil_shadows": bool(veil_shadows), "sub_bands": sub_bands,
                    "pixel_samples": pixel_samples,
                    "edge_samples": edge_samples, "backscatter_grid": backscatter_grid,
                    "backscatter_nodes": backscatter_nodes,
                    "threads": threads, "multiple_scattering": bool(multiple), "multiple": ms_info,
                    "ignored": {"spp": spp, "max_depth": max_depth}},
    }
    meta["scene_hash"] = hashlib.sha256(json.dumps(
        {k: meta[k] for k in ("water", "camera", "lights", "targets")}, sort_keys=True,
        default=str).encode()).hexdigest()[:16]
    meta["wall_time_s"] = time.perf_counter() - t_start
    if traced_out is not None:
        traced_out.update(ms_by_group)
    tick(1.0, "done")
    return SpectralImage(radiance=radiance, wavelength_nm=wl, bandwidth_nm=bw, layers=out_layers, meta=meta,
                         scene=scene, render=RenderInfo("preview"))


#: Pixels of the image (about) at which :func:`class_b_noise` measures the photons' noise.
NOISE_PIXELS = 4096


def class_b_noise(group: "_Group", ms: MultipleScattering, wavelength_nm) -> float:
    """The multiply scattered light's own photon noise in a light group's image: at about :data:`NOISE_PIXELS`
    pixels spread over the image, the standard error of its class-B light (the veil up to what the pixel sees,
    and on a target ``ρ/π E`` seen through ``e^{−κ s}``, a ray length ``s``) over the independent batches of
    ``ms``'s photons, divided by the group's image there (``full``), averaged over each colour group's bands
    (:data:`rigsim.spectrum.COLOUR_GROUPS_NM`, of the bands ``wavelength_nm``); the 90th percentile over the pixels, in the worst colour group.
    (The light on a target is taken through the camera leg's attenuation alone, not the forward blur: this
    measures the noise to choose the photons by, it is not part of the image.)  NaN where nothing can be said
    (fewer than two batches, no light)."""
    from rigsim.spectrum import colour_groups

    v = group.view
    nb = ms.n_batches
    if nb < 2 or group.full is None:
        return float("nan")
    H, W = v.height, v.width
    step = max(1, int(np.sqrt(H * W / NOISE_PIXELS)))
    r0 = step // 2
    rows, cols = np.arange(r0, H, step), np.arange(r0, W, step)
    R, C = np.meshgrid(rows, cols, indexing="ij")
    rng_m = np.asarray(v.range_m, float)[R, C]
    batches = [ms.batch(k) for k in range(nb)]
    x = np.stack([b.veil_at(C + 0.5, R + 0.5, rng_m) + b.veil_at(C + 0.5, R + 0.5, rng_m, surfaces=True)
                  for b in batches])  # (nb, nr, nc, B)
    w = group.water
    kappa = (w.c - w.b * w.F) if group.forward else w.c
    for (y0, _), h in zip(v.tiles, v.hits):
        if h is None or not len(h):
            continue
        py, px = np.divmod(h.idx, W)
        py = py + y0
        m = ((py - r0) % step == 0) & ((px - r0) % step == 0)
        if not np.any(m):
            continue
        hs = h.subset(m)
        wt = np.ones(len(hs)) if hs.w is None else np.asarray(hs.w, float)
        seen = (group.rho_c[hs.oid] / np.pi) * np.exp(-np.outer(np.asarray(hs.ts, float), kappa)) * wt[:, None]
        ir, ic = (py[m] - r0) // step, (px[m] - r0) // step
        for k, b in enumerate(batches):
            np.add.at(x[k], (ir, ic), seen * b.irradiance_at(group.surf, hs.oid, hs.p, hs.nrm))
    full = np.asarray(group.full, float)[R, C]
    worst = float("nan")
    for idx in colour_groups(wavelength_nm).values():
        se = x[..., idx].mean(axis=-1).std(axis=0, ddof=1) / np.sqrt(nb)
        tot = full[..., idx].mean(axis=-1)
        ok = tot > 0
        if np.any(ok):
            q = float(np.percentile(se[ok] / tot[ok], 90))
            worst = q if not np.isfinite(worst) else max(worst, q)
    return worst


def render_photon_batches(scene: Scene, traced: Mapping[str, MultipleScattering], *, traced_size: tuple[int, int],
                          width: int, height: int, reuse: dict | None = None, **kwargs) -> list[SpectralImage]:
    """The image of ``scene`` once with each independent batch of the photons that traced its multiply
    scattered light, at ``width × height``: the scatter of a number measured on them is the photons'
    noise in that number.

    The class-B light enters the image linearly, so the batch images average to the image made with all
    the photons, and the standard error of a number measured on that image is about the standard
    deviation of its values on the ``n`` batch images over √n (to first order in the noise; ``n`` is
    :attr:`~rigsim.preview.multiple.MultipleScattering.n_batches`, 4 by default: the error of that
    standard error is itself ~40 %).  Nothing is traced again; at a small size each image costs the
    analytic model's time alone (a few tenths of a second at 96×64).

    Parameters
    ----------
    traced
        The ``traced_out`` of a :func:`render_preview` of the same scene (light group → traced light).
    traced_size
        ``(width, height)`` of that render.
    width, height, kwargs
        Size of the batch images and the other :func:`render_preview` arguments (wavelengths, layers, …;
        not ``multiple``, ``traced``, ``traced_out``).
    reuse
        :func:`render_preview`'s, shared by the batch images (a new one if None): what does not depend on the
        photons is computed once (4 batch images at 96×64: ~4 s → ~1.5 s).

    Returns
    -------
    list of SpectralImage
        One per batch; empty if no group kept its batches (no multiple scattering in this scene).
    """
    n = min((ms.n_batches for ms in traced.values()), default=0)
    if n < 2:
        return []
    sx, sy = width / float(traced_size[0]), height / float(traced_size[1])
    reuse = {} if reuse is None else reuse
    return [render_preview(scene, width=width, height=height, multiple=True,
                           traced={g: ms.batch(k).scaled(sx, sy) for g, ms in traced.items()}, reuse=reuse, **kwargs)
            for k in range(n)]


# --- geometry ------------------------------------------------------------------------------
@dataclasses.dataclass(eq=False)
class _Hits:
    """The samples of one tile that hit a surface: flat index of their pixel in the tile, point, normal
    facing the camera (``side``: the surface's normal reversed), object id, ray length from the port,
    and their weight in the pixel's mean (``w``; None: one sample per pixel, the pixel centre)."""

    idx: np.ndarray
    p: np.ndarray
    nrm: np.ndarray
    side: np.ndarray
    oid: np.ndarray
    ts: np.ndarray
    w: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.idx)

    def subset(self, m: np.ndarray) -> "_Hits":
        return _Hits(self.idx[m], self.p[m], self.nrm[m], self.side[m], self.oid[m], self.ts[m],
                     None if self.w is None else self.w[m])


@dataclasses.dataclass(eq=False)
class _View:
    """What the camera sees: pixel-centre hits (H, W), and per tile the hits of its samples."""

    camera: object
    n_out: float
    width: int
    height: int
    n: int  # pixel_samples
    tiles: list[tuple[int, int]]
    t_c: np.ndarray
    oid_c: np.ndarray
    d_c: np.ndarray  # pixel-centre ray directions (H, W, 3) and the height of their origins (H, W)
    oy_c: np.ndarray
    range_m: np.ndarray
    cols: np.ndarray
    rows: np.ndarray
    hits: list[_Hits]
    path_max: list[float]  # per lit light: longest light → surface → port path over all samples (m)
    #: per tile, the sample rays of its edge pixels (:func:`_edge_pixels`; all pixels with ``n`` > 1), for
    #: their veil: (pixel in the
    #: tile, column, row (image units), origin height, direction, distance from the port (inf: nothing),
    #: range from the pupil (inf)), or None
    edge_rays: list = dataclasses.field(default_factory=list)

    def rays(self, y0: int, y1: int) -> tuple[np.ndarray, np.ndarray]:
        """Pixel-centre rays (origin, direction) of rows y0 … y1 − 1: (rows, W, 3) each."""
        X, Y = np.meshgrid(self.cols / self.width, self.rows[y0:y1] / self.height)
        return camera_rays(self.camera, X, Y, n_outside=self.n_out)


def _view(scene: Scene, surf: SceneSurfaces, width: int, height: int, n: int, n_out: float,
          light_positions: list, pmap, edge_n: int = 1) -> _View:
    """The camera's view: pixel centres, and per tile the surface samples: ``n²`` per pixel (``n`` > 1),
    else the pixel centre, and ``edge_n²`` in the pixels on an edge (:func:`_edge_pixels`)."""
    cam = scene.camera
    pupil = np.asarray(cam.position_m, float)
    tiles = row_tiles(height, width * n * n)
    cols = np.arange(width) + 0.5
    rows = np.arange(height) + 0.5
    t_c, oid_c = np.empty((height, width)), np.empty((height, width), np.int32)
    d_c, oy_c = np.empty((height, width, 3)), np.empty((height, width))
    range_m = np.empty((height, width), np.float32)
    n_c = np.zeros((height, width, 3)) if edge_n > 1 else None  # the centres' normals, for the edge pass
    lpos = [np.asarray(x, float) for x in light_positions]
    hits: list = [None] * len(tiles)
    path_max = np.full((len(tiles), len(lpos)), -np.inf)

    def make_hits(i, o, d, t, oid, nrm, pix, w):
        """Hits of the samples (o, d, t, oid, normal flat) that meet a surface; ``pix`` their pixels in
        the tile."""
        idx = np.flatnonzero(oid > 0)
        ts, oid = t[idx], oid[idx]
        p = o[idx] + ts[:, None] * d[idx]
        nrm = nrm[idx]
        side = np.sum(nrm * d[idx], axis=-1) > 0  # two-sided: face the camera
        nrm = np.where(side[:, None], -nrm, nrm)
        h = _Hits(pix[idx], p, nrm, side, oid, ts, None if w is None else w[idx])
        hits[i] = h
        if len(h):
            for j, lp in enumerate(lpos):
                path_max[i, j] = np.max(np.linalg.norm(h.p - lp, axis=-1) + h.ts)

    def subsamples(y0, py, px, m, keep_rays=None, jitter=False):
        """``m²`` sample rays in each of the pixels (py, px) (rows relative to the tile's y0), their pixels
        (``keep_rays``: the tile index under which to keep the rays for the veil, ``view.edge_rays``;
        ``jitter``: each at a random place in its cell)."""
        g = (np.arange(m) + 0.5) / m
        X = ((px[:, None, None] + g[None, None, :]) / width) * np.ones((1, m, 1))
        Y = ((y0 + py[:, None, None] + g[None, :, None]) / height) * np.ones((1, 1, m))
        if jitter:
            # jittered within each of the m × m cells (by a hash of pixel and cell: deterministic, the same
            # in every tiling), as the renderer's random positions: at a straight edge a fixed grid gets the
            # same coverage wrong in every pixel along it (by up to 1/(2m)), which does not average out
            # over a region — the veil beyond a chart's rim is 20× the veil in front of it in clear water
            cell = np.arange(m * m, dtype=float).reshape(1, m, m)
            key = np.stack(np.broadcast_arrays((y0 + py)[:, None, None].astype(float),
                                               px[:, None, None].astype(float), cell), -1).reshape(-1, 3)
            u = (_hash2(key) - 0.5).reshape(len(px), m, m, 2) / m
            X = X + u[..., 0] / width
            Y = Y + u[..., 1] / height
        o, d = camera_rays(cam, X, Y, n_outside=n_out)
        t, oid, nrm = cast_rays(surf, o, d, normals=True)
        pix = np.repeat(py * width + px, m * m)
        o, d, t, oid = o.reshape(-1, 3), d.reshape(-1, 3), t.ravel(), oid.ravel()
        if keep_rays is not None:
            met = oid > 0
            rng = np.full(len(t), np.inf)
            rng[met] = np.linalg.norm(o[met] + t[met, None] * d[met] - pupil, axis=-1)
            view.edge_rays[keep_rays] = (pix, X.ravel() * width, Y.ravel() * height - y0, o[:, 1], d,
                                         np.where(met, t, np.inf), rng)
        return o, d, t, oid, nrm.reshape(-1, 3), pix

    def centre(i):
        y0, y1 = tiles[i]
        o, d = view.rays(y0, y1)
        t, oid, nrm = cast_rays(surf, o, d, normals=True)
        t_c[y0:y1], oid_c[y0:y1], d_c[y0:y1], oy_c[y0:y1] = t, oid, d, o[..., 1]
        if n_c is not None:
            n_c[y0:y1] = nrm
        o, d, t, oid, nrm = o.reshape(-1, 3), d.reshape(-1, 3), t.ravel(), oid.ravel(), nrm.reshape(-1, 3)
        idx = np.flatnonzero(oid > 0)
        r = np.full(len(t), np.inf, np.float32)
        r[idx] = np.linalg.norm(o[idx] + t[idx, None] * d[idx] - pupil, axis=-1)
        range_m[y0:y1] = r.reshape(y1 - y0, width)
        if n > 1:
            py, px = np.divmod(np.arange((y1 - y0) * width), width)
            o, d, t, oid, nrm, pix = subsamples(y0, py, px, n, keep_rays=i)
            make_hits(i, o, d, t, oid, nrm, pix, np.full(len(t), 1.0 / (n * n), np.float32))
        elif edge_n == 1:
            make_hits(i, o, d, t, oid, nrm, np.arange(len(t)), None)

    def edges(i):
        y0, y1 = tiles[i]
        o, d = view.rays(y0, y1)
        o, d = o.reshape(-1, 3), d.reshape(-1, 3)
        t, oid, nrm = t_c[y0:y1].ravel(), oid_c[y0:y1].ravel(), n_c[y0:y1].reshape(-1, 3)
        on_edge = edge[y0:y1].ravel()
        keep = np.flatnonzero(~on_edge)
        py, px = np.divmod(np.flatnonzero(on_edge), width)
        so, sd, st, soid, snrm, spix = subsamples(y0, py, px, edge_n, keep_rays=i, jitter=True)
        w = np.concatenate([np.ones(len(keep), np.float32), np.full(len(st), 1.0 / edge_n ** 2, np.float32)])
        make_hits(i, np.concatenate([o[keep], so]), np.concatenate([d[keep], sd]), np.concatenate([t[keep], st]),
                  np.concatenate([oid[keep], soid]), np.concatenate([nrm[keep], snrm]), np.concatenate([keep, spix]), w)

    view = _View(cam, n_out, width, height, n, tiles, t_c, oid_c, d_c, oy_c, range_m, cols, rows, hits, [],
                 [None] * len(tiles))
    run(pmap, centre, range(len(tiles)))
    if n == 1 and edge_n > 1:
        edge = _edge_pixels(oid_c, range_m)
        run(pmap, edges, range(len(tiles)))
    view.path_max = [float(m) if np.isfinite(m) else 1.0 for m in path_max.max(axis=0, initial=-np.inf)]
    return view


#: Neighbouring pixel centres whose ranges differ by more than this fraction are on an edge (m/m).
EDGE_RANGE_STEP = 0.05


def _edge_pixels(oid: np.ndarray, range_m: np.ndarray) -> np.ndarray:
    """(H, W) bool: pixels whose centre sees another object, or a range more than :data:`EDGE_RANGE_STEP`
    different, than one of its eight neighbours' — where a pixel's box holds more than one surface
    (or a surface and the open water), so its centre alone is not its mean."""
    pad_o = np.pad(oid, 1, mode="edge")
    r = np.where(np.isfinite(range_m), range_m, np.inf).astype(np.float64)
    pad_r = np.pad(r, 1, mode="edge")
    H, W = oid.shape
    out = np.zeros((H, W), bool)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            if dy == dx == 0:
                continue
            o2 = pad_o[1 + dy:1 + dy + H, 1 + dx:1 + dx + W]
            r2 = pad_r[1 + dy:1 + dy + H, 1 + dx:1 + dx + W]
            out |= o2 != oid
            both = np.isfinite(r) & np.isfinite(r2)
            with np.errstate(invalid="ignore"):
                out |= both & (np.abs(r2 - r) > EDGE_RANGE_STEP * np.minimum(r, r2))
    return out


# --- lights --------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True, eq=False)
class _Lamp:
    """One light as the per-pixel passes use it; the per-band tables in one dtype (:meth:`astype`).

    ``rho_I`` (S+1, B): band average of ρ I (the clear view); ``tab`` (S+1, n_L, B): band average of
    ρ I e^{−c L} at the path lengths ``L_nodes`` (light → surface → port); ``rho_Ic``: ρ I at the band
    centres; ``light``: the integrals' view of the light (with the blurred beam if forward) — None
    without water.
    """

    position: np.ndarray
    axis: np.ndarray
    beam: Callable
    rho_I: np.ndarray
    tab: np.ndarray | None = None
    L_nodes: np.ndarray | None = None
    rho_Ic: np.ndarray | None = None
    light: LightTables | None = None

    def astype(self, dt) -> "_Lamp":
        def cast(a):
            return None if a is None else a.astype(dt, copy=False)

        lt = self.light
        if lt is not None and lt.blurred is not None:
            lt = dataclasses.replace(lt, blurred=cast(lt.blurred))
        return dataclasses.replace(self, rho_I=cast(self.rho_I), tab=cast(self.tab), rho_Ic=cast(self.rho_Ic), light=lt)


def _lamp(light, lam, lam_w, band_lo, band_hi, rho_sub, rho_c, water: _Water | None, forward: bool,
          r_nodes: np.ndarray, path_max: float) -> _Lamp:
    lpos = np.asarray(light.position_m, float)
    axis = unit(light.aim)
    lwl, lval = np.asarray(light.wavelength_nm, float), np.asarray(light.axial_intensity, float)
    # the light's band averages, exact for its table (zero outside it, as in the renderer); the
    # sub-band values keep their shape inside a band but are scaled to that average (a flash
    # spectrum that starts at 400 nm would otherwise put twice the power into the 395–405 nm band)
    I_c = band_average(lwl, lval, band_lo, band_hi)  # (B,)
    I_sub = np.interp(lam, lwl, lval, left=0.0, right=0.0)  # (B, n_sub)
    quad = I_sub @ lam_w
    I_sub = np.where(quad[:, None] > 0, I_sub * (I_c / np.where(quad > 0, quad, 1.0))[:, None], I_c[:, None])
    rho_I = (rho_sub * I_sub) @ lam_w
    if water is None:
        return _Lamp(lpos, axis, light.beam.relative_intensity, rho_I)
    # band averages of ρ I e^{−c L} on a table of path lengths L = r + s
    L_nodes = np.linspace(0.0, max(path_max, 1e-3) * 1.0001, 513)
    tab = np.ascontiguousarray(np.einsum("kbs,lbs->klb", rho_sub * (I_sub * lam_w),
                                         np.exp(-water.c_sub[None] * L_nodes[:, None, None]),
                                         optimize=True))  # (S+1, nL, B)
    lt = LightTables(lpos, axis, light.beam.relative_intensity, I_c)
    if forward:
        th_n, btab = water.small_angle.blurred_beam(light.beam, r_nodes)
        lt = dataclasses.replace(lt, theta_nodes=th_n, r_nodes=r_nodes, blurred=btab)
    return _Lamp(lpos, axis, light.beam.relative_intensity, rho_I, tab, L_nodes, rho_c * I_c, lt)


# --- one light group: the per-pixel passes -------------------------------------------------
@dataclasses.dataclass(frozen=True, eq=False)
class _Bands:
    """A group's per-band constants in one dtype."""

    lamps: list
    rho_c: np.ndarray
    c: np.ndarray | None
    bF: np.ndarray | None
    kappa: np.ndarray | None


class _Group:
    """The image of one light group (continuous or strobe): shaded tile by tile into float32 layers.

    ``full`` = direct + forward-lit target + backscatter (+ the forward blur, :meth:`add_forward`).
    """

    def __init__(self, view: _View, surf: SceneSurfaces, water: _Water | None, lamps: list[_Lamp], rho_c, forward,
                 shadows, day: "_Daylight | None", grid: tuple | None, ms, *, want: set):
        self.view, self.surf, self.water, self.shadows = view, surf, water, bool(shadows)
        self.forward, self.day, self.grid, self.ms = forward, day, grid, ms
        self.lamps64 = lamps
        B = len(rho_c[0])
        self.B = B
        self.bands = {}
        for dt in (_F32, _F64):
            w = water
            c = bF = kappa = None
            if w is not None:
                c, bF = w.c.astype(dt), (w.b * w.F).astype(dt)
                kappa = (w.c - w.b * w.F).astype(dt)
            self.bands[dt] = _Bands([l.astype(dt) for l in lamps], rho_c.astype(dt), c, bF, kappa)
        self.rho_c = rho_c
        if water is not None:
            self.c_sub_max = float(np.max(water.c_sub))
            self.bF_max = float(np.max(water.b * water.F))
        H, W = view.height, view.width
        shape = (H, W, B)
        wet = water is not None
        # layers that are zero off the targets start as zeros (untouched pages cost nothing): only the
        # targets' pixels are written
        self.full = np.empty(shape, np.float32) if wet else np.zeros(shape, np.float32)
        self.clear = np.zeros(shape, np.float32) if ("clear" in want and wet) else None
        self.direct = np.zeros(shape, np.float32) if ("direct" in want and wet) else None
        self.back = np.empty(shape, np.float32) if ("backscatter" in want and wet) else None
        # the forward blur's source, per tile: (flat pixel index, (N, B) values) of the pixels holding any
        self.src = [None] * len(view.tiles) if forward and (lamps or ms is not None) else None
        # the veil from behind the targets that the camera leg's small-angle scattering brings into their pixels
        # (:meth:`_behind`), per tile: (flat pixel index, (N, B) s·V_b), blurred by add_forward with minus sign
        self.behind = [None] * len(view.tiles) if self.src is not None and water is not None and VEIL_BEHIND else None

    def layers(self) -> dict[str, np.ndarray]:
        if self.water is None:  # the view without water: every layer is the clear view, no backscatter
            zero = np.zeros_like(self.full)
            return {"full": self.full, "clear": self.full, "direct": self.full, "backscatter": zero}
        out = {"full": self.full}
        for k, a in (("clear", self.clear), ("direct", self.direct), ("backscatter", self.back)):
            if a is not None:
                out[k] = a
        return out

    def shade(self, pmap) -> None:
        run(pmap, self._shade_tile, range(len(self.view.tiles)))

    def add_forward(self, small_angle: SmallAngle, pitch: tuple[float, float], pmap,
                    bands_per_pass: int = 8) -> None:
        """``full +=`` the forward blur of the source (the source itself if there is nothing to blur,
        as :meth:`~rigsim.preview.forward.SmallAngle.blur_bands`), a few bands at a time; and ``full`` and
        ``backscatter`` ``−=`` the blur of the veil from behind the targets (:meth:`_behind`, whose
        unblurred value the tiles added)."""
        if self.src is None:
            return
        v, B, W = self.view, self.B, self.view.width

        def gather(parts):
            parts = [t for t in (parts or []) if t is not None]
            index = np.concatenate([t[0] for t in parts]) if parts else np.zeros(0, np.int64)
            values = np.concatenate([t[1] for t in parts]) if len(index) else np.zeros((0, B), np.float32)
            return index, values

        sources = [gather(self.src)]
        behind = gather(self.behind)
        if len(behind[0]):
            sources.append(behind)
        nonzero = np.zeros(v.height * W, bool)
        for index, _ in sources:
            nonzero[index] = True
        nonzero = nonzero.reshape(v.height, W)
        geometry = dict(port_m=port_reach_m(v.camera), viewpoint_m=port_viewpoint_m(v.camera, n_outside=v.n_out)) \
            if BLUR_PORT else {}
        if BLUR_EQUIDISTANT:
            geometry["warp"] = equidistant_maps(v.camera, W, v.height, n_outside=v.n_out, pitch_rad=pitch)
        plan = small_angle.blur_plan(v.range_m.astype(float), pitch, nonzero, **geometry)
        if plan is None:  # nothing to blur: the source itself (and the veil from behind cancels)
            index, values = sources[0]
            self.full.reshape(-1, B)[index] += values
            for index, values in sources[1:]:
                self.full.reshape(-1, B)[index] -= values
                if self.back is not None:
                    self.back.reshape(-1, B)[index] -= values
            return

        local = threading.local()

        def image(k, b):  # this thread's image of source k, band b (zero off the source's pixels)
            imgs = getattr(local, "imgs", None)
            if imgs is None:
                imgs = local.imgs = [np.zeros(v.height * W, np.float32) for _ in sources]
            index, values = sources[k]
            imgs[k][index] = values[:, b]
            return imgs[k].reshape(v.height, W)

        bufs = [np.empty((min(B, bands_per_pass), v.height, W), np.float32) for _ in sources]

        def blur(job):
            j, b = job
            for k, buf in enumerate(bufs):
                buf[j] = plan.blur(b, image(k, b))

        def add(job):
            i, b0, b1 = job
            y0, y1 = v.tiles[i]
            self.full[y0:y1, :, b0:b1] += np.moveaxis(bufs[0][:b1 - b0, y0:y1], 0, -1)
            if len(bufs) > 1:
                part = np.moveaxis(bufs[1][:b1 - b0, y0:y1], 0, -1)
                self.full[y0:y1, :, b0:b1] -= part
                if self.back is not None:
                    self.back[y0:y1, :, b0:b1] -= part

        for b0 in range(0, B, bands_per_pass):
            b1 = min(B, b0 + bands_per_pass)
            run(pmap, blur, enumerate(range(b0, b1)))
            run(pmap, add, [(i, b0, b1) for i in range(len(v.tiles))])

    def _behind(self, y0: int, y1: int):
        """The veil from behind the tile's targets that small-angle scattering on the camera leg brings into
        their pixels, before its blur: ``(flat pixel index in the tile, (N, B) s·V_b)``, ``V_b`` the lights'
        veil of the water beyond the pixel's range (what the target blocks: the veil of the whole line of
        sight less the veil in front of the target), ``s = 1 − e^{−bF r}`` the share of it scattered by small
        angles over the range ``r`` (None: no target in the tile).  The daylight's path radiance is not in
        ``V_b``: it is Duntley's, seen through ``e^{−c s}`` without a halo, as the renderer's.

        The quasi-single camera leg ``e^{−(c − bF) s}`` keeps the light scattered by small angles on the way
        back where it was: right for a veil that is smooth across the image, not at a target's silhouette,
        where the veil from behind stops.  Really the part ``s`` of the light that passes beside the target is
        spread by the camera leg's kernel ``K`` (:mod:`rigsim.preview.forward`, at the target's range), so some
        of it reaches the target's pixels, and the water next to the target lacks what would have come from
        behind it: ``ΔL = s [M V_b − K ⊛ (M V_b)]`` (``M`` the target's pixels; the smooth rest,
        ``s [K ⊛ V_b − V_b]``, is left out as everywhere: summed over range bins of the veil, with the field
        beyond the frame, it is within ±0.9 % of the veil in every 12-pixel column group — edge-lit rig, Jerlov 9C,
        450 nm, 96 × 64, measured 2026-12-05 on a field twice the image's; without the field beyond the frame it
        would take 14 % from the outer columns, so a blur of the frame alone would be wrong).  The tiles add ``s M V_b``; :meth:`add_forward`
        subtracts its blur.  Measured 2026-12-04 (``benchmarks/bench_fast_engine_decompose.py``, the demo's
        edge-lit black disk in Jerlov 3C at 1 m, 450 nm, 16 Monte Carlo renders): without it the veil in front
        of the disk was 0.3945 of the disk's Monte Carlo radiance against Monte Carlo's 0.427, while the
        tracer's independent estimators of the same split agreed with the fast engine's parts; the estimate
        of this term was +0.026."""
        v = self.view
        r = v.range_m[y0:y1].astype(float).reshape(-1)
        pix = np.flatnonzero(np.isfinite(r))
        if not pix.size:
            return None
        W = v.width
        cols, rows = v.cols[pix % W], v.rows[y0 + pix // W]
        everything = np.zeros((pix.size, self.B), np.float32)
        inf = np.full(pix.size, np.inf)
        self._lamps_veil(cols, rows, inf, inf, everything)
        here = np.zeros_like(everything)
        self._lamps_veil(cols, rows, v.t_c[y0:y1].reshape(-1)[pix], r[pix], here)
        vb = np.maximum(everything - here, 0.0)
        s = -np.expm1(-np.outer(r[pix], self.water.b * self.water.F))
        return pix, (s * vb).astype(np.float32)

    # -- one tile
    def _shade_tile(self, i: int) -> None:
        v, B = self.view, self.B
        y0, y1 = v.tiles[i]
        hits = v.hits[i]
        clear, direct, scattered, src = self._surface_terms(hits)
        if self.water is None:
            self._put(self.full[y0:y1], y0, y1, hits, clear)
            return
        full = self.full[y0:y1]
        if self.back is not None:
            back = self.back[y0:y1]
            self._backscatter(y0, y1, back, tile=i)
            full[...] = back
        else:
            self._backscatter(y0, y1, full, tile=i)
        if self.behind is not None:
            got = self._behind(y0, y1)
            if got is not None:
                pix, val = got
                full.reshape(-1, B)[pix] += val
                if self.back is not None:
                    back.reshape(-1, B)[pix] += val
                self.behind[i] = (y0 * v.width + pix, val)
        if self.ms is not None:  # light reflected by a target, then scattered into the camera
            v_ = self.view
            C_, R_ = np.meshgrid(v_.cols, v_.rows[y0:y1])
            full += self.ms.veil_at(C_, R_, v_.range_m[y0:y1].astype(float), surfaces=True)
        self._put(full, y0, y1, hits, direct + scattered, add=True)
        if self.clear is not None:
            self._put(self.clear[y0:y1], y0, y1, hits, clear)
        if self.direct is not None:
            self._put(self.direct[y0:y1], y0, y1, hits, direct)
        if self.src is not None:
            W = v.width
            if hits.w is None:
                self.src[i] = (y0 * W + hits.idx, src)
            else:
                px = _pixel_sum(hits, src, (y1 - y0) * W)
                nz = np.flatnonzero(np.any(px != 0, axis=-1))
                self.src[i] = (y0 * W + nz, px[nz])

    def _put(self, out: np.ndarray, y0: int, y1: int, hits: _Hits, a: np.ndarray, add: bool = False) -> None:
        """Per-hit values ``a`` (N, B) → ``out`` (the tile's pixels, (rows, W, B), zero where no sample hits
        unless ``add``): each pixel's mean over its samples, written (``add``: added)."""
        flat = out.reshape(-1, self.B)
        if hits.w is None:
            if add:
                flat[hits.idx] += a
            else:
                flat[hits.idx] = a
            return
        px = _pixel_sum(hits, a, len(flat))
        if add:
            flat += px
        else:
            flat[...] = px

    def _surface_terms(self, hits: _Hits):
        """(clear, direct, scattered, src) per hit sample, (N, B) float32: the clear view, the unscattered
        image (with the daylight), the target lit by forward-scattered light (× e^{−c s}), the blur's source.

        Float32 where every exponent is within ±:data:`F32_EXP_MAX`, the other samples in float64.
        """
        far = self._far(hits) if self.water is not None else None
        if far is None or not far.any():
            return self._terms(hits, _F32)
        near_t, far_t = self._terms(hits.subset(~far), _F32), self._terms(hits.subset(far), _F64)
        out = []
        for a, b in zip(near_t, far_t):
            if a is None:
                out.append(None)
                continue
            m = np.empty((len(hits), self.B), np.float32)
            m[~far], m[far] = a, b
            out.append(m)
        return tuple(out)

    def _far(self, hits: _Hits) -> np.ndarray:
        """Samples whose exponents may leave ±F32_EXP_MAX (c L on a light's path, b F s for the blur)."""
        path = np.zeros(len(hits))
        for lamp in self.lamps64:
            path = np.maximum(path, np.linalg.norm(hits.p - lamp.position, axis=-1))
        far = self.c_sub_max * (path + hits.ts) > F32_EXP_MAX
        if self.forward:
            far |= self.bF_max * hits.ts > F32_EXP_MAX
        return far

    def _terms(self, h: _Hits, dt):
        K = self.bands[dt]
        N, B = len(h), self.B
        clear = np.zeros((N, B), dt)
        direct = np.zeros((N, B), dt)
        scattered = np.zeros((N, B), dt)  # target lit by forward-scattered light, unscattered to the camera
        for lamp in K.lamps:
            v = h.p - lamp.position
            r = np.linalg.norm(v, axis=-1)
            vh = v / np.maximum(r, 1e-12)[..., None]
            cos_i = np.clip(-np.sum(vh * h.nrm, axis=-1), 0.0, None)
            if self.shadows:
                cos_i = cos_i * ~occluded(self.surf, h.p, lamp.position, exclude=h.oid)
            theta = beam_angle(vh, lamp.axis)
            f = lamp.beam(theta)
            geo = cos_i / (np.pi * np.maximum(r, 1e-9) ** 2)  # (N,)
            gf = (geo * f).astype(dt)[:, None]
            clear += gf * lamp.rho_I[h.oid]
            if lamp.tab is None:
                continue
            direct += gf * _interp_table(lamp.tab, h.oid, r + h.ts, lamp.L_nodes)
            if self.forward:
                fb = lamp.light.blurred_at(theta, r)  # (N, B)
                rr = r.astype(dt)[:, None]
                amp = np.exp(-K.kappa * rr) - np.exp(-K.c * rr)  # e^{−cr}(e^{bFr} − 1)
                scattered += geo.astype(dt)[:, None] * fb * amp * lamp.rho_Ic[h.oid]
        if self.ms is not None and N:  # targets lit by the multiply scattered light
            scattered += (self.rho_c[h.oid] / np.pi * self.ms.irradiance_at(self.surf, h.oid, h.p, h.nrm)).astype(dt)
        day_seen = None
        if self.day is not None and N:
            day_lit, day_seen = self.day.reflected(h, dt, None if self.water is None else h.ts[:, None])
            clear += day_lit
        if self.water is None:
            return clear, None, None, None
        s = h.ts.astype(dt)[:, None]
        T = np.exp(-K.c * s)
        src = None
        if self.forward:  # (direct + scattered)(e^{bFs} − 1), the scattered part as e^{−κs} − e^{−cs}
            src = _times_expm1(direct, K.bF * s) + scattered * (np.exp(-K.kappa * s) - T)
        scattered *= T
        if day_seen is not None:
            direct += day_seen
        return clear, direct, scattered, src

    def veil_in_front(self, pixel: np.ndarray, range_m: np.ndarray) -> np.ndarray:
        """(n, B) the veil along the lines of sight of pixels ``pixel`` (flat indices) up to ``range_m`` (n,)
        from the pupil — what is in front of something at that distance, which it cannot hide."""
        v = self.view
        range_m = np.asarray(range_m, float)
        t = np.where(np.isfinite(range_m), np.maximum(range_m - port_reach_m(v.camera), 0.0), np.inf)
        out = np.zeros(range_m.shape + (self.B,), np.float32)
        self._veil(v.cols[pixel % v.width], v.rows[pixel // v.width], v.oy_c.reshape(-1)[pixel],
                   v.d_c.reshape(-1, 3)[pixel], t, range_m, out)
        return out

    def _backscatter(self, y0: int, y1: int, back: np.ndarray, tile: int | None = None) -> None:
        """``back`` (rows, W, B) = the veil of each pixel's whole line of sight (paths that met no target, as
        the renderer's ``backscatter`` layer); in the pixels on an edge (``tile``'s ``edge_rays``) the mean
        of their sample rays' veils, as the renderer's box filter: a ray past a target's rim sees the water
        to the end — in clear water at 15 m 20× the veil in front of a chart 1 m away, so the chart's
        rim pixels held the fast engine's backscatter share 27 % under Monte Carlo's."""
        v = self.view
        back[...] = 0.0
        C_, R_ = np.meshgrid(v.cols, v.rows[y0:y1])
        self._veil(C_, R_, v.oy_c[y0:y1], v.d_c[y0:y1], v.t_c[y0:y1], v.range_m[y0:y1].astype(float), back)
        er = v.edge_rays[tile] if tile is not None and v.edge_rays and SAMPLE_VEILS else None
        if er is None or not len(er[0]):
            return
        pix, cols, rows, oy, d, t, rng = er
        per = np.zeros((len(t), self.B), back.dtype)
        self._veil(cols, rows + y0, oy, d, t, rng, per)
        flat = back.reshape(-1, self.B)
        first = np.flatnonzero(np.r_[True, pix[1:] != pix[:-1]])  # (each pixel's samples are together)
        counts = np.diff(np.r_[first, len(pix)])
        flat[pix[first]] = np.add.reduceat(per, first, axis=0) / counts[:, None].astype(back.dtype)

    def _veil(self, cols, rows, oy, d, t_port, range_m, out) -> None:
        """``out`` += the veil along lines of sight at image positions (cols, rows) (origin heights ``oy``,
        directions ``d``) up to ``t_port`` from the port (``range_m`` from the pupil; inf: all of it): the
        lights' backscatter, the multiply scattered veil and the daylight's path radiance."""
        self._lamps_veil(cols, rows, t_port, range_m, out)
        if self.day is not None:
            out += self.day.path_radiance(oy, d, t_port)

    def _lamps_veil(self, cols, rows, t_port, range_m, out) -> None:
        """``out`` += the lights' part of :meth:`_veil` (their backscatter and multiply scattered veil)."""
        if self.grid is not None:
            cum, shape, gcol, grow, s = self.grid
            interpolate_cumulative(cum, shape, gcol, grow, s, cols, rows, t_port, out=out)
        if self.ms is not None:
            out += self.ms.veil_at(cols, rows, range_m).astype(out.dtype)


def _times_expm1(v: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``v (e^x − 1)`` for ``v ≥ 0``: in float32 (for |x| ≤ F32_EXP_MAX) ``e^x − 1``, whose absolute error
    ~6e-8 is relative to ``v``; in float64 ``expm1``, in log space where ``e^x`` would overflow."""
    if x.dtype == _F32:
        return v * (np.exp(x) - np.float32(1.0))
    big = x > 700.0
    out = v * np.expm1(np.minimum(x, 700.0))
    if np.any(big):
        with np.errstate(divide="ignore"):
            out[big] = np.exp(np.log(v[big]) + x[big]) - v[big]
    return out


def _interp_table(tab: np.ndarray, oid: np.ndarray, x: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    """``tab[oid, ·, :]`` read at ``x`` on the uniform ``nodes`` (linear): shape ``x.shape + (B,)``, tab's dtype."""
    u = np.clip((x - nodes[0]) / (nodes[1] - nodes[0]), 0.0, len(nodes) - 1.000001)
    j = u.astype(np.int64)
    fr = (u - j)[..., None].astype(tab.dtype)
    flat = tab.reshape(-1, tab.shape[-1])
    k = oid * tab.shape[1] + j
    return np.take(flat, k, axis=0) * (1 - fr) + np.take(flat, k + 1, axis=0) * fr


def _pixel_sum(hits: _Hits, a: np.ndarray, n_pixels: int) -> np.ndarray:
    """(n_pixels, B) Σ w·a over each pixel's samples (the pixel's mean; zero where none meets a surface)."""
    out = np.empty((n_pixels, a.shape[-1]), a.dtype)
    wa = a * hits.w.astype(a.dtype)[:, None]
    for b in range(a.shape[-1]):
        out[:, b] = np.bincount(hits.idx, weights=wa[:, b], minlength=n_pixels)
    return out


def _backscatter_grid(scene, surf, tables, water, forward, cam, width, height, world_r, grid, n_nodes,
                      shadows, pmap) -> tuple:
    """The cumulative backscatter integral on the coarse grid of rays (every pixel if ``grid`` is None):
    ``(cum float32, (rows, cols), grid cols, grid rows, s nodes)`` for :func:`interpolate_cumulative`."""
    kappa_cam = water.c - water.b * water.F if forward else water.c
    kappa_light = water.c - water.b * water.F if forward else water.c
    k_min = float(np.min(kappa_cam + kappa_light))
    s_max = world_r if k_min <= 0 else min(world_r, 50.0 / k_min)
    s, _ = s_nodes(s_max, n_nodes)
    from rigsim.scene.optics import pixel_rays

    if grid is None:
        o, d, gcol, grow = pixel_rays(cam, width, height, n_outside=outside_index(scene))
    else:
        step = max(width, height) / float(grid)
        o, d, gcol, grow = pixel_rays(cam, width, height, n_outside=outside_index(scene), step=max(step, 1e-9))
    o, d = o.reshape(-1, 3), d.reshape(-1, 3)
    chunks = np.array_split(np.arange(len(o)), max(1, min(len(o) // 64, 8)))
    cum = np.empty((len(o), len(s), len(water.c)), np.float32)
    spread = two_leg = None
    if forward and SPREAD_PHASE and water.small_angle is not None:
        sa, bw = water.small_angle, water.bw

        def spread(cos_psi, r):
            return sa.spread_beta(cos_psi, r, bw)

        if SPREAD_CAMERA_LEG:
            def two_leg(cos_psi, beta, r, s_):
                return sa.two_leg_beta(cos_psi, beta, r, s_, bw)

    def chunk(ix):
        cum[ix] = cumulative_backscatter(o[ix], d[ix], s, tables, bw=water.bw, c=water.c, kappa_light=kappa_light,
                                         kappa_cam=kappa_cam, components=water.components, forward=forward,
                                         surfaces=surf if shadows else None, spread=spread,
                                         shade_beyond_hit=not VEIL_SHADOWS, two_leg=two_leg)

    run(pmap, chunk, chunks)
    return cum, (len(grow), len(gcol)), gcol, grow, s


#: Distances from the pupil (log-spaced over the particles' range) at which the veil in front of them is tabulated.
_HIDE_NODES = 12


def _coarse_pixels(H: int, W: int):
    """Rows, columns and flat indices of every :data:`_SHADOW_STEP`-th pixel (and the last row and column)."""
    rs = np.unique(np.r_[np.arange(0, H, _SHADOW_STEP), H - 1])
    cs = np.unique(np.r_[np.arange(0, W, _SHADOW_STEP), W - 1])
    RR, CC = np.meshgrid(rs, cs, indexing="ij")
    return rs, cs, (RR * W + CC).ravel()


def _to_full(a: np.ndarray, rs, cs, H: int, W: int) -> np.ndarray:
    """(len(rs)·len(cs), B) values on the coarse pixels → (H, W, B), bilinear."""
    import cv2

    B = a.shape[-1]
    g = a.reshape(len(rs), len(cs), B).astype(np.float32)
    if (len(rs), len(cs)) == (H, W):
        return g
    return cv2.resize(g, (W, H), interpolation=cv2.INTER_LINEAR).reshape(H, W, B)


def _veil_behind(group: "_Group", image: np.ndarray, hiders) -> np.ndarray:
    """(rows, W, B): what the particles hide on the way to the camera, ``Σ share · (light − veil in front of
    the particle)`` over every point of their images (``hiders``, :class:`~rigsim.preview.particles.
    ParticleLayers`).  The veil in front is smooth across the image and in distance: tabulated on coarse
    pixels at :data:`_HIDE_NODES` distances; the shares are split linearly (in log distance) between the
    two nodes about each particle."""
    pix, rng_h, share = hiders
    H, W, B = image.shape
    out = np.zeros(image.shape, np.float32)
    if not len(pix):
        return out
    nodes = np.geomspace(max(float(rng_h.min()), 1e-3), max(float(rng_h.max()), 1e-3) * 1.0001, _HIDE_NODES)
    x = np.interp(np.log(rng_h), np.log(nodes), np.arange(_HIDE_NODES))
    k0 = np.minimum(np.floor(x).astype(np.int64), _HIDE_NODES - 2)
    f = x - k0
    rs, cs, gpix = _coarse_pixels(H, W)
    rng_pix = group.view.range_m.reshape(-1)[gpix].astype(float)
    # only the pixels the particles cover (whole-image arithmetic per node was most of the time)
    upix, inv = np.unique(pix, return_inverse=True)
    light = image.reshape(-1, B)[upix]
    acc = np.zeros((len(upix), B), np.float32)
    for k in range(_HIDE_NODES):
        wk = np.where(k0 == k, share * (1.0 - f), 0.0) + np.where(k0 + 1 == k, share * f, 0.0)
        if not np.any(wk):
            continue
        weight = np.bincount(inv, weights=wk, minlength=len(upix))[:, None]
        front = _to_full(group.veil_in_front(gpix, np.minimum(nodes[k], rng_pix)), rs, cs, H, W).reshape(-1, B)[upix]
        acc += weight * np.maximum(light - front, 0.0)
    out.reshape(-1, B)[upix] = acc
    return out


#: Depth nodes over the particles' placement region at which their shadows on the veil are summed.
_SHADOW_NODES = 6
#: Pixels between the points at which the particles' shadow on the veil is computed (then interpolated).
_SHADOW_STEP = 8


def _particle_shadows(group: "_Group", image: np.ndarray, ps, scene: Scene) -> np.ndarray:
    """(rows, W, B): the light a group's lights lose to the particles' shadows before it reaches the water
    and the targets in view.  The particles' geometric extinction ``c_p`` (their field's, in the placement
    region only: the renderer has none beyond it) acts on each light's way to the lit point along the
    length of that way inside the region (:func:`rigsim.scene.particles.length_inside`), averaged over
    the group's lights: a veil element at depth z of a pixel's line of sight (nodes over the region;
    the veil's loss is smooth across the image and is computed every :data:`_SHADOW_STEP` pixels and
    interpolated) and what lies beyond the region (the target the line meets, per pixel).  Their shadow
    on the way to the camera is the ``coverage`` of :mod:`rigsim.preview.particles`."""
    from rigsim.scene.particles import length_inside, placement_frustum

    c_p = ps.expected / max(ps.volume_m3, 1e-300) * ps.field.mean_cross_section_m2
    z_max = float(ps.depth_range_m[1])
    lamps = group.lamps64
    if c_p * z_max < 1e-6 or not lamps:
        return np.zeros(image.shape)
    fr = placement_frustum(scene, ps.field, z_max)
    v = group.view
    H, W, B = image.shape
    pupil = np.asarray(scene.camera.position_m, float)
    fwd = scene.camera.frame()[2]

    def keep(points):  # (n, 3) → (n,) mean over the lights of e^{−c_p ℓ}
        return np.mean([np.exp(-c_p * length_inside(fr, scene.camera, np.broadcast_to(l.position, points.shape),
                                                       points)) for l in lamps], axis=0)

    # the veil's loss and the veil up to the region's end, on a coarse grid of pixels
    rs, cs, pix = _coarse_pixels(H, W)
    rng = v.range_m.reshape(-1)[pix].astype(float)
    d = v.d_c.reshape(-1, 3)[pix]
    cos_f = np.maximum(d @ fwd, 1e-3)
    z = np.linspace(0.0, z_max, _SHADOW_NODES + 1)
    lost = np.zeros((len(pix), B))
    prev = np.zeros((len(pix), B), np.float32)
    for k in range(1, len(z)):
        cum = group.veil_in_front(pix, np.minimum(z[k] / cos_f, rng))
        r_mid = np.minimum(0.5 * (z[k - 1] + z[k]) / cos_f, rng)
        lost += (cum - prev) * (1.0 - keep(pupil + d * r_mid[:, None]))[:, None]
        prev = cum

    lost, near_veil = _to_full(lost, rs, cs, H, W), _to_full(prev, rs, cs, H, W)
    # beyond the region (the farther veil and the targets' light), per pixel
    rng_all = v.range_m.astype(float)
    d_all = v.d_c.reshape(-1, 3)
    cos_all = np.maximum(d_all @ fwd, 1e-3)
    far = np.where(np.isfinite(rng_all.reshape(-1)), rng_all.reshape(-1), 2.0 * z_max / cos_all)
    keep_far = keep(pupil + d_all * far[:, None]).reshape(H, W, 1)
    return lost + np.maximum(image - near_veil, 0.0) * (1.0 - keep_far)


# --- daylight ------------------------------------------------------------------------------
#: Length of the shadow test towards the sun (m): far beyond any target.
_SUN_RAY_M = 1000.0

#: Nodes of the grid of surface normals (zenith 0–180°, azimuth −180–180°) on which the diffuse daylight's
#: irradiance of mesh samples is interpolated (every 5.6° in each).
_NORMAL_GRID = (33, 65)

#: Directions per surface sample (a 4 × 4 stratified cosine-weighted pattern) over which targets are
#: looked for that hide the diffuse daylight (with ``shadows``): :meth:`_Daylight._hidden_diffuse`.
_HIDDEN_SKY_RAYS = 16


#: Largest bias of a daylight band's value from its field and transmission taken as band means apart
#: (:func:`daylight_sub_bands`, relative).
DAYLIGHT_SUB_BIAS = 0.005
#: Most sub-bands per band for the daylight.
DAYLIGHT_MAX_SUB = 8
#: Pixels of several samples (on an edge, or all with ``pixel_samples`` > 1) take the mean of their sample
#: rays' veils (:meth:`_Group._backscatter`); False: the centre's (as before 2026-12-03; for the frozen
#: reference in tests/preview/test_preview_speed.py).
SAMPLE_VEILS = True
#: The veil from behind a target that small-angle scattering on the camera leg brings into the target's
#: pixels (:meth:`_Group._behind`); False: left out (as before 2026-12-04; for the frozen reference in
#: tests/preview/test_preview_speed.py).
VEIL_BEHIND = True


def _sinhc(x: float) -> float:
    """``sinh(x)/x`` (1 at 0): the mean of ``e^{t}`` over ``t`` uniform in [−x, x]."""
    return 1.0 if x < 1e-8 else float(np.sinh(x) / x)


def _product_bias(alpha: float, beta: float) -> float:
    """Relative error of ``⟨f⟩⟨g⟩`` for ``⟨f g⟩`` where ``ln f`` and ``ln g`` spread linearly by ``alpha``
    and ``beta`` over a uniformly sampled band, the worse of the two signs: with
    ``S(x) = sinh(x)/x``, ``|S((α ± β)/2) / (S(α/2) S(β/2)) − 1|``."""
    S = _sinhc
    den = S(alpha / 2) * S(beta / 2)
    return max(abs(S((alpha + beta) / 2) / den - 1.0), abs(S(abs(alpha - beta) / 2) / den - 1.0))


def _midpoint_bias(alpha: float, gamma: float) -> float:
    """Relative error of ``g(mid) ⟨f⟩`` for ``⟨f g⟩`` where ``ln f`` and ``ln g`` spread linearly by ``alpha``
    and ``gamma`` over a uniformly sampled band (``g`` taken at the band's middle), the worse of the two signs:
    ``|S((α ± γ)/2) / S(α/2) − 1|`` with ``S(x) = sinh(x)/x`` (about ``(2αγ + γ²)/24`` when both are small)."""
    S = _sinhc
    return max(abs(S((alpha + gamma) / 2) / S(alpha / 2) - 1.0), abs(S(abs(alpha - gamma) / 2) / S(alpha / 2) - 1.0))


def daylight_sub_bands(day: SceneDaylight, wl: np.ndarray, bw: np.ndarray,
                       reach_m: float, reflectance=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sub-bands for the daylight: (centres (M,), widths (M,), owning band (M,)).

    The renderer draws wavelengths within each band and carries each one's field and transmission
    together, so its band value is the mean of their product; one row of band means per band gives the
    product of the means.  Deep in clear water the two fall steeply together in the red (at 15 m in
    Jerlov I the field drops by e^{2.9} across the band 575–585 nm, where pure water's absorption starts to
    rise, while the path radiance in front of a black disk, ``∝ 1 − e^{−ct}``, rises by e^{0.3}): the fast
    engine's black disk at 1 m was 12 % over Monte Carlo's in the red.  Where the two exponents spread by
    α (``ln`` field: the diffuse radiance or the beam, whichever spreads more) and β (``ln c`` — thin
    water — or ``c × reach_m``, the longest line of sight to a surface, whichever is larger) linearly
    across a band, the product of the means is off by :func:`_product_bias` (about αβ/12 when both are
    small); each band is cut into the fewest equal sub-bands that bring it below
    :data:`DAYLIGHT_SUB_BIAS` (of at least 1 nm, the tables' step; at most :data:`DAYLIGHT_MAX_SUB`) — a
    quadrature of the band in
    the spirit of the k-distribution method (Lacis & Oinas 1991, *J. Geophys. Res.* 96(D5), 9027–9063),
    here in wavelength order since the field and ``c`` are smooth and monotone over a band.

    ``reflectance`` (λ → (S + 1, n) reflectances, :meth:`SceneSurfaces.reflectance`): each sub-band takes the
    targets' reflectance at its middle, so where ``ln ρ`` spreads by γ across a band (the red and magenta
    patches' edge at 580–620 nm, where the field deep in clear water falls by e^{2–3} per band) the sub-bands
    also bring :func:`_midpoint_bias` (α, γ) below :data:`DAYLIGHT_SUB_BIAS`.  Found 2026-12-04 by the
    agreement benchmark with 49–64 Monte Carlo renders: at 15 m in Jerlov I and IA the fast engine's moderate
    red and magenta patches read +4.7 … +8.5 % (± 0.8–1.6 %) in the red — the band-centre reflectance times
    the band's mean field, while the field falls and the reflectance rises across the band.
    """
    wl, bw = np.asarray(wl, float), np.asarray(bw, float)
    tiny = np.finfo(float).tiny
    log_d = np.log(np.maximum(day.diffuse.sum(axis=(1, 2)), tiny))
    log_b = np.log(np.maximum(np.asarray(day.beam, float), tiny))
    c = np.asarray(day.c, float)
    n = np.ones(len(wl), np.int64)
    for b in range(len(wl)):
        lam = np.linspace(wl[b] - bw[b] / 2, wl[b] + bw[b] / 2, 33)
        rows = np.unique(day.band_index(lam))
        gamma = 0.0
        if reflectance is not None:  # the steepest target spectrum across the band (rows of zeros: no surface)
            rho = np.asarray(reflectance(lam), float)
            rho = rho[np.all(rho > 0, axis=1)]
            if rho.size:
                gamma = min(float(np.ptp(np.log(rho), axis=1).max()), 50.0)
        lit = [x[rows] for x in (log_d, log_b) if np.any(x[rows] > np.log(tiny) + 1)]
        alpha = min(max((float(np.ptp(x)) for x in lit), default=0.0), 50.0)
        cr = c[rows]
        beta = min(max(float(np.ptp(cr)) * max(float(reach_m), 0.0),
                       float(np.log(cr.max() / cr.min())) if cr.min() > 0 else 50.0), 50.0)
        top = max(1, min(DAYLIGHT_MAX_SUB, int(bw[b])))
        k = 1
        while k < top and max(_product_bias(alpha / k, beta / k), _midpoint_bias(alpha / k, gamma / k)) > DAYLIGHT_SUB_BIAS:
            k += 1
        n[b] = k
    owner = np.repeat(np.arange(len(wl)), n)
    j = np.concatenate([np.arange(k) for k in n])
    width = bw[owner] / n[owner]
    centre = wl[owner] - bw[owner] / 2 + (j + 0.5) * width
    return centre, width, owner


def _hash2(p: np.ndarray) -> np.ndarray:
    """(N, 2) pseudo-random numbers in [0, 1) from points ``p`` (N, 3): the same point, the same numbers
    (a sample's directions do not depend on how the image is cut into tiles, nor on the run)."""
    q = np.round(np.asarray(p, float) * 1e5).astype(np.int64).view(np.uint64)
    h = q[:, 0] * np.uint64(0x9E3779B97F4A7C15) ^ q[:, 1] * np.uint64(0xC2B2AE3D27D4EB4F) \
        ^ q[:, 2] * np.uint64(0x165667B19E3779F9)
    out = []
    for salt in (np.uint64(0x27D4EB2F165667C5), np.uint64(0x94D049BB133111EB)):
        x = h ^ salt
        x ^= x >> np.uint64(31)
        x *= np.uint64(0xBF58476D1CE4E5B9)
        x ^= x >> np.uint64(29)
        out.append((x >> np.uint64(11)).astype(np.float64) / float(1 << 53))
    return np.stack(out, -1)


def _diffuse_irradiance(diffuse: np.ndarray, dirs: np.ndarray, dw: float, normals: np.ndarray) -> np.ndarray:
    """(U, B) irradiance of the diffuse field (B, nθ, nφ radiances over its bins, sub-sampled directions
    ``dirs`` of solid angle ``dw`` each: :meth:`DaylightField.bin_directions`) on surfaces of unit normals
    ``normals`` (U, 3): the cosine-weighted integral over the hemisphere about each normal."""
    out = [np.einsum("btp,ntp->nb", diffuse,
                     np.clip(np.einsum("tpsk,nk->ntps", dirs, normals[a:a + 64]), 0.0, None).sum(axis=-1) * dw)
           for a in range(0, len(normals), 64)]  # (64 normals at a time: bounded memory)
    return np.concatenate(out) if out else np.zeros((0, diffuse.shape[0]))


def _on_normal_grid(grid: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Bilinear interpolation of ``grid`` (nθ, nφ, B) at unit normals ``n`` (N, 3)."""
    nt, nph = grid.shape[:2]
    th = np.arccos(np.clip(n[:, 1], -1.0, 1.0)) / np.pi * (nt - 1)
    ph = (np.arctan2(n[:, 0], n[:, 2]) + np.pi) / (2 * np.pi) * (nph - 1)
    i0 = np.clip(np.floor(th).astype(np.int64), 0, nt - 2)
    j0 = np.clip(np.floor(ph).astype(np.int64), 0, nph - 2)
    ft, fp = (th - i0)[:, None].astype(grid.dtype), (ph - j0)[:, None].astype(grid.dtype)
    return ((1 - ft) * ((1 - fp) * grid[i0, j0] + fp * grid[i0, j0 + 1])
            + ft * ((1 - fp) * grid[i0 + 1, j0] + fp * grid[i0 + 1, j0 + 1]))


class _Daylight:
    """The scene's daylight field (:mod:`rigsim.scene.daylight_field`) for the per-pixel passes.

    It works on sub-bands (:func:`daylight_sub_bands`: as many per band as its spectral spread needs)
    and hands band means out (:meth:`bands`, :meth:`reflected`, :meth:`path_radiance`)."""

    def __init__(self, day: SceneDaylight, wl: np.ndarray, surf: SceneSurfaces, bw: np.ndarray | None = None,
                 shadows: bool = False, reach_m: float = 0.0):
        self.surf, self.shadows = surf, bool(shadows)
        self.n_bands = len(wl)
        if bw is not None:
            wl, bw, self.owner = daylight_sub_bands(day, wl, bw, reach_m, reflectance=surf.reflectance)
            day = day.band_means(wl, bw)
        else:
            self.owner = np.arange(len(wl))
        #: (S + 1, M) the targets' reflectances at the sub-bands' middles (not the bands' centres: the
        #: reflectance rises across a band as the field falls, :func:`daylight_sub_bands`)
        self.rho_sub = surf.reflectance(wl)
        # (M, B): the mean of each band's sub-bands
        counts = np.bincount(self.owner, minlength=self.n_bands)
        self.to_bands = np.zeros((len(wl), self.n_bands))
        self.to_bands[np.arange(len(wl)), self.owner] = 1.0 / counts[self.owner]
        self.day, self.wl = day, wl
        idx = day.band_index(wl)
        self.sun = np.asarray(day.sun_direction, float)
        self.c, self.k = day.c[idx], day.k_diffuse[idx]
        # the diffuse field's irradiance per distinct normal (targets are flat pieces: few normals), for
        # each surface facing the camera with its normal (row 2k) or against it (row 2k + 1)
        dirs, dw = day.field.bin_directions(4)
        normals = surf.normal if len(surf) else np.zeros((0, 3))
        sides = np.round(np.stack([normals, -normals], axis=1).reshape(-1, 3), 9)
        uniq, inv = np.unique(sides, axis=0, return_inverse=True)
        e_dif = _diffuse_irradiance(day.diffuse[idx], dirs, dw, uniq)[np.asarray(inv).ravel()]
        # meshes have a normal per sample: the diffuse irradiance on a grid of normals (zenith × azimuth
        # nodes), interpolated bilinearly (the field is smooth in the normal: a cosine-weighted integral)
        self.is_mesh = np.r_[False, surf.is_mesh] if len(surf) else np.zeros(1, bool)
        grid = None
        if self.is_mesh.any():
            th = np.linspace(0.0, np.pi, _NORMAL_GRID[0])
            ph = np.linspace(-np.pi, np.pi, _NORMAL_GRID[1])
            TH, PH = np.meshgrid(th, ph, indexing="ij")
            nodes = np.stack([np.sin(TH) * np.sin(PH), np.cos(TH), np.sin(TH) * np.cos(PH)], -1).reshape(-1, 3)
            grid = _diffuse_irradiance(day.diffuse[idx], dirs, dw, nodes).reshape(TH.shape + (len(idx),))
        self.t = {dt: dict(beam=day.beam[idx].astype(dt), k_beam=day.k_beam[idx].astype(dt),
                           k_diffuse=self.k.astype(dt), c=self.c.astype(dt), e_dif=e_dif.astype(dt),
                           e_grid=None if grid is None else grid.astype(dt))
                  for dt in (_F32, _F64)}
        self.day32 = dataclasses.replace(day, diffuse=day.diffuse.astype(np.float32))

    def irradiance(self, h: _Hits, dt, rho: np.ndarray | None = None) -> np.ndarray:
        """Daylight irradiance (N, B) on surface samples (facing the camera).

        Sun beam × cos × the beam's height factor × caustics, plus the diffuse field integrated over the
        hemisphere about the normal × its height factor.  With ``shadows`` (as the renderer's shadow ray and
        its cosine-sampled diffuse rays): the sun beam is zero where a target stops it, and the diffuse
        field loses what targets hide (:meth:`_hidden_diffuse`; ``rho`` (objects + 1, B) are the
        targets' reflectances, for the light the hiding targets reflect in its place).
        """
        t = self.t[dt]
        dy = (h.p[..., 1] - self.day.y0).astype(dt)[..., None]
        e_sun = self._sun(h.p, h.nrm, h.oid, dt)
        e_dif = self._diffuse_about(h.oid, h.side, h.nrm, dt)
        out = e_sun + e_dif * height_factor(t["k_diffuse"], dy, np.exp)
        if self.shadows and len(h) and rho is not None:  # (≥ 0: the estimate is noisy where all is hidden)
            out = np.maximum(out - self._hidden_diffuse(h, rho).astype(dt), 0.0)
        return out

    def _sun(self, p: np.ndarray, nrm: np.ndarray, oid: np.ndarray, dt) -> np.ndarray:
        """(N, B) the sun beam's irradiance at points ``p`` of normals ``nrm`` on objects ``oid`` (with
        ``shadows``: zero where a target stops it on the way — the renderer's shadow ray)."""
        t = self.t[dt]
        cos_sun = np.clip(-(nrm @ self.sun), 0.0, None)
        if self.shadows and len(p):
            lit = np.flatnonzero(cos_sun > 0)
            if lit.size:
                q = p[lit] + 1e-7 * nrm[lit]
                far = q - _SUN_RAY_M * self.sun
                cos_sun[lit] = np.where(occluded(self.surf, q, far, exclude=oid[lit]), 0.0, cos_sun[lit])
        dy = (p[..., 1] - self.day.y0).astype(dt)[..., None]
        return (cos_sun * self.day.caustic(p)).astype(dt)[..., None] * t["beam"] \
            * height_factor(t["k_beam"], dy, np.exp)

    def _diffuse_about(self, oid: np.ndarray, side: np.ndarray, nrm: np.ndarray, dt) -> np.ndarray:
        """(N, B) the diffuse field's irradiance at the field's height on surfaces of normals ``nrm``
        (objects ``oid``, ``side`` 1 where ``nrm`` is the flat piece's normal reversed), unoccluded."""
        t = self.t[dt]
        e_dif = t["e_dif"][2 * (oid - 1) + side]
        if t["e_grid"] is not None:
            m = self.is_mesh[oid]
            if np.any(m):
                e_dif[m] = _on_normal_grid(t["e_grid"], nrm[m])
        return e_dif

    def _hidden_diffuse(self, h: _Hits, rho: np.ndarray) -> np.ndarray:
        """(N, B) float64: the diffuse daylight that targets hide from each sample, less the light they
        reflect towards it in its place — the renderer's rule for a cosine-sampled direction that meets
        an object at ``s``: the field's path radiance up to it plus ``e^{−c s}`` × the object's radiance.

        The field beyond the object, ``L_amb(v) e^{K Δy} e^{−(c − K v_y) s}`` (what Duntley's path
        radiance :func:`~rigsim.scene.daylight_field.path_radiance` leaves out at length ``s``), is hidden;
        the object's radiance is its reflectance / π × the daylight on it (the sun if it reaches it, and the
        diffuse field about its normal, itself unoccluded: one bounce).  Estimated with
        :data:`_HIDDEN_SKY_RAYS` cosine-weighted directions per sample (stratified, rotated by a hash of the
        sample's position: deterministic, the same in every tiling), ``E = π/n Σ L``; exact (zero) where
        nothing is in the way.
        """
        p, nrm, n = h.p, h.nrm, _HIDDEN_SKY_RAYS
        N, B = len(p), len(self.c)
        out = np.zeros((N, B))
        if not N:
            return out
        g = int(round(np.sqrt(n)))
        jit = _hash2(p)  # (N, 2) in [0, 1)
        i, j = np.divmod(np.arange(g * g), g)
        x1 = ((i[None, :] + jit[:, :1]) / g) % 1.0
        x2 = ((j[None, :] + jit[:, 1:]) / g) % 1.0
        r, phi = np.sqrt(x1), 2 * np.pi * x2
        local = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(np.clip(1.0 - x1, 0.0, None))], -1)
        d = _cosine_about(np.repeat(nrm, g * g, axis=0), local.reshape(-1, 3)).reshape(local.shape)
        o = p + (1e-7 * (1.0 + np.abs(p).max(axis=1)))[:, None] * nrm
        s, oid, nq = cast_rays(self.surf, np.broadcast_to(o[:, None], d.shape), d, normals=True, precise=False)
        hit = np.isfinite(s) & (oid > 0)
        if not hit.any():
            return out
        k, _ = np.nonzero(hit)
        dd, s, oid, nq = d[hit], s[hit], oid[hit], nq[hit]
        back = np.sum(nq * dd, axis=-1) > 0  # the normal it meets, turned towards the sample
        nq = np.where(back[:, None], -nq, nq)
        side = back.astype(np.int64)  # (for a flat piece: its own normal reversed)
        q = p[k] + s[:, None] * dd
        dy = (p[k, 1] - self.day.y0)[:, None]
        beyond = self.day.radiance(dd, self.wl) * np.exp(self.k * dy - (self.c - self.k * dd[:, 1:2]) * s[:, None])
        e_q = self._sun(q, nq, oid, _F64) + self._diffuse_about(oid, side, nq, _F64) \
            * height_factor(self.k, (q[:, 1] - self.day.y0)[:, None], np.exp)
        own = rho[oid] / np.pi * e_q * np.exp(-self.c * s[:, None])
        first = np.flatnonzero(np.r_[True, k[1:] != k[:-1]])  # (k ascends: np.nonzero's order)
        out[k[first]] = np.add.reduceat(beyond - own, first, axis=0)
        return out * (np.pi / (g * g))

    def path_radiance(self, o_y: np.ndarray, d: np.ndarray, t_hit: np.ndarray) -> np.ndarray:
        """Duntley's path radiance along each pixel ray (…, B) float32, as the renderer's.

        Float32, except on lines of sight whose optical depth may be below F32_PATH_MIN in some band
        (``1 − e^{−x}`` would lose its relative precision): float64 there.
        """
        t = np.where(np.isfinite(t_hit), t_hit, np.inf)[..., None]
        vy, dy = d[..., 1:2], (o_y - self.day.y0)[..., None]
        f = self.t[_F32]
        look = self.day32.radiance(d, self.wl)
        dy32 = dy.astype(np.float32)
        # a line of sight that meets nothing sees all of the field at its origin's height (Duntley's law
        # at t = ∞, exactly); the others in full
        out = look * height_factor(f["k_diffuse"], dy32, np.exp)
        hit = np.isfinite(t[..., 0])
        if np.any(hit):
            out[hit] = path_radiance(look[hit], f["c"], f["k_diffuse"], vy[hit].astype(np.float32), dy32[hit],
                                     t[hit].astype(np.float32), np.exp)
        # a lower bound of min over bands of (c − K v_y) t
        x_lo = t[..., 0] * (self.c.min() - np.maximum(self.k.max() * vy[..., 0], self.k.min() * vy[..., 0]))
        short = x_lo < F32_PATH_MIN
        if np.any(short):
            with np.errstate(over="ignore"):
                out[short] = path_radiance(self.day.radiance(d[short], self.wl), self.c, self.k, vy[short],
                                           dy[short], t[short], np.exp)
        return self.bands(out)

    def bands(self, x: np.ndarray) -> np.ndarray:
        """(…, M) on the sub-bands → (…, B) band means (the input itself with one sub-band per band)."""
        if len(self.wl) == self.n_bands:
            return x
        return (x @ self.to_bands.astype(x.dtype)).astype(x.dtype, copy=False)

    def reflected(self, h: _Hits, dt, s: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
        """The daylight surface samples ``h`` reflect (the targets' own reflectances at the sub-bands,
        Lambertian): (N, B) at the surface, and (N, B) after ``s`` (N, 1) m of water, ``e^{−c s}`` (None
        without ``s``) — each the band mean of the sub-bands' products (the field, the reflectance and the
        water's transmission change together with wavelength deep in the red: the product of band means is
        not the band mean)."""
        rho_m = self.rho_sub
        lit = (rho_m[h.oid] / np.pi).astype(dt) * self.irradiance(h, dt, rho_m)
        seen = None if s is None else self.bands(lit * np.exp(-self.t[dt]["c"] * s.astype(dt)))
        return self.bands(lit), seen
