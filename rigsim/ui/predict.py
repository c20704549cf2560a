"""Predicted images and their numbers for the rig designer.

One call, :func:`predict`, takes a :class:`~rigsim.scene.types.Rig` and the
:class:`Conditions` (water, distance, target, sensor, exposure) and returns a
:class:`Prediction`: the developed sRGB image and the same numbers a study
reports (:mod:`rigsim.study.case`), computed with that module's functions:

``contrast_radiance``
    Michelson contrast of the target in the noise-free radiance (photopic), e.g.
    the ColorChecker's white against its black patch.
``contrast_image``
    The same from the developed image of the chosen sensor.
``snr_white``
    EMVA 1288 temporal SNR of the sensor at the white patch's mean signal.
``delta_e_mean``
    Mean ΔE2000 of the 24 chart patches against the chart under D65 in air.
``backscatter_share``
    Share of the target pixels' light that the water scattered back without
    reaching the target (ground-truth split).

Engines: the fast preview model :func:`rigsim.preview.render_preview` when it is
installed, otherwise a small, few-sample Monte Carlo render
(:func:`rigsim.render.render`); :func:`preview_engine` is the one place that
chooses.  The converged image is a full render with progress.

No physics lives here: water, scene, renderer, sensor and metrics come from
their packages.
"""

from __future__ import annotations

import dataclasses
import functools
import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from rigsim.errors import ConfigError
from rigsim.scene.types import Rig

log = logging.getLogger(__name__)

__all__ = ["Conditions", "Prediction", "Quality", "QUALITIES", "PREVIEW", "CURVE", "predict", "SCENE_CONDITIONS",
           "contrast_curve", "measure", "preview_engine", "image_size", "load_water_cached", "TARGETS",
           "WHITE_BALANCES", "METRIC_LABELS"]

#: Band centres for previews (nm): 20 nm bands covering 400–700 nm.
PREVIEW_WAVELENGTHS_NM = tuple(np.arange(410.0, 700.0, 20.0).tolist())
#: Band centres for converged renders (nm): 10 nm bands covering 400–700 nm.
RENDER_WAVELENGTHS_NM = tuple(np.arange(405.0, 700.0, 10.0).tolist())
#: Ground-truth layers every prediction needs (masks and the backscatter split).
LAYERS = ("range_m", "object_id", "backscatter", "particles", "particle_id")
#: Targets the designer offers.
TARGETS = ("colorchecker", "black-disk", "white-disk", "slanted-edge")
#: White balance choices: ``auto`` = the chart's neutral 5 patch (a grey card), else grey world.
WHITE_BALANCES = ("auto", "grayworld", "white_patch")

#: Label and unit of each metric, for the UI and reports.
METRIC_LABELS = {
    "contrast_radiance": ("contrast (scene)", ""),
    "contrast_image": ("contrast (image)", ""),
    "snr_white": ("SNR white", "dB"),
    "delta_e_mean": ("mean ΔE2000", ""),
    "backscatter_share": ("backscatter", "%"),
}


@dataclass(frozen=True)
class Quality:
    """Image size and paths per pixel (``spp=None``: the preview engine decides)."""

    name: str
    width: int
    spp: int | None
    wavelengths_nm: tuple[float, ...] = PREVIEW_WAVELENGTHS_NM
    fallback_spp: int = 4  # paths per pixel when the preview model is missing and a render stands in


#: The live preview (photograph-sized: the fast engine makes it in 1-4.5 s on 2 cores, by the water and the machine;
#: an edit of the sensor or exposure alone re-develops the last render, well under a second: :func:`predict`).
PREVIEW = Quality("preview", 960, None)
#: Each cell of the side-by-side comparison (shown small; up to four of them per edit).
COMPARE = Quality("compare", 320, None)
#: Points of the contrast-versus-distance curve (metrics only, no sensor).
CURVE = Quality("curve", 96, None, fallback_spp=16)
#: Converged renders offered by the "Render" button.
QUALITIES = {
    "draft 240 px, 16 spp": Quality("draft", 240, 16, RENDER_WAVELENGTHS_NM),
    "good 360 px, 64 spp": Quality("good", 360, 64, RENDER_WAVELENGTHS_NM),
    "high 720 px, 128 spp": Quality("high", 720, 128, RENDER_WAVELENGTHS_NM),
}


