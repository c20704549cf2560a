"""Typed, frozen descriptions of what is in a scene (SI units, wavelengths in nm)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from rigsim.water.model import Water


def unit(v) -> np.ndarray:
    """Unit vector along ``v``."""
    a = np.asarray(v, float)
    n = np.linalg.norm(a)
    if n == 0:
        raise ValueError("zero-length direction")
    return a / n


@dataclass(frozen=True)
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
    radius_m: float = 0.1
    thickness_m: float = 0.008
    glass_index: float = 1.49
    standoff_m: float = 0.02


@dataclass(frozen=True)
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
        lights must be outside it.
    """

    position_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    forward: tuple[float, float, float] = (0.0, 0.0, 1.0)
    up: tuple[float, float, float] = (0.0, 1.0, 0.0)
    sensor_width_mm: float = 36.0
    sensor_height_mm: float = 24.0
    focal_length_mm: float = 24.0
    f_number: float = 8.0
    focus_distance_m: float | None = None
    port: Port = field(default_factory=Port)
    housing_radius_m: float = 0.12

    def frame(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Orthonormal ``(right, up, forward)`` in world coordinates.

        ``forward`` is the normalised viewing direction, ``up`` the camera's up made
        orthogonal to it, ``right = forward × up`` (the image's right in a right-handed
        world: −x for the default camera looking along +z with +y up).
        """
        from rigsim.errors import ConfigError

        f = np.asarray(self.forward, float)
        nf = np.linalg.norm(f)
        if not np.isfinite(nf) or nf == 0:
            raise ConfigError("camera forward must be a non-zero vector", field="camera.forward")
        f = f / nf
        u = np.asarray(self.up, float)
        u = u - f * np.dot(u, f)
        if np.linalg.norm(u) < 1e-9:
            raise ConfigError("camera up is parallel to its forward direction", field="camera.up")
        u = u / np.linalg.norm(u)
        return np.cross(f, u), u, f

    @property
    def fov_air_x_deg(self) -> float:
        """Horizontal field of view in air (deg)."""
        return float(np.degrees(2 * np.arctan(self.sensor_width_mm / (2 * self.focal_length_mm))))


@dataclass(frozen=True)
class BeamPattern:
    """Angular intensity profile of a light, relative to its axis, f(0) = 1.

    Attributes
    ----------
    kind
        ``"soft-cone"``: ``f(θ) = 2^{−(θ/θ_½)^p}`` for θ < 90° (0 behind), θ_½ = half the
        beam angle at half intensity, p the edge sharpness (2: Gaussian-like);
        ``"table"``: linear interpolation of (angle_deg, relative) pairs (0 beyond).
    beam_angle_deg
        Full beam angle at half intensity (deg), for ``soft-cone``.
    edge_exponent
        p above.
    angle_deg, relative
        The table for ``kind="table"``.
    """

    kind: Literal["soft-cone", "table"] = "soft-cone"
    beam_angle_deg: float = 100.0
    edge_exponent: float = 2.0
    angle_deg: tuple[float, ...] = ()
    relative: tuple[float, ...] = ()

    def relative_intensity(self, theta_rad) -> np.ndarray:
        """f(θ) for angles θ (rad) off the axis."""
        th = np.asarray(theta_rad, float)
        if self.kind == "soft-cone":
            half = np.radians(self.beam_angle_deg) / 2
            f = np.power(2.0, -np.power(np.abs(th) / half, self.edge_exponent))
            return np.where(th < np.pi / 2, f, 0.0)
        return np.interp(np.degrees(th), self.angle_deg, self.relative, right=0.0)


@dataclass(frozen=True)
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
        Position (m) and beam axis direction.
    beam
        Angular profile.
    wavelength_nm, axial_intensity
        On-axis spectral radiant intensity: W/(sr·nm) for continuous lights,
        J/(sr·nm) per flash for strobes, tabulated at ``wavelength_nm`` (must cover
        the rendered bands).  Off axis: ``axial_intensity · beam.relative_intensity(θ)``.
    spectrum_name
        Name of the spectrum it was built from (for reports).
    """

    name: str
    kind: Literal["strobe", "continuous"]
    position_m: tuple[float, float, float]
    aim: tuple[float, float, float]
    beam: BeamPattern
    wavelength_nm: tuple[float, ...]
    axial_intensity: tuple[float, ...]
    spectrum_name: str = ""

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


@dataclass(frozen=True)
class Rig:
    """A camera with its lights, as described by a rig file."""

    name: str
    camera: Camera
    lights: tuple[Light, ...] = ()
    source: str = ""  # file it came from
    description: str = ""


@dataclass(frozen=True)
class Target:
    """Something to look at, placed in camera coordinates.

    Attributes
    ----------
    kind
        ``"colorchecker"``, ``"black-disk"``, ``"white-disk"``, ``"slanted-edge"``,
        ``"bottom"`` (sand plane) or ``"mesh"``.
    distance_m
        Distance from the entrance pupil along the optical axis to the target's
        centre (m).
    size_m
        Characteristic size: chart width, disk diameter, edge-target width,
        mesh scale (m).
    mesh_path
        OBJ/PLY file for ``mesh``.
    reflectance_wavelength_nm, reflectance
        Reflectance spectrum for disks, meshes and the bottom (0…1).
    tilt_deg
        Rotation about the optical axis (slanted edge: 5° by ISO 12233).
    offset_m
        Lateral offset of the centre from the optical axis, (right, up) in the camera
        frame (m); the centre lies on the plane at ``distance_m`` ahead.
    yaw_deg, pitch_deg
        Turn of the target away from facing the camera: about its own vertical axis,
        then about its own horizontal axis (deg).
    """

    kind: str
    distance_m: float
    size_m: float = 0.3
    mesh_path: str | None = None
    reflectance_wavelength_nm: tuple[float, ...] = ()
    reflectance: tuple[float, ...] = ()
    tilt_deg: float = 0.0
    offset_m: tuple[float, float] = (0.0, 0.0)
    yaw_deg: float = 0.0
    pitch_deg: float = 0.0


@dataclass(frozen=True)
class Daylight:
    """Ambient daylight at depth (filled in by the daylight issue's models).

    Attributes
    ----------
    depth_m
        Depth of the camera below the surface (m).
    sun_zenith_deg, sun_azimuth_deg
        Sun position above the surface (deg).
    surface_irradiance_wavelength_nm, surface_irradiance
        Plane irradiance just above the surface, W/(m²·nm).
    model
        ``"kd"`` (fast: Kd attenuation) or ``"monte-carlo"`` (through the water column).
    sky
        Sky radiance model above the sea: ``"cie"`` (CIE clear sky for the sun),
        ``"cie:N"``, ``"uniform"`` or ``"black"`` (:func:`rigsim.daylight.sky_model`).
    photons
        Photons per wavelength of the Monte Carlo field (``model="monte-carlo"``).
    waves
        Surface for caustics on the sun beam: ``"flat"`` (none), ``"sines"`` (one
        sine wave of ``wave_amplitude_m``, ``wave_length_m``, ``wave_direction_deg``)
        or ``"pierson-moskowitz"`` (a wind sea of ``wind_speed_m_s`` towards
        ``wave_direction_deg``).
    wind_speed_m_s, wave_amplitude_m, wave_length_m, wave_direction_deg
        Wave parameters (m/s, m, m, deg from +z towards +x).
    """

    depth_m: float
    sun_zenith_deg: float = 30.0
    sun_azimuth_deg: float = 0.0
    surface_irradiance_wavelength_nm: tuple[float, ...] = ()
    surface_irradiance: tuple[float, ...] = ()
    model: Literal["kd", "monte-carlo"] = "kd"
    sky: str = "cie"
    photons: int = 20_000
    waves: Literal["flat", "sines", "pierson-moskowitz"] = "flat"
    wind_speed_m_s: float = 5.0
    wave_amplitude_m: float = 0.05
    wave_length_m: float = 1.0
    wave_direction_deg: float = 0.0


@dataclass(frozen=True, eq=False)
class Scene:
    """Everything a renderer needs: rig, water, targets and optional daylight."""

    rig: Rig
    water: Water | None  # None: no water (vacuum/air) — the "clear" ground truth
    targets: tuple[Target, ...]
    daylight: Daylight | None = None

    @property
    def camera(self) -> Camera:
        return self.rig.camera

    @property
    def lights(self) -> tuple[Light, ...]:
        return self.rig.lights
