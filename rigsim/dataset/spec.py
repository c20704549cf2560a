"""Dataset specs (TOML): the distributions each sample is drawn from.

::

    [dataset]
    name = "underwater-training"
    width = 128
    height = 96
    spp = 64
    wavelengths = "400:700:10"

    [water]
    presets = ["clear", "coastal", "jerlov-II"]   # drawn uniformly ...
    constituent_probability = 0.5                 # ... or, with this probability, constituents:
    chl_mg_per_m3 = [0.01, 20.0]                  # log-uniform in [lo, hi] (lo > 0)
    cdom_a440_per_m = [0.001, 1.0]                # log-uniform
    small_particles_ppm = [0.0, 0.3]              # uniform
    large_particles_ppm = [0.0, 0.6]              # uniform

    [rig]
    files = ["../rigs/twin-strobes-45-wide.toml"]
    power_fraction = [0.25, 1.0]                  # strobe/video power setting, uniform

    [sensor]
    names = ["sony_ilce-7rm2", "action_cam_1-2.3in"]
    noise = true                                  # sensor noise on the underwater image

    [scene]
    distance_m = [0.8, 4.0]                       # camera → objects, uniform
    objects = [1, 3]                              # number of objects, uniform integer
    kinds = ["colorchecker", "white-disk", "mesh"]
    meshes = ["../data/meshes/rock.obj"]          # for kind "mesh"
    size_fraction = [0.1, 0.35]                   # object size / field-of-view width at its distance
    reflectances = "training"                     # disks/meshes: colour-science's 190 training spectra
    bottom_probability = 0.6                      # add a sand bottom below the camera
    bottom_altitude_m = [0.6, 3.0]

Every range is checked when the spec is read, so an impossible range fails before rendering.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigsim.config.tomlfile import check_keys, get_number, read_toml
from rigsim.errors import ConfigError, unknown_name_error
from rigsim.spectrum import parse_wavelength_range

__all__ = ["DatasetSpec", "load_dataset_spec", "OBJECT_KINDS"]

#: Object kinds a dataset scene can hold.
OBJECT_KINDS = ("colorchecker", "white-disk", "black-disk", "slanted-edge", "mesh")

_KEYS = {
    "dataset": ("name", "width", "height", "spp", "wavelengths", "description"),
    "water": ("presets", "constituent_probability", "chl_mg_per_m3", "cdom_a440_per_m", "small_particles_ppm",
              "large_particles_ppm"),
    "rig": ("files", "power_fraction"),
    "sensor": ("names", "noise"),
    "scene": ("distance_m", "objects", "kinds", "meshes", "size_fraction", "reflectances", "bottom_probability",
              "bottom_altitude_m"),
}


@dataclass(frozen=True)
class DatasetSpec:
    """A validated dataset spec (ranges are (lo, hi) tuples)."""

    name: str
    source: str
    width: int
    height: int
    spp: int
    wavelengths_nm: tuple[float, ...]
    presets: tuple[str, ...]
    constituent_probability: float
    chl_mg_per_m3: tuple[float, float]
    cdom_a440_per_m: tuple[float, float]
    small_particles_ppm: tuple[float, float]
    large_particles_ppm: tuple[float, float]
    rigs: tuple[str, ...]
    power_fraction: tuple[float, float]
    sensors: tuple[str, ...]
    noise: bool
    distance_m: tuple[float, float]
    objects: tuple[int, int]
    kinds: tuple[str, ...]
    meshes: tuple[str, ...]
    size_fraction: tuple[float, float]
    reflectances: str
    bottom_probability: float
    bottom_altitude_m: tuple[float, float]

    def describe(self) -> dict:
        from dataclasses import asdict

        return asdict(self)


def _range(t: dict, key: str, default, *, file, sec: str, lo: float, hi: float = np.inf,
           positive: bool = False, integer: bool = False) -> tuple[float, float]:
    field = f"{sec}.{key}"
    v = t.get(key, default)
    allowed = f"[lo, hi] with {'0 <' if positive else f'{lo:g} <='} lo <= hi" + (f" <= {hi:g}" if np.isfinite(hi) else "")
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        v = [v, v]
    if not (isinstance(v, list) and len(v) == 2 and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                        for x in v)):
        raise ConfigError(f"must be a range [lo, hi], got {v!r}", file=file, field=field, allowed=allowed)
    a, b = float(v[0]), float(v[1])
    if not (np.isfinite(a) and np.isfinite(b)) or a > b or a < lo or b > hi or (positive and a <= 0):
        raise ConfigError(f"impossible range [{a:g}, {b:g}]", file=file, field=field, allowed=allowed)
    if integer and (a != int(a) or b != int(b)):
        raise ConfigError(f"must be whole numbers, got [{a:g}, {b:g}]", file=file, field=field, allowed=allowed)
    return a, b


def _names(t: dict, key: str, default, *, file, sec: str) -> list[str]:
    v = t.get(key, default)
    if isinstance(v, str):
        v = [v]
    if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
        raise ConfigError(f"must be a list of names, got {v!r}", file=file, field=f"{sec}.{key}")
    return v


def _resolve(p: str, base: Path) -> str:
    q = Path(p)
    return str(q if q.is_absolute() else (base / q).resolve())


def load_dataset_spec(path: str | Path) -> DatasetSpec:
    """Read and validate a dataset spec; rigs, sensors, presets and meshes are all loaded here."""
    path = Path(path)
    doc = read_toml(path)
    check_keys(doc, _KEYS, file=path)
    for sec, keys in _KEYS.items():
        if sec in doc:
            if not isinstance(doc[sec], dict):
                raise ConfigError("must be a table", file=path, field=sec)
            check_keys(doc[sec], keys, file=path, prefix=f"{sec}.")
    base = path.parent
    ds, wt, rg, sn, sc = (doc.get(k, {}) for k in ("dataset", "water", "rig", "sensor", "scene"))

    width = int(get_number(ds, "width", file=path, prefix="dataset.", default=128, minimum=8, maximum=4096))
    height = int(get_number(ds, "height", file=path, prefix="dataset.", default=96, minimum=8, maximum=4096))
    spp = int(get_number(ds, "spp", file=path, prefix="dataset.", default=64, minimum=1, maximum=1 << 16))
    try:
        wls = parse_wavelength_range(str(ds.get("wavelengths", "400:700:10")))
    except ConfigError as exc:
        raise ConfigError(exc.message, file=path, field="dataset.wavelengths", allowed=exc.allowed) from None

    from rigsim.water.presets import preset

    presets = _names(wt, "presets", ["clear", "coastal"], file=path, sec="water")
    for i, p in enumerate(presets):
        try:
            preset(p)
        except ConfigError as exc:
            raise ConfigError(exc.message, file=path, field=f"water.presets[{i}]", allowed=exc.allowed) from None
    cprob = get_number(wt, "constituent_probability", file=path, prefix="water.", default=0.0, minimum=0.0,
                       maximum=1.0)
    if not presets and cprob < 1.0:
        raise ConfigError("no presets to draw from", file=path, field="water.presets",
                          allowed="at least one preset, or constituent_probability = 1")
    chl = _range(wt, "chl_mg_per_m3", [0.01, 10.0], file=path, sec="water", lo=0.0, positive=True)
    cdom = _range(wt, "cdom_a440_per_m", [0.001, 0.5], file=path, sec="water", lo=0.0, positive=True)
    small = _range(wt, "small_particles_ppm", [0.0, 0.3], file=path, sec="water", lo=0.0)
    large = _range(wt, "large_particles_ppm", [0.0, 0.5], file=path, sec="water", lo=0.0)

    from rigsim.config.rig import load_rig

    rigs = [_resolve(r, base) for r in _names(rg, "files", [], file=path, sec="rig")]
    if not rigs:
        raise ConfigError("no rig files", file=path, field="rig.files", allowed="a list of rig TOML files")
    port_reach = []
    for i, r in enumerate(rigs):
        try:
            rig = load_rig(r)
        except ConfigError as exc:
            raise ConfigError(str(exc), file=path, field=f"rig.files[{i}]") from None
        from rigsim.scene.optics import port_reach_m

        port_reach.append(port_reach_m(rig.camera))
    power = _range(rg, "power_fraction", [1.0, 1.0], file=path, sec="rig", lo=0.0, hi=1.0, positive=True)

    from rigsim.sensor import load_sensor

    sensors = _names(sn, "names", ["sony_ilce-7rm2"], file=path, sec="sensor")
    if not sensors:
        raise ConfigError("no sensors", file=path, field="sensor.names")
    for i, s in enumerate(sensors):
        try:
            load_sensor(s)
        except ConfigError as exc:
            raise ConfigError(str(exc), file=path, field=f"sensor.names[{i}]") from None
    noise = sn.get("noise", True)
    if not isinstance(noise, bool):
        raise ConfigError(f"must be true or false, got {noise!r}", file=path, field="sensor.noise")

    dist = _range(sc, "distance_m", [0.8, 4.0], file=path, sec="scene", lo=0.0, positive=True)
    if dist[0] <= max(port_reach) + 0.05:
        raise ConfigError(f"impossible range [{dist[0]:g}, {dist[1]:g}]: objects would touch the port "
                          f"(reaches {max(port_reach):.3f} m)", file=path, field="scene.distance_m",
                          allowed=f"lo > {max(port_reach) + 0.05:.2f} m")
    objects = _range(sc, "objects", [1, 3], file=path, sec="scene", lo=1, hi=20, integer=True)
    kinds = _names(sc, "kinds", ["colorchecker", "white-disk", "mesh"], file=path, sec="scene")
    for i, k in enumerate(kinds):
        if k not in OBJECT_KINDS:
            raise unknown_name_error("object kind", k, OBJECT_KINDS, file=path, field=f"scene.kinds[{i}]")
    meshes = [_resolve(m, base) for m in _names(sc, "meshes", [], file=path, sec="scene")]
    if "mesh" in kinds and not meshes:
        meshes = [str(Path(__file__).resolve().parents[2] / "data" / "meshes" / "rock.obj")]
    for i, m in enumerate(meshes):
        from rigsim.scene.meshes import mesh_vertices

        try:
            mesh_vertices(m)
        except ConfigError as exc:
            raise ConfigError(str(exc), file=path, field=f"scene.meshes[{i}]") from None
    size = _range(sc, "size_fraction", [0.1, 0.35], file=path, sec="scene", lo=0.0, hi=1.0, positive=True)
    refl = sc.get("reflectances", "training")
    if refl not in ("training", "colorchecker"):
        raise ConfigError(f"unknown reflectance library {refl!r}", file=path, field="scene.reflectances",
                          allowed="training (colour-science RAW to ACES, 190 spectra), colorchecker")
    bprob = get_number(sc, "bottom_probability", file=path, prefix="scene.", default=0.5, minimum=0.0, maximum=1.0)
    balt = _range(sc, "bottom_altitude_m", [0.6, 3.0], file=path, sec="scene", lo=0.0, positive=True)
    return DatasetSpec(
        name=str(ds.get("name", path.stem)), source=str(path.resolve()), width=width, height=height, spp=spp,
        wavelengths_nm=tuple(float(x) for x in wls), presets=tuple(presets), constituent_probability=cprob,
        chl_mg_per_m3=chl, cdom_a440_per_m=cdom, small_particles_ppm=small, large_particles_ppm=large,
        rigs=tuple(rigs), power_fraction=power, sensors=tuple(sensors), noise=noise, distance_m=dist,
        objects=(int(objects[0]), int(objects[1])), kinds=tuple(kinds), meshes=tuple(meshes), size_fraction=size,
        reflectances=refl, bottom_probability=bprob, bottom_altitude_m=balt)
