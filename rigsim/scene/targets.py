"""Test targets: reflectances, 3-D geometry in the scene, and where they land in the image.

A :class:`~rigsim.scene.types.Target` says *what* is looked at and how far away;
:func:`target_surfaces` turns it into explicit flat :class:`Surface` pieces in
world coordinates (rectangles, disks, a bottom plane, or a mesh) with their
reflectance spectra and object ids — what a renderer builds its shapes from —
and :func:`target_layout` maps them into image pixels for the metrics.

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

Reflectances (Lambertian, tabulated 360–830 nm every 5 nm, :data:`REFLECTANCE_WAVELENGTHS_NM`):

* ColorChecker: N. Ohta's measurements (as shipped with colour-science,
  ``colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]``, 380–780 nm every 5 nm)
  **edge-held** to 360–830 nm; chart 279.4 × 215.9 mm, 24 patches of
  40 mm on a 45 mm pitch (the patch pitch is our approximation of the X-Rite
  layout); the chart body is black (4 %).  Patches sit 0.5 mm proud of the body
  (as real patches do) so the two never share a plane.
* black disk: flat 4 %; white disk: flat 90 % (a matte white paint/board; a
  Spectralon-type standard would be ~99 %) — stated values, not measurements.
* slanted edge (ISO 12233): a square of side ``size_m`` split into a black (4 %)
  left half and a white (90 %) right half; default tilt 5°.
* bottom: generic sand (data/targets/sand_generic_assumed.csv — an assumption,
  see its header).
* mesh: a flat reflectance given by the caller (default 18 % grey) or a CSV
  ``wavelength_nm, reflectance``.

Image coordinates: pixel ``(col, row)``, origin at the top-left corner of the
image, col to the right, row down, pixel centres at half-integers; the image's
right is ``forward × up`` (as Mitsuba renders); rays and projections through the
port are those of :mod:`rigsim.scene.optics` (the one camera and port model), also
without water (the clear ground truth keeps the in-water view).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from rigsim.data import load_table, read_csv_table
from rigsim.errors import ConfigError, DataError, unknown_name_error
from rigsim.scene.types import Camera, Scene, Target

__all__ = [
    "TARGET_KINDS",
    "REFLECTANCE_WAVELENGTHS_NM",
    "COLORCHECKER_WIDTH_M",
    "COLORCHECKER_HEIGHT_M",
    "COLORCHECKER_PATCH_M",
    "COLORCHECKER_PITCH_M",
    "BLACK_REFLECTANCE",
    "WHITE_REFLECTANCE",
    "DEFAULT_SIZE_M",
    "Surface",
    "TargetLayout",
    "reflectance_colorchecker_Ohta",
    "reflectance_sand_assumed",
    "reflectance_from_csv",
    "target_surfaces",
    "target_layout",
    "mesh_vertices",
]

#: Built-in target kinds (besides ``mesh``).
TARGET_KINDS = ("colorchecker", "black-disk", "white-disk", "slanted-edge", "bottom")

#: Wavelengths at which target reflectances are tabulated (nm): 360–830, 5 nm.
REFLECTANCE_WAVELENGTHS_NM = np.arange(360.0, 830.0 + 0.5, 5.0)

COLORCHECKER_WIDTH_M = 0.2794   #: Classic ColorChecker width, 11 in (m).
COLORCHECKER_HEIGHT_M = 0.2159  #: Classic ColorChecker height, 8.5 in (m).
COLORCHECKER_PATCH_M = 0.040    #: Patch side (m), approximate.
COLORCHECKER_PITCH_M = 0.045    #: Patch centre-to-centre spacing (m), our approximation.
_PATCH_RAISE_M = 0.0005         #: Patches stand this far in front of the chart body (m).

BLACK_REFLECTANCE = 0.04        #: Black disk / chart body / black half of the edge target.
WHITE_REFLECTANCE = 0.90        #: White disk / white half of the edge target.
MESH_DEFAULT_REFLECTANCE = 0.18  #: Grey for meshes without a reflectance.

#: Default ``size_m`` per kind (m): chart width, disk diameter, edge-target side, bottom side.
DEFAULT_SIZE_M = {"colorchecker": COLORCHECKER_WIDTH_M, "black-disk": 0.30, "white-disk": 0.30,
                  "slanted-edge": 0.30, "bottom": 100.0}

#: Default tilt about the optical axis (deg): 5° for the slanted edge (ISO 12233).
DEFAULT_TILT_DEG = {"slanted-edge": 5.0}


# ----------------------------------------------------------------------------- reflectances

def _hold(wl_table, values, wavelength_nm) -> np.ndarray:
    return np.interp(np.asarray(wavelength_nm, float), wl_table, values)


def reflectance_colorchecker_Ohta(wavelength_nm=REFLECTANCE_WAVELENGTHS_NM) -> dict[str, np.ndarray]:
    """ColorChecker patch reflectances (N. Ohta 1997), chart order, edge-held outside 380–780 nm.

    The data are colour-science's ``SDS_COLOURCHECKERS["ColorChecker N Ohta"]`` (380–780 nm,
    5 nm), interpolated linearly.

    Returns
    -------
    dict
        Patch name → reflectance (0–1) at ``wavelength_nm``; 24 entries in chart
        order (row-major from the top-left, ``dark skin`` … ``black 2 (1.5 D)``).
    """
    import colour

    sds = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    return {n: _hold(sd.wavelengths, sd.values, wavelength_nm) for n, sd in sds.items()}


def reflectance_sand_assumed(wavelength_nm=REFLECTANCE_WAVELENGTHS_NM) -> np.ndarray:
    """Generic sand bottom reflectance (assumed, see data/targets/sand_generic_assumed.csv)."""
    t = load_table("targets/sand_generic_assumed.csv")
    return _hold(t["wavelength_nm"], t["reflectance"], wavelength_nm)


def reflectance_from_csv(path: str | Path, wavelength_nm=REFLECTANCE_WAVELENGTHS_NM) -> np.ndarray:
    """A reflectance CSV (``wavelength_nm, reflectance``, 0–1, covering 400–700 nm), edge-held."""
    p = Path(path)
    if not p.is_file():
        raise ConfigError("reflectance file not found", file=p,
                          allowed="a CSV with columns wavelength_nm, reflectance")
    try:
        t = read_csv_table(p)
    except DataError as exc:
        raise ConfigError(f"cannot read reflectance: {exc}", file=p) from None
    if "wavelength_nm" not in t.columns or "reflectance" not in t.columns:
        raise ConfigError("needs columns wavelength_nm, reflectance", file=p,
                          allowed="columns wavelength_nm, reflectance")
    wl, r = t.columns["wavelength_nm"], t.columns["reflectance"]
    if wl.dtype.kind != "f" or r.dtype.kind != "f" or not (np.all(np.isfinite(wl)) and np.all(np.isfinite(r))):
        raise ConfigError("non-numeric or blank values", file=p)
    if wl.size < 2 or np.any(np.diff(wl) <= 0) or wl[0] > 400 or wl[-1] < 700:
        raise ConfigError("wavelengths must increase and cover 400–700 nm", file=p,
                          allowed="increasing wavelengths covering 400–700 nm")
    if np.any(r < 0) or np.any(r > 1):
        raise ConfigError("reflectance must be within 0–1", file=p, allowed="0 <= reflectance <= 1")
    return _hold(wl, r, wavelength_nm)


# ----------------------------------------------------------------------------- geometry

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


def target_surfaces(target: Target, camera: Camera) -> tuple[Surface, ...]:
    """Explicit geometry of a target in world coordinates (see the module notes for placement).

    Returns
    -------
    tuple of Surface
        Object ids 1…n in order.  ColorChecker: the chart body then the 24
        patches (chart order); disks: one disk; slanted edge: ``black`` (left)
        and ``white`` (right); bottom: one rectangle; mesh: one mesh.
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
                            _target_reflectance(target, reflectance_sand_assumed()), 1),)
    if kind == "mesh":
        if target.mesh_path is None:
            raise ConfigError("a mesh target needs mesh_path", field="target")
        verts = mesh_vertices(target.mesh_path)
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


