"""Camera rays in water: pinhole lens behind a dome or a flat port.

The lens is a pinhole at the entrance pupil (``Camera.position_m``) with the in-air
field of view of the sensor and focal length (no depth of field).  Image axes (as
:mod:`rigsim.scene.targets` and Mitsuba): column → ``right = forward × up``, row →
−up; row 0 is the top.  The horizontal field of view comes from the sensor width,
the vertical one from the sensor height (an image whose aspect differs from the
sensor's has non-square pixels).

Ports (exact ray geometry, no paraxial approximation):

* **dome** — a thin dome concentric with the entrance pupil: directions are
  unchanged, the ray enters the water at the outer dome surface,
  ``radius + thickness`` from the pupil.
* **flat** — a plane window normal to the optical axis at ``standoff`` from the
  pupil, ``thickness`` thick.  Each ray is refracted air → glass → water by Snell's
  law (``sin θ_water = sin θ_air / n_water``, the glass cancels for the direction
  but shifts the ray sideways), which narrows the field of view and gives the
  flat port's pincushion distortion exactly.

The radiance returned is the in-water radiance arriving at the port along each ray;
port transmission (Fresnel) and the n² radiance change into air are left to the
sensor model.
"""

from __future__ import annotations

import numpy as np

from rigsim.render.variant import mitsuba
from rigsim.scene.types import Camera
from rigsim.water.kd import WATER_INDEX

__all__ = ["camera_frame", "flat_port_angle_water", "fov_water_deg", "generate_rays", "tan_half_fov"]

mi, dr = mitsuba()


def camera_frame(camera: Camera) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(forward, right, up)``: :meth:`rigsim.scene.types.Camera.frame` in the order the ray code uses."""
    r, u, f = camera.frame()
    return f, r, u


def tan_half_fov(camera: Camera, width: int, height: int) -> tuple[float, float]:
    """tan of the half field of view in air, horizontal and vertical."""
    return (camera.sensor_width_mm / (2.0 * camera.focal_length_mm),
            camera.sensor_height_mm / (2.0 * camera.focal_length_mm))


def flat_port_angle_water(theta_air_rad, n_water: float = WATER_INDEX):
    """Angle to the axis in water of a ray at ``theta_air`` in air behind a flat port (Snell)."""
    return np.arcsin(np.sin(np.asarray(theta_air_rad, float)) / n_water)


def fov_water_deg(camera: Camera, n_water: float = WATER_INDEX) -> float:
    """Horizontal field of view in water (deg): unchanged for a dome, Snell-narrowed for a flat port."""
    half_air = np.radians(camera.fov_air_x_deg) / 2
    if camera.port.kind == "flat":
        return float(np.degrees(2 * flat_port_angle_water(half_air, n_water)))
    return float(np.degrees(2 * half_air))


def generate_rays(camera: Camera, px, py, width: int, height: int, *, n_water: float = WATER_INDEX):
    """In-water rays for film positions ``px``, ``py`` in [0, 1] (left→right, top→bottom).

    Returns ``(origin, direction)`` as Mitsuba ``Point3f``/``Vector3f``.
    """
    f, r, u = camera_frame(camera)
    tx, ty = tan_half_fov(camera, width, height)
    F, R, U = (mi.Vector3f(*[float(c) for c in v]) for v in (f, r, u))
    pupil = mi.Point3f(*[float(c) for c in camera.position_m])
    x = (2.0 * px - 1.0) * tx
    y = (1.0 - 2.0 * py) * ty
    d_air = dr.normalize(F + R * x + U * y)
    port = camera.port
    if port.kind == "flat":
        cos_a = dr.dot(d_air, F)
        trans = d_air - F * cos_a  # tangential part, |trans| = sin θ_air
        sin2_a = dr.squared_norm(trans)
        ng = float(port.glass_index)
        cos_g = dr.safe_sqrt(1.0 - sin2_a / (ng * ng))
        cos_w = dr.safe_sqrt(1.0 - sin2_a / (n_water * n_water))
        d_glass = trans / ng + F * cos_g
        d_water = trans / n_water + F * cos_w
        p1 = pupil + d_air * (float(port.standoff_m) / cos_a)
        origin = p1 + d_glass * (float(port.thickness_m) / cos_g)
        return origin, d_water
    if port.kind == "dome":
        origin = pupil + d_air * float(port.radius_m + port.thickness_m)
        return origin, d_air
    raise ValueError(f"unknown port kind {port.kind!r}")
