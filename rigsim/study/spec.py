"""Study files (TOML in ``studies/``), validated completely before anything is rendered.

::

    [study]
    name = "demo"
    description = "strobes close to the port vs far out"
    seed = 1

    [sweep]
    rigs = ["../rigs/twin-strobes-45-wide.toml", "../rigs/twin-strobes-edge-lighting.toml"]
    sensors = ["sony_ilce-7rm2", "sony_ilce-7sm2"]
    waters = ["clear", "coastal", "jerlov-II", "coastal-regions"]   # presets or water TOML files
    distances_m = [0.5, 1, 1.5, 2, 3, 4]
    targets = ["colorchecker", "black-disk"]
    target_fill = 0.35      # optional: targets span this fraction of the image width at every
                            # distance (a larger chart farther out); default: their real size
    depth_m = 10            # optional: camera depth for ambient daylight (sun at 30°, Kd field)

    [render]
    width = 128
    height = 96
    spp = 64
    wavelengths = "400:700:10"
    engine = "mitsuba"      # or "fast" (the semi-analytic engine, rigsim.preview; also called "preview")
    integrator = "rigsim"   # or "volpath"
    noise_target = 0.2      # optional: more batches of spp until the Monte Carlo noise is below this
    max_spp = 512           # optional: ... but at most this many paths per pixel (default 8 × spp)
    check_with_mitsuba = 8  # optional (fast engine): this many cases, chosen to cover the waters and
                            # distances, are also rendered by Monte Carlo at the [check] size; the report
                            # says how far the fast engine's numbers can be trusted in each water

    [check]                 # optional: the Monte Carlo checks of a fast-engine study
    width = 96
    height = 64
    spp = 256               # paths per pixel of each of `seeds` independent renders
    seeds = 4               # the reference is their mean; its standard error is their spread / sqrt(seeds)
    max_seeds = 16          # optional: two stages — from the first `seeds` renders' noise, as many more as bring
    target_se = 0.015       # the regions' relative standard error (90th percentile) to target_se, up to max_seeds
    reference = "monte-carlo"  # or "hybrid": a chart lit by the rig's strobes or its continuous lights (no daylight)
                            # is referenced by images whose chart light is
                            # light-traced and seen through the water by a camera pass (rigsim.render.hybrid;
                            # for turbid water, where the renders' chart patches are heavy-tailed)
    hybrid_photons = 1000000  # per reference image (hybrid)
    hybrid_spp = 64         # camera-pass paths per pixel and band, per reference image (hybrid)
    hybrid_veil_renders = 16  # renders whose veil (backscatter layer) each hybrid image averages
    hybrid_veil_max_renders = 64  # optional: from the pilot's noise, as many renders' veil per image as make the
                            # reference cheapest for it, up to this many (rigsim.render.hybrid.veil_renders_for)
    hybrid_veil_sigma_px = 4.0  # the veil over the chart pooled by a local quadratic, Gaussian kernel of this
                            # many pixels (rigsim.render.hybrid.smooth_chart_veil); 0: each pixel's own
    hybrid_order = 4        # optional: order of the polynomial fitted to the chart's light-traced irradiance (0-6;
                            # default rigsim.render.hybrid.DEFAULT_FIT_ORDER)
    hybrid_max_seeds = 8    # optional: max_seeds for the hybrid cases alone (the others keep max_seeds)
    fast_noise_seeds = 3    # optional: further fast renders (other seeds) whose photon batches join the checked
                            # image's own in its noise estimate (default 0: its 4 batches alone, 3 degrees of freedom)

    [sweep]
    extend_visibility = true  # default: where a target stays visible over the whole sweep, the study
                              # goes on with the fast engine (distance x 1.5 per step) until it is not

    [capture]
    exposure = "auto"       # or "manual" with iso, shutter_s
    iso = 100
    shutter_s = 0.008
    white_balance = "auto"  # chart's neutral 5 patch for chart targets, else grayworld; or any method
    demosaic = "Malvar2004"

    [metrics]
    contrast_threshold = 0.02

    [quick]                 # overrides used with --quick (CI)
    width = 48
    height = 36
    spp = 8
    distances_m = [1, 2]
"""

from __future__ import annotations

