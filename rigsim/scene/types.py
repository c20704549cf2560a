"""Typed, frozen descriptions of what is in a scene (SI units, wavelengths in nm).

Each type validates itself when it is built — from a rig file or from Python —
with the constraints written on its fields (pydantic dataclasses made by
:func:`rigsim.schema.frozen_type`).  An invalid value raises
:class:`~rigsim.errors.ConfigError` naming the class, the field and the allowed
range, e.g. ``BeamPattern.beam_angle_deg: out of range: 400 (allowed: > 0 and <
360 (deg, full angle at half intensity))``; code downstream relies on these
checks instead of repeating them.  The types stay standard dataclasses:
frozen, hashable, ``dataclasses.replace`` (which validates again) and ``asdict``
work as before.

Examples
--------
>>> BeamPattern(beam_angle_deg=400.0)
Traceback (most recent call last):
...
rigsim.errors.ConfigError: BeamPattern.beam_angle_deg: out of range: 400 (allowed: > 0 and < 360 (deg, full angle at half intensity))
"""

from __future__ import annotations

from dataclasses import field
from typing import Annotated, Literal, get_args

import numpy as np
from pydantic import Field, model_validator

from rigsim.schema import Direction, Int, Real, Unit, Vec3, float_table, frozen_type, invalid
from rigsim.water.model import Water

__all__ = ["Port", "Camera", "BeamPattern", "Light", "Rig", "Target", "Daylight", "Scene", "unit",
           "TARGET_KIND_NAMES", "LIGHT_KINDS", "DAYLIGHT_MODELS", "WAVE_KINDS"]

TargetKind = Literal["colorchecker", "black-disk", "white-disk", "slanted-edge", "bottom", "seabed", "mesh"]
LightKind = Literal["strobe", "continuous"]
DaylightModel = Literal["kd", "monte-carlo"]
WaveKind = Literal["flat", "sines", "pierson-moskowitz"]
#: Kinds of :class:`Target` (``mesh`` needs ``mesh_path``).
TARGET_KIND_NAMES: tuple[str, ...] = get_args(TargetKind)
#: Kinds of :class:`Light`.
LIGHT_KINDS: tuple[str, ...] = get_args(LightKind)
#: Daylight models of :class:`Daylight` (``kd`` fast, ``monte-carlo`` through the water column).
DAYLIGHT_MODELS: tuple[str, ...] = get_args(DaylightModel)
#: Sea surfaces of :class:`Daylight` for caustics.
WAVE_KINDS: tuple[str, ...] = get_args(WaveKind)

_Metres = Annotated[Real, Unit("m")]
_PositiveM = Annotated[Real, Field(gt=0), Unit("m")]
_NonNegativeM = Annotated[Real, Field(ge=0), Unit("m")]
_PositiveMm = Annotated[Real, Field(gt=0), Unit("mm")]
_Degrees = Annotated[Real, Unit("deg")]
_Wavelengths = float_table(increasing=True, unit="nm")


def _same_length(obj, values: str, grid: str) -> None:
    n, m = len(getattr(obj, values)), len(getattr(obj, grid))
    if n != m:
        raise invalid(f"has {n} values for {m} wavelengths in {grid}", field=values,
                      allowed=f"one value per entry of {grid}")


def unit(v) -> np.ndarray:
    """Unit vector along ``v``."""
    a = np.asarray(v, float)
    n = np.linalg.norm(a)
    if n == 0:
        raise ValueError("zero-length direction")
    return a / n


@frozen_type
class Port:
    """Housing port in front of the lens.

    Attributes
    ----------
    kind
        ``"flat"``: a plane window; refraction water→glass→air narrows the field of
        view by about the water's index and adds pincushion distortion.
        ``"dome"``: a spherical window centred on the entrance pupil; no angular
        change (a thin concentric dome), the virtual image lies near the dome.
    radius_m
        Dome radius, or half-width of a flat port's clear aperture (m).
    thickness_m
        Glass thickness (m).
    glass_index
        Refractive index of the port glass (acrylic 1.49, BK7 1.52).
    standoff_m
        Distance from the entrance pupil to the inner port surface (flat ports), m.
    """

    kind: Literal["flat", "dome"] = "dome"
    radius_m: _PositiveM = 0.1
    thickness_m: _NonNegativeM = 0.008
    glass_index: Annotated[Real, Field(ge=1.0)] = 1.49
    standoff_m: _NonNegativeM = 0.02