@dataclass(frozen=True)
class Conditions:
    """Everything but the rig that a prediction depends on.

    Attributes
    ----------
    water
        Preset name (``coastal``, ``jerlov-IB`` …) or a water TOML path.
    water_overrides
        ``((key, value), …)`` constituent overrides (``chl_mg_per_m3``, ``cdom_a440_per_m``,
        ``small_particles_ppm``, ``large_particles_ppm``) — constituent presets only.
    distance_m
        Entrance pupil → target (m).
    target
        One of :data:`TARGETS`.
    target_fill
        Scale the target to this fraction of the frame width (so that its patches are
        resolved at any distance, as studies do with ``target_fill``), or None for its
        real size (ColorChecker 0.279 m).
    sensor
        Sensor name (``sensors/*.toml``).
    exposure
        ``"auto"`` (spot meter on the target; TTL for strobes) or ``"manual"``.
    shutter_s, iso, flash_scale
        Manual exposure: shutter (s), ISO and the strobes' output (1 = the rig's power).
    white_balance
        One of :data:`WHITE_BALANCES`.
    depth_m
        Camera depth (m): tints the water in the 3-D view only; the prediction is lit by the
        rig's lights alone (studies with ``depth_m`` add daylight at depth).
    particles
        Marine snow: ``"none"`` or a particle level (:func:`rigsim.water.particles.particle_level_names`);
        the specks are the same particles whatever the rig (a scene input, seed 0), so they move only
        in brightness as a strobe is dragged.
    """

    water: str = "coastal"
    water_overrides: tuple[tuple[str, float], ...] = ()
    distance_m: float = 1.5
    target: str = "colorchecker"
    target_fill: float | None = 0.5
    sensor: str = "sony_ilce-7rm2"
    exposure: str = "auto"
    shutter_s: float = 1 / 125
    iso: float = 100.0
    flash_scale: float = 1.0
    white_balance: str = "auto"
    depth_m: float = 10.0
    particles: str = "none"

    def replace(self, **kw) -> "Conditions":
        return dataclasses.replace(self, **kw)


#: The fields of :class:`Conditions` that change the scene and so the render; the others (sensor, exposure, white
#: balance, and ``depth_m``, which tints the 3-D view only) change only how the render is photographed.
SCENE_CONDITIONS = ("water", "water_overrides", "distance_m", "target", "target_fill", "particles")


@dataclass(frozen=True, eq=False)
class Prediction:
    """A predicted photograph and its numbers."""

    srgb: np.ndarray | None             # (rows, cols, 3) uint8, None for curve points
    metrics: dict[str, float]
    exposure: dict
    engine: str
    seconds: float
    width: int
    height: int
    spp: int | None
    label: str = ""
    notes: tuple[str, ...] = field(default_factory=tuple)
    reused: bool = False  # the render came from ``render_cache``: only the photograph was made (``seconds``)


@dataclass(frozen=True, eq=False)
class _Rendered:
    """A render and what is measured on it alone: what :func:`predict` keeps between edits of the photograph."""

    si: object
    metrics: dict
    masks: dict
    engine: str
    width: int
    height: int


# ----------------------------------------------------------------------------- engines

#: Photons of the fast engine's multiply scattered light in the rig designer (where the water needs
#: it): a third of a study's (:func:`rigsim.preview.multiple.default_photons`), so an edit is shown
#: within about 2 s at 960×640; the class-B light's noise is then about 4 % of itself (≈ 1 % of the
#: veil in Jerlov 3C), against 2 % in a study's photographs.
UI_PHOTONS = 30_000


def preview_engine(quality: Quality = PREVIEW) -> tuple[str, Callable]:
    """``(name, render_fn)`` of the fast preview: the preview model if installed, else a small render.

    ``render_fn(scene, width, height, wavelengths_nm, progress)`` → SpectralImage.
    """
    try:
        from rigsim.preview import render_preview  # the semi-analytic model (same interface)
    except ImportError:
        render_preview = None
    if render_preview is not None:
        def fn(scene, width, height, wavelengths_nm, progress=None):
            return render_preview(scene, width=width, height=height, wavelengths_nm=wavelengths_nm, layers=LAYERS,
                                  photons=UI_PHOTONS)
        return "preview model", fn

    from rigsim.render import render

    def fn(scene, width, height, wavelengths_nm, progress=None):
        return render(scene, width=width, height=height, spp=quality.fallback_spp, seed=0,
                      wavelengths_nm=wavelengths_nm, layers=LAYERS, progress=progress)
    return f"Monte Carlo {quality.fallback_spp} spp (no preview model)", fn


