"""Dataset specs (TOML): the distributions each sample is drawn from.

::

    [dataset]
    name = "underwater-training"
    width = 128
    height = 96
    spp = 64                                      # Monte Carlo paths per pixel (engine "mitsuba")
    engine = "mitsuba"                            # or "fast": the fast engine (photograph-sized samples
                                                  # in seconds; rigsim.preview), Monte Carlo noise-free
    snow_labels = "instances"                     # marine-snow specks in COCO/YOLO: each an instance, "crowd"
                                                  # (one iscrowd region per image, no YOLO lines) or "none"
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

    [seabed]                                      # seabed scenes (rigsim.scene.seabed), instead of the above
    probability = 0.0                             # share of samples that are seabed scenes
    altitude_m = [0.8, 2.5]                       # the rig above the mean sand level
    camera_pitch_deg = [20, 60]                   # the whole rig turned down
    ripple_wavelength_m = [0.15, 0.4]             # sand ripples (uniform), their height,
    ripple_height_m = [0.0, 0.04]
    relief_m = [0.0, 0.25]                        # undulation (rms) and slope
    slope_deg = [0, 10]
    rocks = [0, 4]                                # meshes of [scene] meshes lying partly buried,
    rock_size_m = [0.15, 0.6]                     # log-uniform sizes
    rubble = [0, 25]
    rubble_size_m = [0.03, 0.1]
    rock_reflectances = "benthic"                 # rocks covered in sand or algae (Maritorena et al. 1994)
    extent_m = 12.0                               # the patch's side and its grid (>= 4 cells a ripple)
    cells = 384

    [daylight]                                    # daylight besides the rig's lights (Kd model, clear sky)
    probability = 0.0
    depth_m = [3, 20]                             # camera depth (uniform)
    sun_zenith_deg = [10, 60]                     # sun zenith angle (uniform; azimuth uniform)

Every range is checked when the spec is read, so an impossible range fails before rendering.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BeforeValidator, Field, field_validator

from rigsim.schema import Bool, FileModel, Int, Real, WavelengthGrid, invalid, load_file, names_list
from rigsim.errors import ConfigError, unknown_name_error
from rigsim.spectrum import parse_wavelength_range

__all__ = ["DatasetSpec", "load_dataset_spec", "OBJECT_KINDS", "DatasetFile"]

#: Object kinds a dataset scene can hold.
OBJECT_KINDS = ("colorchecker", "white-disk", "black-disk", "slanted-edge", "mesh")


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
    particle_levels: tuple[str, ...]
    particle_probability: float
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
    engine: str = "mitsuba"
    snow_labels: str = "instances"  # marine-snow specks in COCO/YOLO (rigsim.dataset.formats.SNOW_LABELS)
    seabed: dict | None = None  # the [seabed] table's ranges (None: no seabed scenes)
    daylight: dict | None = None  # the [daylight] table's ranges (None: strobes only)

    def describe(self) -> dict:
        from dataclasses import asdict

        return asdict(self)


# ---------------------------------------------------------------------------- the file schema

def value_range(*, lo: float = 0.0, hi: float = math.inf, positive: bool = False, integer: bool = False) -> Any:
    """The type of a range ``[lo, hi]`` (a single number x means ``[x, x]``) drawn from.

    Parameters
    ----------
    lo, hi
        Bounds the range must lie in.
    positive
        The lower end must be > 0 (log-uniform draws) instead of >= ``lo``.
    integer
        Both ends whole numbers.
    """
    allowed = f"[lo, hi] with {'0 <' if positive else f'{lo:g} <='} lo <= hi" + (
        f" <= {hi:g}" if math.isfinite(hi) else "")

    def check(v: Any) -> tuple[float, float]:
        if isinstance(v, numbers.Real) and not isinstance(v, bool):
            v = [v, v]
        if not (isinstance(v, (list, tuple)) and len(v) == 2
                and all(isinstance(x, numbers.Real) and not isinstance(x, bool) for x in v)):
            raise invalid(f"must be a range [lo, hi], got {v!r}", allowed=allowed)
        a, b = float(v[0]), float(v[1])
        if not (math.isfinite(a) and math.isfinite(b)) or a > b or a < lo or b > hi or (positive and a <= 0):
            raise invalid(f"impossible range [{a:g}, {b:g}]", allowed=allowed)
        if integer and (a != int(a) or b != int(b)):
            raise invalid(f"must be whole numbers, got [{a:g}, {b:g}]", allowed=allowed)
        return a, b

    return Annotated[tuple[float, float], BeforeValidator(check)]


_Probability = Annotated[Real, Field(ge=0, le=1)]
_Names = names_list(allow_empty=True)


class DatasetTable(FileModel):
    """``[dataset]``: name, image size (px), paths per pixel and wavelengths (nm)."""

    name: str | None = None
    description: str = ""
    width: Annotated[Int, Field(ge=8, le=4096)] = 128
    height: Annotated[Int, Field(ge=8, le=4096)] = 96
    spp: Annotated[Int, Field(ge=1, le=1 << 16)] = 64
    engine: Literal["mitsuba", "fast"] = "mitsuba"
    snow_labels: Literal["instances", "crowd", "none"] = "instances"
    wavelengths: WavelengthGrid = tuple(float(x) for x in parse_wavelength_range("400:700:10"))


class WaterRanges(FileModel):
    """``[water]``: presets drawn uniformly, or constituents (log-uniform chl and CDOM, uniform particles);
    with probability ``particle_probability`` marine snow of one of ``particle_levels`` (uniformly), its
    placement seeded per sample."""

    presets: _Names = ("clear", "coastal")
    constituent_probability: _Probability = 0.0
    chl_mg_per_m3: value_range(positive=True) = (0.01, 10.0)
    cdom_a440_per_m: value_range(positive=True) = (0.001, 0.5)
    small_particles_ppm: value_range() = (0.0, 0.3)
    large_particles_ppm: value_range() = (0.0, 0.5)
    particle_levels: _Names = ("clear-ocean", "coastal")
    particle_probability: _Probability = 0.0


class RigRanges(FileModel):
    """``[rig]``: rig files and the power setting (fraction of full power, uniform)."""

    files: _Names = ()
    power_fraction: value_range(hi=1.0, positive=True) = (1.0, 1.0)


class SensorTable(FileModel):
    """``[sensor]``: sensor names or files, and whether the sensor adds noise."""

    names: _Names = ("sony_ilce-7rm2",)
    noise: Bool = True


class SceneRanges(FileModel):
    """``[scene]``: distances (m), object counts, kinds, sizes (fraction of the field of view) and the bottom."""

    distance_m: value_range(positive=True) = (0.8, 4.0)
    objects: value_range(lo=1, hi=20, integer=True) = (1, 3)
    kinds: _Names = ("colorchecker", "white-disk", "mesh")
    meshes: _Names = ()
    size_fraction: value_range(hi=1.0, positive=True) = (0.1, 0.35)
    reflectances: Literal["training", "colorchecker", "benthic"] = "training"
    bottom_probability: _Probability = 0.5
    bottom_altitude_m: value_range(positive=True) = (0.6, 3.0)

    @field_validator("kinds")
    @classmethod
    def _kinds(cls, v: tuple[str, ...]) -> tuple[str, ...]:
        if not v:  # found by tools/soak.py: an empty list reached rng.choice (a traceback)
            raise invalid("must name at least one object kind", allowed=", ".join(OBJECT_KINDS))
        for i, k in enumerate(v):
            if k not in OBJECT_KINDS:
                exc = unknown_name_error("object kind", k, OBJECT_KINDS)
                raise invalid(exc.message, field=f"[{i}]", allowed=exc.allowed)
        return v


class SeabedRanges(FileModel):
    """``[seabed]``: with ``probability`` a sample is a seabed scene (:mod:`rigsim.scene.seabed`): the rig
    ``altitude_m`` above a sand height field, turned ``camera_pitch_deg`` down; the scene's objects,
    ``rocks`` and ``rubble`` (meshes of ``[scene] meshes``, default the shipped rock, in random poses)
    rest on it where random pixels' rays meet it."""

    probability: _Probability = 0.0
    altitude_m: value_range(positive=True) = (0.8, 2.5)
    camera_pitch_deg: value_range(lo=0.0, hi=89.0) = (20.0, 60.0)
    ripple_wavelength_m: value_range(lo=0.05, hi=5.0) = (0.15, 0.4)
    ripple_height_m: value_range(lo=0.0, hi=0.5) = (0.0, 0.04)
    relief_m: value_range(lo=0.0, hi=2.0) = (0.0, 0.25)
    slope_deg: value_range(lo=0.0, hi=30.0) = (0.0, 10.0)
    rocks: value_range(lo=0, hi=50, integer=True) = (0, 4)
    rock_size_m: value_range(positive=True, hi=5.0) = (0.15, 0.6)
    rubble: value_range(lo=0, hi=200, integer=True) = (0, 25)
    rubble_size_m: value_range(positive=True, hi=1.0) = (0.03, 0.1)
    extent_m: Annotated[Real, Field(ge=2.0, le=100.0)] = 12.0
    cells: Annotated[Int, Field(ge=16, le=2048)] = 384
    rock_reflectances: Literal["benthic", "training", "colorchecker"] = "benthic"


