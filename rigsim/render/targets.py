"""Target geometry for the renderer: surfaces in metres with spectral reflectance.

Every target is placed in the camera's frame: centred on the optical axis at
``Target.distance_m`` from the entrance pupil, facing the camera, rotated by
``tilt_deg`` about the axis.  All surfaces are Lambertian (two-sided).

* ``colorchecker`` — a ColorChecker Classic: a 279.4 × 215.9 mm black board with
  4 × 6 patches of 40 mm at a 46 mm pitch, all scaled so that the board is
  ``size_m`` wide; patch reflectances from ``colour.SDS_COLOURCHECKERS["ColorChecker
  N Ohta"]`` (380–780 nm, ends held), the board has the reflectance of the chart's
  own black patch.  Patch 1 (dark skin) is at the top left as seen by the camera.
* ``white-disk`` / ``black-disk`` — a disk of diameter ``size_m``.
* ``slanted-edge`` — a ``size_m`` square, left half white, right half black, the
  edge through the centre, slanted by ``tilt_deg``.
* ``bottom`` — a sand plane normal to the camera's ``up``: through the point at
  ``distance_m`` on the axis if the camera looks down, else ``distance_m`` below
  the pupil; it extends (almost) to the edge of the water volume.
* ``mesh`` — an OBJ/PLY file, centred on the axis, scaled so that its largest
  bounding-box extent is ``size_m``; its x, y, z axes along the camera's right, up,
  forward.

Reflectances default (when a target gives none) to :data:`DEFAULT_REFLECTANCE`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigsim.errors import ConfigError
from rigsim.render.camera import camera_frame
from rigsim.render.variant import mitsuba
from rigsim.scene.types import Camera, Target

__all__ = ["Surface", "target_surfaces", "colorchecker_reflectances", "DEFAULT_REFLECTANCE",
           "TARGET_KINDS", "CHART_BOARD_MM", "CHART_PATCH_MM", "CHART_PITCH_MM"]

mi, dr = mitsuba()

#: Flat reflectance used when a target has none: by kind.
DEFAULT_REFLECTANCE = {"white-disk": 0.9, "black-disk": 0.03, "slanted-edge-white": 0.9,
                       "slanted-edge-black": 0.03, "bottom": 0.3, "mesh": 0.5}
TARGET_KINDS = ("colorchecker", "black-disk", "white-disk", "slanted-edge", "bottom", "mesh")
CHART_BOARD_MM = (279.4, 215.9)
CHART_PATCH_MM = 40.0
CHART_PITCH_MM = 46.0
_CHART_PATCH_OFFSET_MM = 0.5  # patches stand proud of the board (no coplanar faces)


@dataclass(frozen=True)
class Surface:
    """One Mitsuba shape of a target.

    Attributes
    ----------
    key
        Unique shape id in the Mitsuba scene.
    shape
        Mitsuba dict of the shape (without BSDF or media).
    wavelength_nm, reflectance
        Spectral reflectance samples.
    label
        Human-readable name (for the object-id legend).
    target_index
        Index of the target in ``Scene.targets``.
    """

    key: str
    shape: dict
    wavelength_nm: np.ndarray
    reflectance: np.ndarray
    label: str
    target_index: int


def colorchecker_reflectances() -> list[tuple[str, np.ndarray, np.ndarray]]:
    """(name, wavelength_nm, reflectance) of the 24 patches, in chart order."""
    import colour

    sds = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    return [(name, np.asarray(sd.wavelengths, float), np.asarray(sd.values, float)) for name, sd in sds.items()]


def _frame(camera: Camera, tilt_deg: float):
    f, r, u = camera_frame(camera)
    t = np.radians(tilt_deg)
    r2 = np.cos(t) * r + np.sin(t) * u
    u2 = -np.sin(t) * r + np.cos(t) * u
    return f, r2, u2


def _plane_transform(centre, ax, ay, normal) -> "mi.ScalarTransform4f":
    """Affine map of Mitsuba's unit rectangle/disk (x, y ∈ [−1, 1], normal +z)."""
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = ax, ay, normal, centre
    return mi.ScalarTransform4f(m.tolist())


def _rect(centre, right, up, normal, half_w, half_h) -> dict:
    # right × up must equal the normal for a proper (non-mirroring) transform
    ax, ay = np.asarray(right) * half_w, np.asarray(up) * half_h
    if np.dot(np.cross(ax, ay), normal) < 0:
        ay = -ay
    return {"type": "rectangle", "to_world": _plane_transform(centre, ax, ay, normal)}


def _disk(centre, right, up, normal, radius) -> dict:
    d = _rect(centre, right, up, normal, radius, radius)
    d["type"] = "disk"
    return d


def _reflectance(target: Target, default_key: str):
    if target.reflectance:
        wl = np.asarray(target.reflectance_wavelength_nm, float)
        r = np.asarray(target.reflectance, float)
        if wl.shape != r.shape or wl.size == 0:
            raise ConfigError("reflectance and reflectance_wavelength_nm differ in length",
                              field=f"target.{target.kind}.reflectance")
        if wl.size == 1:
            return np.array([360.0, 830.0]), np.full(2, r[0])
        return wl, r
    v = DEFAULT_REFLECTANCE[default_key]
    return np.array([360.0, 830.0]), np.array([v, v])