@frozen_type
class Camera:
    """Camera pose and lens.

    Attributes
    ----------
    position_m
        Entrance pupil position (m).
    forward, up
        Viewing direction and up vector (unit-less; normalised on use).
    sensor_width_mm, sensor_height_mm
        Sensor size (mm); the image aspect follows it.
    focal_length_mm
        Lens focal length (mm) — the in-air horizontal field of view is
        ``2 atan(w / 2f)``.
    f_number
        Aperture (N).
    focus_distance_m
        Focus distance (m), for depth of field (optional; None = pinhole).
    port
        The housing port.
    housing_radius_m
        Radius of a sphere around the entrance pupil that stands for the housing:
        lights must be outside it (checked by the rig reader, m).

    Raises
    ------
    ConfigError
        Non-finite numbers, a zero ``forward`` or ``up``, ``up`` parallel to
        ``forward``, sizes, focal length, f-number, focus distance or housing
        radius not > 0.
    """

    position_m: Vec3 = (0.0, 0.0, 0.0)
    forward: Direction = (0.0, 0.0, 1.0)
    up: Direction = (0.0, 1.0, 0.0)
    sensor_width_mm: _PositiveMm = 36.0
    sensor_height_mm: _PositiveMm = 24.0
    focal_length_mm: _PositiveMm = 24.0
    f_number: Annotated[Real, Field(gt=0)] = 8.0
    focus_distance_m: _PositiveM | None = None
    port: Port = field(default_factory=Port)
    housing_radius_m: _PositiveM = 0.12

    @model_validator(mode="after")
    def _up_not_parallel(self) -> "Camera":
        f, u = np.asarray(self.forward), np.asarray(self.up)
        if np.linalg.norm(np.cross(f, u)) < 1e-6 * np.linalg.norm(f) * np.linalg.norm(u):
            raise invalid("must not be parallel to forward", field="up",
                          allowed="a direction not parallel to camera.forward")
        return self

    def frame(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Orthonormal ``(right, up, forward)`` in world coordinates.

        ``forward`` is the normalised viewing direction, ``up`` the camera's up made
        orthogonal to it, ``right = forward × up`` (the image's right in a right-handed
        world: −x for the default camera looking along +z with +y up).  The camera's
        validation guarantees both are non-zero and not parallel.
        """
        f = np.asarray(self.forward, float)
        f = f / np.linalg.norm(f)
        u = np.asarray(self.up, float)
        u = u - f * np.dot(u, f)
        u = u / np.linalg.norm(u)
        return np.cross(f, u), u, f

    @property
    def fov_air_x_deg(self) -> float:
        """Horizontal field of view in air (deg)."""
        return float(np.degrees(2 * np.arctan(self.sensor_width_mm / (2 * self.focal_length_mm))))


@frozen_type
class BeamPattern:
    """Angular intensity profile of a light, relative to its axis, f(0) = 1.

    Attributes
    ----------
    kind
        ``"soft-cone"``: ``f(θ) = 2^{−(θ/θ_½)^p}`` for θ < 90° (0 behind), θ_½ = half the
        beam angle at half intensity, p the edge sharpness (2: Gaussian-like);
        ``"table"``: linear interpolation of (angle_deg, relative) pairs (0 beyond).
    beam_angle_deg
        Full beam angle at half intensity (deg), for ``soft-cone``: 0 < angle < 360.
    edge_exponent
        p above, 0 < p <= 100.
    angle_deg, relative
        The table for ``kind="table"``: angles (deg) from 0, strictly increasing, at
        most 180; relative intensities >= 0, one per angle (at least two rows).
    """

    kind: Literal["soft-cone", "table"] = "soft-cone"
    beam_angle_deg: Annotated[Real, Field(gt=0, lt=360), Unit("deg, full angle at half intensity")] = 100.0
    edge_exponent: Annotated[Real, Field(gt=0, le=100)] = 2.0
    angle_deg: float_table(increasing=True, unit="deg") = ()
    relative: float_table(nonnegative=True) = ()

    @model_validator(mode="after")
    def _table(self) -> "BeamPattern":
        if self.kind == "table":
            a = self.angle_deg
            if len(a) < 2:
                raise invalid(f"a table beam needs at least 2 angles, got {len(a)}", field="angle_deg",
                              allowed="0 = a0 < a1 < ... <= 180 deg")
            if a[0] != 0.0 or a[-1] > 180.0:
                raise invalid(f"angles must run from 0 to at most 180 deg, got {a[0]:g}–{a[-1]:g}",
                              field="angle_deg", allowed="0 = a0 < a1 < ... <= 180 deg")
        if len(self.relative) != len(self.angle_deg):
            raise invalid(f"has {len(self.relative)} values for {len(self.angle_deg)} angles", field="relative",
                          allowed="one value per entry of angle_deg")
        return self

    def relative_intensity(self, theta_rad) -> np.ndarray:
        """f(θ) for angles θ (rad) off the axis."""
        th = np.asarray(theta_rad, float)
        if self.kind == "soft-cone":
            half = np.radians(self.beam_angle_deg) / 2
            f = np.power(2.0, -np.power(np.abs(th) / half, self.edge_exponent))
            return np.where(th < np.pi / 2, f, 0.0)
        return np.interp(np.degrees(th), self.angle_deg, self.relative, right=0.0)


@frozen_type
class Light:
    """A strobe or a continuous (video) light.

    Attributes
    ----------
    name
        Label from the rig file.
    kind
        ``"strobe"`` (one flash per exposure; intensities in J/(sr·nm)) or
        ``"continuous"`` (video light; W/(sr·nm)).
    position_m, aim
        Position (m, finite) and beam axis direction (non-zero; normalised on use).
    beam
        Angular profile.
    wavelength_nm, axial_intensity
        On-axis spectral radiant intensity: W/(sr·nm) for continuous lights,
        J/(sr·nm) per flash for strobes, finite and >= 0, tabulated at
        ``wavelength_nm`` (strictly increasing, at least one, one value each; must
        cover the rendered bands).  Off axis: ``axial_intensity · beam.relative_intensity(θ)``.
    spectrum_name
        Name of the spectrum it was built from (for reports).
    """

    name: str
    kind: LightKind
    position_m: Vec3
    aim: Direction
    beam: BeamPattern
    wavelength_nm: float_table(increasing=True, min_length=1, unit="nm")
    axial_intensity: float_table(nonnegative=True, unit="W/(sr·nm), or J/(sr·nm) per flash")
    spectrum_name: str = ""

    @model_validator(mode="after")
    def _table(self) -> "Light":
        _same_length(self, "axial_intensity", "wavelength_nm")
        return self

    def describe(self) -> dict:
        """JSON-serialisable summary for metadata (the spectral table reduced to its ranges)."""
        from dataclasses import asdict

        d = asdict(self)
        d.pop("wavelength_nm", None)
        d.pop("axial_intensity", None)
        wl = np.asarray(self.wavelength_nm, float)
        a = np.asarray(self.axial_intensity, float)
        d["axial_intensity_range"] = [float(a.min()), float(a.max())] if a.size else []
        d["wavelength_range_nm"] = [float(wl.min()), float(wl.max())] if wl.size else []
        return d


@frozen_type
class Rig:
    """A camera with its lights, as described by a rig file.

    Attributes
    ----------
    name
        Label.
    camera
        The camera, lens and port.
    lights
        The lights, in world coordinates.
    source
        The file it came from (``""`` if built in code).
    description
        Free text.

    Notes
    -----
    A rig file also requires unique light names and lights outside the housing
    (:mod:`rigsim.config.rig`); rigs built in code may break those rules (tests
    put point lights at the pupil).
    """

    name: str
    camera: Camera
    lights: tuple[Light, ...] = ()
    source: str = ""
    description: str = ""


@frozen_type
class Target:
    """Something to look at, placed in camera coordinates.

    Attributes
    ----------
    kind
        ``"colorchecker"``, ``"black-disk"``, ``"white-disk"``, ``"slanted-edge"``,
        ``"bottom"`` (sand plane), ``"seabed"`` (a procedural height field of sand:
        :mod:`rigsim.scene.seabed`) or ``"mesh"`` (:data:`TARGET_KIND_NAMES`).
    distance_m
        Distance from the entrance pupil along the optical axis to the target's
        centre (m, > 0); for ``bottom`` and ``seabed`` the camera's altitude above it.
    size_m
        Characteristic size: chart width, disk diameter, edge-target width,
        mesh scale (m, > 0).
    mesh_path
        OBJ/PLY file for ``mesh`` (required for it; read when rendered); for ``seabed``
        the height field's mesh (:func:`rigsim.scene.seabed.seabed_mesh_file`; none: the
        default :class:`~rigsim.scene.seabed.SeabedSpec`), in its own frame (y up).
    reflectance_wavelength_nm, reflectance
        Reflectance spectrum for disks, meshes and the bottom: wavelengths (nm)
        strictly increasing, values >= 0 (0…1; the renderers refuse values above 1),
        one per wavelength; both empty for the kind's own reflectance.
    tilt_deg
        Rotation about the optical axis (slanted edge: 5° by ISO 12233).
    offset_m
        Lateral offset of the centre from the optical axis, (right, up) in the camera
        frame (m); the centre lies on the plane at ``distance_m`` ahead.
    yaw_deg, pitch_deg
        Turn of the target away from facing the camera: about its own vertical axis,
        then about its own horizontal axis (deg).
    """

    kind: TargetKind
    distance_m: _PositiveM
    size_m: _PositiveM = 0.3
    mesh_path: str | None = None
    reflectance_wavelength_nm: _Wavelengths = ()
    reflectance: float_table(nonnegative=True) = ()
    tilt_deg: _Degrees = 0.0
    offset_m: tuple[_Metres, _Metres] = (0.0, 0.0)
    yaw_deg: _Degrees = 0.0
    pitch_deg: _Degrees = 0.0

    @model_validator(mode="after")
    def _check(self) -> "Target":
        if self.kind == "mesh" and not self.mesh_path:
            raise invalid("a mesh target needs mesh_path", field="mesh_path", allowed="an OBJ or PLY file")
        _same_length(self, "reflectance", "reflectance_wavelength_nm")
        return self


@frozen_type
class Daylight:
    """Ambient daylight at depth (filled in by the daylight issue's models).

    Attributes
    ----------
    depth_m
        Depth of the camera below the surface (m, > 0).
    sun_zenith_deg, sun_azimuth_deg
        Sun position above the surface (deg; zenith 0 <= z < 90).
    surface_irradiance_wavelength_nm, surface_irradiance
        Plane irradiance just above the surface, W/(m²·nm) (>= 0, one per wavelength;
        both empty: the clear-sky model).
    model
        ``"kd"`` (fast: Kd attenuation) or ``"monte-carlo"`` (through the water column).
    sky
        Sky radiance model above the sea: ``"cie"`` (CIE clear sky for the sun),
        ``"cie:N"``, ``"uniform"`` or ``"black"`` (:func:`rigsim.daylight.sky_model`).
    photons
        Photons per wavelength of the Monte Carlo field (``model="monte-carlo"``), >= 100.
    waves
        Surface for caustics on the sun beam: ``"flat"`` (none), ``"sines"`` (one
        sine wave of ``wave_amplitude_m``, ``wave_length_m``, ``wave_direction_deg``)
        or ``"pierson-moskowitz"`` (a wind sea of ``wind_speed_m_s`` towards
        ``wave_direction_deg``).
    wind_speed_m_s, wave_amplitude_m, wave_length_m, wave_direction_deg
        Wave parameters (m/s > 0, m >= 0, m > 0, deg from +z towards +x).
    field_seed
        Seed of the Monte Carlo daylight field and of the caustic pattern (>= 0).  The field is
        an input of the scene, not part of a render's noise: every render (whatever its own
        seed) and the fast engine light the scene with the same field.
    """

    depth_m: _PositiveM
    sun_zenith_deg: Annotated[Real, Field(ge=0, lt=90), Unit("deg")] = 30.0
    sun_azimuth_deg: _Degrees = 0.0
    surface_irradiance_wavelength_nm: _Wavelengths = ()
    surface_irradiance: float_table(nonnegative=True, unit="W/(m²·nm)") = ()
    model: DaylightModel = "kd"
    sky: str = "cie"
    photons: Annotated[Int, Field(ge=100)] = 20_000
    waves: WaveKind = "flat"
    wind_speed_m_s: Annotated[Real, Field(gt=0), Unit("m/s")] = 5.0
    wave_amplitude_m: _NonNegativeM = 0.05
    wave_length_m: _PositiveM = 1.0
    wave_direction_deg: _Degrees = 0.0
    field_seed: Annotated[Int, Field(ge=0)] = 0

    @model_validator(mode="after")
    def _check(self) -> "Daylight":
        _same_length(self, "surface_irradiance", "surface_irradiance_wavelength_nm")
        from rigsim.daylight.sky import sky_model  # the one parser of sky names (imported late: no cycle)
        from rigsim.errors import ConfigError

        try:
            sky_model(self.sky, self.sun_zenith_deg)
        except ConfigError as exc:
            raise invalid(exc.message, field="sky", allowed=exc.allowed) from None
        return self


@frozen_type(eq=False, arbitrary_types=True)
class Scene:
    """Everything a renderer needs: rig, water, targets and optional daylight.

    Attributes
    ----------
    rig
        Camera and lights.
    water
        The :class:`~rigsim.water.model.Water` (its own classes validate it), or None.
    targets
        What the camera looks at.
    daylight
        Ambient daylight at depth, or None.
    particle_seed
        Seed of the placement of the water's discrete particles (marine snow,
        :mod:`rigsim.scene.particles`), >= 0.  Like the daylight field, the particles are an
        input of the scene: every render (whatever its own seed) and the fast engine see the same.
    """

    rig: Rig
    water: Water | None  # None: no water (vacuum/air) — the "clear" ground truth
    targets: tuple[Target, ...]
    daylight: Daylight | None = None
    particle_seed: Annotated[Int, Field(ge=0)] = 0

    @property
    def camera(self) -> Camera:
        return self.rig.camera

    @property
    def lights(self) -> tuple[Light, ...]:
        return self.rig.lights