class DaylightRanges(FileModel):
    """``[daylight]``: with ``probability`` a sample is also lit by daylight (:class:`~rigsim.scene.types.Daylight`,
    the Kd model under a clear sky): the camera ``depth_m`` below the surface, the sun ``sun_zenith_deg``
    from the zenith at a uniform azimuth; targets shadow the sun (and the strobes)."""

    probability: _Probability = 0.0
    depth_m: value_range(positive=True, hi=200.0) = (3.0, 20.0)
    sun_zenith_deg: value_range(lo=0.0, hi=85.0) = (10.0, 60.0)


class DatasetFile(FileModel):
    """A whole dataset spec (see the module docstring)."""

    dataset: DatasetTable = DatasetTable()
    water: WaterRanges = WaterRanges()
    rig: RigRanges = RigRanges()
    sensor: SensorTable = SensorTable()
    scene: SceneRanges = SceneRanges()
    seabed: SeabedRanges = SeabedRanges()
    daylight: DaylightRanges = DaylightRanges()


def _resolve(p: str, base: Path) -> str:
    q = Path(p)
    return str(q if q.is_absolute() else (base / q).resolve())


def load_dataset_spec(path: str | Path) -> DatasetSpec:
    """Read and validate a dataset spec; rigs, sensors, presets and meshes are all loaded here.

    Raises
    ------
    ConfigError
        One line naming the file, the field (``scene.distance_m``) and what is allowed.
    """
    path = Path(path)
    f = load_file(DatasetFile, path)
    base = path.parent
    ds, wt, rg, sn, sc = f.dataset, f.water, f.rig, f.sensor, f.scene
    sb = f.seabed
    if sb.probability > 0 and sb.ripple_height_m[1] > 0:  # a grid too coarse for the shortest ripples: now
        from rigsim.scene.seabed import SeabedSpec

        try:
            SeabedSpec(extent_m=sb.extent_m, cells=sb.cells, ripple_wavelength_m=sb.ripple_wavelength_m[0],
                       ripple_height_m=sb.ripple_height_m[1])
        except ConfigError as exc:
            raise ConfigError(exc.message, file=path, field="seabed." + str(exc.field).rsplit(".", 1)[-1],
                              allowed=exc.allowed) from None

    from rigsim.water.presets import preset

    for i, p in enumerate(wt.presets):
        try:
            preset(p)
        except ConfigError as exc:
            raise ConfigError(exc.message, file=path, field=f"water.presets[{i}]", allowed=exc.allowed) from None
    from rigsim.water.particles import particle_level

    for i, lv in enumerate(wt.particle_levels):
        try:
            particle_level(lv)
        except ConfigError as exc:
            raise ConfigError(exc.message, file=path, field=f"water.particle_levels[{i}]", allowed=exc.allowed) from None
    if wt.particle_probability > 0 and not wt.particle_levels:
        raise ConfigError("no particle levels to draw from", file=path, field="water.particle_levels",
                          allowed="at least one level, or particle_probability = 0")
    if not wt.presets and wt.constituent_probability < 1.0:
        raise ConfigError("no presets to draw from", file=path, field="water.presets",
                          allowed="at least one preset, or constituent_probability = 1")

    from rigsim.config.rig import load_rig
    from rigsim.scene.optics import port_reach_m

    rigs = [_resolve(r, base) for r in rg.files]
    if not rigs:
        raise ConfigError("no rig files", file=path, field="rig.files", allowed="a list of rig TOML files")
    port_reach = []
    for i, r in enumerate(rigs):
        try:
            rig = load_rig(r)
        except ConfigError as exc:
            raise ConfigError(str(exc), file=path, field=f"rig.files[{i}]") from None
        port_reach.append(port_reach_m(rig.camera))

    from rigsim.sensor import load_sensor

    if not sn.names:
        raise ConfigError("no sensors", file=path, field="sensor.names")
    for i, s in enumerate(sn.names):
        try:
            load_sensor(s)
        except ConfigError as exc:
            raise ConfigError(str(exc), file=path, field=f"sensor.names[{i}]") from None

    dist = sc.distance_m
    if dist[0] <= max(port_reach) + 0.05:
        raise ConfigError(f"impossible range [{dist[0]:g}, {dist[1]:g}]: objects would touch the port "
                          f"(reaches {max(port_reach):.3f} m)", file=path, field="scene.distance_m",
                          allowed=f"lo > {max(port_reach) + 0.05:.2f} m")
    meshes = [_resolve(m, base) for m in sc.meshes]
    if "mesh" in sc.kinds and not meshes:
        meshes = [str(Path(__file__).resolve().parents[2] / "data" / "meshes" / "rock.obj")]
    from rigsim.scene.meshes import mesh_vertices

    for i, m in enumerate(meshes):
        try:
            mesh_vertices(m)
        except ConfigError as exc:
            raise ConfigError(str(exc), file=path, field=f"scene.meshes[{i}]") from None
    return DatasetSpec(
        name=ds.name if ds.name is not None else path.stem, source=str(path.resolve()), width=ds.width,
        height=ds.height, spp=ds.spp, wavelengths_nm=ds.wavelengths, presets=wt.presets,
        constituent_probability=wt.constituent_probability, chl_mg_per_m3=wt.chl_mg_per_m3,
        cdom_a440_per_m=wt.cdom_a440_per_m, small_particles_ppm=wt.small_particles_ppm,
        large_particles_ppm=wt.large_particles_ppm, particle_levels=wt.particle_levels,
        particle_probability=wt.particle_probability, rigs=tuple(rigs), power_fraction=rg.power_fraction,
        sensors=sn.names, noise=sn.noise, distance_m=dist, objects=(int(sc.objects[0]), int(sc.objects[1])),
        kinds=sc.kinds, meshes=tuple(meshes), size_fraction=sc.size_fraction, reflectances=sc.reflectances,
        bottom_probability=sc.bottom_probability, bottom_altitude_m=sc.bottom_altitude_m, engine=ds.engine,
        snow_labels=ds.snow_labels,
        seabed=sb.model_dump() if sb.probability > 0 else None,
        daylight=f.daylight.model_dump() if f.daylight.probability > 0 else None)
