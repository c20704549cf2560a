"""The camera's optics in the scene: film positions ↔ rays in the water, through the port.

The one implementation of the camera and port model (numpy, float64).  The Monte Carlo
renderer (:mod:`rigsim.render`) converts the rays computed here into Dr.Jit arrays, the
fast engine (:mod:`rigsim.preview`), the target layout (:mod:`rigsim.scene.layout`) and the
sensor stage (:mod:`rigsim.sensor`) call these functions directly.

Lens
----
The chief rays: a pinhole at the entrance pupil (``Camera.position_m``) with the in-air field of view of
the sensor and focal length: a film position ``(px, py)`` in [0, 1]² (left → right, top →
bottom) looks along ``forward + x right + y up`` in air with
``x = (2 px − 1) w/(2f)``, ``y = (1 − 2 py) h/(2f)`` (``w, h`` the sensor size, ``f`` the
focal length).  The image's right is ``forward × up`` (:meth:`Camera.frame`), row 0 is the
top, as Mitsuba renders.  The horizontal field of view comes from the sensor width, the
vertical one from its height.

Depth of field (a camera with ``focus_distance_m``): a thin lens in the water's object space.  The
entrance pupil as seen from the water has the diameter :func:`aperture_diameter_water_m`; the rays
of a film position leave points of that aperture and meet the film position's chief ray where it
is ``focus_distance_m`` ahead of the pupil (depth along the optical axis), so a point at depth ``z``
is spread over a disc of angular diameter ``D_w |1/z − 1/s_f|`` (:func:`defocus_blur_rad`), the
thin-lens law in object space.  Both engines use this: the renderer draws an aperture point per
path (:func:`camera_rays` with ``aperture=``), the fast engine blurs by the disc.

Ports (exact ray geometry, no paraxial approximation)
-----------------------------------------------------
* **dome** — a thin dome concentric with the entrance pupil: chief rays cross both of its
  surfaces at normal incidence, so directions are unchanged; the ray enters the water at
  the outer surface, ``radius + thickness`` from the pupil.
* **flat** — a plane window normal to the optical axis at ``standoff`` from the pupil,
  ``thickness`` thick.  A ray is refracted air → glass → water by Snell's law at both faces
  (``n_air sin θ_a = n_g sin θ_g = n_w sin θ_w``; the glass cancels for the direction but
  shifts the ray sideways), which narrows the field of view and gives the flat port's
  pincushion distortion exactly.

The medium outside the port has the index :func:`outside_index` (sea water,
:data:`~rigsim.water.refraction.WATER_INDEX`), also in the ground-truth ``clear`` view
without water, so that its pixels see the same points.

Radiance through the port
-------------------------
The renderers report the in-water radiance arriving at the port.  Behind the port, in air,
the radiance is ``T_port L / n_w²`` (the basic radiance ``L/n²`` is conserved through
lossless interfaces, Mobley 1994 §4.3); ``T_port`` is the product of the unpolarised
Fresnel transmittances of the water→glass and glass→air surfaces at the ray's angles
(:func:`port_transmittance`; multiple reflections inside the window and glass absorption
neglected).

References
----------
Mobley, C. D. (1994). *Light and Water*, Academic Press, §4.3 (the n² law of radiance).
Born, M. & Wolf, E. (1999). *Principles of Optics*, 7th ed., §1.5 (Fresnel).
"""

from __future__ import annotations

import math

import numpy as np

from rigsim.errors import ConfigError
from rigsim.scene.types import Camera, Scene
from rigsim.water.refraction import WATER_INDEX, fresnel_reflectance_unpolarised

__all__ = [
    "WATER_INDEX",
    "port_viewpoint_m",
    "equidistant_maps",
    "outside_index",
    "tan_half_fov",
    "field_width_m",
    "air_directions",
    "camera_rays",
    "pixel_rays",
    "fov_water_deg",
    "angular_pitch_rad",
    "project_points",
    "port_transmittance",
    "air_radiance_factor",
    "port_reach_m",
    "world_radius_m",
    "aperture_diameter_water_m",
    "defocus_blur_rad",
    "aperture_offsets",
    "cell_solid_angles",
]