def _full_render(spp: int, seed: int):
    from rigsim.render import render

    def fn(scene, width, height, wavelengths_nm, progress=None):
        return render(scene, width=width, height=height, spp=spp, seed=seed, wavelengths_nm=wavelengths_nm,
                      layers=LAYERS, progress=progress)
    return f"Monte Carlo {spp} spp", fn


# ----------------------------------------------------------------------------- inputs

@functools.lru_cache(maxsize=32)
def load_water_cached(spec: str, overrides: tuple[tuple[str, float], ...] = (), particles: str = "none"):
    """:func:`rigsim.config.water.load_water`, cached (waters are immutable)."""
    from rigsim.config.water import load_water

    return load_water(spec, particles=particles, **dict(overrides))


def image_size(rig: Rig, width: int) -> tuple[int, int]:
    """(width, height) with the sensor's aspect ratio."""
    cam = rig.camera
    h = max(8, int(round(width * cam.sensor_height_mm / cam.sensor_width_mm)))
    return int(width), h


def _scene(rig: Rig, cond: Conditions, distance_m: float | None = None, fill: float | None = None):
    from rigsim.scene.optics import field_width_m
    from rigsim.scene.build import build_scene

    if cond.target not in TARGETS:
        raise ConfigError(f"unknown target {cond.target!r}", field="target", allowed=", ".join(TARGETS))
    d = cond.distance_m if distance_m is None else distance_m
    if not (isinstance(d, (int, float)) and math.isfinite(d) and d > 0):
        raise ConfigError(f"distance must be > 0 m, got {d}", field="distance_m", allowed="> 0 m")
    fill = cond.target_fill if fill is None else fill
    size = None
    if fill is not None:
        if not 0 < fill <= 1.5:
            raise ConfigError(f"target fill must be within (0, 1.5], got {fill}", field="target_fill")
        size = fill * field_width_m(rig.camera, d)
    water = load_water_cached(cond.water, tuple(cond.water_overrides), cond.particles)
    return build_scene(rig, water, cond.target, d, size_m=size)


# ----------------------------------------------------------------------------- metrics

def measure(si, target_kind: str, *, cap=None, sensor=None, exposure=None, masks=None,
            radiance_metrics: bool = True) -> tuple[dict[str, float], dict]:
    """The study's numbers for one image: :func:`rigsim.metrics.scene.scene_metrics` (and, with marine snow,
    :func:`rigsim.metrics.specks.speck_metrics`)."""
    from rigsim.metrics.scene import scene_metrics

    m, masks = scene_metrics(si, target_kind, cap=cap, sensor=sensor, exposure=exposure, masks=masks,
                             radiance_metrics=radiance_metrics)
    if radiance_metrics and si.meta.get("particles"):
        from rigsim.metrics.specks import speck_metrics, subject_mask

        m.update({k: v for k, v in speck_metrics(si, subject_mask(masks, target_kind)).items() if k != "speck_threshold"})
    return m, masks


def _develop(si, rig: Rig, cond: Conditions, masks: dict, seed: int):
    """Photograph the render with the conditions' sensor (:func:`rigsim.sensor.photograph.photograph`:
    the studies' exposure and white-balance rules)."""
    from rigsim.sensor import load_sensor
    from rigsim.sensor.optics import lens_for
    from rigsim.sensor.photograph import photograph
    from rigsim.sensor.pipeline import Exposure

    sensor = load_sensor(cond.sensor)
    lens = lens_for(si)
    if cond.exposure == "manual":
        exposure = Exposure(float(cond.shutter_s), float(cond.iso), lens, flash_scale=float(cond.flash_scale))
    elif cond.exposure == "auto":
        exposure = "auto"
    else:
        raise ConfigError(f"unknown exposure mode {cond.exposure!r}", field="exposure", allowed="auto, manual")
    if cond.white_balance not in WHITE_BALANCES:
        raise ConfigError(f"unknown white balance {cond.white_balance!r}", field="white_balance",
                          allowed=", ".join(WHITE_BALANCES))
    shot = photograph(si, sensor, exposure=exposure, white_balance=cond.white_balance,
                      masks=masks, target_kind=cond.target, seed=seed)
    cap, ex = shot.capture, shot.exposure
    has_flash = "flash" in si.layers
    exposure_info = {"shutter_s": ex.exposure_time_s, "iso": ex.iso, "f_number": lens.f_number,
                     "flash_scale": ex.flash_scale if has_flash else None, "white_balance": shot.white_balance,
                     "sensor": sensor.name, "saturated_fraction": float(np.mean(cap.raw >= cap.white_level))}
    return cap, sensor, ex, exposure_info


