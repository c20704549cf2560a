"""Test targets as explicit geometry: flat pieces (and meshes) in world coordinates, with object ids.

A :class:`~rigsim.scene.types.Target` says *what* is looked at and how far away;
:func:`target_surfaces` turns it into explicit :class:`Surface` pieces in world coordinates
(rectangles, disks, a bottom plane, or a mesh) with their reflectance spectra
(:mod:`rigsim.scene.reflectances`) and object ids — what both engines build their shapes from
and what :func:`rigsim.scene.layout.target_layout` maps into image pixels.

Placement (all targets but ``bottom``): the target's centre is on the optical
axis at ``distance_m`` from the entrance pupil, its face perpendicular to the
axis and facing the camera, its "right" and "up" along the image's right and up,
then rotated by ``tilt_deg`` about the axis (counter-clockwise as seen by the
camera).

``bottom``: a horizontal sand plane (normal = world +y, the scene's "up")
``distance_m`` **below** the entrance pupil, i.e. ``distance_m`` is the camera's
altitude above the bottom; a square of side ``size_m`` (default 100 m) centred
under the camera.  With a level camera the bottom fills the lower half of the
frame up to the horizon; pitch the camera down to look at it.

Pieces: ColorChecker 279.4 × 215.9 mm, 24 patches of 40 mm on a 45 mm pitch (the patch pitch
is our approximation of the X-Rite layout) on a black (4 %) body; patches sit 0.5 mm proud of
the body (as real patches do) so the two never share a plane.  Slanted edge (ISO 12233): a
square of side ``size_m`` split into a black left half and a white right half, default tilt 5°.
Meshes: the file's triangles (:mod:`rigsim.scene.meshes`), scaled to ``size_m`` and centred,
with a flat reflectance given by the caller (default 18 % grey) or a CSV.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Literal

import numpy as np

from rigsim.errors import ConfigError, unknown_name_error
from rigsim.scene.meshes import read_mesh
from rigsim.scene.reflectances import (
    BLACK_REFLECTANCE,
    MESH_DEFAULT_REFLECTANCE,
    REFLECTANCE_WAVELENGTHS_NM,
    WHITE_REFLECTANCE,
    reflectance_benthic_Maritorena1994,
    reflectance_colorchecker_Ohta,
)
from rigsim.scene.types import Camera, Target

__all__ = ["TARGET_KINDS", "COLORCHECKER_WIDTH_M", "COLORCHECKER_HEIGHT_M", "COLORCHECKER_PATCH_M",
           "COLORCHECKER_PITCH_M", "DEFAULT_SIZE_M", "DEFAULT_TILT_DEG", "Surface", "disk_cell_fraction", "target_surfaces"]

#: Built-in target kinds (besides ``mesh``).
TARGET_KINDS = ("colorchecker", "black-disk", "white-disk", "slanted-edge", "bottom", "seabed")

COLORCHECKER_WIDTH_M = 0.2794   #: Classic ColorChecker width, 11 in (m).
COLORCHECKER_HEIGHT_M = 0.2159  #: Classic ColorChecker height, 8.5 in (m).
COLORCHECKER_PATCH_M = 0.040    #: Patch side (m), approximate.
COLORCHECKER_PITCH_M = 0.045    #: Patch centre-to-centre spacing (m), our approximation.
_PATCH_RAISE_M = 0.0005         #: Patches stand this far in front of the chart body (m).

#: Default ``size_m`` per kind (m): chart width, disk diameter, edge-target side, bottom side.
DEFAULT_SIZE_M = {"colorchecker": COLORCHECKER_WIDTH_M, "black-disk": 0.30, "white-disk": 0.30,
                  "slanted-edge": 0.30, "bottom": 100.0, "seabed": 12.0}

#: Default tilt about the optical axis (deg): 5° for the slanted edge (ISO 12233).
DEFAULT_TILT_DEG = {"slanted-edge": 5.0}


@dataclass(frozen=True)
class Surface:
    """One flat piece of a target (or a mesh), in world coordinates.

    Attributes
    ----------
    name
        Patch or part name (``"dark skin"``, ``"chart"``, ``"disk"``, ``"black"``,
        ``"white"``, ``"bottom"``, ``"mesh"``).
    shape
        ``"rectangle"`` (side ``size_m[0]`` along ``u_axis``, ``size_m[1]`` along
        ``v_axis``), ``"disk"`` (diameter ``size_m[0]``), ``"mesh"``.
    center_m
        Centre (m).
    u_axis, v_axis, normal
        Orthonormal in-plane axes and the normal (towards the camera; up for the bottom).
    size_m
        (width, height) in m; for a mesh, its largest extent twice.
    wavelength_nm, reflectance
        Lambertian reflectance (0–1) at ``wavelength_nm``.
    object_id
        1-based id (0 is "no target") — use it for the per-pixel object-id layer.
    mesh_path
        For meshes, the absolute path of the OBJ/PLY file.
    to_world
        4×4 affine matrix (row-major tuple of tuples).  Rectangles: maps the
        square [−1, 1]² of the local xy plane (normal +z) onto the surface; disks:
        the unit disk; meshes: the file's coordinates (metres, x right, y up,
        +z towards the camera) onto the scene (bounding-box centre to
        ``center_m``, uniform scale).  Same conventions as Mitsuba's
        ``rectangle`` and ``disk`` shapes.
    """

    name: str
    shape: Literal["rectangle", "disk", "mesh"]
    center_m: tuple[float, float, float]
    u_axis: tuple[float, float, float]
    v_axis: tuple[float, float, float]
    normal: tuple[float, float, float]
    size_m: tuple[float, float]
    wavelength_nm: tuple[float, ...]
    reflectance: tuple[float, ...]
    object_id: int
    mesh_path: str | None = None
    to_world: tuple[tuple[float, ...], ...] = field(default=(), repr=False)

    def matrix(self) -> np.ndarray:
        """``to_world`` as a 4×4 array."""
        return np.array(self.to_world, float)

    def outline_m(self, n: int = 64) -> np.ndarray:
        """Outline points (k, 3) in world coordinates (4 corners, or ``n`` points on a disk)."""
        c, u, v = (np.asarray(x) for x in (self.center_m, self.u_axis, self.v_axis))
        if self.shape == "disk":
            a = np.linspace(0, 2 * np.pi, n, endpoint=False)
            r = self.size_m[0] / 2
            return c + r * (np.cos(a)[:, None] * u + np.sin(a)[:, None] * v)
        w, h = self.size_m[0] / 2, self.size_m[1] / 2
        corners = [(-w, -h), (w, -h), (w, h), (-w, h)]
        return np.array([c + a * u + b * v for a, b in corners])


def _affine(center, ax, ay, az) -> tuple[tuple[float, ...], ...]:
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = ax, ay, az, center
    return tuple(tuple(float(x) for x in row) for row in m)


def _t3(a) -> tuple[float, float, float]:
    return tuple(float(x) for x in a)  # type: ignore[return-value]


def _flat_piece(name, shape, center, u, v, n, w, h, refl, oid) -> Surface:
    scale_u, scale_v = (w / 2, h / 2)
    return Surface(name=name, shape=shape, center_m=_t3(center), u_axis=_t3(u), v_axis=_t3(v),
                   normal=_t3(n), size_m=(float(w), float(h)),
                   wavelength_nm=tuple(REFLECTANCE_WAVELENGTHS_NM.tolist()),
                   reflectance=tuple(np.asarray(refl, float).tolist()), object_id=oid,
                   to_world=_affine(center, scale_u * u, scale_v * v, n))


def _flat(value: float) -> np.ndarray:
    return np.full(REFLECTANCE_WAVELENGTHS_NM.shape, float(value))


def _target_reflectance(target: Target, default) -> np.ndarray:
    if target.reflectance:
        return np.interp(REFLECTANCE_WAVELENGTHS_NM, target.reflectance_wavelength_nm, target.reflectance)
    return default


def _rotate_pair(a: np.ndarray, b: np.ndarray, angle_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Rotate two orthonormal vectors by ``angle_deg`` within their plane."""
    t = np.radians(angle_deg)
    return np.cos(t) * a + np.sin(t) * b, -np.sin(t) * a + np.cos(t) * b


