"""Rig files (TOML) → a typed, frozen :class:`~rigsim.scene.types.Rig`.

The format is documented in ``rigs/README.md``.  Parsing happens once, here;
everything downstream receives the ``Rig``.  The file's schema is a set of
pydantic models (:class:`RigFile` with :class:`RigTable`, :class:`CameraTable`,
:class:`PortTable` and :class:`LightTable`, all :class:`~rigsim.schema.FileModel`):
they hold the file's own conventions (arm length and angle, yaw and pitch, aim
points, spectrum names, makers' power ratings) and the file's limits, and convert to
the scene types, which check themselves.  Errors are one line naming the file, the
field path (``lights[1].beam_angle_deg``) and what is allowed.

Frames: the camera's ``position_m``, ``forward`` and ``up`` are in the world
(scene) frame.  Light positions, arms and aims are given in the *camera frame*
relative to the entrance pupil: components ``[right, up, forward]`` (m), where
*right* is the image's right, ``right = forward × up`` (right-handed world), and
*up* is the image's up.  They are converted to world coordinates here, so the
``Light`` objects in the ``Rig`` are in the world frame.

The conventions, and their inverses (for editors such as :mod:`rigsim.config.rigdoc`):

* arm: :func:`arm_to_position` / :func:`position_to_arm`;
* yaw and pitch: :func:`yaw_pitch_to_direction` / :func:`direction_to_yaw_pitch`;
* camera frame → world: :func:`camera_to_world` / :func:`world_to_camera`.

Examples
--------
>>> p = arm_to_position(0.45, 165.0, -0.1)
>>> [round(x, 6) for x in position_to_arm(p)]
[0.45, 165.0, -0.1]
>>> [round(x, 6) for x in direction_to_yaw_pitch(yaw_pitch_to_direction(-20.0, 5.0))]
[-20.0, 5.0]
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import BeforeValidator, Field, model_validator

from rigsim.schema import (
    Direction,
    FileModel,
    Real,
    Unit,
    Vec3,
    allowed_for,
    built,
    exclusive,
    invalid,
    read_toml,
    reported_at,
    validate,
)
from rigsim.light.beam import beam_from_csv, soft_cone
from rigsim.light.photometry import XENON_FLASH_EFFICACY_LM_S_PER_J
from rigsim.light.sources import strobe_light, video_light
from rigsim.light.spectra import SPECTRUM_METHODS
from rigsim.scene.types import BeamPattern, Camera, Light, Port, Rig

__all__ = ["load_rig", "parse_rig", "RigFile", "RigTable", "LimitsTable", "CameraTable", "PortTable", "LightTable",
           "SPECTRUM_NAMES", "DEFAULT_SPECTRUM", "arm_to_position", "position_to_arm", "yaw_pitch_to_direction",
           "direction_to_yaw_pitch", "camera_to_world", "world_to_camera"]

#: Named spectra a light may use (``blackbody:T`` and CSV files are accepted too).
SPECTRUM_NAMES: tuple[str, ...] = tuple(SPECTRUM_METHODS)
#: Spectrum of a light that names none, by the file's ``kind``.
DEFAULT_SPECTRUM = {"strobe": "xenon-strobe", "video": "daylight-led"}

_STROBE_ONLY = ("flash_energy_J", "guide_number_m", "guide_number_iso", "luminous_efficacy_lm_s_per_J",
                "power_fraction")
_VIDEO_ONLY = ("lumens",)
_PORT, _CAMERA = Port(), Camera()


# ---------------------------------------------------------------------------- the file's conventions

def arm_to_position(arm_length_m: float, arm_angle_deg: float = 0.0, arm_forward_m: float = 0.0) -> np.ndarray:
    """Camera-frame position ``[right, up, forward]`` (m) of a light on an arm.

    Parameters
    ----------
    arm_length_m
        Distance from the lens axis in the image plane (m).
    arm_angle_deg
        Angle from the image's right towards its up (deg): 0 = right, 90 = above,
        180 = left, 270 = below.
    arm_forward_m
        Offset along the lens axis (m; negative = behind the entrance pupil).
    """
    a = math.radians(arm_angle_deg)
    return np.array([arm_length_m * math.cos(a), arm_length_m * math.sin(a), float(arm_forward_m)])


def position_to_arm(position_m) -> tuple[float, float, float]:
    """Inverse of :func:`arm_to_position`: ``(arm_length_m, arm_angle_deg in [0, 360), arm_forward_m)``."""
    p = np.asarray(position_m, float)
    angle = math.degrees(math.atan2(p[1], p[0])) % 360.0
    return float(math.hypot(p[0], p[1])), (0.0 if angle == 360.0 else angle), float(p[2])


def yaw_pitch_to_direction(yaw_deg: float, pitch_deg: float) -> np.ndarray:
    """Camera-frame unit direction ``d = (sin y cos p, sin p, cos y cos p)``.

    Parameters
    ----------
    yaw_deg
        Turn from the lens axis towards the image's right (deg, −180…180).
    pitch_deg
        Turn up (deg, −90…90).
    """
    y, p = math.radians(yaw_deg), math.radians(pitch_deg)
    return np.array([math.sin(y) * math.cos(p), math.sin(p), math.cos(y) * math.cos(p)])


def direction_to_yaw_pitch(direction) -> tuple[float, float]:
    """Inverse of :func:`yaw_pitch_to_direction` for any non-zero direction: ``(yaw_deg, pitch_deg)``.

    Yaw is in (−180, 180], pitch in [−90, 90]; straight up or down the yaw is 0.
    """
    d = np.asarray(direction, float)
    d = d / np.linalg.norm(d)
    pitch = math.degrees(math.asin(float(np.clip(d[1], -1.0, 1.0))))
    yaw = math.degrees(math.atan2(float(d[0]), float(d[2])))
    return yaw, pitch


def camera_to_world(camera: Camera, local, *, direction: bool = False) -> np.ndarray:
    """A camera-frame ``[right, up, forward]`` point (m) — or direction — in world coordinates."""
    r, u, f = camera.frame()
    v = np.asarray(local, float)
    w = v[0] * r + v[1] * u + v[2] * f
    return w if direction else np.asarray(camera.position_m, float) + w


def world_to_camera(camera: Camera, world, *, direction: bool = False) -> np.ndarray:
    """World points (m) — or directions — in the camera frame ``[right, up, forward]``.

    Parameters
    ----------
    camera
        The camera; its frame is :meth:`~rigsim.scene.types.Camera.frame`, its origin the
        entrance pupil ``camera.position_m``.
    world
        Array of shape ``(..., 3)``: points (m) or, with ``direction=True``, directions.
    direction
        Directions are turned but not moved.

    Returns
    -------
    numpy.ndarray
        Shape ``(..., 3)``: ``[(p − pupil)·right, (p − pupil)·up, (p − pupil)·forward]`` (m), the
        inverse of :func:`camera_to_world`.

    Examples
    --------
    >>> cam = Camera()  # looks along +z with +y up: the image's right is −x
    >>> world_to_camera(cam, [-1.0, 2.0, 3.0]).tolist()
    [1.0, 2.0, 3.0]
    """
    r, u, f = camera.frame()
    w = np.asarray(world, float)
    if not direction:
        w = w - np.asarray(camera.position_m, float)
    return np.stack([w @ r, w @ u, w @ f], axis=-1)


# ---------------------------------------------------------------------------- the file schema

class RigTable(FileModel):
    """``[rig]``: a label (default: the file's stem) and free text."""

    name: str | None = None
    description: str = ""


class PortTable(FileModel):
    """``[port]``: the housing port (see :class:`~rigsim.scene.types.Port`), with the file's limits."""

    kind: Literal["flat", "dome"] = _PORT.kind
    radius_m: Annotated[Real, Field(gt=0, le=1.0), Unit("m")] = _PORT.radius_m
    thickness_m: Annotated[Real, Field(ge=0, le=0.1), Unit("m")] = _PORT.thickness_m
    glass_index: Annotated[Real, Field(ge=1.0, le=3.0)] = _PORT.glass_index
    standoff_m: Annotated[Real, Field(ge=0, le=1.0), Unit("m")] = _PORT.standoff_m

    def to_port(self) -> Port:
        """The :class:`Port`."""
        return Port(**self.model_dump())


class CameraTable(FileModel):
    """``[camera]``: pose (world frame) and lens; ``focal_length_mm`` or ``fov_deg`` (in air).

    The camera's own checks (directions non-zero and not parallel) are those of
    :class:`~rigsim.scene.types.Camera`, run here so they name this table's fields.
    """

    position_m: Vec3 = _CAMERA.position_m
    forward: Direction = _CAMERA.forward
    up: Direction = _CAMERA.up
    sensor_width_mm: Annotated[Real, Field(gt=0, le=200), Unit("mm")] = _CAMERA.sensor_width_mm
    sensor_height_mm: Annotated[Real, Field(gt=0, le=200), Unit("mm")] = _CAMERA.sensor_height_mm
    focal_length_mm: Annotated[Real, Field(gt=0, le=2000), Unit("mm")] | None = None
    fov_deg: Annotated[Real, Field(gt=0, lt=180), Unit("deg, horizontal, in air")] | None = None
    f_number: Annotated[Real, Field(ge=0.5, le=128)] = _CAMERA.f_number
    focus_distance_m: Annotated[Real, Field(gt=0), Unit("m")] | None = None
    housing_radius_m: Annotated[Real, Field(gt=0, le=2.0), Unit("m")] = _CAMERA.housing_radius_m

    @model_validator(mode="after")
    def _check(self) -> "CameraTable":
        exclusive(self, ("focal_length_mm",), ("fov_deg",))
        self.to_camera(_PORT, check=True)
        return self

    @property
    def focal_length(self) -> float:
        """Focal length (mm): as given, from ``fov_deg`` (``w / (2 tan(fov/2))``), or the default."""
        if self.fov_deg is not None:
            return self.sensor_width_mm / (2 * math.tan(math.radians(self.fov_deg) / 2))
        return self.focal_length_mm if self.focal_length_mm is not None else _CAMERA.focal_length_mm

    def to_camera(self, port: Port, *, check: bool = False) -> Camera:
        """The :class:`Camera` behind ``port``."""
        kwargs = dict(position_m=self.position_m, forward=self.forward, up=self.up,
                      sensor_width_mm=self.sensor_width_mm, sensor_height_mm=self.sensor_height_mm,
                      focal_length_mm=self.focal_length, f_number=self.f_number,
                      focus_distance_m=self.focus_distance_m, port=port, housing_radius_m=self.housing_radius_m)
        return built(Camera, **kwargs) if check else Camera(**kwargs)


class LightTable(FileModel):
    """One ``[[lights]]`` table: a strobe or video light in the file's terms (camera frame).

    Exactly one position (``position_m`` or the arm keys), at most one aim (``aim``,
    ``aim_at_m`` or ``yaw_deg``/``pitch_deg``; default along the lens axis), exactly
    one beam (``beam_angle_deg`` or ``beam_profile``), and for strobes exactly one
    rating (``flash_energy_J`` or ``guide_number_m``); video lights give ``lumens``.
    """

    name: str | None = None
    kind: Literal["strobe", "video"]
    position_m: Vec3 | None = None
    arm_length_m: Annotated[Real, Field(gt=0, le=5.0), Unit("m")] | None = None
    arm_angle_deg: Annotated[Real, Field(ge=-360, le=360), Unit("deg, 0 = right, 90 = up")] | None = None
    arm_forward_m: Annotated[Real, Field(ge=-5.0, le=5.0), Unit("m, negative = behind the pupil")] | None = None
    aim: Direction | None = None
    aim_at_m: Vec3 | None = None
    yaw_deg: Annotated[Real, Field(ge=-180, le=180), Unit("deg, + = towards the right")] | None = None
    pitch_deg: Annotated[Real, Field(ge=-90, le=90), Unit("deg, + = up")] | None = None
    beam_angle_deg: Annotated[Real, Field(gt=0, lt=360), Unit("deg, full angle at half intensity")] | None = None
    beam_edge_exponent: Annotated[Real, Field(gt=0, le=100)] | None = None
    beam_profile: str | None = None
    spectrum: str | None = None
    flash_energy_J: Annotated[Real, Field(gt=0, le=1e4), Unit("J (W·s)")] | None = None
    luminous_efficacy_lm_s_per_J: Annotated[Real, Field(gt=0, le=683), Unit("lm·s per J")] | None = None
    guide_number_m: Annotated[Real, Field(gt=0, le=500), Unit("m, in air")] | None = None
    guide_number_iso: Annotated[Real, Field(gt=0, le=1e6)] | None = None
    power_fraction: Annotated[Real, Field(gt=0, le=1)] | None = None
    lumens: Annotated[Real, Field(gt=0, le=1e6), Unit("lm")] | None = None

    def _require(self, key: str) -> None:
        if getattr(self, key) is None:
            raise invalid("missing required field", field=key, allowed=allowed_for(type(self), key))

    @model_validator(mode="after")
    def _check(self) -> "LightTable":
        for key in _VIDEO_ONLY if self.kind == "strobe" else _STROBE_ONLY:
            if getattr(self, key) is not None:
                raise invalid(f"not a field of a {self.kind} light", field=key,
                              allowed="lumens (video lights)" if self.kind == "strobe"
                              else "flash_energy_J or guide_number_m, guide_number_iso, "
                                   "luminous_efficacy_lm_s_per_J, power_fraction (strobes)")
        if exclusive(self, ("position_m",), ("arm_length_m", "arm_angle_deg", "arm_forward_m"), required=True):
            self._require("arm_length_m")
        if exclusive(self, ("aim",), ("aim_at_m",), ("yaw_deg", "pitch_deg")) == 1 and \
                np.linalg.norm(np.asarray(self.aim_at_m) - self.local_position()) < 1e-9:
            raise invalid("aim point coincides with the light's position", field="aim_at_m",
                          allowed="a point away from the light")
        if exclusive(self, ("beam_angle_deg", "beam_edge_exponent"), ("beam_profile",), required=True) == 0:
            self._require("beam_angle_deg")
        if self.kind == "video":
            self._require("lumens")
        elif exclusive(self, ("flash_energy_J", "luminous_efficacy_lm_s_per_J"),
                       ("guide_number_m", "guide_number_iso"), required=True) == 0:
            self._require("flash_energy_J")
        else:
            self._require("guide_number_m")
        return self

    # ------------------------------------------------------------ the conventions, in the camera frame
    @property
    def position_key(self) -> str:
        """The key that places this light (``position_m`` or ``arm_length_m``), for messages."""
        return "position_m" if self.position_m is not None else "arm_length_m"

    @property
    def spectrum_name(self) -> str:
        """The spectrum as given, or the default of the light's kind."""
        return self.spectrum if self.spectrum is not None else DEFAULT_SPECTRUM[self.kind]

    def local_position(self) -> np.ndarray:
        """Position ``[right, up, forward]`` (m) relative to the entrance pupil."""
        if self.position_m is not None:
            return np.asarray(self.position_m, float)
        return arm_to_position(self.arm_length_m or 0.0, self.arm_angle_deg or 0.0, self.arm_forward_m or 0.0)

    def local_aim(self) -> np.ndarray:
        """Unit beam axis ``[right, up, forward]`` (default: along the lens axis)."""
        if self.aim is not None:
            d = np.asarray(self.aim, float)
        elif self.aim_at_m is not None:
            d = np.asarray(self.aim_at_m, float) - self.local_position()
        elif self.yaw_deg is not None or self.pitch_deg is not None:
            d = yaw_pitch_to_direction(self.yaw_deg or 0.0, self.pitch_deg or 0.0)
        else:
            d = np.array([0.0, 0.0, 1.0])
        return d / np.linalg.norm(d)

    def beam(self, base_dir: Path) -> BeamPattern:
        """The beam: a soft cone, or the profile CSV (relative paths against ``base_dir``)."""
        if self.beam_profile is None:
            p = self.beam_edge_exponent if self.beam_edge_exponent is not None else 2.0
            return soft_cone(self.beam_angle_deg, p)
        rel = Path(self.beam_profile)
        return beam_from_csv(rel if rel.is_absolute() else base_dir / rel)

    def to_light(self, name: str, camera: Camera, base_dir: Path, *, file=None, field: str = "lights") -> Light:
        """The :class:`Light` in world coordinates (spectrum and beam CSVs read here).

        Errors from the light package (an unknown spectrum, a missing CSV) are
        reported at ``field.spectrum`` / ``field.beam_profile`` of ``file``.
        """
        pos = camera_to_world(camera, self.local_position())
        aim = camera_to_world(camera, self.local_aim(), direction=True)
        aim = aim / np.linalg.norm(aim)
        with reported_at(file, f"{field}.{'beam_profile' if self.beam_profile else 'beam_angle_deg'}"):
            beam = self.beam(base_dir)
        with reported_at(file, f"{field}.spectrum"):
            if self.kind == "video":
                return video_light(name, pos, aim, beam, lumens=self.lumens, spectrum=self.spectrum_name,
                                   base_dir=base_dir)
            frac = self.power_fraction if self.power_fraction is not None else 1.0
            if self.flash_energy_J is not None:
                eff = self.luminous_efficacy_lm_s_per_J
                return strobe_light(name, pos, aim, beam, flash_energy_J=self.flash_energy_J,
                                    luminous_efficacy_lm_s_per_J=XENON_FLASH_EFFICACY_LM_S_PER_J if eff is None
                                    else eff, power_fraction=frac, spectrum=self.spectrum_name, base_dir=base_dir)
            iso = self.guide_number_iso if self.guide_number_iso is not None else 100.0
            return strobe_light(name, pos, aim, beam, guide_number_m=self.guide_number_m, guide_number_iso=iso,
                                power_fraction=frac, spectrum=self.spectrum_name, base_dir=base_dir)


def _interval(lo_min: float, hi_max: float, unit: str):
    """A ``[lo, hi]`` pair within ``[lo_min, hi_max]`` (``unit``), lo <= hi."""
    def check(v):
        if not isinstance(v, (list, tuple)) or len(v) != 2:
            raise invalid("must be a pair [low, high]", allowed=f"[low, high] within {lo_min:g} … {hi_max:g} {unit}")
        lo, hi = (_real_or_fail(x, lo_min, hi_max, unit) for x in v)
        if lo > hi:
            raise invalid(f"low {lo:g} is above high {hi:g}", allowed="low <= high")
        return lo, hi
    return Annotated[tuple[float, float], BeforeValidator(check), Unit(unit)]


def _real_or_fail(x, lo: float, hi: float, unit: str) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(float(x)) \
            or not lo <= float(x) <= hi:
        raise invalid(f"{x!r} is not a number within {lo:g} … {hi:g} {unit}", allowed=f"{lo:g} … {hi:g} {unit}")
    return float(x)


def _beam_options(v):
    if not isinstance(v, (list, tuple)) or not 1 <= len(v) <= 8:
        raise invalid("must be a list of 1 to 8 beam angles", allowed="e.g. [80, 110] (deg: diffuser off, on)")
    return tuple(sorted({_real_or_fail(x, 1.0, 359.0, "deg") for x in v}))


class LimitsTable(FileModel):
    """``[limits]``: what the rig's hardware allows, for ``rigsim optimise`` (all optional).

    Keys are the placement of each light as a diver states it, in the camera frame of the
    file (:func:`arm_to_position`, :func:`yaw_pitch_to_direction`).  For a mirrored pair of
    lights (the left one the mirror image of the right one about the vertical plane through
    the lens axis) ``arm_elevation_deg`` is the right arm's angle above the horizontal and
    ``yaw_out_deg`` the turn away from the lens axis (positive = outward); a single light or
    lights moved one by one use ``arm_angle_deg`` (a span about each light's own angle) and
    ``yaw_deg``.  ``beam_angles_deg`` lists the beams the lights can be given (e.g. a strobe
    without and with its diffuser).  Limits the file does not state are
    :data:`rigsim.optimise.space.DEFAULT_LIMITS`.
    """

    arm_length_m: _interval(0.0, 5.0, "m") | None = None
    arm_forward_m: _interval(-5.0, 5.0, "m") | None = None
    arm_elevation_deg: _interval(-90.0, 90.0, "deg") | None = None
    arm_angle_span_deg: Annotated[Real, Field(ge=0, le=180), Unit("deg either side of each light's own")] | None = None
    yaw_out_deg: _interval(-90.0, 90.0, "deg") | None = None
    yaw_deg: _interval(-90.0, 90.0, "deg") | None = None
    pitch_deg: _interval(-90.0, 90.0, "deg") | None = None
    beam_angles_deg: Annotated[tuple[float, ...], BeforeValidator(_beam_options), Unit("deg")] | None = None

    def stated(self) -> dict:
        """The limits the file states (key → value)."""
        return {k: v for k, v in self.model_dump().items() if v is not None}


def _lights_array(v):
    if not isinstance(v, (list, tuple)):
        raise invalid("must be an array of tables [[lights]]", allowed="[[lights]] tables")
    return v


class RigFile(FileModel):
    """A whole rig file: ``[rig]``, ``[camera]``, ``[port]``, ``[[lights]]`` and the optional ``[limits]``.

    Across tables: light names must be unique and every light must sit outside the
    housing sphere (``camera.housing_radius_m`` around the entrance pupil).
    """

    rig: RigTable = RigTable()
    camera: CameraTable = CameraTable()
    port: PortTable = PortTable()
    lights: Annotated[tuple[LightTable, ...], BeforeValidator(_lights_array)] = ()
    limits: LimitsTable = LimitsTable()

    def light_names(self) -> list[str]:
        """Names of the lights (``light<i>`` where a table names none)."""
        return [lt.name if lt.name is not None else f"light{i}" for i, lt in enumerate(self.lights)]

    @model_validator(mode="after")
    def _check(self) -> "RigFile":
        housing = self.camera.housing_radius_m
        for i, lt in enumerate(self.lights):
            dist = float(np.linalg.norm(lt.local_position()))
            if dist <= housing:
                raise invalid(f"light is inside the housing: {dist:.3g} m from the entrance pupil",
                              field=f"lights[{i}].{lt.position_key}",
                              allowed=f"> housing_radius_m = {housing:g} m from the entrance pupil")
        names = self.light_names()
        for i, n in enumerate(names):
            if n in names[:i]:
                raise invalid(f"duplicate light name {n!r}", field=f"lights[{i}].name", allowed="unique names")
        return self

    def to_rig(self, *, source: str | Path = "<rig>", base_dir: str | Path | None = None) -> Rig:
        """The :class:`Rig` (lights in world coordinates; CSVs relative to ``base_dir``, default cwd)."""
        base = Path(base_dir) if base_dir is not None else Path.cwd()
        default_name = Path(str(source)).stem if str(source) != "<rig>" else "rig"
        camera = self.camera.to_camera(self.port.to_port())
        lights = tuple(lt.to_light(name, camera, base, file=source, field=f"lights[{i}]")
                       for i, (lt, name) in enumerate(zip(self.lights, self.light_names())))
        return Rig(name=self.rig.name if self.rig.name is not None else default_name, camera=camera,
                   lights=lights, source=str(source), description=self.rig.description)


# ---------------------------------------------------------------------------- loaders

def load_rig(path: str | Path) -> Rig:
    """Read and validate a rig file.

    Parameters
    ----------
    path
        The TOML file.  Relative paths inside it (spectra, beam profiles) resolve
        against its folder.

    Raises
    ------
    ConfigError
        One line: ``file: field: what is wrong (allowed: ...)``.

    Examples
    --------
    >>> from pathlib import Path
    >>> rig = load_rig(Path(__file__).parents[2] / "rigs" / "single-strobe-short-arm.toml")
    >>> rig.lights[0].kind
    'strobe'
    """
    p = Path(path)
    return parse_rig(read_toml(p), source=p, base_dir=p.resolve().parent)


def parse_rig(data: dict, *, source: str | Path = "<rig>", base_dir: str | Path | None = None) -> Rig:
    """Validate a parsed rig table (as from :func:`~rigsim.schema.read_toml`) into a :class:`Rig`.

    Parameters
    ----------
    data
        The file's table.
    source
        What messages name (the file), and the default rig name (its stem).
    base_dir
        Folder that relative CSV paths resolve against (default: the working directory).
    """
    return validate(RigFile, data, file=source).to_rig(source=source, base_dir=base_dir)