import hashlib
import json
import math
import numbers
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BeforeValidator, Field, field_validator, model_validator

from rigsim.schema import Bool, FileModel, Int, Real, Unit, WavelengthGrid, invalid, names_list, read_toml, validate
from rigsim.errors import ConfigError, RigsimError, unknown_name_error
from rigsim.spectrum import parse_wavelength_range

__all__ = ["RenderSettings", "CheckSettings", "CaptureSettings", "select_check_cases", "StudySpec", "Case", "load_study", "TARGETS", "StudyFile"]

#: Built-in target names (besides mesh files).
TARGETS = ("colorchecker", "black-disk", "white-disk", "slanted-edge", "bottom")


@dataclass(frozen=True)
class RenderSettings:
    """How each scene is rendered (sizes in pixels, wavelengths in nm)."""

    width: int = 128
    height: int = 96
    spp: int = 64
    wavelengths_nm: tuple[float, ...] = tuple(np.arange(400.0, 701.0, 10.0))
    engine: str = "mitsuba"  # "mitsuba" (Monte Carlo) or "preview" (the fast engine)
    integrator: str = "rigsim"
    #: render in batches of ``spp`` until the noise (:func:`rigsim.render.renderer.relative_noise_p99`)
    #: is below this, up to ``max_spp`` (None: one batch)
    noise_target: float | None = None
    max_spp: int | None = None
    #: fast-engine studies: this many cases are also rendered by Monte Carlo (:class:`CheckSettings`)
    check_with_mitsuba: int = 0
    #: fast engine: its multiply scattered light, ``"off"``, ``"on"`` or ``"auto"`` (where the water
    #: scatters widely; :func:`rigsim.preview.render_preview`'s ``multiple``)
    multiple_scattering: str = "auto"

    @property
    def preview_multiple(self) -> bool | str:
        """``render_preview(multiple=...)`` of :attr:`multiple_scattering`."""
        return {"off": False, "on": True, "auto": "auto"}[self.multiple_scattering]