# ----------------------------------------------------------------------------- meshes

def mesh_vertices(path: str | Path) -> np.ndarray:
    """Vertex positions (n, 3) of an OBJ or PLY file (read-only; :func:`rigsim.scene.meshes.read_mesh`,
    the reader the renderer uses too); a missing/unreadable file is a ConfigError."""
    from rigsim.scene.meshes import read_mesh

    return read_mesh(path).vertices


# ----------------------------------------------------------------------------- image mapping

@dataclass(frozen=True, eq=False)
class TargetLayout:
    """Where a target lands in an image of ``width × height`` pixels.

    Attributes
    ----------
    surfaces
        The target's :class:`Surface` pieces (object id i ↔ ``surfaces[i-1]``).
    label_map
        (height, width) int array: object id of the surface seen by each pixel's
        chief ray (0 = none), by exact ray casting (meshes are not rasterised:
        use the renderer's object-id layer for them).
    polygons
        Name → (k, 2) outline in pixel coordinates ``(col, row)``, for surfaces
        entirely in front of the camera.
    centers
        Name → projected centre ``(col, row)`` (NaN if not imaged).
    edge
        Slanted edge only: the edge's two end points in pixels, (2, 2), else None.
    """

    surfaces: tuple[Surface, ...]
    label_map: np.ndarray
    polygons: dict[str, np.ndarray]
    centers: dict[str, np.ndarray]
    edge: np.ndarray | None = None

    def mask(self, name: str) -> np.ndarray:
        """Boolean (height, width) mask of the pixels that see surface ``name``."""
        for s in self.surfaces:
            if s.name == name:
                return self.label_map == s.object_id
        raise unknown_name_error("surface", name, [s.name for s in self.surfaces])