# ----------------------------------------------------------------------------- public

def predict(rig: Rig, cond: Conditions, *, quality: Quality = PREVIEW, seed: int = 0, label: str = "",
            progress: Callable[[float, str], None] | None = None, render_cache=None,
            rig_key: str | None = None) -> Prediction:
    """Render (preview or converged), photograph with the sensor, measure.

    ``render_cache`` (a mapping with ``put``, e.g. the designer's LRU; one thread at a time) and ``rig_key`` (a
    string that changes with any edit of the rig): the render of the same rig, scene conditions
    (:data:`SCENE_CONDITIONS`), quality and seed is taken from there instead of rendered again, so an edit of the
    sensor, exposure or white balance only makes the photograph (``Prediction.reused``).

    Raises
    ------
    ConfigError
        An impossible setup (target inside the port, unknown water or sensor …), one line.
    """
    t0 = time.perf_counter()
    key = (None if render_cache is None or rig_key is None else
           (rig_key, tuple(getattr(cond, f) for f in SCENE_CONDITIONS), quality, seed))
    r = render_cache.get(key) if key is not None else None
    reused = r is not None
    if r is None:
        scene = _scene(rig, cond)
        w, h = image_size(rig, quality.width)
        engine, fn = preview_engine(quality) if quality.spp is None else _full_render(quality.spp, seed)
        si = fn(scene, w, h, quality.wavelengths_nm, progress)
        metrics, masks = measure(si, cond.target)
        r = _Rendered(si, metrics, masks, engine, w, h)
    if key is not None:
        render_cache.put(key, r)  # (again where it was there: the most recently used)
    si, masks, w, h, engine = r.si, r.masks, r.width, r.height, r.engine
    metrics = dict(r.metrics)
    cap, sensor, ex, exposure = _develop(si, rig, cond, masks, seed)
    metrics.update(measure(si, cond.target, cap=cap, sensor=sensor, exposure=ex, masks=masks,
                           radiance_metrics=False)[0])
    notes = []
    if exposure["saturated_fraction"] > 0.01:
        notes.append(f"{100 * exposure['saturated_fraction']:.0f}% of pixels clipped")
    if not any(k in masks for k in ("signal",)):
        notes.append("target too small in the frame to measure contrast")
    return Prediction(srgb=np.asarray(cap.srgb), metrics=metrics, exposure=exposure, engine=engine,
                      seconds=time.perf_counter() - t0, width=w, height=h, spp=quality.spp, label=label,
                      notes=tuple(notes), reused=reused)


def contrast_curve(rig: Rig, cond: Conditions, distances_m: Sequence[float], *,
                   should_stop: Callable[[], bool] | None = None) -> list[dict]:
    """Sensor-independent contrast and backscatter share at each distance (preview engine).

    The target is scaled to ``cond.target_fill`` of the frame (0.5 if the conditions
    use its real size) so that its patches are resolved at every distance.  Distances
    the target cannot be at (inside the port) are skipped.

    Returns
    -------
    list of ``{"distance_m", "contrast_radiance", "backscatter_share"}``
    """
    from rigsim.scene.optics import port_reach_m

    engine, fn = preview_engine(CURVE)
    fill = cond.target_fill if cond.target_fill is not None else 0.5
    w, h = image_size(rig, CURVE.width)
    out = []
    for d in distances_m:
        if should_stop is not None and should_stop():
            break
        if d <= port_reach_m(rig.camera) + 0.02:
            continue
        si = fn(_scene(rig, cond, d, fill), w, h, CURVE.wavelengths_nm, None)
        m, _ = measure(si, cond.target)
        out.append({"distance_m": float(d), "contrast_radiance": m.get("contrast_radiance"),
                    "backscatter_share": m.get("backscatter_share")})
    return out


def snr_db(snr: float) -> float:
    """SNR as 20 log10 (dB)."""
    return 20 * math.log10(snr) if snr and snr > 0 else float("nan")
