"""``render(scene) → SpectralImage`` with Mitsuba 3 (volumetric path tracing).

How a render works
------------------
Camera rays come from the scene's optics (pinhole + dome/flat port,
:func:`rigsim.scene.optics.camera_rays`, numpy float64) for film positions jittered
uniformly inside each pixel by the path's sampler (box filter: the pixel value is the
pixel-averaged radiance), and are handed to the kernel as float32 arrays.  Each path carries
four wavelengths (Mitsuba's spectral variants): the first is drawn stratified over
the pixel's samples from the union of the bands (each band with probability 1/B,
uniform inside it), the other three are rotated by 1/4, 2/4, 3/4 of that range.
The integrator (``rigsim_vol`` by default, or Mitsuba's ``volpath``) returns the radiance at those four wavelengths and
each value is added to the band it fell in; the band average is
``Σ L · B / (4 · spp)`` — an unbiased estimate of the radiance averaged over the
band, W·m⁻²·sr⁻¹·nm⁻¹.  Sums are accumulated in float64 with numpy (deterministic:
the same seed gives the same image bit for bit).

Lights are linear, so continuous lights (→ ``radiance``) and strobes (→ ``flash``,
J·m⁻²·sr⁻¹·nm⁻¹ per flash) are separate passes, as are the ground-truth layers
``clear`` (no water), ``direct`` (albedo 0) and ``backscatter`` (black targets);
see :mod:`rigsim.render.mitsuba_scene`.  ``range_m`` and ``object_id`` come from one
ray through each pixel centre.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import time
import warnings
from collections.abc import Callable, Sequence

import numpy as np

from rigsim.errors import ConfigError, RigsimError
from rigsim.render.mitsuba_scene import MitsubaScene, build_mitsuba_scene, forget_scenes_except
from rigsim.render.variant import is_jit, mitsuba, variant
from rigsim.scene.imaging import IMAGE_LAYERS, check_int, check_scene_for_bands, image_request
from rigsim.scene.optics import camera_rays, fov_water_deg, outside_index, world_radius_m
from rigsim.scene.particles import particle_id_image, scene_particles
from rigsim.scene.types import Scene
from rigsim.spectral_image import RenderInfo, SpectralImage
from rigsim.spectrum import COLOUR_GROUPS_NM, DEFAULT_WAVELENGTHS_NM, band_edges, colour_groups

__all__ = ["MAX_LANES", "NOISE_GROUPS_NM", "RENDER_LAYERS", "band_edges", "noise_groups", "render", "render_pass",
           "relative_noise_p99"]

mi, dr = mitsuba()

#: Ground-truth layers ``render`` can make (``direct``/``backscatter`` also via ``split=True``).
RENDER_LAYERS = IMAGE_LAYERS
#: Most paths traced in one kernel launch (memory bound).
MAX_LANES = 1 << 21

ProgressCallback = Callable[[float, str], None]


def _chunk_seed(seed: int, pass_index: int, chunk: int) -> int:
    h = hashlib.blake2b(f"{seed}:{pass_index}:{chunk}".encode(), digest_size=4).digest()
    return int.from_bytes(h, "little")


def _aligned_float(a: np.ndarray):
    """A Dr.Jit Float of ``a`` (float32) from a 64-byte aligned buffer.

    Dr.Jit takes numpy memory as it is and writes the buffer's alignment into the kernel (``align 32``
    or ``align 1`` loads), so buffers of varying alignment made every render trace a "new" kernel and
    compile it again (40 s for the strobe integrator): aligned buffers keep one kernel per scene class.
    """
    a = np.asarray(a, np.float32).ravel()
    buf = np.empty(a.size + 16, np.float32)
    off = (-buf.ctypes.data % 64) // 4
    out = buf[off:off + a.size]
    out[:] = a
    return mi.Float(out)


def _rays(camera, px, py, n_outside: float, aperture=None):
    """Mitsuba rays for film positions (Dr.Jit arrays) from the scene's optics (numpy); through the
    thin lens's aperture points ``aperture = (u, v)`` (Dr.Jit arrays) if given."""
    dr.eval(px, py)
    ap = None
    if aperture is not None:
        dr.eval(*aperture)
        ap = tuple(np.asarray(a, np.float64) for a in aperture)
    o, d = camera_rays(camera, np.asarray(px, np.float64), np.asarray(py, np.float64), n_outside=n_outside,
                       aperture=ap)
    return (mi.Point3f(*(_aligned_float(o[:, k]) for k in range(3))),
            mi.Vector3f(*(_aligned_float(d[:, k]) for k in range(3))))