@dataclass(frozen=True)
class CheckSettings:
    """The Monte Carlo checks of a fast-engine study: image size (px), paths per pixel of each of
    ``seeds`` independent renders (the reference is their mean, its standard error their spread).

    ``max_seeds`` > ``seeds``: a two-stage reference (Stein 1945) — the first ``seeds`` renders are a
    pilot; from the 90th percentile ``s`` of its regions' relative standard errors the case gets
    ``ceil(seeds · (s / target_se)²)`` renders in all (at most ``max_seeds``), decided once, before any
    of the rest is seen, and never from the fast engine's numbers: turbid water, where a few renders
    leave a reference too noisy to judge anything, gets more of them; clear water keeps the pilot."""

    width: int = 96
    height: int = 64
    spp: int = 256
    seeds: int = 4
    integrator: str = "rigsim"
    max_seeds: int | None = None
    target_se: float = 0.015
    #: ``"monte-carlo"`` (each reference image a render) or ``"hybrid"`` (:mod:`rigsim.render.hybrid`: for a
    #: chart lit by strobes, or by continuous lights without daylight — ``rigsim.render.hybrid.hybrid_group`` —
    #: each render's flash (or radiance) is its veil plus the chart's light by light tracing and a camera pass
    #: of ``hybrid_spp`` per band, ``hybrid_photons`` photons; other cases stay renders).
    reference: str = "monte-carlo"
    hybrid_photons: int = 1_000_000
    hybrid_spp: int = 64
    #: Renders whose veil each hybrid image averages (a render is cheap beside a camera pass — ~3 s against ~170 s
    #: at 96×64, 32 spp, 128 spp per band — and the veil over the chart is the hybrid's noisiest part, heavy-tailed
    #: where the beams cross in front of it: Jerlov III, twin-strobes-45-wide, chart at 3 m, the white patch's blue
    #: read −12.0 ± 13.7 % with 4 and −4.5 ± 3.1 % with 16, 2026-12-06; Jerlov 7C, edge-lit rig at 1 m, 16 renders of
    #: 32 spp left the open water's blue ±7.5 %).  (Until 2026-12-06: 4.)
    hybrid_veil_renders: int = 16
    #: Where set (above ``hybrid_veil_renders``), the pilot's images say how many renders' veil each image averages
    #: from then on, up to this many (:func:`rigsim.render.hybrid.veil_renders_for`: the count that makes the
    #: reference cheapest for its noise; every image is then made again of that many, the pilot's renders among
    #: them).  A chart 3–6 m into Jerlov II/III is 75–99 % veil, one render's veil varying 100–10⁵× as much as one
    #: camera pass's light; at 0.5–1 m the pass's light is most of a patch.  None: ``hybrid_veil_renders`` always.
    hybrid_veil_max_renders: int | None = None
    #: Kernel (pixels) of the local quadratic that pools the hybrid images' veil over the chart
    #: (:func:`rigsim.render.hybrid.smooth_chart_veil`: the veil does not depend on the patches, and pooled over
    #: neighbouring ones its noise fell 1.6–1.9× in Jerlov 7C; its bias on the fast engine's veil ≤ 0.6 % of a
    #: patch); 0 keeps each pixel's own.
    hybrid_veil_sigma_px: float = 4.0
    #: Order of the polynomial fitted to the chart's light-traced irradiance
    #: (None: :data:`rigsim.render.hybrid.DEFAULT_FIT_ORDER`; order 2 missed the direct beam's shape on a chart by up to
    #: 4 %).
    hybrid_order: int | None = None
    #: The cap of ``max_seeds`` for the hybrid cases alone (a hybrid image costs a light trace and a camera pass
    #: besides its renders); the other cases keep ``max_seeds``.  None: ``max_seeds`` for all.  (With one cap
    #: for all, 8, an edge-lit Jerlov 9C black disk's reference fell from 32 renders to 4-8 and its open water's
    #: -9.0 % read as within noise.)
    hybrid_max_seeds: int | None = None
    #: Further fast-engine renders of the case with other seeds, made only for the fast image's noise: the spread
    #: of their photon batches joins the checked image's own (``fast_batches`` and ``noise_batches`` of
    #: :func:`rigsim.metrics.agreement.compare_renders`), 3 more degrees of freedom each.  With the image's 4
    #: batches alone a contrast's noise was once read as a third of its spread over seeds (the edge-lit chart at
    #: 6 m in Jerlov II, 2026-12-06: ±0.9 % where 12 seeds scatter by 3.3 %).  0: the image's batches alone.
    fast_noise_seeds: int = 0

    def renders_for(self, pilot_se_p90: float, hybrid: bool = False) -> int:
        """Renders in all for a pilot whose regions' relative SE has the 90th percentile ``pilot_se_p90``
        (``hybrid``: a case referenced by hybrid images, capped by ``hybrid_max_seeds`` where it is set)."""
        cap = self.hybrid_max_seeds if hybrid and self.hybrid_max_seeds is not None else self.max_seeds
        top = max(self.seeds, cap or self.seeds)
        if not math.isfinite(pilot_se_p90) or top == self.seeds:
            return top
        return int(min(top, max(self.seeds, math.ceil(self.seeds * (pilot_se_p90 / self.target_se) ** 2))))


@dataclass(frozen=True)
class CaptureSettings:
    """How each render is captured by each sensor."""

    exposure: str = "auto"
    iso: float = 100.0
    shutter_s: float = 1 / 125
    white_balance: str = "auto"
    demosaic: str = "Malvar2004"
    target_percentile: float = 99.0
    target_level: float = 0.8
    save_raw: bool = False


@dataclass(frozen=True)
class Case:
    """One scene of the sweep: rendered once, captured by every sensor."""

    rig: str          # rig file (resolved path)
    rig_name: str
    water: str        # preset name or water file
    water_name: str
    distance_m: float
    target: str
    depth_m: float | None
    target_fill: float | None = None
    #: a distance beyond the sweep, rendered by the fast engine to find the visibility range
    extension: bool = False

    def key(self) -> dict:
        d = asdict(self)
        if not self.extension:  # the ids of sweep cases stay what they were before extensions existed
            d.pop("extension")
        return d


