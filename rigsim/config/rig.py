"""Rig files (TOML) → a typed, frozen :class:`~rigsim.scene.types.Rig`.

The format is documented in ``rigs/README.md``.  Parsing happens once, here;
everything downstream receives the ``Rig``.  Errors are one line naming the
file, the field path (``lights[1].beam_angle_deg``) and what is allowed.

Frames: the camera's ``position_m``, ``forward`` and ``up`` are in the world
(scene) frame.  Light positions, arms and aims are given in the *camera frame*
relative to the entrance pupil: components ``[right, up, forward]`` (m), where
*right* is the image's right, ``right = forward × up`` (right-handed world), and
*up* is the image's up.  They are converted to world coordinates here, so the
``Light`` objects in the ``Rig`` are in the world frame.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from rigsim.config.reader import MISSING, Section, read_toml
from rigsim.errors import ConfigError
from rigsim.light.beam import beam_from_csv, soft_cone
from rigsim.light.photometry import XENON_FLASH_EFFICACY_LM_S_PER_J
from rigsim.light.sources import strobe_light, video_light
from rigsim.scene.types import BeamPattern, Camera, Light, Port, Rig

__all__ = ["load_rig", "parse_rig"]

_TOP = ("rig", "camera", "port", "lights")
_RIG = ("name", "description")
_CAMERA = ("position_m", "forward", "up", "sensor_width_mm", "sensor_height_mm", "focal_length_mm",
           "fov_deg", "f_number", "focus_distance_m", "housing_radius_m")
_PORT = ("kind", "radius_m", "thickness_m", "glass_index", "standoff_m")
_LIGHT_COMMON = ("name", "kind", "position_m", "arm_length_m", "arm_angle_deg", "arm_forward_m",
                 "aim", "aim_at_m", "yaw_deg", "pitch_deg", "beam_angle_deg", "beam_edge_exponent",
                 "beam_profile", "spectrum")
_STROBE_ONLY = ("flash_energy_J", "guide_number_m", "guide_number_iso", "luminous_efficacy_lm_s_per_J",
                "power_fraction")
_VIDEO_ONLY = ("lumens",)
_DEFAULT_SPECTRUM = {"strobe": "xenon-strobe", "video": "daylight-led"}


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
    data = read_toml(p)
    return parse_rig(data, source=p, base_dir=p.resolve().parent)


def parse_rig(data: dict, *, source: str | Path = "<rig>", base_dir: str | Path | None = None) -> Rig:
    """Validate a parsed rig table (as from ``tomllib``) into a :class:`Rig`."""
    file = source
    base = Path(base_dir) if base_dir is not None else Path.cwd()
    top = Section(data, "", file, _TOP)
    rig_s = Section(top.data.get("rig", {}), "rig", file, _RIG)
    default_name = Path(str(source)).stem if str(source) != "<rig>" else "rig"
    name = rig_s.string("name", default_name)
    description = rig_s.string("description", "")

    port = _parse_port(Section(top.data.get("port", {}), "port", file, _PORT))
    camera = _parse_camera(Section(top.data.get("camera", {}), "camera", file, _CAMERA), port)

    raw_lights = top.data.get("lights", [])
    if not isinstance(raw_lights, list):
        raise ConfigError("must be an array of tables [[lights]]", file=file, field="lights",
                          allowed="[[lights]] tables")
    lights = tuple(_parse_light(Section(item, f"lights[{i}]", file, _LIGHT_COMMON + _STROBE_ONLY
                                        + _VIDEO_ONLY), i, camera, base)
                   for i, item in enumerate(raw_lights))
    names = [lt.name for lt in lights]
    for i, n in enumerate(names):
        if n in names[:i]:
            raise ConfigError(f"duplicate light name {n!r}", file=file, field=f"lights[{i}].name",
                              allowed="unique names")
    return Rig(name=name, camera=camera, lights=lights, source=str(source), description=description)


def _parse_port(s: Section) -> Port:
    kind = s.string("kind", "dome", choices=("flat", "dome"))
    d = Port()
    return Port(kind=kind,
                radius_m=s.number("radius_m", d.radius_m, gt=0, le=1.0, unit="m"),
                thickness_m=s.number("thickness_m", d.thickness_m, ge=0, le=0.1, unit="m"),
                glass_index=s.number("glass_index", d.glass_index, ge=1.0, le=3.0),
                standoff_m=s.number("standoff_m", d.standoff_m, ge=0, le=1.0, unit="m"))


def _parse_camera(s: Section, port: Port) -> Camera:
    d = Camera()
    position = s.vector("position_m", d.position_m)
    forward = s.vector("forward", d.forward, nonzero=True)
    up = s.vector("up", d.up, nonzero=True)
    fn, un = np.asarray(forward), np.asarray(up)
    if np.linalg.norm(np.cross(fn, un)) < 1e-6 * np.linalg.norm(fn) * np.linalg.norm(un):
        raise s.error("up", "must not be parallel to forward", "a direction not parallel to camera.forward")
    width = s.number("sensor_width_mm", d.sensor_width_mm, gt=0, le=200, unit="mm")
    height = s.number("sensor_height_mm", d.sensor_height_mm, gt=0, le=200, unit="mm")
    which = s.exclusive(("focal_length_mm",), ("fov_deg",))
    if which == 1:
        fov = s.number("fov_deg", gt=0, lt=180, unit="deg, horizontal, in air")
        focal = width / (2 * math.tan(math.radians(fov) / 2))
    else:
        focal = s.number("focal_length_mm", d.focal_length_mm, gt=0, le=2000, unit="mm")
    f_number = s.number("f_number", d.f_number, ge=0.5, le=128)
    focus = s.number("focus_distance_m", None, gt=0, unit="m")
    housing = s.number("housing_radius_m", d.housing_radius_m, gt=0, le=2.0, unit="m")
    return Camera(position_m=position, forward=forward, up=up, sensor_width_mm=width,
                  sensor_height_mm=height, focal_length_mm=focal, f_number=f_number,
                  focus_distance_m=focus, port=port, housing_radius_m=housing)


def _direction_from_yaw_pitch(yaw_deg: float, pitch_deg: float) -> np.ndarray:
    y, p = math.radians(yaw_deg), math.radians(pitch_deg)
    return np.array([math.sin(y) * math.cos(p), math.sin(p), math.cos(y) * math.cos(p)])


def _parse_light(s: Section, index: int, camera: Camera, base: Path) -> Light:
    name = s.string("name", f"light{index}")
    kind = s.string("kind", MISSING, choices=("strobe", "video"))
    wrong = _VIDEO_ONLY if kind == "strobe" else _STROBE_ONLY
    for key in wrong:
        if s.has(key):
            raise s.error(key, f"not a field of a {kind} light",
                          "lumens (video lights)" if kind == "strobe"
                          else "flash_energy_J or guide_number_m, guide_number_iso, "
                               "luminous_efficacy_lm_s_per_J, power_fraction (strobes)")

    # --- position, in the camera frame [right, up, forward] (m)
    where = s.exclusive(("position_m",), ("arm_length_m", "arm_angle_deg", "arm_forward_m"), required=True)
    if where == 0:
        local_pos = np.asarray(s.vector("position_m"))
        pos_key = "position_m"
    else:
        length = s.number("arm_length_m", MISSING, gt=0, le=5.0, unit="m")
        angle = s.number("arm_angle_deg", 0.0, ge=-360, le=360, unit="deg, 0 = right, 90 = up")
        fwd = s.number("arm_forward_m", 0.0, ge=-5.0, le=5.0, unit="m, negative = behind the pupil")
        a = math.radians(angle)
        local_pos = np.array([length * math.cos(a), length * math.sin(a), fwd])
        pos_key = "arm_length_m"
    dist = float(np.linalg.norm(local_pos))
    if dist <= camera.housing_radius_m:
        raise s.error(pos_key, f"light is inside the housing: {dist:.3g} m from the entrance pupil",
                      f"> housing_radius_m = {camera.housing_radius_m:g} m from the entrance pupil")

    # --- aim, in the camera frame
    how = s.exclusive(("aim",), ("aim_at_m",), ("yaw_deg", "pitch_deg"))
    if how == 0:
        local_aim = np.asarray(s.vector("aim", nonzero=True))
    elif how == 1:
        target = np.asarray(s.vector("aim_at_m"))
        local_aim = target - local_pos
        if np.linalg.norm(local_aim) < 1e-9:
            raise s.error("aim_at_m", "aim point coincides with the light's position",
                          "a point away from the light")
    elif how == 2:
        yaw = s.number("yaw_deg", 0.0, ge=-180, le=180, unit="deg, + = towards the right")
        pitch = s.number("pitch_deg", 0.0, ge=-90, le=90, unit="deg, + = up")
        local_aim = _direction_from_yaw_pitch(yaw, pitch)
    else:
        local_aim = np.array([0.0, 0.0, 1.0])

    # --- beam
    which = s.exclusive(("beam_angle_deg", "beam_edge_exponent"), ("beam_profile",), required=True)
    beam: BeamPattern
    try:
        if which == 0:
            angle = s.number("beam_angle_deg", MISSING, gt=0, lt=360, unit="deg, full angle at half intensity")
            p = s.number("beam_edge_exponent", 2.0, gt=0, le=100)
            beam = soft_cone(angle, p)
        else:
            rel = s.string("beam_profile")
            path = Path(rel) if Path(rel).is_absolute() else base / rel
            beam = beam_from_csv(path)
    except ConfigError as exc:
        raise _in_table(s, "beam_profile" if which == 1 else "beam_angle_deg", exc) from None

    spectrum = s.string("spectrum", _DEFAULT_SPECTRUM[kind])

    # --- to world
    r, u, f = camera.frame()
    world_pos = np.asarray(camera.position_m) + local_pos[0] * r + local_pos[1] * u + local_pos[2] * f
    world_aim = local_aim[0] * r + local_aim[1] * u + local_aim[2] * f
    world_aim = world_aim / np.linalg.norm(world_aim)

    try:
        if kind == "video":
            lumens = s.number("lumens", MISSING, gt=0, le=1e6, unit="lm")
            return video_light(name, world_pos, world_aim, beam, lumens=lumens, spectrum=spectrum,
                               base_dir=base)
        power = s.exclusive(("flash_energy_J", "luminous_efficacy_lm_s_per_J"),
                            ("guide_number_m", "guide_number_iso"), required=True)
        frac = s.number("power_fraction", 1.0, gt=0, le=1)
        if power == 0:
            energy = s.number("flash_energy_J", MISSING, gt=0, le=1e4, unit="J (W·s)")
            eff = s.number("luminous_efficacy_lm_s_per_J", XENON_FLASH_EFFICACY_LM_S_PER_J, gt=0, le=683,
                           unit="lm·s per J")
            return strobe_light(name, world_pos, world_aim, beam, flash_energy_J=energy,
                                luminous_efficacy_lm_s_per_J=eff, power_fraction=frac,
                                spectrum=spectrum, base_dir=base)
        gn = s.number("guide_number_m", MISSING, gt=0, le=500, unit="m, in air")
        iso = s.number("guide_number_iso", 100.0, gt=0, le=1e6)
        return strobe_light(name, world_pos, world_aim, beam, guide_number_m=gn, guide_number_iso=iso,
                            power_fraction=frac, spectrum=spectrum, base_dir=base)
    except ConfigError as exc:
        raise _in_table(s, "spectrum", exc) from None


def _in_table(s: Section, key: str, exc: ConfigError) -> ConfigError:
    """Re-home an error from the light package (bare field, or a data file) in this rig table."""
    if exc.file == (str(s.file) if s.file is not None else None) and exc.field \
            and exc.field.startswith(s.path + "."):
        return exc
    field = key if exc.file is not None or not exc.field or exc.field.startswith("--") else exc.field
    where = f"{exc.file}: " if exc.file is not None else ""
    inner = f"{exc.field}: " if exc.file is not None and exc.field else ""
    return s.error(field, f"{where}{inner}{exc.message}", exc.allowed)