def target_layout(scene: Scene, width: int, height: int, *, target_index: int = 0) -> TargetLayout:
    """Map a scene's target into image pixels (labels, outlines, edge) for the metrics.

    Parameters
    ----------
    scene
        The scene (camera and targets); the rays are the renderers' (in-water
        geometry, also for the clear ground truth without water).
    width, height
        Image size (pixels).
    target_index
        Which of ``scene.targets``.

    Examples
    --------
    >>> from rigsim.scene.build import build_scene
    >>> from rigsim.scene.types import Rig, Camera
    >>> sc = build_scene(Rig(name="r", camera=Camera()), None, "white-disk", 2.0)
    >>> lay = target_layout(sc, 60, 40)
    >>> bool(lay.mask("disk")[20, 30]), bool(lay.mask("disk")[0, 0])
    (True, False)
    """
    from rigsim.scene.optics import outside_index, pixel_rays, project_points

    camera = scene.camera
    target = scene.targets[target_index]
    surfaces = target_surfaces(target, camera)
    n_w = outside_index(scene)
    origin, dirs = pixel_rays(camera, width, height, n_outside=n_w)[:2]
    best = np.full((height, width), np.inf)
    label = np.zeros((height, width), dtype=np.int32)
    for s in surfaces:
        if s.shape == "mesh":
            continue
        c, n = np.asarray(s.center_m), np.asarray(s.normal)
        u, v = np.asarray(s.u_axis), np.asarray(s.v_axis)
        den = dirs @ n
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(np.abs(den) > 1e-12, ((c - origin) @ n) / den, np.inf)
        p = origin + t[..., None] * dirs
        a, b = (p - c) @ u, (p - c) @ v
        if s.shape == "disk":
            inside = a * a + b * b <= (s.size_m[0] / 2) ** 2
        else:
            inside = (np.abs(a) <= s.size_m[0] / 2) & (np.abs(b) <= s.size_m[1] / 2)
        hit = inside & (t > 0) & (t < best)
        best = np.where(hit, t, best)
        label = np.where(hit, s.object_id, label)
    polygons = {}
    centers = {}
    right, up, fwd = camera.frame()
    for s in surfaces:
        centers[s.name] = project_points(camera, np.asarray(s.center_m), width, height, n_outside=n_w)
        if s.shape == "mesh":
            continue
        pts = s.outline_m()
        if np.all((pts - np.asarray(camera.position_m, float)) @ fwd > 0):
            px = project_points(camera, pts, width, height, n_outside=n_w)
            if np.all(np.isfinite(px)):
                polygons[s.name] = px
    edge = None
    if target.kind == "slanted-edge":
        white = surfaces[1]
        c, u, v = (np.asarray(x) for x in (white.center_m, white.u_axis, white.v_axis))
        ends = np.array([c - white.size_m[0] / 2 * u - white.size_m[1] / 2 * v,
                         c - white.size_m[0] / 2 * u + white.size_m[1] / 2 * v])
        edge = project_points(camera, ends, width, height, n_outside=n_w)
    return TargetLayout(surfaces=surfaces, label_map=label, polygons=polygons, centers=centers, edge=edge)