@dataclass(frozen=True)
class StudySpec:
    """A validated study."""

    name: str
    description: str
    seed: int
    rigs: tuple[str, ...]
    rig_names: tuple[str, ...]
    sensors: tuple[str, ...]
    waters: tuple[str, ...]
    water_names: tuple[str, ...]
    distances_m: tuple[float, ...]
    targets: tuple[str, ...]
    depth_m: float | None
    target_fill: float | None
    render: RenderSettings
    capture: CaptureSettings
    contrast_threshold: float = 0.02
    source: str = ""
    quick: bool = False
    extra: dict = field(default_factory=dict, compare=False)
    check: CheckSettings = CheckSettings()
    extend_visibility: bool = True

    def cases(self) -> list[Case]:
        """All scenes, in a fixed order (rig, water, target, distance)."""
        out = []
        for rig, rn in zip(self.rigs, self.rig_names):
            for w, wn in zip(self.waters, self.water_names):
                for t in self.targets:
                    for d in self.distances_m:
                        out.append(Case(rig, rn, w, wn, float(d), t, self.depth_m, self.target_fill))
        return out

    def check_cases(self) -> list[Case]:
        """The cases also rendered by Monte Carlo (``render.check_with_mitsuba`` of them; fast-engine
        studies only): spread over the waters first (as evenly as the number allows), then over each
        water's distances (nearest, farthest, between), alternating the rigs and targets."""
        n = self.render.check_with_mitsuba if self.render.engine == "preview" else 0
        return select_check_cases(self.cases(), n)

    def check_id(self, case: Case) -> str:
        """Stable id of a case's Monte Carlo check (the case's id + a hash of the check settings)."""
        ck = asdict(self.check)
        if not ck["fast_noise_seeds"]:  # the ids of checks made before the option existed stay
            ck.pop("fast_noise_seeds")
        if ck["hybrid_veil_max_renders"] is None:  # the same
            ck.pop("hybrid_veil_max_renders")
        if ck["reference"] == "monte-carlo":  # the ids of checks made before the hybrid reference existed stay
            for k in ("reference", "hybrid_photons", "hybrid_spp", "hybrid_veil_renders", "hybrid_veil_sigma_px",
                      "hybrid_order", "hybrid_veil_max_renders"):
                ck.pop(k, None)
        h = hashlib.sha1(json.dumps(ck, sort_keys=True).encode()).hexdigest()[:6]
        return f"{self.case_id(case)}__check-{h}"

    def describe(self) -> dict:
        d = asdict(self)
        d.pop("extra", None)
        return d

    def case_id(self, case: Case) -> str:
        """Stable id of a case: readable prefix + hash of everything that changes its result."""
        render = {k: v for k, v in asdict(self.render).items()
                  if not (k in ("noise_target", "max_spp") and v is None)  # ids of older studies stay
                  and k != "check_with_mitsuba"}  # the checks do not change a case's result
        payload = {"case": case.key(), "render": render, "capture": asdict(self.capture),
                   "sensors": list(self.sensors), "seed": self.seed}
        h = hashlib.sha1(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:10]
        safe = lambda s: "".join(c if c.isalnum() or c in "-_." else "-" for c in s)  # noqa: E731
        return f"{safe(case.rig_name)}__{safe(case.water_name)}__{safe(case.target)}__{case.distance_m:g}m__{h}"

    def case_seed(self, case: Case) -> int:
        """Seed of a case: derived from the study seed and the case's inputs (order-independent), the
        files among them (rig, water, mesh) by their contents, not where they are: the same study in
        another checkout draws the same random numbers (with absolute paths it did not, and the demo's
        Monte Carlo checks and multiply scattered light came out differently in every clone)."""
        h = hashlib.sha1(json.dumps({"seed": self.seed, "case": self.content_key(case)}, sort_keys=True).encode())
        return int(h.hexdigest()[:8], 16)

    def content_key(self, case: Case) -> dict:
        """A case's inputs with the files among them (rig, water, mesh) replaced by their contents' hashes:
        the same case in another checkout has the same key (:meth:`case_seed`, the kept Monte Carlo renders
        of :func:`rigsim.study.case.cached_render_dir`)."""
        key = case.key()
        for name, value in key.items():
            if isinstance(value, str) and value.endswith((".toml", ".obj", ".ply", ".gltf", ".glb")):
                f = Path(value)
                if f.is_file():
                    key[name] = hashlib.sha1(f.read_bytes()).hexdigest()
        return key


