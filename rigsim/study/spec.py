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
    engine = "mitsuba"      # or "preview"
    integrator = "rigsim"   # or "volpath"
    noise_target = 0.2      # optional: more batches of spp until the Monte Carlo noise is below this
    max_spp = 512           # optional: ... but at most this many paths per pixel (default 8 × spp)

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
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from rigsim.config.tomlfile import check_keys, get_number, read_toml
from rigsim.errors import ConfigError, RigsimError
from rigsim.spectrum import parse_wavelength_range

__all__ = ["RenderSettings", "CaptureSettings", "StudySpec", "Case", "load_study", "TARGETS"]

#: Built-in target names (besides mesh files).
TARGETS = ("colorchecker", "black-disk", "white-disk", "slanted-edge", "bottom")

_STUDY_KEYS = ("name", "description", "seed")
_SWEEP_KEYS = ("rigs", "sensors", "waters", "distances_m", "targets", "depth_m", "target_fill")
_RENDER_KEYS = ("width", "height", "spp", "wavelengths", "engine", "integrator", "noise_target", "max_spp")
_CAPTURE_KEYS = ("exposure", "iso", "shutter_s", "white_balance", "demosaic", "target_percentile",
                 "target_level")
_METRIC_KEYS = ("contrast_threshold",)
_QUICK_KEYS = _RENDER_KEYS + _SWEEP_KEYS


@dataclass(frozen=True)
class RenderSettings:
    """How each scene is rendered (sizes in pixels, wavelengths in nm)."""

    width: int = 128
    height: int = 96
    spp: int = 64
    wavelengths_nm: tuple[float, ...] = tuple(np.arange(400.0, 701.0, 10.0))
    engine: str = "mitsuba"
    integrator: str = "rigsim"
    #: render in batches of ``spp`` until the noise (:func:`rigsim.render.renderer.relative_noise_p99`)
    #: is below this, up to ``max_spp`` (None: one batch)
    noise_target: float | None = None
    max_spp: int | None = None


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

    def key(self) -> dict:
        return asdict(self)


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

    def cases(self) -> list[Case]:
        """All scenes, in a fixed order (rig, water, target, distance)."""
        out = []
        for rig, rn in zip(self.rigs, self.rig_names):
            for w, wn in zip(self.waters, self.water_names):
                for t in self.targets:
                    for d in self.distances_m:
                        out.append(Case(rig, rn, w, wn, float(d), t, self.depth_m, self.target_fill))
        return out

    def describe(self) -> dict:
        d = asdict(self)
        d.pop("extra", None)
        return d

    def case_id(self, case: Case) -> str:
        """Stable id of a case: readable prefix + hash of everything that changes its result."""
        render = {k: v for k, v in asdict(self.render).items()
                  if not (k in ("noise_target", "max_spp") and v is None)}  # ids of older studies stay
        payload = {"case": case.key(), "render": render, "capture": asdict(self.capture),
                   "sensors": list(self.sensors), "seed": self.seed}
        h = hashlib.sha1(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:10]
        safe = lambda s: "".join(c if c.isalnum() or c in "-_." else "-" for c in s)  # noqa: E731
        return f"{safe(case.rig_name)}__{safe(case.water_name)}__{safe(case.target)}__{case.distance_m:g}m__{h}"

    def case_seed(self, case: Case) -> int:
        """Seed of a case: derived from the study seed and the case's inputs (order-independent)."""
        h = hashlib.sha1(json.dumps({"seed": self.seed, "case": case.key()}, sort_keys=True).encode())
        return int(h.hexdigest()[:8], 16)


def sensor_key(name: str) -> str:
    """Short sensor label for tables: a file's stem (``.toml`` removed) or the name itself."""
    base = name.replace("\\", "/").rsplit("/", 1)[-1]
    return base[:-5] if base.endswith(".toml") else base


def _str_list(t: dict, key: str, *, file, prefix: str) -> list[str]:
    v = t.get(key)
    if v is None:
        raise ConfigError("missing", file=file, field=f"{prefix}{key}", allowed="a non-empty list")
    if isinstance(v, str):
        v = [v]
    if not isinstance(v, list) or not v or not all(isinstance(x, str) for x in v):
        raise ConfigError(f"must be a non-empty list of names, got {v!r}", file=file, field=f"{prefix}{key}")
    return v