def outside_index(scene: Scene) -> float:
    """Refractive index of the medium outside the port: sea water, :data:`WATER_INDEX`.

    Also for a scene without water (``scene.water is None``): that is the *clear* ground
    truth, the same view with the water's attenuation and scattering removed, so its pixels
    see the same points as the image in water (the renderer's ``clear`` pass, the fast
    engine and the target layout all use these rays).
    """
    return WATER_INDEX


def tan_half_fov(camera: Camera) -> tuple[float, float]:
    """tan of the half field of view in air, horizontal and vertical (from the sensor size)."""
    return (camera.sensor_width_mm / (2.0 * camera.focal_length_mm),
            camera.sensor_height_mm / (2.0 * camera.focal_length_mm))


def air_directions(camera: Camera, px, py) -> np.ndarray:
    """Unit directions in air (…, 3) behind the port for film positions ``px, py`` in [0, 1]."""
    r, u, f = camera.frame()
    tx, ty = tan_half_fov(camera)
    x = (2.0 * np.asarray(px, float) - 1.0) * tx
    y = (1.0 - 2.0 * np.asarray(py, float)) * ty
    d = f + r * x[..., None] + u * y[..., None]
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def _through_port(camera: Camera, d_air: np.ndarray, n_out: float) -> tuple[np.ndarray, np.ndarray]:
    """Origins on the port's outer surface and directions outside, for air directions ``d_air``."""
    f = camera.frame()[2]
    pupil = np.asarray(camera.position_m, float)
    port = camera.port
    if port.kind == "dome":
        return pupil + d_air * float(port.radius_m + port.thickness_m), d_air
    if port.kind != "flat":
        raise ConfigError(f"unknown port kind {port.kind!r}", field="camera.port.kind", allowed="dome, flat")
    cos_a = d_air @ f
    trans = d_air - f * cos_a[..., None]  # tangential part, |trans| = sin θ_air
    sin2_a = np.sum(trans * trans, axis=-1)
    ng = float(port.glass_index)
    cos_g = np.sqrt(np.maximum(1.0 - sin2_a / (ng * ng), 0.0))
    cos_w = np.sqrt(np.maximum(1.0 - sin2_a / (n_out * n_out), 0.0))
    d_glass = trans / ng + f * cos_g[..., None]
    d_out = trans / n_out + f * cos_w[..., None]
    p1 = pupil + d_air * (float(port.standoff_m) / cos_a)[..., None]
    origin = p1 + d_glass * (float(port.thickness_m) / cos_g)[..., None]
    return origin, d_out


def aperture_diameter_water_m(camera: Camera) -> float:
    """Diameter (m) of the entrance pupil as seen from the water: the thin lens of :func:`camera_rays`.

    ``f / N`` behind a flat port (a plane window does not magnify laterally); ``f / (N n_w)`` behind a
    dome concentric with the pupil (an object at a spherical surface's centre of curvature is imaged
    onto itself with lateral magnification ``n_air / n_water``; Born & Wolf 1999, §4.4).
    """
    d = camera.focal_length_mm * 1e-3 / camera.f_number
    return float(d / WATER_INDEX) if camera.port.kind == "dome" else float(d)


def defocus_blur_rad(camera: Camera, depth_m) -> np.ndarray:
    """Angular diameter (rad) of the defocus disc of points at ``depth_m`` ahead of the pupil.

    ``D_w |1/z − 1/s_f|`` (:func:`aperture_diameter_water_m`, ``s_f = focus_distance_m``); 0 for a
    camera without a focus distance (a pinhole).

    Examples
    --------
    >>> from rigsim.scene.types import Camera, Port
    >>> cam = Camera(port=Port(kind="flat"), focal_length_mm=24.0, f_number=8.0, focus_distance_m=1.0)
    >>> float(defocus_blur_rad(cam, 1.0)), round(float(defocus_blur_rad(cam, 0.5)) * 1e3, 6)   # 3 mm at 1/0.5 − 1
    (0.0, 3.0)
    """
    z = np.asarray(depth_m, float)
    if camera.focus_distance_m is None:
        return np.zeros(z.shape)
    with np.errstate(divide="ignore"):
        return aperture_diameter_water_m(camera) * np.abs(1.0 / z - 1.0 / float(camera.focus_distance_m))