def select_check_cases(cases: list[Case], n: int) -> list[Case]:
    """``n`` of ``cases`` (sweep order) covering their waters, then their distances (see
    :meth:`StudySpec.check_cases`); all of them if ``n`` is at least their number."""
    if n <= 0:
        return []
    if n >= len(cases):
        return list(cases)
    by_water: dict[str, list[Case]] = {}
    for c in cases:
        by_water.setdefault(c.water, []).append(c)
    waters = list(by_water)
    share = [n // len(waters) + (1 if i < n % len(waters) else 0) for i in range(len(waters))]
    picked: list[Case] = []
    for wi, (w, k) in enumerate(zip(waters, share)):
        cs = by_water[w]
        dists = sorted({c.distance_m for c in cs})
        combos = list(dict.fromkeys((c.rig, c.target) for c in cs))
        for j in range(k):
            # distances: nearest, farthest, then between; combos rotate (offset by the water's index)
            pos = [0, len(dists) - 1] if k > 1 else [len(dists) // 2]
            pos += [round(i * (len(dists) - 1) / (k - 1)) for i in range(1, k - 1)] if k > 2 else []
            d = dists[pos[j % len(pos)]] if j < len(pos) else dists[j % len(dists)]
            for t in range(len(combos)):
                rig, target = combos[(j + wi + t) % len(combos)]
                c = next((c for c in cs if c.rig == rig and c.target == target and c.distance_m == d), None)
                if c is not None and c not in picked:
                    picked.append(c)
                    break
            else:  # every combination at this distance is taken: the next case of this water not yet taken
                c = next((c for c in cs if c not in picked), None)
                if c is not None:
                    picked.append(c)
    order = {c: i for i, c in enumerate(cases)}
    return sorted(picked, key=order.__getitem__)


def sensor_key(name: str) -> str:
    """Short sensor label for tables: a file's stem (``.toml`` removed) or the name itself."""
    base = name.replace("\\", "/").rsplit("/", 1)[-1]
    return base[:-5] if base.endswith(".toml") else base


# ---------------------------------------------------------------------------- the file schema

def _distances(v: Any) -> tuple[float, ...]:
    """``distances_m``: a number or a non-empty list of them, positive, increasing and distinct."""
    if isinstance(v, numbers.Real) and not isinstance(v, bool):
        v = [v]
    if not isinstance(v, list) or not v or not all(isinstance(x, numbers.Real) and not isinstance(x, bool)
                                                   for x in v):
        raise invalid(f"must be a non-empty list of numbers, got {v!r}", allowed="a non-empty list of numbers")
    if any(not np.isfinite(x) or x <= 0 for x in v) or sorted(v) != list(v) or len(set(v)) != len(v):
        raise invalid(f"must be positive, increasing and distinct, got {v}", allowed="> 0 m, increasing")
    return tuple(float(x) for x in v)


_Names = names_list()
_Distances = Annotated[tuple[float, ...], BeforeValidator(_distances)]
_Depth = Annotated[Real, Field(gt=0)]
_TargetFill = Annotated[Real, Field(gt=0, le=1)]
_ImageSide = Annotated[Int, Field(ge=8, le=8192)]
_Spp = Annotated[Int, Field(ge=1, le=1 << 20)]
_NoiseTarget = Annotated[Real, Field(gt=0, le=10)]
_MaxSpp = Annotated[Int, Field(ge=1, le=1 << 24)]
_DEFAULT_WAVELENGTHS = tuple(float(x) for x in parse_wavelength_range("400:700:10"))
_Checks = Annotated[Int, Field(ge=0, le=10000)]
_Engine = Annotated[Literal["mitsuba", "preview"],
                    BeforeValidator(lambda v: "preview" if v == "fast" else v)]  # "fast" = "preview"
_Integrator = Literal["rigsim", "volpath"]


class StudyTable(FileModel):
    """``[study]``: a name (default: the file's stem), free text, and the seed (>= 0)."""

    name: str | None = None
    description: str = ""
    seed: Annotated[Int, Field(ge=0)] = 1


class SweepTable(FileModel):
    """``[sweep]``: what is varied (rig, sensor and water files or names, distances in m, targets)."""

    rigs: _Names
    sensors: _Names
    waters: _Names
    distances_m: _Distances
    targets: _Names = ("colorchecker",)
    depth_m: _Depth | None = None
    target_fill: _TargetFill | None = None
    extend_visibility: Bool = True


class RenderTable(FileModel):
    """``[render]``: image size (px), paths per pixel, wavelengths (nm), engine and noise target."""

    width: _ImageSide = 128
    height: _ImageSide = 96
    spp: _Spp = 64
    wavelengths: WavelengthGrid = _DEFAULT_WAVELENGTHS
    engine: _Engine = "mitsuba"
    integrator: _Integrator = "rigsim"
    noise_target: _NoiseTarget | None = None
    max_spp: _MaxSpp | None = None
    check_with_mitsuba: _Checks = 0
    #: the fast engine's multiply scattered light (rigsim.preview.multiple): "auto" (default) where
    #: the water's wide-angle scattering matters, "on" always, "off" never (single scattering only)
    multiple_scattering: Literal["off", "on", "auto"] = "auto"

    @model_validator(mode="after")
    def _check(self) -> "RenderTable":
        if self.max_spp is not None and self.max_spp < self.spp:
            raise invalid(f"max_spp {self.max_spp} is below spp {self.spp}", field="max_spp",
                          allowed=f">= spp ({self.spp})")
        if self.check_with_mitsuba and self.engine != "preview":
            raise invalid("check_with_mitsuba checks the fast engine: it needs engine = \"fast\"",
                          field="check_with_mitsuba", allowed='0 with engine = "mitsuba"')
        return self

    def settings(self) -> RenderSettings:
        """The :class:`RenderSettings`."""
        return RenderSettings(width=self.width, height=self.height, spp=self.spp, wavelengths_nm=self.wavelengths,
                              engine=self.engine, integrator=self.integrator, noise_target=self.noise_target,
                              max_spp=self.max_spp, check_with_mitsuba=self.check_with_mitsuba,
                              multiple_scattering=self.multiple_scattering)


class CheckTable(FileModel):
    """``[check]``: the Monte Carlo checks' image size (px), paths per pixel and independent seeds."""

    width: _ImageSide = 96
    height: _ImageSide = 64
    spp: _Spp = 256
    seeds: Annotated[Int, Field(ge=2, le=64)] = 4
    max_seeds: Annotated[Int, Field(ge=2, le=1024)] | None = None
    target_se: Annotated[Real, Field(gt=0.0, le=1.0)] = 0.015
    integrator: _Integrator = "rigsim"
    reference: Literal["monte-carlo", "hybrid"] = "monte-carlo"
    hybrid_photons: Annotated[Int, Field(ge=10_000, le=1_000_000_000)] = 1_000_000
    hybrid_spp: Annotated[Int, Field(ge=1, le=65_536)] = 64
    hybrid_veil_renders: Annotated[Int, Field(ge=1, le=256)] = 16
    hybrid_veil_max_renders: Annotated[Int, Field(ge=1, le=1024)] | None = None
    hybrid_veil_sigma_px: Annotated[Real, Field(ge=0.0, le=64.0)] = 4.0
    hybrid_order: Annotated[Int, Field(ge=0, le=6)] | None = None
    hybrid_max_seeds: Annotated[Int, Field(ge=2, le=1024)] | None = None
    fast_noise_seeds: Annotated[Int, Field(ge=0, le=64)] = 0

    @model_validator(mode="after")
    def _two_stages(self) -> "CheckTable":
        for name in ("max_seeds", "hybrid_max_seeds"):
            v = getattr(self, name)
            if v is not None and v < self.seeds:
                raise invalid(f"{name} {v} is below seeds {self.seeds}", field=name, allowed=f">= seeds ({self.seeds})")
        v = self.hybrid_veil_max_renders
        if v is not None and v < self.hybrid_veil_renders:
            k = self.hybrid_veil_renders
            raise invalid(f"hybrid_veil_max_renders {v} is below hybrid_veil_renders {k}",
                          field="hybrid_veil_max_renders", allowed=f">= hybrid_veil_renders ({k})")
        return self

    def settings(self) -> CheckSettings:
        """The :class:`CheckSettings`."""
        return CheckSettings(width=self.width, height=self.height, spp=self.spp, seeds=self.seeds,
                             integrator=self.integrator, max_seeds=self.max_seeds, target_se=self.target_se,
                             reference=self.reference, hybrid_photons=self.hybrid_photons,
                             hybrid_spp=self.hybrid_spp, hybrid_veil_renders=self.hybrid_veil_renders,
                             hybrid_veil_max_renders=self.hybrid_veil_max_renders,
                             hybrid_veil_sigma_px=self.hybrid_veil_sigma_px, hybrid_order=self.hybrid_order,
                             hybrid_max_seeds=self.hybrid_max_seeds, fast_noise_seeds=self.fast_noise_seeds)


class CaptureTable(FileModel):
    """``[capture]``: exposure (``auto``, or ``manual`` ISO and shutter in s), white balance, demosaicing."""

    exposure: Literal["auto", "manual"] = "auto"
    iso: Annotated[Real, Field(ge=1)] = 100.0
    shutter_s: Annotated[Real, Field(gt=0, le=3600), Unit("s")] = 1 / 125
    white_balance: str = "auto"
    demosaic: str = "Malvar2004"
    target_percentile: Annotated[Real, Field(ge=1, le=100)] = 99.0
    target_level: Annotated[Real, Field(gt=0, le=1)] = 0.8
    save_raw: Bool = False  # also write each capture's raw mosaic as a DNG (cases/<id>/<sensor>.dng)

    @field_validator("white_balance")
    @classmethod
    def _wb(cls, v: str) -> str:
        from rigsim.sensor.white_balance import WHITE_BALANCE_METHODS

        if v != "auto" and v not in WHITE_BALANCE_METHODS:
            exc = unknown_name_error("white balance", v, ["auto", *WHITE_BALANCE_METHODS])
            raise invalid(exc.message, allowed=exc.allowed)
        return v

    @field_validator("demosaic")
    @classmethod
    def _demosaic(cls, v: str) -> str:
        from rigsim.sensor.demosaic import DEMOSAICING_METHODS

        if v not in DEMOSAICING_METHODS:
            exc = unknown_name_error("demosaicing method", v, DEMOSAICING_METHODS)
            raise invalid(exc.message, allowed=exc.allowed)
        return v

    def settings(self) -> CaptureSettings:
        """The :class:`CaptureSettings`."""
        return CaptureSettings(exposure=self.exposure, iso=self.iso, shutter_s=self.shutter_s,
                               white_balance=self.white_balance, demosaic=self.demosaic,
                               target_percentile=self.target_percentile, target_level=self.target_level,
                               save_raw=self.save_raw)


class MetricsTable(FileModel):
    """``[metrics]``: the contrast threshold of the visibility range (0 < C <= 1)."""

    contrast_threshold: Annotated[Real, Field(gt=0, le=1)] = 0.02


class QuickTable(FileModel):
    """``[quick]``: render and sweep values used instead with ``--quick`` (CI)."""

    width: _ImageSide | None = None
    height: _ImageSide | None = None
    spp: _Spp | None = None
    wavelengths: WavelengthGrid | None = None
    engine: _Engine | None = None
    integrator: _Integrator | None = None
    noise_target: _NoiseTarget | None = None
    max_spp: _MaxSpp | None = None
    check_with_mitsuba: _Checks | None = None
    rigs: _Names | None = None
    sensors: _Names | None = None
    waters: _Names | None = None
    distances_m: _Distances | None = None
    targets: _Names | None = None
    depth_m: _Depth | None = None
    target_fill: _TargetFill | None = None
    extend_visibility: Bool | None = None
    check: CheckTable | None = None  # the [check] table's values with --quick


class StudyFile(FileModel):
    """A whole study file (see the module docstring)."""

    study: StudyTable = StudyTable()
    sweep: SweepTable
    render: RenderTable = RenderTable()
    capture: CaptureTable = CaptureTable()
    metrics: MetricsTable = MetricsTable()
    check: CheckTable = CheckTable()
    quick: QuickTable | None = None


def _resolve(p: str, base: Path) -> str:
    q = Path(p)
    return str(q if q.is_absolute() else (base / q).resolve())


def _with_quick(doc: dict, path: Path) -> StudyFile:
    """The study with its ``[quick]`` values in place (and one batch unless ``[quick]`` asks for more)."""
    quick = doc.get("quick", {})
    sweep_keys = set(SweepTable.model_fields)
    render = {k: v for k, v in doc.get("render", {}).items() if k not in ("noise_target", "max_spp")}
    sweep = dict(doc["sweep"])
    check = doc.get("check", {})
    for k, v in quick.items():
        if k == "check":
            check = {**check, **v} if isinstance(v, dict) else v
        else:
            (sweep if k in sweep_keys else render)[k] = v
    try:
        return validate(StudyFile, {**doc, "sweep": sweep, "render": render, "check": check, "quick": quick},
                        file=path)
    except ConfigError as exc:  # a check across keys that failed because of a [quick] value: say so
        key = (exc.field or "").split(".", 1)[-1]
        if key in quick:
            raise ConfigError(exc.message, file=path, field=f"quick.{key}", allowed=exc.allowed) from None
        raise


def load_study(path: str | Path, *, quick: bool = False) -> StudySpec:
    """Read and validate a study file: every rig, sensor and water is loaded (so a typo fails
    here, before any rendering), distances and targets are checked.

    Parameters
    ----------
    path
        The study TOML (relative rig, sensor, water and mesh files resolve against its folder).
    quick
        Use the ``[quick]`` table's values (small images, few paths; one batch).

    Raises
    ------
    ConfigError
        One line naming the file, the field (``sweep.waters[0]``, ``render.spp``) and
        what is allowed.
    """
    path = Path(path)
    doc = read_toml(path)
    f = validate(StudyFile, doc, file=path)
    if quick:
        f = _with_quick(doc, path)
    base = path.parent
    sweep = f.sweep

    # --- sweep: every file and name is loaded now
    rig_files = [_resolve(r, base) for r in sweep.rigs]
    rig_names = []
    try:
        from rigsim.config.rig import load_rig
    except ImportError as exc:  # pragma: no cover - during development only
        raise RigsimError(f"rig files cannot be read: {exc}") from None
    for i, rf in enumerate(rig_files):
        try:
            rig_names.append(load_rig(rf).name)
        except ConfigError as exc:
            raise ConfigError(f"rig {i}: {exc}", file=path, field=f"sweep.rigs[{i}]") from None
    if len(set(rig_names)) != len(rig_names):
        raise ConfigError(f"rig names must differ, got {rig_names}", file=path, field="sweep.rigs")

    from rigsim.sensor import load_sensor

    for i, s in enumerate(sweep.sensors):
        try:
            load_sensor(s if not s.endswith(".toml") else _resolve(s, base))
        except ConfigError as exc:
            raise ConfigError(f"sensor {s!r}: {exc}", file=path, field=f"sweep.sensors[{i}]") from None
    sensors = [s if not s.endswith(".toml") else _resolve(s, base) for s in sweep.sensors]

    from rigsim.config.water import load_water

    waters, water_names = [], []
    for i, w in enumerate(sweep.waters):
        spec = _resolve(w, base) if w.endswith(".toml") else w
        try:
            water = load_water(spec)
        except ConfigError as exc:
            raise ConfigError(f"{exc}", file=path, field=f"sweep.waters[{i}]") from None
        waters.append(spec)
        water_names.append(water.name)

    for i, t in enumerate(sweep.targets):
        if t not in TARGETS and not Path(_resolve(t, base)).is_file():
            raise unknown_name_error("target", t, TARGETS, file=path, field=f"sweep.targets[{i}]")
    targets = [t if t in TARGETS else _resolve(t, base) for t in sweep.targets]

    return StudySpec(
        name=f.study.name if f.study.name is not None else path.stem, description=f.study.description,
        seed=f.study.seed, rigs=tuple(rig_files), rig_names=tuple(rig_names), sensors=tuple(sensors),
        waters=tuple(waters), water_names=tuple(water_names), distances_m=sweep.distances_m,
        targets=tuple(targets), depth_m=sweep.depth_m, target_fill=sweep.target_fill, render=f.render.settings(),
        capture=f.capture.settings(), contrast_threshold=f.metrics.contrast_threshold,
        source=str(path.resolve()), quick=quick, check=f.check.settings(), extend_visibility=sweep.extend_visibility)
