"""One case of a study: build the scene, render it once, capture it with every sensor, measure.

The metrics are those of :func:`rigsim.metrics.scene.scene_metrics` (see its module for
their definitions); the study adds the inputs and exposure of each row.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from rigsim.fileio import png_bytes
from rigsim.scene.meshes import MESH_SUFFIXES
from rigsim.study.spec import Case, StudySpec, sensor_key

log = logging.getLogger(__name__)

__all__ = ["compute_case", "compute_check", "fast_check_images", "case_scene", "case_engine", "STUDY_LAYERS"]


def case_scene(spec: StudySpec, case: Case):
    """The scene of a case: ``(scene, water, target_kind)`` (a mesh file's kind is ``"mesh"``)."""
    from rigsim.config.rig import load_rig
    from rigsim.config.water import load_water
    from rigsim.scene.build import build_scene

    rig = load_rig(case.rig)
    water = load_water(case.water)
    target_kind = case.target if not case.target.lower().endswith(MESH_SUFFIXES) else "mesh"
    size_m = None
    if case.target_fill is not None:
        from rigsim.scene.optics import field_width_m

        size_m = case.target_fill * field_width_m(rig.camera, case.distance_m)
    daylight = None
    if case.depth_m is not None:  # ambient daylight at depth: sun at 30°, Kd field (rigsim.render.daylight)
        from rigsim.scene.daylight_field import daylight_from_options

        daylight = daylight_from_options(case.depth_m, sun_zenith_deg=30.0, model="kd")
    return build_scene(rig, water, case.target, case.distance_m, size_m=size_m, daylight=daylight), water, target_kind


#: the layers a study renders besides the radiance
STUDY_LAYERS = ("range_m", "object_id", "backscatter")
#: and in a water with discrete particles (marine snow)
PARTICLE_LAYERS = ("particles", "particle_id")


def study_layers(water) -> tuple[str, ...]:
    """The layers a study renders of a case in ``water``."""
    return STUDY_LAYERS + (PARTICLE_LAYERS if getattr(water, "particles", None) is not None else ())


def case_engine(spec: StudySpec, case: Case) -> str:
    """The engine that renders a case: the study's, except distances beyond the sweep (the fast engine)."""
    return "preview" if case.extension else spec.render.engine


#: The contrast's standard error from the fast engine's photons is measured where the contrast is at most
#: this factor above the study's threshold (where it can move the visibility range — below the threshold
#: too: the last point of a sweep, however faint, is one of the two the range lies between; well above it
#: it costs ~1.5 s a case for nothing the report uses), on images this many pixels wide (the photons' noise in a
#: contrast does not depend on the image's size: a Jerlov 3C chart at 4.5 m, the same four batches at
#: 64, 96, 160 px wide gave 0.015, 0.020, 0.019).
PHOTON_NOISE_WINDOW = 8.0
PHOTON_NOISE_WIDTH = 96


def contrast_photon_noise(spec: StudySpec, scene, traced: dict, contrast, target_kind: str,
                          layers) -> float | None:
    """Standard error of a fast-engine case's ``contrast_radiance`` from the multiple-scattering photons
    (:func:`rigsim.preview.render_photon_batches`: the contrast of each batch's image, their standard
    deviation over √batches); None where nothing was traced or the contrast is far above the threshold
    (:data:`PHOTON_NOISE_WINDOW`)."""
    from rigsim.metrics.scene import scene_metrics, target_masks
    from rigsim.preview import render_photon_batches

    thr = spec.contrast_threshold
    if not traced or contrast is None or not np.isfinite(contrast) \
            or abs(contrast) > thr * PHOTON_NOISE_WINDOW:
        return None
    rs = spec.render
    w = min(PHOTON_NOISE_WIDTH, rs.width)
    h = max(1, round(w * rs.height / rs.width))
    imgs = render_photon_batches(scene, traced, traced_size=(rs.width, rs.height), width=w, height=h,
                                 wavelengths_nm=rs.wavelengths_nm, layers=layers)
    vals = []
    for im in imgs:
        m = target_masks(np.asarray(im.layers["object_id"]), im.meta.get("object_ids", {}), target_kind)
        vals.append(scene_metrics(im, target_kind, masks=m)[0].get("contrast_radiance", np.nan))
    vals = np.asarray(vals, float)
    if vals.size < 2 or not np.all(np.isfinite(vals)):
        return None
    return float(vals.std(ddof=1) / np.sqrt(vals.size))


def compute_case(spec: StudySpec, case: Case) -> dict:
    """Render one scene and capture it with every sensor of the study.

    Returns ``{"rows": [...], "files": {name: bytes}, "meta": {...}}`` (see the runner).
    """
    from rigsim.metrics.scene import scene_metrics, target_masks
    from rigsim.sensor import load_sensor
    from rigsim.sensor.optics import lens_for
    from rigsim.sensor.photograph import photograph
    from rigsim.sensor.pipeline import Exposure

    from rigsim.metrics.specks import speck_metrics, subject_mask

    scene, water, target_kind = case_scene(spec, case)
    seed = spec.case_seed(case)
    rs = spec.render
    engine = case_engine(spec, case)
    layers = study_layers(water)
    traced: dict = {}
    if engine == "preview":
        from rigsim.preview import render_preview as _render

        si = _render(scene, width=rs.width, height=rs.height, wavelengths_nm=rs.wavelengths_nm, layers=layers,
                     multiple=rs.preview_multiple, seed=seed, traced_out=traced)
    else:
        from rigsim.render import render as _render

        si = _render(scene, width=rs.width, height=rs.height, spp=rs.spp, seed=seed, integrator=rs.integrator,
                     wavelengths_nm=rs.wavelengths_nm, layers=layers,
                     noise_target=rs.noise_target, max_spp=rs.max_spp)
    masks = target_masks(np.asarray(si.layers["object_id"]), si.meta.get("object_ids", {}), target_kind)
    has_flash = "flash" in si.layers
    base = {"rig": case.rig_name, "water": case.water_name, "target": target_kind if target_kind != "mesh"
            else case.target, "distance_m": case.distance_m, "depth_m": case.depth_m,
            "c_550_per_m": float(water.c_per_m(550.0)), "b_550_per_m": float(water.b_per_m(550.0)),
            "a_550_per_m": float(water.a_per_m(550.0)),
            "width": rs.width, "height": rs.height, "spp": si.render.spp,
            "mc_noise_p99": max((si.meta.get("noise_p99") or {}).values(), default=None),
            "engine": engine, "integrator": rs.integrator if engine != "preview" else None,
            "extension": case.extension, "case_id": spec.case_id(case),
            "ms_photons": (sum(int(g.get("photons", 0)) for g in ((si.meta.get("preview") or {}).get("multiple") or {})
                                .values()) if engine == "preview" else None)}
    base.update(scene_metrics(si, target_kind, masks=masks)[0])  # sensor-independent numbers
    base["contrast_radiance_se"] = contrast_photon_noise(spec, scene, traced, base.get("contrast_radiance"),
                                                         target_kind, layers)
    pm = si.meta.get("particles")
    if pm is not None:  # marine snow: the specks the subject is seen through (rigsim.metrics.specks)
        base.update(speck_metrics(si, subject_mask(masks, target_kind)))
        base.update({"particles_level": pm["field"]["level"] or "custom", "particles_placed": pm["count"]})
    else:
        base.update({"speck_count": None, "speck_share": None, "speck_share_subject": None,
                     "particles_level": None, "particles_placed": None})
    files = {}
    rows = []
    for sname in spec.sensors:
        sensor = load_sensor(sname)
        lens = lens_for(si)
        cs = spec.capture
        exposure = "auto" if cs.exposure == "auto" else Exposure(cs.shutter_s, cs.iso, lens)
        shot = photograph(si, sensor, exposure=exposure, white_balance=cs.white_balance,
                          masks=masks, target_kind=target_kind, iso=cs.iso, percentile=cs.target_percentile,
                          target_level=cs.target_level, demosaic=cs.demosaic, seed=seed)
        cap, ex, wb = shot.capture, shot.exposure, shot.white_balance
        row = dict(base)
        skey = sensor_key(sname)
        row.update({"sensor": skey, "iso": ex.iso, "exposure_time_s": ex.exposure_time_s,
                    "f_number": lens.f_number, "flash_scale": ex.flash_scale if has_flash else None,
                    "raw_saturated_fraction": float(np.mean(cap.raw >= cap.white_level)),
                    "white_balance": wb, "target_size_m": scene.targets[0].size_m})
        row.update(scene_metrics(si, target_kind, cap=cap, sensor=sensor, exposure=ex, masks=masks,
                                 radiance_metrics=False)[0])
        rows.append(row)
        files[f"{skey}.png"] = png_bytes(cap.srgb)
        if cs.save_raw:
            files[f"{skey}.dng"] = _dng_bytes(cap)
    return {"rows": rows, "files": files, "meta": {"render_wall_time_s": si.meta.get("wall_time_s"),
                                                    "seed": seed}}


def _dng_bytes(cap) -> bytes:
    """The raw mosaic of a capture as DNG bytes (:func:`rigsim.sensor.raw_io.save_dng`)."""
    import tempfile
    from pathlib import Path

    from rigsim.sensor.raw_io import save_dng

    with tempfile.TemporaryDirectory() as d:
        return save_dng(cap, Path(d) / "raw.dng").read_bytes()


def fast_check_images(spec: StudySpec, case: Case, scene=None, water=None) -> tuple:
    """The fast engine's side of a case's check: its image at the check's size (the case's seed), the same
    image with each batch of its multiple-scattering photons, and those batches of ``fast_noise_seeds``
    further renders with other seeds (for the noise estimate alone: :class:`~rigsim.study.spec.CheckSettings`).
    Returns ``(fast, fast_batches, noise_batches)``; ``scene``, ``water``: the case's, where already built."""
    from rigsim.preview import render_photon_batches, render_preview

    if scene is None:
        scene, water, _ = case_scene(spec, case)
    ck, wl = spec.check, spec.render.wavelengths_nm
    seed = spec.case_seed(case)
    layers = study_layers(water)
    traced: dict = {}
    reuse: dict = {}  # every image below is of this scene at this size: the lights' single scattering computed once
    fast = render_preview(scene, width=ck.width, height=ck.height, wavelengths_nm=wl, layers=layers,
                          multiple=spec.render.preview_multiple, seed=seed, traced_out=traced, reuse=reuse)
    # the fast engine's own noise: the same image with each batch of its multiple-scattering photons
    fast_batches = render_photon_batches(scene, traced, traced_size=(ck.width, ck.height), width=ck.width,
                                         height=ck.height, wavelengths_nm=wl, layers=layers, reuse=reuse)
    # ... and of further renders with other seeds, for that noise estimate alone (CheckSettings.fast_noise_seeds)
    noise_batches = []
    for j in range(1, ck.fast_noise_seeds + 1 if fast_batches else 1):
        tr: dict = {}
        render_preview(scene, width=ck.width, height=ck.height, wavelengths_nm=wl, layers=layers,
                       multiple=spec.render.preview_multiple, seed=(seed + 104_729 * j) % 2**32, traced_out=tr,
                       reuse=reuse)
        noise_batches.append(render_photon_batches(scene, tr, traced_size=(ck.width, ck.height), width=ck.width,
                                                   height=ck.height, wavelengths_nm=wl, layers=layers, reuse=reuse))
    return fast, fast_batches, noise_batches


def compute_check(spec: StudySpec, case: Case, render_cache=None) -> dict:
    """The Monte Carlo check of one case: the fast engine and ``spec.check.seeds`` independent
    Monte Carlo renders at the check size (more, up to ``max_seeds``, where the first ones are too
    noisy: :class:`~rigsim.study.spec.CheckSettings`), compared region by region
    (:mod:`rigsim.metrics.agreement`), with the fast engine's own noise from the images of each batch of its
    multiple-scattering photons (:func:`rigsim.preview.render_photon_batches`).

    ``render_cache``: a folder (the study's ``mc-renders``) where each Monte Carlo render is kept as it
    finishes (:func:`cached_render_dir`), so a check that is interrupted, or run again with more renders
    (``max_seeds``, ``target_se``) or after a change to the fast engine, renders only what it lacks.  The
    renders are deterministic in their seeds; a render made by an older renderer is reused as the check
    records are (delete the folder after changing the renderer).

    Returns ``{"record": {...}, "files": {"fast.png": ..., "monte-carlo.png": ...}}``.
    """
    import time

    from rigsim.metrics.agreement import chart_beyond_visibility, compare_renders, relative_se, tolerance_for
    from rigsim.render import render

    scene, water, target_kind = case_scene(spec, case)
    ck, wl = spec.check, spec.render.wavelengths_nm
    seed = spec.case_seed(case)
    t0 = time.perf_counter()
    layers = study_layers(water)
    fast, fast_batches, noise_batches = fast_check_images(spec, case, scene, water)
    t_fast = time.perf_counter() - t0
    t0 = time.perf_counter()

    mc_layers = ("object_id", "backscatter") + tuple(k for k in layers if k.startswith("particle"))
    keep = None if render_cache is None else cached_render_dir(render_cache, spec, case)
    from rigsim.metrics.specks import has_particle_layer
    from rigsim.render.hybrid import DEFAULT_FIT_ORDER, hybrid_group

    group = hybrid_group(scene)
    hybrid = ck.reference == "hybrid" and group is not None
    # marine snow: the particles' light (a second, particle-free pass of every render: about 1.6x a render's time)
    # only in the pilot's renders, which the speck share is measured on (compare_renders); the renders the
    # pilot asks for beyond them serve the regions' means and the contrast
    particle_renders = ck.seeds * (ck.hybrid_veil_renders if hybrid else 1) if "particles" in mc_layers else 0

    def mc(i):
        f = None if keep is None else keep / f"render-{i:03d}"
        img = None if f is None else _read_render(f, (ck.height, ck.width, len(wl)))
        if img is not None and i < particle_renders and not has_particle_layer(img):
            img = None  # kept without the particles' light (by a check that wanted fewer renders with it)
        if img is None:
            want = mc_layers if i < particle_renders else tuple(k for k in mc_layers if k != "particles")
            img = render(scene, width=ck.width, height=ck.height, spp=ck.spp, seed=(seed + 7919 * i) % 2**32,
                         integrator=ck.integrator, wavelengths_nm=wl, layers=want)
            if f is not None:
                _write_render(f, img)
        return img

    fit_order = DEFAULT_FIT_ORDER if ck.hybrid_order is None else ck.hybrid_order
    veil = {"k": ck.hybrid_veil_renders, "render": {}, "pass": {}, "render_s": [], "pass_s": []}
    if hybrid:  # the regions the check judges, for the split of the pilot's noise (_veil_allocation)
        from rigsim.metrics.agreement import colour_groups, comparison_regions

        veil["masks"] = [(name, g, m, idx) for name, m in comparison_regions(
            np.asarray(fast.layers["object_id"]), fast.meta.get("object_ids", {}), target_kind).items()
            for g, idx in colour_groups(fast.wavelength_nm).items()]

    def region_means(a) -> list[float]:
        """Means of an image's (rows, cols, bands) array over each judged region and colour group."""
        return [float(a[m][:, idx].mean()) for _, _, m, idx in veil["masks"]]

    def reference(i):
        """Reference image ``i``: render ``i``; or (hybrid) the mean of renders ``i·k … i·k + k − 1`` (k
        ``hybrid_veil_renders``, or as chosen after the pilot: ``hybrid_veil_max_renders``) with its chart light
        replaced by hybrid estimate ``i`` and its veil over the chart pooled (``hybrid_veil_sigma_px``)."""
        if not hybrid:
            return mc(i)
        from rigsim.metrics.agreement import mean_image
        from rigsim.render.hybrid import HybridSettings, hybrid_image, hybrid_reflected

        k = veil["k"]
        renders = [mc(i * k + j) for j in range(k)]
        for j, r in enumerate(renders):  # each render's veil over the judged regions (the pilot's noise split)
            if i * k + j not in veil["render"]:
                veil["render"][i * k + j] = region_means(hybrid_image(
                    r, np.zeros_like(np.asarray(r.radiance, float)), group=group,
                    veil_sigma_px=ck.hybrid_veil_sigma_px).radiant_exposure(1.0))
                veil["render_s"].append(float(r.meta.get("wall_time_s", float("nan"))))
        img = mean_image(renders)
        hs = HybridSettings(photons=ck.hybrid_photons, spp=ck.hybrid_spp, order=fit_order)
        f = None if keep is None else keep / f"{hs.key()}-{i:03d}.npz"
        refl, seconds = _read_array(f, (ck.height, ck.width, len(wl)))
        if refl is None:
            t = time.perf_counter()
            refl, _ = hybrid_reflected(scene, width=ck.width, height=ck.height, wavelength_nm=wl, settings=hs,
                                       seed=(seed + 7919 * i) % 2**31)
            seconds = time.perf_counter() - t
            if f is not None:
                _write_array(f, refl, seconds=seconds)
        if i not in veil["pass"]:
            veil["pass"][i] = region_means(refl)
            veil["pass_s"].append(seconds)
        return hybrid_image(img, refl, group=group, veil_sigma_px=ck.hybrid_veil_sigma_px)

    refs = [reference(i) for i in range(ck.seeds)]
    regions, metrics = compare_renders(fast, refs, target_kind, fast_batches=fast_batches,
                                       noise_batches=noise_batches)
    pilot = None
    adapt = hybrid and (ck.hybrid_veil_max_renders or 0) > ck.hybrid_veil_renders
    if (ck.max_seeds or ck.seeds) > ck.seeds or adapt:  # two stages (CheckSettings): the pilot's noise sets the count
        # (the reference's noise alone: more renders do not change the fast engine's), over the regions that will
        # be judged: a chart the pilot puts beyond its visibility in both engines gets no more renders for its
        # patches (chart_beyond_visibility; the demo's Jerlov 3C chart at 6 m would take 24 renders for them)
        unseen = chart_beyond_visibility(target_kind, [m.record() for m in metrics], len(refs))
        keys = {(r.region, r.group) for r in regions if not (unseen and r.region.startswith("patch:"))}
        se = np.array([relative_se(r.reference, r.reference_se) for r in regions if (r.region, r.group) in keys],
                      float)
        se = se[np.isfinite(se)]
        pilot = {"seeds": ck.seeds, "se_p90": float(np.percentile(se, 90)) if se.size else float("nan")}
        n = ck.renders_for(pilot["se_p90"], hybrid=hybrid)
        changed = n > len(refs)
        if adapt:  # as many renders' veil per image as make the reference cheapest for its noise
            k, se_p90 = _veil_allocation(ck, veil, regions, keys)
            pilot.update(veil_renders=ck.hybrid_veil_renders, veil_renders_chosen=k, se_p90_predicted=se_p90)
            if k != veil["k"]:  # every image made again of k renders (the pilot's renders among them)
                veil["k"] = k
                n = ck.renders_for(se_p90, hybrid=True)
                refs, changed = [], True
        if changed:
            refs += [reference(i) for i in range(len(refs), n)]
            regions, metrics = compare_renders(fast, refs, target_kind, fast_batches=fast_batches,
                                               noise_batches=noise_batches)
    t_mc = time.perf_counter() - t0
    record = {"case_id": spec.case_id(case), "case": case.key(), "rig": case.rig_name, "water": case.water_name,
              "target": target_kind if target_kind != "mesh" else case.target, "distance_m": case.distance_m,
              "c_550_per_m": float(water.c_per_m(550.0)), "b_550_per_m": float(water.b_per_m(550.0)),
              "tolerance": tolerance_for(case.water_name), "width": ck.width, "height": ck.height,
              "spp": ck.spp, "seeds": len(refs), "pilot": pilot, "integrator": ck.integrator,
              "reference": "hybrid" if hybrid else "monte-carlo",
              "hybrid": {"photons": ck.hybrid_photons, "spp": ck.hybrid_spp,
                         "veil_renders": veil["k"], "veil_sigma_px": ck.hybrid_veil_sigma_px,
                         "order": fit_order}
              if hybrid else None,
              "fast_noise_renders": 1 + len(noise_batches) if fast_batches else 0,
              "particle_renders": sum(has_particle_layer(r) for r in refs) if particle_renders else None,
              "fast_wall_time_s": t_fast, "monte_carlo_wall_time_s": t_mc,
              "regions": [r.record() for r in regions], "metrics": [m.record() for m in metrics]}
    from rigsim.spectral_image import srgb_preview

    fast_rgb, shown = srgb_preview(fast)  # one exposure for both pictures: the fast image's
    mc_rgb, _ = srgb_preview(_mean_image(refs), scale=shown["xyz_scale"])
    return {"record": record, "files": {"fast.png": png_bytes(fast_rgb), "monte-carlo.png": png_bytes(mc_rgb)}}


def _write_array(path, a: np.ndarray, seconds: float | None = None) -> None:
    """Keep an array atomically (``.npz``, :func:`rigsim.fileio.atomic_write_npz`), with the seconds it took."""
    from rigsim.fileio import atomic_write_npz

    extra = {} if seconds is None else {"seconds": np.float64(seconds)}
    atomic_write_npz(path, {"a": np.asarray(a, np.float64), **extra})


def _veil_allocation(ck, veil: dict, regions: list, keys: set) -> tuple[int, float]:
    """Renders' veil per hybrid image for the rest of a check, from its pilot
    (:func:`rigsim.render.hybrid.veil_renders_for`), and the judged regions' relative SE (90th percentile) that
    ``ck.seeds`` images of that many would have.

    Each judged region's relative variance is split into one render's veil (over the pilot's renders) and one
    camera pass's light (over its images), each over the region's reference mean; the costs are the renders'
    and passes' times (kept ones: their recorded times; passes kept without one:
    :data:`~rigsim.render.hybrid.PASS_RENDER_COST_RATIO` renders)."""
    from rigsim.render.hybrid import PASS_RENDER_COST_RATIO, veil_renders_for

    ref = {(r.region, r.group): r.reference for r in regions}
    rv = np.array(list(veil["render"].values()), float)  # (renders, regions)
    pv = np.array(list(veil["pass"].values()), float)  # (images, regions)
    sel = [j for j, (name, g, _, _) in enumerate(veil["masks"]) if (name, g) in keys and ref.get((name, g), 0) > 0]
    k0 = ck.hybrid_veil_renders
    if len(rv) < 2 or len(pv) < 2 or not sel:
        return k0, float("nan")
    mu = np.array([ref[(veil["masks"][j][0], veil["masks"][j][1])] for j in sel])
    v = rv[:, sel].var(axis=0, ddof=1) / mu ** 2
    p = pv[:, sel].var(axis=0, ddof=1) / mu ** 2
    render_s = float(np.nanmedian(veil["render_s"])) if np.any(np.isfinite(veil["render_s"])) else 1.0
    pass_s = float(np.nanmedian(veil["pass_s"])) if np.any(np.isfinite(veil["pass_s"])) else float("nan")
    if not math.isfinite(pass_s):
        pass_s = PASS_RENDER_COST_RATIO * render_s
    k = veil_renders_for(v, p, render_s=max(render_s, 1e-3), pass_s=max(pass_s, 1e-3), k_min=k0,
                         k_max=ck.hybrid_veil_max_renders)
    se = np.sqrt((v / k + p) / ck.seeds)
    se = se[np.isfinite(se)]
    return k, float(np.percentile(se, 90)) if se.size else float("nan")


def _read_array(path, shape: tuple) -> tuple[np.ndarray | None, float]:
    """A kept array of ``shape`` and the seconds it took (NaN where not kept), or ``(None, nan)`` (none,
    unreadable, another shape: made again)."""
    if path is None or not path.is_file():
        return None, float("nan")
    try:
        with np.load(path) as z:
            a = z["a"]
            seconds = float(z["seconds"]) if "seconds" in z.files else float("nan")
    except (OSError, ValueError, KeyError) as exc:
        log.warning("%s: %s; making it again", path, exc)
        return None, float("nan")
    return (a, seconds) if a.shape == tuple(shape) and np.all(np.isfinite(a)) else (None, float("nan"))


def cached_render_dir(root, spec: StudySpec, case: Case):
    """The folder of a check's kept Monte Carlo renders below ``root``: one per scene (the case's inputs, its
    files by their contents — the same in any checkout: :meth:`StudySpec.content_key`), seed, bands and
    setting of a render (size, paths per pixel, integrator and its default sampling options:
    :func:`rigsim.render.integrators.integrator_key`); not per ``seeds`` / ``max_seeds`` /
    ``target_se``, which only say how many, nor per setting of the fast engine (a change to it is checked
    against the same renders)."""
    import hashlib
    import json
    from pathlib import Path

    from rigsim.render.integrators import integrator_key

    ck = spec.check
    key = {"case": spec.content_key(case), "seed": spec.seed, "wavelengths_nm": [float(x) for x in spec.render.wavelengths_nm],
           "render": [ck.width, ck.height, ck.spp, ck.integrator], "sampler": integrator_key(ck.integrator)}
    h = hashlib.sha1(json.dumps(key, sort_keys=True).encode()).hexdigest()[:10]
    prefix = spec.case_id(case).rsplit("__", 1)[0]  # rig, water, target, distance (readable)
    return Path(root) / f"{prefix}__{ck.width}x{ck.height}-{ck.spp}spp-{ck.integrator}__{h}"


def _write_render(d, img) -> None:
    """Keep a render as :meth:`SpectralImage.save` writes it, staged so that ``spectral.npz`` arrives last."""
    from rigsim.fileio import staged_output

    with staged_output(d) as stage:
        img.save(stage)


def _read_render(d, shape: tuple[int, int, int]):
    """A kept render (:meth:`SpectralImage.load`), or None where there is none or it cannot be read or is not
    a ``shape`` render (then it is rendered again)."""
    from rigsim.errors import ConfigError
    from rigsim.spectral_image import SpectralImage

    if not (d / "spectral.npz").is_file():
        return None
    try:
        img = SpectralImage.load(d)
    except ConfigError as exc:
        log.warning("%s: rendering it again", exc)
        return None
    if img.radiance.shape != tuple(shape):
        log.warning("%s is not a %s render: rendering it again", d, shape)
        return None
    return img


def _mean_image(refs: list):
    """A SpectralImage holding the mean radiance and flash of independent renders (for display)."""
    import dataclasses

    layers = {k: np.mean([np.asarray(r.layers[k], np.float32) for r in refs], axis=0)
              for k in ("flash",) if k in refs[0].layers}
    return dataclasses.replace(refs[0], radiance=np.mean([np.asarray(r.radiance, np.float32) for r in refs], axis=0),
                               layers={**refs[0].layers, **layers})