def aperture_offsets(camera: Camera, u, v) -> np.ndarray:
    """Points (…, 3) of the water-side aperture, relative to its centre, for uniform ``u, v`` in [0, 1)².

    Shirley & Chiu's (1997) concentric map of the square onto the disc of diameter
    :func:`aperture_diameter_water_m`, in the plane across the optical axis.
    """
    a = 2.0 * np.asarray(u, float) - 1.0
    b = 2.0 * np.asarray(v, float) - 1.0
    first = np.abs(a) > np.abs(b)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(first, a, b)
        phi = np.where(first, (np.pi / 4) * b / np.where(a == 0, 1, a), np.pi / 2 - (np.pi / 4) * a / np.where(b == 0, 1, b))
    r = np.where((a == 0) & (b == 0), 0.0, r) * (0.5 * aperture_diameter_water_m(camera))
    right, up, _ = camera.frame()
    return (r * np.cos(phi))[..., None] * right + (r * np.sin(phi))[..., None] * up


def _thin_lens(camera: Camera, origin: np.ndarray, direction: np.ndarray, aperture) -> tuple[np.ndarray, np.ndarray]:
    """The rays of a film position through aperture points (``aperture = (u, v)``): from the aperture
    point to where the chief ray ``(origin, direction)`` is ``focus_distance_m`` deep."""
    pupil = np.asarray(camera.position_m, float)
    fwd = camera.frame()[2]
    depth0 = (origin - pupil) @ fwd
    t = (float(camera.focus_distance_m) - depth0) / (direction @ fwd)
    focus = origin + direction * t[..., None]
    off = aperture_offsets(camera, *aperture)
    if camera.port.kind == "dome":
        start = pupil + off  # the water-side pupil sits at the dome's centre
        d = focus - start
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        rel = start - pupil  # leave the dome's outer sphere: |rel + s d| = R
        R = float(camera.port.radius_m + camera.port.thickness_m)
        bq = np.sum(rel * d, axis=-1)
        s = -bq + np.sqrt(np.maximum(bq * bq - np.sum(rel * rel, axis=-1) + R * R, 0.0))
        return start + d * s[..., None], d
    start = origin + off  # a flat port: across the window's outer face
    d = focus - start
    return start, d / np.linalg.norm(d, axis=-1, keepdims=True)


def camera_rays(camera: Camera, px, py, *, n_outside: float, aperture=None) -> tuple[np.ndarray, np.ndarray]:
    """Rays leaving the port for film positions ``px``, ``py`` in [0, 1] (see module notes).

    Parameters
    ----------
    camera
        Pose, lens and port.
    px, py
        Film positions, any (equal) shape: 0 is the left / top edge, 1 the right / bottom.
    n_outside
        Refractive index outside the port (:func:`outside_index`).
    aperture
        ``(u, v)``, uniform numbers in [0, 1)² of the same shape: the rays through those points of
        the thin lens's aperture (module notes; a camera without ``focus_distance_m`` ignores them).
        None: the chief rays.

    Returns
    -------
    (origin, direction)
        Arrays of shape ``shape(px) + (3,)``: points on the port's outer surface (m) and unit
        directions in the outside medium.

    Examples
    --------
    >>> from rigsim.scene.types import Camera, Port
    >>> o, d = camera_rays(Camera(port=Port(kind="flat")), np.array(1.0), np.array(0.5), n_outside=1.34)
    >>> bool(abs(np.degrees(np.arcsin(d[0])) + np.degrees(np.arcsin(np.sin(np.arctan(0.75)) / 1.34))) < 1e-9)
    True
    """
    o, d = _through_port(camera, air_directions(camera, px, py), float(n_outside))
    if aperture is None or camera.focus_distance_m is None:
        return o, d
    return _thin_lens(camera, o, d, aperture)


