"""PyVista meshes of a scene for the rig designer's 3-D view.

:func:`scene_parts` turns a :class:`~rigsim.scene.types.Scene` into named
:class:`Part` objects — housing and port, the camera's field of view in water,
each light as a cone whose half-angle is half its beam angle (capped at 80° for
drawing) along its aim, the arms, the target's explicit surfaces
(:func:`rigsim.scene.surfaces.target_surfaces`) in their colours, the water volume
tinted by the water's colour at the chosen depth, and distance markers along the
lens axis — and :func:`draw` puts them in a :class:`pyvista.Plotter`, replacing
the previous parts by name.

Colours are display colours (sRGB of a spectrum under D65 or of the light's own
spectrum), not measurements.  The water's colour is the upwelling radiance at depth
from :func:`rigsim.daylight.shortcut.ambient_light_kd`.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from rigsim.colorimetry import XYZ_from_bands
from rigsim.scene.types import Scene

__all__ = ["Part", "scene_parts", "draw", "spectrum_to_srgb", "water_colour", "reflectance_colour"]

_WL = np.arange(400.0, 701.0, 10.0)


@dataclass
class Part:
    """One named mesh and how to draw it."""

    name: str
    mesh: object  # pyvista.DataSet
    color: tuple[float, float, float] = (0.7, 0.7, 0.7)
    opacity: float = 1.0
    style: str = "surface"
    line_width: float = 1.0
    labels: list[tuple[tuple[float, float, float], str]] = field(default_factory=list)


@functools.lru_cache(maxsize=1)
def _d65() -> np.ndarray:
    import colour

    d65 = colour.SDS_ILLUMINANTS["D65"]
    return np.interp(_WL, d65.wavelengths, d65.values)


def _xyz_to_srgb(xyz: np.ndarray) -> tuple[float, float, float]:
    import colour

    lin = np.asarray(colour.XYZ_to_RGB(xyz, "sRGB", apply_cctf_encoding=False), float)
    lin = np.clip(lin, 0.0, None)
    enc = np.clip(np.asarray(colour.cctf_encoding(np.clip(lin, 0, 1), function="sRGB"), float), 0, 1)
    return tuple(float(x) for x in enc)  # type: ignore[return-value]


def spectrum_to_srgb(wavelength_nm, values, *, normalise: bool = True) -> tuple[float, float, float]:
    """Display colour of an emission spectrum (brightest channel = 1 if ``normalise``)."""
    s = np.interp(_WL, np.asarray(wavelength_nm, float), np.asarray(values, float), left=0, right=0)
    xyz = XYZ_from_bands(s, _WL)
    if normalise:
        import colour

        lin = np.clip(np.asarray(colour.XYZ_to_RGB(xyz, "sRGB", apply_cctf_encoding=False), float), 0, None)
        if lin.max() > 0:
            xyz = xyz / lin.max()
    return _xyz_to_srgb(xyz)


def reflectance_colour(wavelength_nm, reflectance) -> tuple[float, float, float]:
    """sRGB of a reflectance under D65 (white = 1)."""
    r = np.interp(_WL, np.asarray(wavelength_nm, float), np.asarray(reflectance, float))
    xyz = XYZ_from_bands(r, _WL, illuminant=_d65())
    return _xyz_to_srgb(xyz)


def water_colour(water, depth_m: float) -> tuple[float, float, float]:
    """Display colour of the water at ``depth_m``: hue of the upwelling radiance Lu(λ) there,
    darkened with depth by the cube root of its luminance relative to just below the surface."""
    from rigsim.daylight.shortcut import ambient_light_kd

    depth = float(max(depth_m, 0.0))
    res = ambient_light_kd(water, _WL, [0.0, depth])
    lu = np.asarray(res["Lu"], float)
    y0, y = (float(v) for v in XYZ_from_bands(lu[:2], _WL)[:, 1])
    hue = spectrum_to_srgb(_WL, lu[1])
    k = 0.85 * (y / y0) ** (1 / 3) if y0 > 0 else 0.3
    return tuple(float(c * max(k, 0.08)) for c in hue)  # type: ignore[return-value]


def _polygon(points: np.ndarray):
    import pyvista as pv

    n = len(points)
    return pv.PolyData(np.asarray(points, float), faces=np.concatenate([[n], np.arange(n)]))


def _lines(segments: list[tuple[np.ndarray, np.ndarray]]):
    import pyvista as pv

    pts = np.array([p for s in segments for p in s], float)
    cells = np.concatenate([[2, 2 * i, 2 * i + 1] for i in range(len(segments))])
    return pv.PolyData(pts, lines=cells)


def scene_parts(scene: Scene, *, water_rgb: tuple[float, float, float] | None = None,
                selected_light: int | None = None) -> list[Part]:
    """The named parts of the 3-D view (see the module docstring)."""
    import pyvista as pv

    from rigsim.scene.optics import fov_water_deg
    from rigsim.scene.surfaces import target_surfaces

    cam = scene.camera
    right, up, fwd = cam.frame()
    pupil = np.asarray(cam.position_m, float)
    parts: list[Part] = []
    dist = max((t.distance_m for t in scene.targets if t.kind != "bottom"), default=1.5)

    # --- housing (behind the port) and port
    hr = cam.housing_radius_m
    port = cam.port
    body_c = pupil - fwd * (hr * 0.9)
    body = pv.Box(bounds=(-hr, hr, -0.75 * hr, 0.75 * hr, -0.8 * hr, 0.8 * hr))
    rot = np.stack([right, up, fwd], axis=1)
    m = np.eye(4)
    m[:3, :3] = rot
    m[:3, 3] = body_c
    parts.append(Part("housing", body.transform(m, inplace=False), (0.18, 0.2, 0.24)))
    if port.kind == "dome":
        dome = pv.Sphere(radius=port.radius_m, center=pupil, direction=fwd, theta_resolution=32,
                         phi_resolution=16, start_phi=0, end_phi=90)
        parts.append(Part("port", dome, (0.75, 0.9, 1.0), opacity=0.35))
    else:
        disk = pv.Disc(center=pupil + fwd * port.standoff_m, inner=0, outer=port.radius_m, normal=fwd, c_res=48)
        parts.append(Part("port", disk, (0.75, 0.9, 1.0), opacity=0.45))

    # --- field of view in water (frustum to just past the target)
    hx = math.radians(fov_water_deg(cam)) / 2
    tx = math.tan(hx)
    ty = tx * cam.sensor_height_mm / cam.sensor_width_mm
    reach = dist * 1.05
    corners = [pupil + reach * (fwd + sx * tx * right + sy * ty * up) for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    parts.append(Part("frustum", _lines([(pupil, c) for c in corners] +
                                        [(corners[i], corners[(i + 1) % 4]) for i in range(4)]),
                      (1.0, 1.0, 1.0), style="wireframe", line_width=1.5, opacity=0.8))
    faces = pv.PolyData(np.array([pupil, *corners]), faces=np.array([3, 0, 1, 2, 3, 0, 2, 3, 3, 0, 3, 4, 3, 0, 4, 1]))
    parts.append(Part("frustum_faces", faces, (1.0, 1.0, 1.0), opacity=0.06))

    # --- lights: head, arm, beam cone
    labels = []
    arm_segments = []
    for i, light in enumerate(scene.lights):
        pos = np.asarray(light.position_m, float)
        aim = np.asarray(light.aim, float)
        aim = aim / np.linalg.norm(aim)
        col = spectrum_to_srgb(light.wavelength_nm, light.axial_intensity)
        half = math.radians(min(light.beam.beam_angle_deg / 2 if light.beam.kind == "soft-cone"
                                else _table_half_angle(light.beam), 80.0))
        length = max(0.3, dist * 0.9)
        cone = pv.Cone(center=pos + aim * length / 2, direction=-aim, height=length,
                       radius=length * math.tan(half), resolution=48, capping=False)
        sel = selected_light == i
        parts.append(Part(f"beam{i}", cone, col, opacity=0.32 if sel else 0.2))
        head = pv.Cylinder(center=pos - aim * 0.04, direction=aim, radius=0.045, height=0.09)
        parts.append(Part(f"head{i}", head, (1.0, 0.55, 0.1) if sel else (0.85, 0.85, 0.85)))
        # arm: from the housing's side, in the image plane, to the light
        local = np.array([np.dot(pos - pupil, right), np.dot(pos - pupil, up)])
        n = np.linalg.norm(local)
        base = pupil - fwd * (hr * 0.5) + (hr * (local[0] * right + local[1] * up) / n if n > 0 else 0)
        arm_segments.append((base, pos - aim * 0.085))
        labels.append((tuple(pos + up * 0.08), light.name))
    if arm_segments:
        arms = _lines(arm_segments).tube(radius=0.012)
        parts.append(Part("arms", arms, (0.55, 0.57, 0.6)))

    # --- targets
    for ti, target in enumerate(scene.targets):
        for s in target_surfaces(target, cam):
            if s.shape == "mesh":
                continue
            poly = _polygon(s.outline_m(64))
            parts.append(Part(f"target{ti}:{s.object_id}", poly, reflectance_colour(s.wavelength_nm, s.reflectance)))

    # --- distance markers along the axis
    step = 0.5 if dist <= 4 else 1.0
    ticks = np.arange(step, dist + 1e-6, step)
    tick_len = 0.05 + 0.02 * dist
    segs = [(pupil, pupil + fwd * dist)]
    for d in ticks:
        c = pupil + fwd * d
        segs.append((c - right * tick_len, c + right * tick_len))
        labels.append((tuple(c - up * tick_len * 1.6), f"{d:g} m"))
    parts.append(Part("axis", _lines(segs), (1.0, 0.9, 0.3), style="wireframe", line_width=2.0))

    # --- water volume
    if scene.water is not None and water_rgb is not None:
        half_w = reach * tx + 0.6
        half_h = reach * ty + 0.5
        box = pv.Box(bounds=(-half_w, half_w, -half_h, half_h, -0.4, reach + 0.4))
        m2 = np.eye(4)
        m2[:3, :3] = rot
        m2[:3, 3] = pupil
        parts.append(Part("water", box.transform(m2, inplace=False), water_rgb, opacity=0.10))
    parts.append(Part("labels", pv.PolyData(np.array([p for p, _ in labels], float)) if labels else pv.PolyData(),
                      labels=labels))
    return parts


def _table_half_angle(beam) -> float:
    """Half-intensity half-angle (deg) of a tabulated beam."""
    a, r = np.asarray(beam.angle_deg, float), np.asarray(beam.relative, float)
    below = np.nonzero(r < 0.5)[0]
    return float(a[below[0]]) if below.size else float(a[-1])


def draw(plotter, parts: list[Part], *, background=None, previous: set[str] | None = None) -> set[str]:
    """Add (or replace, by name) ``parts`` in ``plotter``; remove names of ``previous`` no longer present.

    Returns the set of names drawn (pass it back as ``previous`` next time).
    """
    names = set()
    for p in parts:
        if p.labels:
            pts = np.array([q for q, _ in p.labels], float)
            plotter.add_point_labels(pts, [t for _, t in p.labels], name=p.name, font_size=13,
                                     text_color="white", shape=None, show_points=False, always_visible=True)
        elif p.mesh is not None and getattr(p.mesh, "n_points", 0) > 0:
            plotter.add_mesh(p.mesh, name=p.name, color=p.color, opacity=p.opacity, style=p.style,
                             line_width=p.line_width, smooth_shading=True, reset_camera=False)
        else:
            continue
        names.add(p.name)
    for old in (previous or set()) - names:
        plotter.remove_actor(old, reset_camera=False)
    if background is not None:
        top = tuple(min(1.0, c * 1.6 + 0.05) for c in background)
        bottom = tuple(c * 0.35 for c in background)
        plotter.set_background(bottom, top=top)
    return names
