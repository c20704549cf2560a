"""What makes one strobe placement better than another: the numbers of a predicted photograph and
their weighted sum.

:func:`evaluate` renders the :class:`Setting` (water, subject distance, sensor, subject, marine
snow) with a rig — by the fast engine (:func:`rigsim.preview.render_preview`) while searching,
by the Monte Carlo renderer (:func:`rigsim.render.render`) to verify — photographs it with the
sensor (:func:`rigsim.sensor.photograph.photograph`: TTL-like auto exposure, so a rig whose
strobes cannot light the subject at full power is shot at a higher ISO and loses SNR) and
measures (:mod:`rigsim.metrics`):

``backscatter_share``
    Share of the subject pixels' light that the water scattered back without reaching the subject
    (ground-truth split; :func:`rigsim.metrics.contrast.backscatter_share`).  Lower is better.
``evenness_cv``
    Coefficient of variation of the light falling on the subject: the unscattered image
    (``direct`` layer) divided by the subject's own reflectance band by band — for a ColorChecker
    one value per patch (:func:`reflectance_colorchecker_Ohta`), for other subjects one per pixel —
    as photopic luminance.  0 is perfectly even.  Lower is better.
``corner_ratio``
    The same light at the subject's corners (the 4 patches, or the 10 % of pixels, farthest from its
    centre) over that at its centre (the 4 nearest / 10 % nearest): 1 is even, 0.5 is one stop
    darker in the corners.  Reported, not weighted (``evenness_cv`` carries it).
``snr_white``
    EMVA 1288 SNR of the sensor at the white patch (a white disk, a mesh subject: on the subject) at the
    chosen exposure.
``delta_e_mean``
    Mean ΔE2000 of the chart patches after white balance (ColorChecker subjects).
``speck_light``
    Share of the image's light that lit marine-snow particles add (``speck_light_share`` of
    :func:`rigsim.metrics.specks.speck_metrics`: nearly independent of the image's size).  Lower is better.
``speck_count``
    Marine-snow specks visible in the frame (ibid.; grows with the image's size, so reported, not weighted).
``contrast``
    Michelson contrast of the chart's white against its black patch in the radiance (a disk, a mesh:
    the subject against the water around it).
``iso``, ``flash_power``
    The auto exposure's ISO and the strobes' output as a fraction of full power.

The score (:meth:`Weights.score`, lower is better) is
``w_b · backscatter_share + w_e · evenness_cv + w_n · 10/snr_white + w_c · delta_e_mean/10 + w_s · 100 speck_light``
with :data:`DEFAULT_WEIGHTS` (each term is about 0.1–0.5 for a typical rig, so equal weights mean
equal concern).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields, replace

import numpy as np

from rigsim.errors import ConfigError
from rigsim.scene.types import Rig

__all__ = ["Setting", "Fidelity", "Weights", "Evaluation", "DEFAULT_WEIGHTS", "SEARCH", "REPORT", "FINAL",
           "evaluate", "photo", "parse_weights", "METRICS", "SUBJECTS", "scene_for"]

#: Band centres (nm) of the optimiser's images: 20 nm bands over 400–700 nm, as the rig designer's.
BANDS_NM = tuple(np.arange(410.0, 700.0, 20.0).tolist())

#: Subjects the optimiser can image (the fast engine's targets with an even reflectance or a chart).
SUBJECTS = ("colorchecker", "white-disk")
#: Metric → (label, unit, which way is better); the order of tables.
METRICS = {
    "backscatter_share": ("backscatter share", "%", "lower"),
    "evenness_cv": ("unevenness (CV)", "", "lower"),
    "corner_ratio": ("corner / centre light", "", "higher"),
    "snr_white": ("SNR at the subject", "", "higher"),  # (a chart: its white patch)
    "delta_e_mean": ("mean ΔE2000", "", "lower"),
    "speck_light": ("light of lit specks", "%", "lower"),
    "speck_count": ("visible specks", "", "lower"),
    "contrast": ("subject contrast", "", "higher"),  # (a chart: white against black patch)
    "iso": ("ISO", "", "lower"),
    "flash_power": ("strobe power used", "%", "lower"),
}


@dataclass(frozen=True)
class Setting:
    """What the rig is optimised for.

    Attributes
    ----------
    water
        Preset name (``coastal``, ``jerlov-3C`` …) or a water TOML path.
    distance_m
        Entrance pupil → subject (m, > 0).
    sensor
        Sensor name (``sensors/*.toml``) or path.
    subject
        ``colorchecker``, ``white-disk`` (:data:`SUBJECTS`) or the path of an OBJ/PLY mesh (a rock, a
        coral head: its own reflectance, 18 % grey unless the file says otherwise; the numbers are then
        those of the subject against the water around it — no ΔE2000, no chart).
    subject_fill
        The subject is scaled to this fraction of the frame's width in water (0–1.5), as a diver
        frames it.
    particles
        Marine snow: ``"none"`` or a level name (:func:`rigsim.water.particles.particle_level_names`).
    """

    water: str = "coastal"
    distance_m: float = 1.5
    sensor: str = "sony_ilce-7rm2"
    subject: str = "colorchecker"
    subject_fill: float = 0.6
    particles: str = "none"

    def __post_init__(self):
        d = self.distance_m
        if isinstance(d, bool) or not isinstance(d, (int, float)) or not (math.isfinite(d) and d > 0):
            raise ConfigError(f"distance must be > 0 m, got {d!r}", field="distance_m", allowed="> 0 m")
        if self.subject_kind == "mesh":
            from rigsim.scene.meshes import read_mesh

            if not len(read_mesh(self.subject).faces):  # (a missing or unreadable file: its own one-line error)
                raise ConfigError("the mesh has no triangles", file=self.subject, field="subject",
                                  allowed="an OBJ/PLY with faces")
        elif self.subject not in SUBJECTS:
            raise ConfigError(f"unknown subject {self.subject!r}", field="subject",
                              allowed=", ".join(SUBJECTS) + ", or an .obj/.ply mesh")
        f = self.subject_fill
        if isinstance(f, bool) or not isinstance(f, (int, float)) or not 0 < f <= 1.5:
            raise ConfigError(f"subject fill must be in (0, 1.5], got {f!r}", field="subject_fill",
                              allowed="0 < fill <= 1.5 (fraction of the frame width)")

    @property
    def subject_kind(self) -> str:
        from rigsim.scene.meshes import MESH_SUFFIXES

        return "mesh" if str(self.subject).lower().endswith(MESH_SUFFIXES) else str(self.subject)

    def load_water(self):
        """The :class:`~rigsim.water.Water` (with its marine snow) of this setting."""
        from rigsim.config.water import load_water

        return load_water(self.water, particles=None if self.particles in ("", None) else self.particles)

    def label(self) -> str:
        snow = "" if self.particles in ("none", "", None) else f", {self.particles} marine snow"
        return f"{self.water} water, subject at {self.distance_m:g} m{snow}"


@dataclass(frozen=True)
class Fidelity:
    """How finely a placement is imaged: width in pixels (height from the sensor's aspect), whether the
    fast engine adds the multiply scattered light (``"auto"``: where the water needs it) and with how
    many photons (None: its default), band centres (nm)."""

    name: str
    width: int
    multiple: bool | str = "auto"
    photons: int | None = None
    wavelengths_nm: tuple[float, ...] = BANDS_NM


#: While searching: 96 px wide, single scattering with the small-angle forward light, no Monte Carlo
#: photons: about 0.1 s per placement (0.3–0.4 s with the multiply scattered light) and a smooth
#: function of the placement (the photons' estimate moves by ~2 % between seeds in turbid water, which
#: a simplex would chase).  The start and the optimum are then measured with it (:data:`REPORT`).
SEARCH = Fidelity("search", 96, False)
#: Sensitivities and the start/optimum tables: multiple scattering where the water needs it, with half the
#: default photons (in an edge-lit Jerlov 3C scene the chart's backscatter share then varies by 0.3 %
#: (absolute, s.d.) between seeds; every placement is imaged with the same seed).
REPORT = Fidelity("report", 192, "auto", 50_000)
#: The before/after photographs.
FINAL = Fidelity("final", 960)


@dataclass(frozen=True)
class Weights:
    """Weights of the score's terms (see the module docstring); all >= 0."""

    backscatter: float = 1.0
    evenness: float = 1.0
    noise: float = 1.0
    colour: float = 0.5
    specks: float = 1.0

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v >= 0):
                raise ConfigError(f"weight must be a number >= 0, got {v!r}", field=f"--weights {f.name}",
                                  allowed=">= 0")

    def terms(self, m: dict[str, float]) -> dict[str, float]:
        """Each weighted term of the score for metrics ``m`` (missing metrics count 0)."""
        snr = m.get("snr_white")
        return {
            "backscatter": self.backscatter * m.get("backscatter_share", 0.0),
            "evenness": self.evenness * m.get("evenness_cv", 0.0),
            "noise": self.noise * (10.0 / snr if snr and snr > 0 else 0.0),
            "colour": self.colour * m.get("delta_e_mean", 0.0) / 10.0,
            "specks": self.specks * 100.0 * m.get("speck_light", 0.0),
        }

    def score(self, m: dict[str, float]) -> float:
        """The score of metrics ``m`` (lower is better)."""
        return float(sum(self.terms(m).values()))


DEFAULT_WEIGHTS = Weights()


def parse_weights(text: str | None) -> Weights:
    """``"backscatter=2,evenness=1"`` → :class:`Weights` (others default); one-line errors."""
    if not text:
        return DEFAULT_WEIGHTS
    names = [f.name for f in fields(Weights)]
    kw = {}
    for part in str(text).split(","):
        if not part.strip():
            continue
        k, eq, v = part.partition("=")
        k = k.strip()
        if not eq or k not in names:
            raise ConfigError(f"{part.strip()!r} is not name=number", field="--weights",
                              allowed=", ".join(f"{n}=<number>" for n in names))
        try:
            kw[k] = float(v)
        except ValueError:
            raise ConfigError(f"{v!r} is not a number", field=f"--weights {k}", allowed=">= 0") from None
    return replace(DEFAULT_WEIGHTS, **kw)


@dataclass(frozen=True)
class Evaluation:
    """The numbers of one placement (:data:`METRICS`) and how they were made."""

    metrics: dict[str, float]
    engine: str
    seconds: float
    infeasible: str | None = None
    se: dict[str, float] = field(default_factory=dict)

    def score(self, weights: Weights) -> float:
        return math.inf if self.infeasible else weights.score(self.metrics)

    def record(self, weights: Weights) -> dict:
        d = asdict(self)
        d["score"] = None if self.infeasible else self.score(weights)
        d["terms"] = {} if self.infeasible else weights.terms(self.metrics)
        return d


# ----------------------------------------------------------------------------- scene and numbers

def scene_for(rig: Rig, setting: Setting, water=None):
    """The scene of ``setting`` with ``rig`` (``water``: an already loaded :class:`~rigsim.water.Water`)."""
    from rigsim.scene.build import build_scene
    from rigsim.scene.optics import field_width_m

    if water is None:
        water = setting.load_water()
    size = setting.subject_fill * field_width_m(rig.camera, setting.distance_m)
    return build_scene(rig, water, setting.subject, setting.distance_m, size_m=size)


def _illumination(si, masks: dict, kind: str) -> tuple[np.ndarray, np.ndarray] | None:
    """(cells' light, cells' (row, col) centres): the unscattered subject image over its reflectance."""
    from rigsim.metrics.scene import photopic_luminance

    direct = si.radiant_exposure(1.0, "direct")
    wl, bw = si.wavelength_nm, si.bandwidth_nm
    if kind == "colorchecker":
        from rigsim.scene.reflectances import reflectance_colorchecker_Ohta

        refl = reflectance_colorchecker_Ohta(np.asarray(wl, float))
        vals, centres = [], []
        for name, rho in refl.items():
            m = masks.get(f"patch:{name}")
            if m is None or m.sum() < 1:
                continue
            e = direct[m].mean(axis=0) / np.maximum(rho, 1e-3)
            vals.append(float(photopic_luminance(e, wl, bw)))
            rr, cc = np.nonzero(m)
            centres.append((rr.mean(), cc.mean()))
        if len(vals) < 4:
            return None
        return np.array(vals), np.array(centres)
    m = masks.get("signal", masks.get("target"))
    if m is None or m.sum() < 8:
        return None
    lum = photopic_luminance(direct[m], wl, bw)
    rr, cc = np.nonzero(m)
    return np.asarray(lum, float), np.stack([rr, cc], axis=1).astype(float)


def illumination_metrics(si, masks: dict, kind: str) -> dict[str, float]:
    """``evenness_cv`` and ``corner_ratio`` of an image (see the module docstring); {} if the subject
    is too small in the frame."""
    got = _illumination(si, masks, kind)
    if got is None:
        return {}
    vals, centres = got
    mean = float(vals.mean())
    if not mean > 0:
        return {}
    r = np.hypot(*(centres - centres.mean(axis=0)).T)
    order = np.argsort(r, kind="stable")
    k = 4 if kind == "colorchecker" else max(1, len(vals) // 10)
    centre, corner = vals[order[:k]].mean(), vals[order[-k:]].mean()
    return {"evenness_cv": float(vals.std() / mean), "corner_ratio": float(corner / centre) if centre > 0 else 0.0}


def measure(si, setting: Setting, *, sensor=None, seed: int = 0) -> dict[str, float]:
    """The :data:`METRICS` of a rendered image of ``setting`` (``sensor``: a loaded Sensor, or None to load it;
    the photograph's noise is seeded)."""
    from rigsim.metrics.scene import scene_metrics
    from rigsim.sensor import load_sensor
    from rigsim.sensor.photograph import photograph

    kind = setting.subject_kind
    m, masks = scene_metrics(si, kind)
    out = {"backscatter_share": m.get("backscatter_share", float("nan"))}
    if "contrast_radiance" in m:
        out["contrast"] = m["contrast_radiance"]
    out.update(illumination_metrics(si, masks, kind))
    if si.meta.get("particles"):
        from rigsim.metrics.specks import speck_metrics, subject_mask

        sm = speck_metrics(si, subject_mask(masks, kind))
        out["speck_count"] = float(sm["speck_count"])
        out["speck_light"] = float(sm["speck_light_share"])
    sensor = load_sensor(setting.sensor) if sensor is None else sensor
    shot = photograph(si, sensor, exposure="auto", white_balance="auto", masks=masks, target_kind=kind, seed=seed)
    cm, _ = scene_metrics(si, kind, cap=shot.capture, sensor=sensor, exposure=shot.exposure, masks=masks,
                          radiance_metrics=False)
    for k in ("snr_white", "delta_e_mean"):
        if k in cm:
            out[k] = cm[k]
    out["iso"] = float(shot.exposure.iso)
    if "flash" in si.layers:
        out["flash_power"] = float(shot.exposure.flash_scale)
    return {k: float(v) for k, v in out.items() if v is not None and math.isfinite(v)}


def render_fast(scene, width: int, height: int, fidelity: Fidelity, seed: int = 0):
    """The fast engine's image with the layers the numbers need."""
    from rigsim.preview import render_preview

    layers = ("range_m", "object_id", "direct", "backscatter", "particles", "particle_id")
    if not scene.water or not getattr(scene.water, "particles", None):
        layers = layers[:4]
    return render_preview(scene, width=width, height=height, wavelengths_nm=fidelity.wavelengths_nm,
                          layers=layers, multiple=fidelity.multiple, photons=fidelity.photons, seed=seed)


def image_height(rig: Rig, width: int) -> int:
    cam = rig.camera
    return max(8, int(round(width * cam.sensor_height_mm / cam.sensor_width_mm)))


def evaluate(rig: Rig, setting: Setting, fidelity: Fidelity = SEARCH, *, water=None, sensor=None,
             seed: int = 0) -> Evaluation:
    """Render ``rig`` in ``setting`` with the fast engine and measure it (:func:`measure`)."""
    import time

    t0 = time.perf_counter()
    scene = scene_for(rig, setting, water)
    h = image_height(rig, fidelity.width)
    si = render_fast(scene, fidelity.width, h, fidelity, seed)
    m = measure(si, setting, sensor=sensor, seed=seed)
    return Evaluation(metrics=m, engine=f"fast engine {fidelity.width}x{h}", seconds=time.perf_counter() - t0)


def photo(rig: Rig, setting: Setting, fidelity: Fidelity = FINAL, *, seed: int = 0) -> np.ndarray:
    """The predicted photograph (8-bit sRGB) of ``rig`` in ``setting`` (fast engine, auto exposure and
    white balance)."""
    scene = scene_for(rig, setting)
    si = render_fast(scene, fidelity.width, image_height(rig, fidelity.width), fidelity, seed)
    return developed(si, setting, seed=seed)


def developed(si, setting: Setting, sensor=None, seed: int = 0) -> np.ndarray:
    """The developed 8-bit sRGB photograph of ``si`` (auto exposure, auto white balance)."""
    from rigsim.metrics.scene import target_masks
    from rigsim.sensor import load_sensor
    from rigsim.sensor.photograph import photograph

    kind = setting.subject_kind
    masks = target_masks(np.asarray(si.layers["object_id"]), si.meta.get("object_ids", {}), kind)
    sensor = load_sensor(setting.sensor) if sensor is None else sensor
    return np.asarray(photograph(si, sensor, masks=masks, target_kind=kind, seed=seed).capture.srgb)