def disk_cell_fraction(cells: int, n_sub: int = 64) -> np.ndarray:
    """(cells, cells) fraction of each cell of a ``cells × cells`` grid over a disk's bounding square that lies
    on the disk (``n_sub``² points per cell): the texture cells of a disk target in the light tracers."""
    g = (np.arange(cells * n_sub) + 0.5) / (cells * n_sub) * 2 - 1
    on = (g[:, None] ** 2 + g[None, :] ** 2 <= 1.0).reshape(cells, n_sub, cells, n_sub)
    return on.mean(axis=(1, 3))


def target_surfaces(target: Target, camera: Camera) -> tuple[Surface, ...]:
    """Explicit geometry of a target in world coordinates (see the module notes for placement).

    Returns
    -------
    tuple of Surface
        Object ids 1…n in order.  ColorChecker: the chart body then the 24
        patches (chart order); disks: one disk; slanted edge: ``black`` (left)
        and ``white`` (right); bottom: one rectangle; seabed: its patch and, where it has one, the
        seabed beyond (:func:`rigsim.scene.seabed.skirt_path`); mesh: one mesh.
    """
    right, up, fwd = camera.frame()
    pupil = np.asarray(camera.position_m, float)
    toward = -fwd
    a = np.radians(target.tilt_deg)
    u = np.cos(a) * right + np.sin(a) * up     # rotated "right" (counter-clockwise seen from the camera)
    v = -np.sin(a) * right + np.cos(a) * up
    if target.yaw_deg or target.pitch_deg:     # turn away from facing the camera: about v, then about u
        u, toward = _rotate_pair(u, toward, target.yaw_deg)
        v, toward = _rotate_pair(v, toward, target.pitch_deg)
    ox, oy = (float(x) for x in target.offset_m)
    centre = pupil + target.distance_m * fwd + ox * right + oy * up
    size = float(target.size_m)
    kind = target.kind

    if kind == "colorchecker":
        s = size / COLORCHECKER_WIDTH_M
        body = _flat_piece("chart", "rectangle", centre, u, v, toward, size, COLORCHECKER_HEIGHT_M * s,
                           _flat(BLACK_REFLECTANCE), 1)
        out = [body]
        patches = reflectance_colorchecker_Ohta()
        for i, (name, refl) in enumerate(patches.items()):
            r, c = divmod(i, 6)
            pc = centre + s * ((c - 2.5) * COLORCHECKER_PITCH_M * u + (1.5 - r) * COLORCHECKER_PITCH_M * v) \
                + _PATCH_RAISE_M * toward
            out.append(_flat_piece(name, "rectangle", pc, u, v, toward, COLORCHECKER_PATCH_M * s,
                                   COLORCHECKER_PATCH_M * s, refl, i + 2))
        return tuple(out)
    if kind in ("black-disk", "white-disk"):
        default = _flat(BLACK_REFLECTANCE if kind == "black-disk" else WHITE_REFLECTANCE)
        return (_flat_piece("disk", "disk", centre, u, v, toward, size, size,
                            _target_reflectance(target, default), 1),)
    if kind == "slanted-edge":
        half = size / 2
        return (_flat_piece("black", "rectangle", centre - half / 2 * u, u, v, toward, half, size,
                            _flat(BLACK_REFLECTANCE), 1),
                _flat_piece("white", "rectangle", centre + half / 2 * u, u, v, toward, half, size,
                            _flat(WHITE_REFLECTANCE), 2))
    if kind == "bottom":
        world_up = np.array([0.0, 1.0, 0.0])
        bu = right - world_up * np.dot(right, world_up)
        if np.linalg.norm(bu) < 1e-6:
            bu = np.array([1.0, 0.0, 0.0])
        bu = bu / np.linalg.norm(bu)
        bv = np.cross(world_up, bu)  # (bu, bv, up) right-handed
        c = pupil - target.distance_m * world_up
        return (_flat_piece("bottom", "rectangle", c, bu, bv, world_up, size, size,
                            _target_reflectance(target, reflectance_benthic_Maritorena1994()["coral_sand"]), 1),)
    if kind == "seabed":
        from rigsim.scene.seabed import AHEAD_FRACTION, SIDE_SHIFT, SeabedSpec, seabed_mesh_file, skirt_path

        path = target.mesh_path or str(seabed_mesh_file(SeabedSpec()))
        verts = read_mesh(path).vertices
        extent = float(np.max((verts.max(axis=0) - verts.min(axis=0))[[0, 2]]))
        world_up = np.array([0.0, 1.0, 0.0])
        bu = right - world_up * np.dot(right, world_up)
        if np.linalg.norm(bu) < 1e-6:
            bu = np.array([1.0, 0.0, 0.0])
        bu = bu / np.linalg.norm(bu)
        ahead = np.cross(bu, world_up)  # the seabed's +z: horizontal, towards where the camera looks
        if np.dot(ahead, fwd) < 0:
            ahead = -ahead
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2] = bu, world_up, np.cross(bu, world_up)
        # (and a hair to the side: no grid line of the patch in the vertical plane through the camera —
        # rays in that plane, the middle column of an image of odd width, would run along shared edges,
        # which single-precision ray casting can miss)
        m[:3, 3] = pupil - target.distance_m * world_up + AHEAD_FRACTION * extent * ahead + SIDE_SHIFT * extent * bu
        refl = tuple(_target_reflectance(target, reflectance_benthic_Maritorena1994()["coral_sand"]).tolist())
        out = [Surface(name="seabed", shape="mesh", center_m=_t3(m[:3, 3]), u_axis=_t3(bu), v_axis=_t3(ahead),
                       normal=_t3(world_up), size_m=(extent, extent),
                       wavelength_nm=tuple(REFLECTANCE_WAVELENGTHS_NM.tolist()), reflectance=refl,
                       object_id=1, mesh_path=str(Path(path).resolve()),
                       to_world=tuple(tuple(float(x) for x in row) for row in m))]
        far = skirt_path(path)
        if far.is_file():  # the seabed beyond the patch (rigsim.scene.seabed): its own surface, same frame
            far_extent = float(np.max(np.ptp(read_mesh(str(far)).vertices, axis=0)[[0, 2]]))
            out.append(replace(out[0], name="seabed far", size_m=(far_extent, far_extent),
                                           object_id=2, mesh_path=str(far.resolve())))
        return tuple(out)
    if kind == "mesh":
        if target.mesh_path is None:
            raise ConfigError("a mesh target needs mesh_path", field="target")
        verts = read_mesh(target.mesh_path).vertices
        lo, hi = verts.min(axis=0), verts.max(axis=0)
        extent = float(np.max(hi - lo))
        scale = size / extent if extent > 0 else 1.0
        bc = (lo + hi) / 2
        rot = np.stack([u, v, toward], axis=1)         # columns: local x, y, z → world
        m = np.eye(4)
        m[:3, :3] = scale * rot
        m[:3, 3] = centre - scale * rot @ bc
        refl = _target_reflectance(target, _flat(MESH_DEFAULT_REFLECTANCE))
        return (Surface(name="mesh", shape="mesh", center_m=_t3(centre), u_axis=_t3(u), v_axis=_t3(v),
                        normal=_t3(toward), size_m=(size, size),
                        wavelength_nm=tuple(REFLECTANCE_WAVELENGTHS_NM.tolist()),
                        reflectance=tuple(refl.tolist()), object_id=1,
                        mesh_path=str(target.mesh_path),
                        to_world=tuple(tuple(float(x) for x in row) for row in m)),)
    raise unknown_name_error("target", kind, (*TARGET_KINDS, "mesh"), field="target")