def _num_list(t: dict, key: str, *, file, prefix: str) -> list[float]:
    v = t.get(key)
    if v is None:
        raise ConfigError("missing", file=file, field=f"{prefix}{key}", allowed="a non-empty list of numbers")
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        v = [v]
    if not isinstance(v, list) or not v or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                   for x in v):
        raise ConfigError(f"must be a non-empty list of numbers, got {v!r}", file=file, field=f"{prefix}{key}")
    if any(x <= 0 for x in v) or sorted(v) != list(v) or len(set(v)) != len(v):
        raise ConfigError(f"must be positive, increasing and distinct, got {v}", file=file,
                          field=f"{prefix}{key}", allowed="> 0 m, increasing")
    return [float(x) for x in v]


def _resolve(p: str, base: Path) -> str:
    q = Path(p)
    return str(q if q.is_absolute() else (base / q).resolve())


def load_study(path: str | Path, *, quick: bool = False) -> StudySpec:
    """Read and validate a study file: every rig, sensor and water is loaded (so a typo fails
    here, before any rendering), distances and targets are checked."""
    path = Path(path)
    doc = read_toml(path)
    check_keys(doc, ("study", "sweep", "render", "capture", "metrics", "quick"), file=path)
    for sec, keys in (("study", _STUDY_KEYS), ("sweep", _SWEEP_KEYS), ("render", _RENDER_KEYS),
                      ("capture", _CAPTURE_KEYS), ("metrics", _METRIC_KEYS), ("quick", _QUICK_KEYS)):
        if sec in doc:
            if not isinstance(doc[sec], dict):
                raise ConfigError("must be a table", file=path, field=sec)
            check_keys(doc[sec], keys, file=path, prefix=f"{sec}.")
    if "sweep" not in doc:
        raise ConfigError("missing [sweep] table", file=path, field="sweep")
    study = doc.get("study", {})
    sweep = dict(doc["sweep"])
    render = dict(doc.get("render", {}))
    if quick:
        # the quick run renders one batch unless [quick] asks for a noise target itself
        for k in ("noise_target", "max_spp"):
            render.pop(k, None)
    if quick and "quick" in doc:
        for k, v in doc["quick"].items():
            (sweep if k in _SWEEP_KEYS else render)[k] = v
    base = path.parent

    # --- sweep
    rig_files = [_resolve(r, base) for r in _str_list(sweep, "rigs", file=path, prefix="sweep.")]
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

    sensors = _str_list(sweep, "sensors", file=path, prefix="sweep.")
    from rigsim.sensor import load_sensor

    for i, s in enumerate(sensors):
        try:
            load_sensor(s if not s.endswith(".toml") else _resolve(s, base))
        except ConfigError as exc:
            raise ConfigError(f"sensor {s!r}: {exc}", file=path, field=f"sweep.sensors[{i}]") from None
    sensors = [s if not s.endswith(".toml") else _resolve(s, base) for s in sensors]

    from rigsim.config.water import load_water

    waters, water_names = [], []
    for i, w in enumerate(_str_list(sweep, "waters", file=path, prefix="sweep.")):
        spec = _resolve(w, base) if w.endswith(".toml") else w
        try:
            water = load_water(spec)
        except ConfigError as exc:
            raise ConfigError(f"{exc}", file=path, field=f"sweep.waters[{i}]") from None
        waters.append(spec)
        water_names.append(water.name)

    distances = _num_list(sweep, "distances_m", file=path, prefix="sweep.")
    targets = _str_list(sweep, "targets", file=path, prefix="sweep.") if "targets" in sweep else ["colorchecker"]
    for i, t in enumerate(targets):
        if t not in TARGETS and not Path(_resolve(t, base)).is_file():
            from rigsim.errors import unknown_name_error

            raise unknown_name_error("target", t, TARGETS, file=path, field=f"sweep.targets[{i}]")
    targets = [t if t in TARGETS else _resolve(t, base) for t in targets]
    depth = get_number(sweep, "depth_m", file=path, prefix="sweep.", minimum=0.0)
    fill = get_number(sweep, "target_fill", file=path, prefix="sweep.", minimum=0.0, exclusive_minimum=True,
                      maximum=1.0)

    # --- render
    wl = render.get("wavelengths", "400:700:10")
    try:
        wls = parse_wavelength_range(str(wl)) if not isinstance(wl, list) else np.array(wl, float)
    except ConfigError as exc:
        raise ConfigError(exc.message, file=path, field="render.wavelengths", allowed=exc.allowed) from None
    engine = render.get("engine", "mitsuba")
    if engine not in ("mitsuba", "preview"):
        raise ConfigError(f"unknown engine {engine!r}", file=path, field="render.engine", allowed="mitsuba, preview")
    integ = render.get("integrator", "rigsim")
    if integ not in ("rigsim", "volpath"):
        raise ConfigError(f"unknown integrator {integ!r}", file=path, field="render.integrator",
                          allowed="rigsim (equiangular light sampling), volpath (Mitsuba's)")
    rs = RenderSettings(
        width=int(get_number(render, "width", file=path, prefix="render.", default=128, minimum=8, maximum=8192)),
        height=int(get_number(render, "height", file=path, prefix="render.", default=96, minimum=8, maximum=8192)),
        spp=int(get_number(render, "spp", file=path, prefix="render.", default=64, minimum=1, maximum=1 << 20)),
        wavelengths_nm=tuple(float(x) for x in wls), engine=engine, integrator=integ,
        noise_target=get_number(render, "noise_target", file=path, prefix="render.", default=None, minimum=0.0,
                                exclusive_minimum=True, maximum=10.0),
        max_spp=(None if "max_spp" not in render else
                 int(get_number(render, "max_spp", file=path, prefix="render.", minimum=1, maximum=1 << 24))))
    if rs.max_spp is not None and rs.max_spp < rs.spp:
        raise ConfigError(f"max_spp {rs.max_spp} is below spp {rs.spp}", file=path, field="render.max_spp",
                          allowed=f">= spp ({rs.spp})")

    cap = doc.get("capture", {})
    mode = cap.get("exposure", "auto")
    if mode not in ("auto", "manual"):
        raise ConfigError(f"unknown exposure mode {mode!r}", file=path, field="capture.exposure",
                          allowed="auto, manual")
    from rigsim.sensor.demosaic import DEMOSAICING_METHODS
    from rigsim.sensor.white_balance import WHITE_BALANCE_METHODS

    wb = cap.get("white_balance", "auto")
    if wb != "auto" and wb not in WHITE_BALANCE_METHODS:
        from rigsim.errors import unknown_name_error

        raise unknown_name_error("white balance", str(wb), ["auto", *WHITE_BALANCE_METHODS], file=path,
                                 field="capture.white_balance")
    dm = cap.get("demosaic", "Malvar2004")
    if dm not in DEMOSAICING_METHODS:
        from rigsim.errors import unknown_name_error

        raise unknown_name_error("demosaicing method", str(dm), DEMOSAICING_METHODS, file=path,
                                 field="capture.demosaic")
    cs = CaptureSettings(
        exposure=mode,
        iso=get_number(cap, "iso", file=path, prefix="capture.", default=100.0, minimum=1.0),
        shutter_s=get_number(cap, "shutter_s", file=path, prefix="capture.", default=1 / 125, minimum=0.0,
                             exclusive_minimum=True, maximum=3600.0),
        white_balance=wb, demosaic=dm,
        target_percentile=get_number(cap, "target_percentile", file=path, prefix="capture.", default=99.0,
                                     minimum=1.0, maximum=100.0),
        target_level=get_number(cap, "target_level", file=path, prefix="capture.", default=0.8,
                                minimum=0.0, exclusive_minimum=True, maximum=1.0))
    met = doc.get("metrics", {})
    thr = get_number(met, "contrast_threshold", file=path, prefix="metrics.", default=0.02, minimum=0.0,
                     exclusive_minimum=True, maximum=1.0)
    seed = get_number(study, "seed", file=path, prefix="study.", default=1, minimum=0)
    return StudySpec(
        name=str(study.get("name", path.stem)), description=str(study.get("description", "")),
        seed=int(seed), rigs=tuple(rig_files), rig_names=tuple(rig_names), sensors=tuple(sensors),
        waters=tuple(waters), water_names=tuple(water_names), distances_m=tuple(distances),
        targets=tuple(targets), depth_m=depth, target_fill=fill, render=rs, capture=cs, contrast_threshold=thr,
        source=str(path.resolve()), quick=quick)


def with_overrides(spec: StudySpec, **kw: Any) -> StudySpec:
    """A copy with some fields replaced (tests, CLI flags)."""
    return replace(spec, **kw)