def render_pass(ms: MitsubaScene, camera, *, width: int, height: int, spp: int, seed: int,
                band_lo: np.ndarray, band_w: np.ndarray, pass_index: int = 0,
                tick: Callable[[], None] | None = None,
                aov_out: dict | None = None) -> tuple[np.ndarray, int]:
    """Band-averaged radiance (height, width, bands) of one loaded Mitsuba scene.

    Parameters
    ----------
    ms
        The scene (``ms.medium`` is the medium the camera sits in, or None).
    camera
        The :class:`~rigsim.scene.types.Camera` whose rays are traced.
    band_lo, band_w
        Lower band edges and widths (nm).
    aov_out
        If given, the band-averaged image of each group of four AOVs the integrator returns
        (``backscatter.j``, ``class_a.j``) is stored in ``aov_out["backscatter"]``, ``aov_out["class_a"]``
        (same layout as the image).

    Returns
    -------
    (image, dropped)
        float64 image and the number of non-finite path values that were dropped.
    """
    B = len(band_lo)
    n_pix = width * height
    acc = np.zeros(n_pix * B, np.float64)
    integrator = ms.scene.integrator()
    aov_groups = list(dict.fromkeys(n.split(".")[0] for n in integrator.aov_names())) if aov_out is not None else []
    acc_aov = {g: np.zeros(n_pix * B, np.float64) for g in aov_groups}
    lo_arr = mi.Float(band_lo.astype(np.float32))
    w_arr = mi.Float(band_w.astype(np.float32))
    dropped = 0
    # With 4·spp ≥ B every band of every pixel gets a fixed number of wavelength draws
    # (n_b = ⌈(b+1)·4spp/B⌉ − ⌈b·4spp/B⌉), uniform and stratified inside the band: the band
    # value is their plain mean (no noise from how many draws a band happened to get).
    # Otherwise bands are drawn at random (probability 1/B) and the sum is scaled by B/4spp.
    fixed_counts = 4 * spp >= B
    # sizes enter the kernels as opaque values: one compiled kernel serves every size
    spp4_o, B_o, spp_o, W_o = (dr.opaque(mi.UInt32, v) for v in (4 * spp, B, spp, width))
    for chunk, (row0, rows, s0, sc) in enumerate(_chunks(width, height, spp)):
        n = rows * width * sc
        sampler = mi.load_dict({"type": "independent"})
        sampler.seed(_chunk_seed(seed, pass_index, chunk), n)
        idx = dr.arange(mi.UInt32, n)
        sc_o, s0_o, row0_o = (dr.opaque(mi.UInt32, v) for v in (sc, s0, row0))
        pix = idx // sc_o
        s_int = idx % sc_o + s0_o
        s = mi.Float(s_int)
        row = mi.Float(pix // W_o + row0_o)
        col = mi.Float(pix % W_o)
        jit = sampler.next_2d()
        # depth of field (a camera with a focus distance): an aperture point per path
        ap = sampler.next_2d() if camera.focus_distance_m is not None else None
        o, d = _rays(camera, (col + jit.x) / width, (row + jit.y) / height, ms.n_outside,
                     aperture=None if ap is None else (ap.x, ap.y))
        ray = mi.RayDifferential3f(o, d)
        lams, bands = [], []
        for j in range(4):
            xi = sampler.next_1d()
            if fixed_counts:
                # draw i = j·spp + s → band ⌊i B / 4spp⌋; stratified inside the band
                i = spp_o * j + s_int
                b = (i * B_o) // spp4_o
                start = (b * spp4_o + (B_o - 1)) // B_o
                stop = ((b + 1) * spp4_o + (B_o - 1)) // B_o
                frac = (mi.Float(i - start) + xi) / mi.Float(stop - start)
            else:
                uj = (s + xi) / mi.Float(spp_o) + 0.25 * j
                uj = dr.select(uj >= 1.0, uj - 1.0, uj)
                fb = uj * mi.Float(B_o)
                b = dr.minimum(mi.UInt32(dr.floor(fb)), B_o - 1)
                frac = fb - mi.Float(b)
            lam = dr.gather(mi.Float, lo_arr, b) + dr.clip(frac, 0.0, 1.0) * dr.gather(mi.Float, w_arr, b)
            lams.append(lam)
            bands.append(b)
        ray.wavelengths = mi.Spectrum(*lams)
        L, _, aovs = integrator.sample(ms.scene, sampler, ray, ms.medium, mi.Bool(True))
        want_b = bool(aov_groups) and len(aovs) == 4 * len(aov_groups)
        bands_arr = mi.Vector4u(*bands) if hasattr(mi, "Vector4u") else bands
        dr.eval(L, bands_arr, *(aovs if want_b else ()))
        Ln = np.asarray(L, np.float64).reshape(4, n)
        Bn = np.stack([np.asarray(b, np.int64) for b in bands])
        bad = ~np.isfinite(Ln)
        if bad.any():
            dropped += int(bad.sum())
            Ln[bad] = 0.0
        pix_g = np.arange(n, dtype=np.int64) // sc + row0 * width
        bins = (pix_g[None, :] * B + Bn).ravel()
        acc += np.bincount(bins, weights=Ln.ravel(), minlength=n_pix * B)
        if want_b:
            for gi, g in enumerate(aov_groups):
                Lb = np.stack([np.asarray(a, np.float64) for a in aovs[4 * gi:4 * gi + 4]])
                Lb[bad | ~np.isfinite(Lb)] = 0.0  # a dropped path is dropped from every layer
                acc_aov[g] += np.bincount(bins, weights=Lb.ravel(), minlength=n_pix * B)
        if tick is not None:
            tick()
    if fixed_counts:
        edges = (np.arange(B + 1) * (4 * spp) + (B - 1)) // B
        scale = 1.0 / np.diff(edges)
    else:
        scale = B / (4.0 * spp)
    img = acc.reshape(height, width, B) * scale
    if aov_out is not None:
        for g, a in acc_aov.items():
            aov_out[g] = a.reshape(height, width, B) * scale
    return img, dropped


#: Spectral groups the noise target looks at separately (nm, [lo, hi); :data:`rigsim.spectrum.COLOUR_GROUPS_NM`): roughly the blue, green
#: and red channels of a camera.  A bright path sample lands in its four wavelengths' bands, so
#: its speckle is coloured; averaged over all bands it would look 1.2–1.4× smaller (measured on
#: the demo's edge-lit turbid scenes) than in the channel it shows up in.
NOISE_GROUPS_NM = tuple(COLOUR_GROUPS_NM.values())


def noise_groups(wavelength_nm) -> list[np.ndarray]:
    """Band indices of each of :data:`NOISE_GROUPS_NM` (empty groups left out)."""
    return list(colour_groups(wavelength_nm).values())


def relative_noise_p99(batches: Sequence[np.ndarray], window: int = 9, groups=None) -> float:
    """Monte Carlo noise of the mean of independent equal-size renders, as one number.

    Per pixel: the standard error of the band-averaged radiance's mean over the batches
    (their standard deviation / √n) divided by the local mean (``window``² pixels, floored at
    1e-3 × the image mean so that black regions do not count); returned: its 99th percentile
    over pixels.  0.1 means that 99 % of the pixels are within ~10 % (one standard error) of
    their converged value, relative to their surroundings.  ``groups`` (sequences of band
    indices, e.g. :func:`noise_groups`): the same for each group's band average, returning the
    largest (colour noise); None: all bands together.
    """
    from scipy.ndimage import uniform_filter

    arrs = [np.asarray(b, np.float64) for b in batches]
    n = len(arrs)
    if n < 2:
        raise ValueError("relative_noise_p99 needs at least two batches")
    worst = 0.0
    for g in ([slice(None)] if groups is None else groups):
        x = np.stack([a[..., g].mean(axis=-1) for a in arrs])
        m = x.mean(0)
        se = x.std(0, ddof=1) / np.sqrt(n)
        local = np.maximum(uniform_filter(m, window, mode="nearest"), 1e-3 * max(float(m.mean()), 1e-300))
        worst = max(worst, float(np.percentile(se / local, 99)))
    return worst


def _chunks(width: int, height: int, spp: int):
    """(row0, rows, sample0, samples) blocks of at most MAX_LANES paths."""
    per_row = width
    if per_row * height * spp <= MAX_LANES:
        yield 0, height, 0, spp
        return
    sc = max(1, min(spp, MAX_LANES // (per_row * height)))
    if sc >= 1 and per_row * height * sc <= MAX_LANES:
        for s0 in range(0, spp, sc):
            yield 0, height, s0, min(sc, spp - s0)
        return
    rows = max(1, MAX_LANES // per_row)
    for s0 in range(spp):
        for r0 in range(0, height, rows):
            yield r0, min(rows, height - r0), s0, 1


def _n_chunks(width: int, height: int, spp: int) -> int:
    return sum(1 for _ in _chunks(width, height, spp))


def _geometry_layers(ms: MitsubaScene, scene: Scene, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """range_m and object_id from one ray through each pixel centre."""
    n = width * height
    idx = dr.arange(mi.UInt32, n)
    row = mi.Float(idx // width) + 0.5
    col = mi.Float(idx % width) + 0.5
    o, d = _rays(scene.camera, col / width, row / height, ms.n_outside)
    si = ms.scene.ray_intersect(mi.Ray3f(o, d))
    oid = dr.zeros(mi.Int32, n)
    for sh in ms.scene.shapes():
        k = ms.shape_ids.get(sh.id())
        if k is not None:
            oid = dr.select(si.is_valid() & (si.shape == mi.ShapePtr(sh)), mi.Int32(k), oid)
    pupil = mi.Point3f(*[float(x) for x in scene.camera.position_m])
    rng = dr.select(oid > 0, dr.norm(si.p - pupil), dr.inf)
    dr.eval(oid, rng)
    return (np.asarray(rng, np.float64).reshape(height, width).astype(np.float32),
            np.asarray(oid, np.int32).reshape(height, width))


def render(scene: Scene, *, width: int = 320, height: int = 240, spp: int = 64, seed: int = 0,
           wavelengths_nm: Sequence[float] = DEFAULT_WAVELENGTHS_NM, bandwidth_nm=None,
           layers: Sequence[str] = ("range_m", "clear", "object_id"), split: bool = False,
           max_depth: int = -1, progress: ProgressCallback | None = None,
           integrator: str = "rigsim", noise_target: float | None = None,
           max_spp: int | None = None) -> SpectralImage:
    """Render a :class:`~rigsim.scene.types.Scene` to a :class:`~rigsim.spectral_image.SpectralImage`.

    Parameters
    ----------
    scene
        Camera, lights, targets and water (``water=None``: no water).
    width, height
        Image size (pixels); the field of view is the sensor's (keep its aspect).
    spp
        Paths per pixel (each carries four wavelengths).
    seed
        Random seed; the same inputs and seed give the same image.
    wavelengths_nm, bandwidth_nm
        Band centres (nm) and widths (default: the grid spacing); each band holds
        the radiance averaged over it.
    layers
        Ground-truth layers from :data:`RENDER_LAYERS`.
    split
        Also render ``direct`` and ``backscatter``.
    max_depth
        Longest path (−1: unlimited, Russian roulette ends paths).
    progress
        Called as ``progress(fraction_done, message)`` after each kernel launch.
    integrator
        ``"rigsim"`` (default: equiangular sampling toward the lights with MIS, far less noise
        in strobe-lit water; :mod:`rigsim.render.integrators`) or ``"volpath"`` (Mitsuba's own).
    noise_target
        Render the ``full`` passes in batches of ``spp`` until the Monte Carlo noise is below
        this: the 99th percentile over pixels of the standard error of the pixel's mean
        (averaged over the bands of each colour group, :data:`NOISE_GROUPS_NM`, from the scatter
        between batches) divided by the local mean radiance (9×9 pixels), in the noisiest group
        — see :func:`relative_noise_p99`.  None: one batch.  Noise that hides in
        a few pixels (the speckle of strobe-lit water) is what this catches.  The stopping rule
        looks at the image's own noise, so the estimate is very slightly biased (an image whose
        batches happen to agree stops earlier); it uses an image-wide percentile, not single
        pixels.
    max_spp
        Most paths per pixel a ``noise_target`` may use (default 8 × ``spp``).

    Returns
    -------
    SpectralImage
        ``radiance`` in W·m⁻²·sr⁻¹·nm⁻¹ from continuous lights and ambient daylight
        (``scene.daylight``: the field at the rig's depth, :mod:`rigsim.render.daylight`;
        zeros if there is neither); strobes go to ``flash`` (J·m⁻²·sr⁻¹·nm⁻¹ per flash) and
        ``flash_clear``/``flash_direct``/``flash_backscatter``.
    """
    t_start = time.perf_counter()
    if noise_target is not None and not (isinstance(noise_target, (int, float)) and 0 < noise_target < 10):
        raise ConfigError(f"noise_target must be a number in (0, 10), got {noise_target!r}", field="noise_target",
                          allowed="e.g. 0.2 (20 % of the local mean at the 99th percentile of pixels)")
    req = image_request(width=width, height=height, wavelengths_nm=wavelengths_nm, bandwidth_nm=bandwidth_nm,
                        layers=layers, split=split)
    width, height, layers = req.width, req.height, req.layers
    spp = check_int("spp", spp, 1, 1 << 20)
    seed = check_int("seed", seed, 0, 2**32 - 1)
    max_spp = check_int("max_spp", 8 * spp if max_spp is None else max_spp, spp, 1 << 24)
    wl, bw = req.wavelength_nm, req.bandwidth_nm
    lo_edges = wl - bw / 2
    check_scene_for_bands(scene, req)
    if not is_jit():
        raise RigsimError(f"rendering needs a vectorised Mitsuba variant (llvm_ad_spectral or cuda_ad_spectral); "
                          f"only {variant()} is available — install libLLVM (e.g. `apt install libllvm19`)")
    forget_scenes_except(scene)  # before any Mitsuba object of this render is made (see there)
    ambient = None
    if scene.daylight is not None:
        from rigsim.render.daylight import ambient_tables

        if integrator != "rigsim":
            raise ConfigError("daylight is rendered by the rigsim integrator only", field="integrator",
                              allowed="rigsim")
        ambient = ambient_tables(scene, req.band_lo_nm, req.band_hi_nm)  # the scene's own field

    groups = {"continuous": [l for l in scene.lights if l.kind == "continuous"],
              "strobe": [l for l in scene.lights if l.kind == "strobe"]}
    water = scene.water is not None
    modes = ["full"]
    if water:
        modes += [m for m in ("clear", "direct", "backscatter") if m in layers]
    # daylight is continuous light: it lights the continuous pass (never the flash pass)
    has = {"continuous": bool(groups["continuous"]) or ambient is not None, "strobe": bool(groups["strobe"])}
    # the rigsim integrator estimates the backscatter layer from the full pass's own paths
    # (their light before they first meet a surface): no separate pass with black targets
    bs_from_full = integrator == "rigsim" and "backscatter" in modes
    if bs_from_full:
        modes.remove("backscatter")
    passes = [(g, m) for g in ("continuous", "strobe") if has[g] for m in modes]
    per_pass = _n_chunks(width, height, spp)
    total = max(1, len(passes) * per_pass)
    done = [0]

    def tick(msg: str):
        def _t():
            done[0] += 1
            if progress is not None:
                progress(min(done[0] / total, 1.0), msg)
        return _t

    results: dict[tuple[str, str], np.ndarray] = {}
    spp_used: dict[str, int] = {}
    noise: dict[str, float] = {}
    dropped = 0
    geom_scene: MitsubaScene | None = None
    for pi, (g, m) in enumerate(passes):
        with_bs = bs_from_full and m == "full"
        ms = build_mitsuba_scene(scene, lights=groups[g], mode=m, max_depth=max_depth, integrator=integrator,
                                 ambient=ambient if g == "continuous" else None, backscatter_aov=with_bs)
        if geom_scene is None:
            geom_scene = ms
        imgs, bss = [], []
        key = f"{g}:{m}"
        while True:
            aov: dict = {}
            # batch 0 keeps the seeds of a plain render; later batches get their own
            img, nd = render_pass(ms, scene.camera, width=width, height=height, spp=spp, seed=seed,
                                  pass_index=pi + 4096 * len(imgs), band_lo=lo_edges, band_w=bw,
                                  tick=tick(f"{g} {m}"), aov_out=aov if with_bs else None)
            imgs.append(img)
            if with_bs:
                bss.append(aov["backscatter"])
            dropped += nd
            if noise_target is None or m != "full":
                break
            if len(imgs) >= 2:
                noise[key] = relative_noise_p99(imgs, groups=noise_groups(wl))
                if noise[key] <= noise_target:
                    break
            if (len(imgs) + 1) * spp > max_spp:
                break
            total += per_pass  # progress: one more batch
        spp_used[key] = spp * len(imgs)
        results[(g, m)] = np.mean(imgs, axis=0).astype(np.float32)
        if with_bs:
            results[(g, "backscatter")] = np.mean(bss, axis=0).astype(np.float32)
    # the particles' layer: the full passes again without the particles, with the same random numbers
    # (a path that meets no particle is the same path in both: the difference holds only the particles'
    # light and the light they hide)
    ps = scene_particles(scene) if water else None
    want_particles = "particles" in layers and ps is not None and len(ps) > 0
    if want_particles:
        for pi, (g, m) in enumerate(passes):
            if m != "full":
                continue
            ms = build_mitsuba_scene(scene, lights=groups[g], mode="full", max_depth=max_depth, integrator=integrator,
                                     ambient=ambient if g == "continuous" else None, particles=False)
            n_b = spp_used[f"{g}:full"] // spp
            imgs = [render_pass(ms, scene.camera, width=width, height=height, spp=spp, seed=seed,
                                pass_index=pi + 4096 * j, band_lo=lo_edges, band_w=bw, tick=tick(f"{g} particles"))[0]
                    for j in range(n_b)]
            results[(g, "particles")] = (results[(g, "full")] - np.mean(imgs, axis=0)).astype(np.float32)
    if dropped:
        warnings.warn(f"{dropped} non-finite path samples were dropped", RuntimeWarning, stacklevel=2)

    shape = (height, width, len(wl))
    zeros = np.zeros(shape, np.float32)
    out_layers: dict[str, np.ndarray] = {}
    radiance = results.get(("continuous", "full"), zeros)
    for g, prefix in (("continuous", ""), ("strobe", "flash_")):
        if not has[g]:
            continue
        full = results[(g, "full")]
        if g == "strobe":
            out_layers["flash"] = full
        for k in ("clear", "direct", "backscatter", "particles"):
            if k not in layers:
                continue
            if k == "particles":
                v = results.get((g, k), zeros)
            elif water:
                v = results[(g, k)]
            else:
                v = zeros if k == "backscatter" else full
            out_layers[f"{prefix}{k}"] = v
    if "range_m" in layers or "object_id" in layers:
        if geom_scene is None or geom_scene.has_particles:  # the targets only (particles: their own layers)
            geom_scene = build_mitsuba_scene(scene, lights=[], mode="clear", integrator=integrator)
        rng, oid = _geometry_layers(geom_scene, scene, width, height)
        if "range_m" in layers:
            out_layers["range_m"] = rng
        if "object_id" in layers:
            out_layers["object_id"] = oid
    if "particle_id" in layers:
        if ps is not None and len(ps):
            if "range_m" in out_layers:
                rng_t = out_layers["range_m"]
            else:
                rng_t, _ = _geometry_layers(build_mitsuba_scene(scene, lights=[], mode="clear", integrator=integrator),
                                            scene, width, height)
            out_layers["particle_id"] = particle_id_image(scene, ps, width, height, rng_t)
        else:
            out_layers["particle_id"] = np.zeros((height, width), np.int32)
    legend = {str(i + 1): s.label for i, s in enumerate(geom_scene.surfaces)} if geom_scene else {}

    meta = {
        "renderer": f"rigsim.render (Mitsuba 3, integrator {integrator})",
        "integrator": integrator,
        "mitsuba_version": mi.__version__,
        "variant": variant(),
        "wavelength_nm": wl.tolist(),
        "bandwidth_nm": bw.tolist(),
        "width": width, "height": height, "spp": max(spp_used.values(), default=spp), "seed": seed,
        "max_depth": max_depth, "spp_per_pass": spp_used,
        "noise_target": noise_target, "noise_p99": noise or None,
        "layers": list(out_layers),
        "passes": [f"{g}:{m}" for g, m in passes],
        "backscatter_estimate": ("the full pass's paths, their light before they first meet a surface"
                                 if bs_from_full else ("a pass with black targets" if water and "backscatter"
                                                       in layers else None)),
        "water": scene.water.describe() if water else None,
        "camera": dataclasses.asdict(scene.camera),
        "fov_water_x_deg": fov_water_deg(scene.camera, outside_index(scene)),
        "lights": [l.describe() for l in scene.lights],
        "targets": [dataclasses.asdict(t) for t in scene.targets],
        "object_ids": legend,
        "world_radius_m": world_radius_m(scene),
        "radiance_reference": "in-water radiance arriving at the port, band-averaged (no port "
                              "transmission or n^2 factor)",
        "dropped_samples": dropped,
        "daylight_rendered": True if scene.daylight is not None else None,
        "particles": ps.describe() if ps is not None else None,
        "daylight": ({**dataclasses.asdict(scene.daylight), "field": ambient.meta}
                     if ambient is not None else None),
    }
    meta["scene_hash"] = hashlib.sha256(json.dumps(
        {k: meta[k] for k in ("water", "camera", "lights", "targets")
         + (("daylight",) if scene.daylight is not None else ())}, sort_keys=True,
        default=str).encode()).hexdigest()[:16]
    meta["wall_time_s"] = time.perf_counter() - t_start
    return SpectralImage(radiance=radiance, wavelength_nm=wl, bandwidth_nm=bw, layers=out_layers, meta=meta,
                         scene=scene, render=RenderInfo("mitsuba", seed=seed, spp=meta["spp"], integrator=integrator))