def target_surfaces(camera: Camera, targets, *, world_radius_m: float) -> list[Surface]:
    """The Mitsuba surfaces of all targets, in order (object ids follow this order, from 1)."""
    out: list[Surface] = []
    pupil = np.asarray(camera.position_m, float)
    for ti, t in enumerate(targets):
        if t.kind not in TARGET_KINDS:
            raise ConfigError(f"unknown target kind {t.kind!r}", field="target.kind",
                              allowed=", ".join(TARGET_KINDS))
        if not (np.isfinite(t.distance_m) and t.distance_m > 0):
            raise ConfigError(f"target distance must be > 0 m, got {t.distance_m}", field="target.distance_m",
                              allowed="> 0")
        if not (np.isfinite(t.size_m) and t.size_m > 0):
            raise ConfigError(f"target size must be > 0 m, got {t.size_m}", field="target.size_m", allowed="> 0")
        f, r, u = _frame(camera, t.tilt_deg)
        centre = pupil + t.distance_m * f
        n = -f
        tag = f"t{ti}"
        if t.kind == "colorchecker":
            s = t.size_m / (CHART_BOARD_MM[0] / 1000.0)
            bw, bh = CHART_BOARD_MM[0] / 2000.0 * s, CHART_BOARD_MM[1] / 2000.0 * s
            patches = colorchecker_reflectances()
            board_wl, board_r = patches[-1][1], patches[-1][2]
            out.append(Surface(f"{tag}_board", _rect(centre, r, u, n, bw, bh), board_wl, board_r,
                               f"target {ti} colorchecker board", ti))
            pitch, half = CHART_PITCH_MM / 1000.0 * s, CHART_PATCH_MM / 2000.0 * s
            c0 = centre - _CHART_PATCH_OFFSET_MM / 1000.0 * s * f
            for k, (name, wl, refl) in enumerate(patches):
                row, col = divmod(k, 6)
                pc = c0 + (col - 2.5) * pitch * r + (1.5 - row) * pitch * u
                out.append(Surface(f"{tag}_patch{k + 1:02d}", _rect(pc, r, u, n, half, half), wl, refl,
                                   f"target {ti} colorchecker patch {k + 1} {name}", ti))
        elif t.kind in ("white-disk", "black-disk"):
            wl, refl = _reflectance(t, t.kind)
            out.append(Surface(f"{tag}_disk", _disk(centre, r, u, n, t.size_m / 2), wl, refl,
                               f"target {ti} {t.kind}", ti))
        elif t.kind == "slanted-edge":
            h = t.size_m / 2
            wl_w, r_w = _reflectance(t, "slanted-edge-white")
            v = DEFAULT_REFLECTANCE["slanted-edge-black"]
            out.append(Surface(f"{tag}_white", _rect(centre - r * h / 2, r, u, n, h / 2, h), wl_w, r_w,
                               f"target {ti} slanted-edge white", ti))
            out.append(Surface(f"{tag}_black", _rect(centre + r * h / 2, r, u, n, h / 2, h),
                               np.array([360.0, 830.0]), np.array([v, v]), f"target {ti} slanted-edge black", ti))
        elif t.kind == "bottom":
            f0, r0, u0 = camera_frame(camera)
            up = u0 if abs(np.dot(f0, np.asarray(camera.up, float))) > 0.999 else \
                np.asarray(camera.up, float) / np.linalg.norm(camera.up)
            if np.dot(f0, up) < -0.05:
                c = pupil + t.distance_m * f0
            else:
                c = pupil - t.distance_m * up
            # in-plane axes: horizontal projection of forward and the right vector
            ax = f0 - np.dot(f0, up) * up
            if np.linalg.norm(ax) < 1e-6:
                ax = u0 - np.dot(u0, up) * up
            ax = ax / np.linalg.norm(ax)
            ay = np.cross(up, ax)
            half = 0.5 * world_radius_m
            wl, refl = _reflectance(t, "bottom")
            out.append(Surface(f"{tag}_bottom", _rect(c, ax, ay, up, half, half), wl, refl,
                               f"target {ti} bottom", ti))
        elif t.kind == "mesh":
            out.append(_mesh_surface(t, ti, tag, centre, f, r, u))
    return out


def _mesh_surface(t: Target, ti: int, tag: str, centre, f, r, u) -> Surface:
    if not t.mesh_path:
        raise ConfigError("a mesh target needs mesh_path", field="target.mesh_path")
    p = Path(t.mesh_path)
    ext = p.suffix.lower()
    if ext not in (".obj", ".ply"):
        raise ConfigError(f"mesh must be .obj or .ply, got {p.name!r}", file=p, field="target.mesh_path",
                          allowed=".obj, .ply")
    if not p.is_file():
        raise ConfigError("mesh file not found", file=p, field="target.mesh_path")
    try:
        raw = mi.load_dict({"type": ext[1:], "filename": str(p)})
    except Exception as e:  # noqa: BLE001 - Mitsuba's parse errors are long; keep the first line
        raise ConfigError(f"cannot read mesh: {str(e).splitlines()[0][:200]}", file=p,
                          field="target.mesh_path") from None
    bb = raw.bbox()
    lo, hi = np.array(bb.min, float), np.array(bb.max, float)
    ext_max = float(np.max(hi - lo))
    if not np.isfinite(ext_max) or ext_max <= 0:
        raise ConfigError("mesh has no extent", file=p, field="target.mesh_path")
    s = t.size_m / ext_max
    mid = 0.5 * (lo + hi)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2] = r * s, u * s, f * s
    m[:3, 3] = centre - m[:3, :3] @ mid
    wl, refl = _reflectance(t, "mesh")
    shape = {"type": ext[1:], "filename": str(p), "to_world": mi.ScalarTransform4f(m.tolist())}
    return Surface(f"{tag}_mesh", shape, wl, refl, f"target {ti} mesh {p.name}", ti)