def pixel_rays(camera: Camera, width: int, height: int, *, n_outside: float,
               step: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rays through a grid of film points ``step`` pixels apart (``step = 1``: the pixel centres).

    Returns
    -------
    (origin, direction, col, row)
        (m, n, 3) arrays and the pixel coordinates (centres at half-integers) of the grid's
        columns and rows.
    """
    if step == 1.0:
        col = np.arange(width) + 0.5
        row = np.arange(height) + 0.5
    else:
        col = np.linspace(0.0, width, max(2, int(np.ceil(width / step)) + 1))
        row = np.linspace(0.0, height, max(2, int(np.ceil(height / step)) + 1))
    PX, PY = np.meshgrid(col / width, row / height)
    o, d = camera_rays(camera, PX, PY, n_outside=n_outside)
    return o, d, col, row


def cell_solid_angles(camera: Camera, cols: int, rows: int, *, n_outside: float, pad_cells: int = 0) -> np.ndarray:
    """(rows, cols) solid angle (sr) outside the port of each cell of a ``cols × rows`` grid over the film
    (``cols, rows = width, height``: the pixels), from the chief rays through the cells' corners (each cell
    two spherical triangles, Van Oosterom & Strackee 1983).  ``pad_cells``: the grid goes on that many
    cells beyond each side of the film, (rows + 2 pad, cols + 2 pad)."""
    ce = np.linspace(-pad_cells / cols, 1.0 + pad_cells / cols, cols + 2 * pad_cells + 1)
    re = np.linspace(-pad_cells / rows, 1.0 + pad_cells / rows, rows + 2 * pad_cells + 1)
    PX, PY = np.meshgrid(ce, re)
    _, d = camera_rays(camera, PX, PY, n_outside=n_outside)

    def tri(a, b, c):
        num = np.abs(np.sum(a * np.cross(b, c), axis=-1))
        den = 1 + np.sum(a * b, -1) + np.sum(b * c, -1) + np.sum(c * a, -1)
        return 2 * np.arctan2(num, den)

    a, b, c_, d_ = d[:-1, :-1], d[:-1, 1:], d[1:, 1:], d[1:, :-1]
    return tri(a, b, c_) + tri(a, c_, d_)


def fov_water_deg(camera: Camera, n_outside: float = WATER_INDEX) -> float:
    """Horizontal field of view outside the port (deg): unchanged by a dome, Snell-narrowed by a flat port."""
    _, d = camera_rays(camera, np.array([0.0, 1.0]), np.array([0.5, 0.5]), n_outside=n_outside)
    return float(np.degrees(np.arccos(np.clip(d[0] @ d[1], -1.0, 1.0))))


def field_width_m(camera: Camera, distance_m: float, n_outside: float = WATER_INDEX) -> float:
    """Width of the field of view (m) on a plane ``distance_m`` ahead of the entrance pupil, square to the
    lens axis: ``2 d tan(fov/2)`` with the horizontal field of view outside the port (:func:`fov_water_deg`)."""
    return float(2.0 * distance_m * math.tan(math.radians(fov_water_deg(camera, n_outside)) / 2.0))


def angular_pitch_rad(camera: Camera, width: int, height: int, *, n_outside: float) -> tuple[float, float]:
    """Angle (rad) between neighbouring pixel rays outside the port at the image centre (x, y)."""
    px = np.array([0.5, 0.5 + 1.0 / width, 0.5])
    py = np.array([0.5, 0.5, 0.5 + 1.0 / height])
    _, d = camera_rays(camera, px, py, n_outside=n_outside)
    return (float(np.arccos(np.clip(d[0] @ d[1], -1, 1))), float(np.arccos(np.clip(d[0] @ d[2], -1, 1))))


def project_points(camera: Camera, points_m, width: int, height: int, *, n_outside: float) -> np.ndarray:
    """Pixel coordinates ``(col, row)`` of world points (NaN where not imaged): the inverse of :func:`camera_rays`.

    Dome: central projection through the pupil.  Flat port: the in-air angle θ of the ray
    that, refracted by :func:`camera_rays`' port model, passes through the point is found by
    bisection on the ray's distance from the axis at the point's depth (monotonic in θ).

    Parameters
    ----------
    points_m
        World points (…, 3), m.
    width, height
        Image size (pixels).
    n_outside
        Refractive index outside the port.
    """
    right, up, fwd = camera.frame()
    d = np.asarray(points_m, float) - np.asarray(camera.position_m, float)
    x, y, z = d @ right, d @ up, d @ fwd
    rho = np.hypot(x, y)
    if camera.port.kind == "flat":
        inner = camera.port.standoff_m + camera.port.thickness_m
        lo = np.zeros_like(rho)
        hi = np.full_like(rho, np.radians(89.999))
        zz = np.where(z > inner, z, inner)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            d_air = np.cos(mid)[..., None] * fwd + np.sin(mid)[..., None] * right  # radial plane: any azimuth
            o, dw = _through_port(camera, d_air, float(n_outside))
            rel = o - np.asarray(camera.position_m, float)
            s = (zz - rel @ fwd) / (dw @ fwd)
            too_far = rel @ right + s * (dw @ right) > rho
            hi = np.where(too_far, mid, hi)
            lo = np.where(too_far, lo, mid)
        theta_a = np.where((z > inner) & (hi < np.radians(89.99)), 0.5 * (lo + hi), np.nan)
    else:
        theta_a = np.where(z > 0, np.arctan2(rho, np.where(z > 0, z, 1.0)), np.nan)
    with np.errstate(invalid="ignore"):
        r_mm = camera.focal_length_mm * np.tan(theta_a)
        cphi = np.where(rho > 0, x / np.where(rho > 0, rho, 1), 1.0)
        sphi = np.where(rho > 0, y / np.where(rho > 0, rho, 1), 0.0)
    col = width * (0.5 + r_mm * cphi / camera.sensor_width_mm)
    row = height * (0.5 - r_mm * sphi / camera.sensor_height_mm)
    return np.stack([col, row], axis=-1)


def port_transmittance(camera: Camera, px, py, *, n_outside: float) -> np.ndarray:
    """Fresnel transmittance (0–1) of the port for the rays of film positions ``px, py``.

    ``(1 − R_og)(1 − R_ga)``: unpolarised Fresnel reflectance of the outside→glass and
    glass→air surfaces at the ray's angles (a dome: normal incidence on both; a flat port:
    θ_w → θ_g and θ_g → θ_a by Snell); multiple reflections and absorption in the glass are
    neglected.
    """
    d_air = air_directions(camera, px, py)
    ng = float(camera.port.glass_index)
    if camera.port.kind == "dome":
        cos_air = np.ones(d_air.shape[:-1])
    else:
        cos_air = d_air @ camera.frame()[2]
    sin2 = 1.0 - cos_air * cos_air
    cos_g = np.sqrt(np.maximum(1.0 - sin2 / ng**2, 0.0))
    cos_o = np.sqrt(np.maximum(1.0 - sin2 / float(n_outside) ** 2, 0.0))
    r1 = fresnel_reflectance_unpolarised(cos_o, float(n_outside), ng)
    r2 = fresnel_reflectance_unpolarised(cos_g, ng, 1.0)
    return (1.0 - r1) * (1.0 - r2)


def air_radiance_factor(camera: Camera, px, py, *, n_outside: float) -> np.ndarray:
    """Radiance in air behind the port per unit radiance outside it: ``T_port / n_outside²``."""
    return port_transmittance(camera, px, py, n_outside=n_outside) / float(n_outside) ** 2


def port_reach_m(camera: Camera) -> float:
    """Distance from the entrance pupil to the outer surface of the port along the axis (m).

    Dome: radius + thickness (the dome is centred on the pupil); flat port: standoff +
    thickness.
    """
    port = camera.port
    if port.kind == "dome":
        return port.radius_m + port.thickness_m
    return port.standoff_m + port.thickness_m


def port_viewpoint_m(camera: Camera, *, n_outside: float) -> float:
    """Distance (m) behind the port's outer surface, along the axis, of the point the rays near the image centre
    appear to come from outside the port: :func:`port_reach_m` for a dome (the pupil, its centre); for a flat
    port the paraxial virtual pupil, found from :func:`camera_rays` (a ray 1/1000 of the frame off the centre,
    extended back to the axis).  The small-angle blur of the camera leg sees a scattering ``u`` before the
    target ``ψ u / (s + this)`` off it (``s`` the water crossed: :meth:`rigsim.preview.forward.SmallAngle.blur_plan`).
    """
    if camera.port.kind == "dome":
        return port_reach_m(camera)
    o, d = camera_rays(camera, np.array([0.5, 0.501]), np.array([0.5, 0.5]), n_outside=float(n_outside))
    fwd = np.asarray(camera.frame()[2], float)
    pupil = np.asarray(camera.position_m, float)
    lat = (o[1] - pupil) - ((o[1] - pupil) @ fwd) * fwd  # the ray's start off the axis
    dl = d[1] - (d[1] @ fwd) * fwd  # its direction's part across the axis
    n_l = float(np.linalg.norm(dl))
    if n_l < 1e-12:
        return port_reach_m(camera)
    back = float(np.linalg.norm(lat)) / n_l * float(d[1] @ fwd)  # along the axis to where it crosses it
    return max(back, 0.0)


def equidistant_maps(camera: Camera, width: int, height: int, *, n_outside: float,
                     pitch_rad: tuple[float, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Maps between the image's pixels and an azimuthal equidistant grid of the same size about its centre.

    The equidistant grid's cell ``(i, j)`` is the direction ``θ`` = |α| off the image centre's ray, at the
    azimuth of α, with ``α = ((j − W/2 + ½) p_x, (i − H/2 + ½) p_y)`` (``p`` = ``pitch_rad``, the angle between
    neighbouring pixels at the centre): its distances from the centre are angles, exactly, at every azimuth (the
    pixels' are not: a pinhole's pixels are ``cos² θ`` narrower off the axis along the radius).  A blur that
    is the same in every direction — the camera leg's small-angle kernel — is a convolution on this grid.

    Returns
    -------
    (to_x, to_y, from_x, from_y)
        float32 (H, W) arrays of (column, row) index coordinates, as :func:`cv2.remap` takes them: where each
        pixel centre lies on the equidistant grid (``to``), and where each equidistant cell lies on the pixel
        grid (``from``; −1 beyond the directions the film can see).
    """
    W, H = int(width), int(height)
    tx, ty = tan_half_fov(camera)
    f = np.asarray(camera.frame()[2], float)
    # the water-side angle off the axis against the film's radius (in tangent units): radial in (x, y)
    rho_max = float(np.hypot(tx, ty)) * 1.000001
    rho = np.linspace(0.0, rho_max, 4097)
    d_air = f[None, :] + np.asarray(camera.frame()[0], float)[None, :] * rho[:, None]
    d_air /= np.linalg.norm(d_air, axis=-1, keepdims=True)
    _, d_out = _through_port(camera, d_air, float(n_outside))
    theta = np.arccos(np.clip(d_out @ f, -1.0, 1.0))
    px, py = float(pitch_rad[0]), float(pitch_rad[1])
    cx, cy = W / 2.0 - 0.5, H / 2.0 - 0.5
    # pixels → equidistant grid
    X = (2.0 * (np.arange(W) + 0.5) / W - 1.0) * tx  # film, tangent units: +x right (columns)
    Y = (2.0 * (np.arange(H) + 0.5) / H - 1.0) * ty  # +y down (rows)
    XX, YY = np.meshgrid(X, Y)
    r = np.hypot(XX, YY)
    th = np.interp(r, rho, theta)
    k = np.where(r > 0, th / np.where(r > 0, r, 1.0), theta[1] / rho[1])  # angle per tangent unit
    to_x = (cx + XX * k / px).astype(np.float32)
    to_y = (cy + YY * k / py).astype(np.float32)
    # equidistant grid → pixels
    ax = (np.arange(W) - cx) * px
    ay = (np.arange(H) - cy) * py
    AX, AY = np.meshgrid(ax, ay)
    t = np.hypot(AX, AY)
    inside = t <= theta[-1]
    rr = np.interp(t, theta, rho)
    q = np.where(t > 0, rr / np.where(t > 0, t, 1.0), rho[1] / theta[1])  # tangent units per angle
    from_x = np.where(inside, ((AX * q / tx) + 1.0) * W / 2.0 - 0.5, -1.0).astype(np.float32)
    from_y = np.where(inside, ((AY * q / ty) + 1.0) * H / 2.0 - 0.5, -1.0).astype(np.float32)
    return to_x, to_y, from_x, from_y


def world_radius_m(scene: Scene) -> float:
    """Radius of the water sphere around the scene (m): ≥ 1 km and ≫ every distance in it.

    The renderer's water volume and the fast engine's longest line of sight.
    """
    pts = [np.asarray(scene.camera.position_m, float)] + [np.asarray(l.position_m, float) for l in scene.lights]
    ext = max([t.distance_m for t in scene.targets] + [float(np.linalg.norm(p)) for p in pts] + [1.0])
    return float(max(1000.0, 100.0 * ext))
