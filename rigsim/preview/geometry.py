"""Geometry of the preview: ray casting against target surfaces, shadow tests.

Camera rays come from :mod:`rigsim.scene.optics` (the one camera and port model, shared with the
renderer).  The surfaces are those of :func:`rigsim.scene.surfaces.target_surfaces`, numbered 1…
across all targets in scene order, as the renderer numbers them; they are two-sided Lambertian
reflectors.

Flat pieces (rectangles, disks: charts, disks, the bottom) are intersected in numpy, plane by plane.
Triangle meshes (:func:`rigsim.scene.meshes.placed_mesh`, the arrays the renderer draws) are found by
Mitsuba's ray intersector (``Scene.ray_intersect_preliminary``: Embree's BVH on the CPU, in single
precision) on one Mitsuba mesh holding every mesh target's triangles; the hit triangle is then
intersected again in double precision (Möller & Trumbore 1997) for the distance and the barycentric
coordinates, and the shading normal is interpolated from the vertex normals as Mitsuba does
(smooth shading; two-sided: the caller turns it to the side it meets).  Rays start
``MESH_EPS_REL · (1 + |o|∞)`` past their origin in the mesh test (single precision would find the
surface a ray leaves at t ≈ 0).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from rigsim.errors import ConfigError
from rigsim.scene.meshes import placed_mesh
from rigsim.scene.surfaces import target_surfaces, Surface
from rigsim.scene.types import Scene

__all__ = ["SceneSurfaces", "MeshSet", "scene_surfaces", "cast_rays", "occluded", "MESH_EPS_REL"]

#: Mesh rays start this far (relative to 1 + the origin's largest coordinate, m) past their origin: a
#: few float32 steps, so a ray leaving a triangle does not meet it again.
MESH_EPS_REL = 4e-6

_ACCEL_LOCK = threading.Lock()

#: Rays per call of Mitsuba's intersector (bounds its memory: ~100 bytes a ray).
_MESH_CHUNK = 1 << 21


@dataclass(frozen=True, eq=False)
class MeshSet:
    """The triangles of every mesh surface of a scene, in world coordinates (m).

    Attributes
    ----------
    v0, e1, e2
        (T, 3) first vertex and the edges to the second and third.
    geo_normal
        (T, 3) unit face normals (the file's winding).
    corner_normals
        (T, 3, 3) unit vertex normals at the three corners (smooth shading).
    oid
        (T,) object id (1-based) of each triangle.
    area_m2
        (T,) triangle areas.
    """

    v0: np.ndarray
    e1: np.ndarray
    e2: np.ndarray
    geo_normal: np.ndarray
    corner_normals: np.ndarray
    oid: np.ndarray
    area_m2: np.ndarray

    def __len__(self) -> int:
        return len(self.oid)

    @classmethod
    def from_surfaces(cls, pieces) -> "MeshSet | None":
        """The :class:`MeshSet` of the mesh pieces among ``pieces`` (object id = position + 1), or None."""
        parts = []
        for k, p in enumerate(pieces):
            if p.shape != "mesh":
                continue
            V, F, N = placed_mesh(p.mesh_path, p.matrix())
            parts.append((V[F], N[F], np.full(len(F), k + 1, np.int32)))
        if not parts:
            return None
        tri = np.concatenate([q[0] for q in parts])
        cn = np.concatenate([q[1] for q in parts])
        e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
        cr = np.cross(e1, e2)
        length = np.linalg.norm(cr, axis=1)
        geo = cr / np.maximum(length, 1e-300)[:, None]
        # a corner without a normal (on no triangle of the file) shades flat
        bad = np.linalg.norm(cn, axis=2) < 0.5
        cn = np.where(bad[..., None], geo[:, None, :], cn)
        out = cls(tri[:, 0].copy(), e1, e2, geo, cn, np.concatenate([q[2] for q in parts]), 0.5 * length)
        out._accel()
        return out

    def _accel(self):
        """One Mitsuba scene with all the triangles (built once; :meth:`from_surfaces` builds it on the
        calling thread, before the image's tiles run on threads)."""
        with _ACCEL_LOCK:
            return self._accel_locked()

    def _accel_locked(self):
        acc = self.__dict__.get("_scene")
        if acc is None:
            from rigsim.render.variant import mitsuba

            mi, _ = mitsuba()
            T = len(self)
            verts = np.stack([self.v0, self.v0 + self.e1, self.v0 + self.e2], axis=1).reshape(-1, 3)
            mesh = mi.Mesh("rigsim_fast_meshes", 3 * T, T)
            params = mi.traverse(mesh)
            params["vertex_positions"] = mi.Float(verts.astype(np.float32).ravel())
            params["faces"] = mi.UInt32(np.arange(3 * T, dtype=np.uint32))
            params.update()
            acc = self.__dict__["_scene"] = (mi, mi.load_dict({"type": "scene", "meshes": mesh}))
        return acc

    def first_hits(self, o: np.ndarray, d: np.ndarray, t_max: np.ndarray | None = None, *, precise: bool = True
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """First triangle along each ray (o, d: (N, 3) unit directions), nearer than ``t_max`` if given:
        ``(t, triangle index, u, v)`` (inf, −1 where none; u, v barycentric of the 2nd and 3rd vertex).
        ``precise=False``: t and (u, v) as the single-precision search found them (no float64 re-intersection:
        for rays whose hit need not be exact to the micrometre: about a quarter less time)."""
        mi, scene = self._accel()
        N = len(d)
        t = np.full(N, np.inf)
        tri = np.full(N, -1, np.int64)
        if not precise:
            u, v = np.zeros(N), np.zeros(N)
        eps = MESH_EPS_REL * (1.0 + np.max(np.abs(o), axis=1)) if N else np.zeros(0)
        for a in range(0, N, _MESH_CHUNK):
            b = min(N, a + _MESH_CHUNK)
            oo = (o[a:b] + eps[a:b, None] * d[a:b]).astype(np.float32)
            dd = d[a:b].astype(np.float32)
            ray = mi.Ray3f(mi.Point3f(*(mi.Float(oo[:, i]) for i in range(3))),
                           mi.Vector3f(*(mi.Float(dd[:, i]) for i in range(3))))
            if t_max is not None:
                ray.maxt = mi.Float(np.maximum(t_max[a:b] - eps[a:b], 0.0).astype(np.float32))
            pi = scene.ray_intersect_preliminary(ray)
            tt = np.asarray(pi.t.numpy(), float)
            hit = np.isfinite(tt)
            tri[a:b] = np.where(hit, np.asarray(pi.prim_index.numpy(), np.int64), -1)
            if not precise:
                t[a:b] = np.where(hit, tt + eps[a:b], np.inf)
                uv = pi.prim_uv.numpy()  # (float32; undefined where nothing was hit: kept out before widening)
                u[a:b], v[a:b] = np.where(hit, uv[0], 0.0), np.where(hit, uv[1], 0.0)
        if not precise:
            return t, tri, u, v
        u = np.zeros(N)
        v = np.zeros(N)
        idx = np.flatnonzero(tri >= 0)
        if idx.size:
            k = tri[idx]
            tt, uu, vv = _moller_trumbore(o[idx], d[idx], self.v0[k], self.e1[k], self.e2[k])
            # single precision may call a hit that double precision puts a hair outside: keep the hit,
            # clamping its coordinates onto the triangle
            uu, vv = np.clip(uu, 0.0, 1.0), np.clip(vv, 0.0, 1.0)
            over = uu + vv > 1.0
            sv = np.where(over, uu + vv, 1.0)
            uu, vv = uu / sv, vv / sv
            ok = np.isfinite(tt) & (tt > 0)
            if t_max is not None:
                ok &= tt < t_max[idx]
            t[idx] = np.where(ok, tt, np.inf)
            tri[idx] = np.where(ok, k, -1)
            u[idx], v[idx] = uu, vv
        return t, tri, u, v

    def shading_normal(self, tri: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """(N, 3) unit normals interpolated from the corners (the face normal where that vanishes)."""
        cn = self.corner_normals[tri]
        n = (1.0 - u - v)[:, None] * cn[:, 0] + u[:, None] * cn[:, 1] + v[:, None] * cn[:, 2]
        length = np.linalg.norm(n, axis=1, keepdims=True)
        return np.where(length > 1e-9, n / np.maximum(length, 1e-300), self.geo_normal[tri])


def _moller_trumbore(o, d, v0, e1, e2):
    """Ray parameter and barycentric (u, v) of the rays' planes crossing with their triangles (float64)."""
    pv = np.cross(d, e2)
    det = np.sum(e1 * pv, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(np.abs(det) > 1e-300, 1.0 / det, np.nan)
        tv = o - v0
        u = np.sum(tv * pv, axis=1) * inv
        qv = np.cross(tv, e1)
        v = np.sum(d * qv, axis=1) * inv
        t = np.sum(e2 * qv, axis=1) * inv
    return t, u, v


@dataclass(frozen=True, eq=False)
class SceneSurfaces:
    """All target surfaces of a scene as arrays (surface k ↔ object id k + 1).

    Attributes
    ----------
    surfaces
        The :class:`~rigsim.scene.surfaces.Surface` pieces.
    labels
        Object-id legend labels (``"target 0 colorchecker: dark skin"``), as the renderer's.
    center, u, v, normal
        (S, 3) arrays.
    half_size
        (S, 2) half extents along u and v (rectangles), radius in column 0 (disks); for a mesh, half
        its largest extent (the square about its centre in the (u, v) plane that holds it).
    is_disk, is_mesh
        (S,) bool.
    meshes
        The triangles of the mesh surfaces (:class:`MeshSet`), None if there are none.
    """

    surfaces: tuple[Surface, ...]
    labels: tuple[str, ...]
    center: np.ndarray
    u: np.ndarray
    v: np.ndarray
    normal: np.ndarray
    half_size: np.ndarray
    is_disk: np.ndarray
    is_mesh: np.ndarray
    meshes: MeshSet | None = None

    def __len__(self) -> int:
        return len(self.surfaces)

    def reflectance(self, wavelength_nm) -> np.ndarray:
        """(S + 1, n_wl) reflectances; row 0 (no surface) is zero."""
        wl = np.asarray(wavelength_nm, float)
        rows = [np.zeros(wl.shape)]
        for s in self.surfaces:
            rows.append(np.interp(wl, np.asarray(s.wavelength_nm, float), np.asarray(s.reflectance, float)))
        return np.stack(rows)


def scene_surfaces(scene: Scene) -> SceneSurfaces:
    """Collect the target surfaces of ``scene`` (ids and labels as the renderer's)."""
    pieces, labels = [], []
    for ti, t in enumerate(scene.targets):
        if not (np.isfinite(t.distance_m) and t.distance_m > 0):
            raise ConfigError(f"distance must be > 0 m, got {t.distance_m}", field=f"targets[{ti}].distance_m",
                              allowed="> 0")
        if not (np.isfinite(t.size_m) and t.size_m > 0):
            raise ConfigError(f"size must be > 0 m, got {t.size_m}", field=f"targets[{ti}].size_m",
                              allowed="> 0")
        for p in target_surfaces(t, scene.camera):
            pieces.append(p)
            labels.append(f"target {ti} {t.kind}: {p.name}")
    S = len(pieces)

    def arr(name):
        return np.array([getattr(p, name) for p in pieces], float).reshape(S, 3)

    half = np.array([p.size_m for p in pieces], float).reshape(S, 2) / 2.0
    return SceneSurfaces(tuple(pieces), tuple(labels), arr("center_m"), arr("u_axis"), arr("v_axis"),
                         arr("normal"), half, np.array([p.shape == "disk" for p in pieces], bool),
                         np.array([p.shape == "mesh" for p in pieces], bool), MeshSet.from_surfaces(pieces))


@dataclass(frozen=True, eq=False)
class _Piece:
    """Surface ``k`` as the ray tests use it: its plane ``x·normal = offset`` and in-plane axes (with the
    keys that identify shared ones: the ColorChecker's patches share one plane and one pair of axes)."""

    normal: np.ndarray
    offset: float
    u: np.ndarray
    v: np.ndarray
    cu: float
    cv: float
    half: tuple[float, float]
    disk: bool
    n_key: tuple
    u_key: tuple
    v_key: tuple

    @property
    def plane_key(self) -> tuple:
        return self.n_key, self.offset


def _key(axis: np.ndarray) -> tuple:
    return tuple(np.round(axis, 15))


def _plan(surf: SceneSurfaces) -> list[_Piece | None]:
    """The :class:`_Piece` of each flat surface (None for a mesh), kept on ``surf``."""
    plan = surf.__dict__.get("_plan")
    if plan is None:
        plan = []
        for k in range(len(surf)):
            if surf.is_mesh[k]:
                plan.append(None)
                continue
            c, n, u, v = surf.center[k], surf.normal[k], surf.u[k], surf.v[k]
            disk = bool(surf.is_disk[k])
            half = (float(surf.half_size[k, 0]), float(surf.half_size[k, 0 if disk else 1]))
            plan.append(_Piece(n, float(c @ n), u, v, float(c @ u), float(c @ v), half, disk, _key(n), _key(u),
                               _key(v)))
        surf.__dict__["_plan"] = plan  # (frozen dataclass: a cache, not a field)
    return plan


class _RayDots:
    """Per-ray quantities shared by the scene's surfaces: dot products with its few distinct directions,
    each distinct plane's ray parameter, the in-plane coordinates of the hit points."""

    def __init__(self, origin: np.ndarray, direction: np.ndarray):
        self.o, self.d = origin, direction
        self._cache: dict = {}

    def dots(self, key: tuple, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        hit = self._cache.get(key)
        if hit is None:
            hit = self._cache[key] = (self.o @ axis, self.d @ axis)
        return hit

    def plane(self, pc: _Piece) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(t, t or 0 where not finite, t > 0 and finite)`` of the piece's plane."""
        key = ("plane", pc.plane_key)
        hit = self._cache.get(key)
        if hit is None:
            on, dn = self.dots(pc.n_key, pc.normal)
            with np.errstate(divide="ignore", invalid="ignore"):
                t = np.where(np.abs(dn) > 1e-12, (pc.offset - on) / dn, np.inf)
            fin = np.isfinite(t)
            hit = self._cache[key] = (t, np.where(fin, t, 0.0), (t > 0) & fin)
        return hit

    def along(self, pc: _Piece, axis_key: tuple, axis: np.ndarray) -> np.ndarray:
        """``o·axis + t d·axis``: the coordinate along ``axis`` of the point where each ray meets the plane."""
        key = ("along", pc.plane_key, axis_key)
        hit = self._cache.get(key)
        if hit is None:
            oa, da = self.dots(axis_key, axis)
            hit = self._cache[key] = oa + self.plane(pc)[1] * da
        return hit

    def candidates(self, pieces: list[_Piece], k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Rays that may hit piece ``k``: those meeting the bounding box of all the pieces that share its plane
        and axes — ``(index, t, coordinate along u, along v)`` of those rays."""
        pc = pieces[k]
        key = ("cand", pc.plane_key, pc.u_key, pc.v_key)
        hit = self._cache.get(key)
        if hit is None:
            group = [q for q in pieces if q is not None and (q.plane_key, q.u_key, q.v_key) == (pc.plane_key, pc.u_key, pc.v_key)]
            t, _, valid = self.plane(pc)
            a, b = self.along(pc, pc.u_key, pc.u), self.along(pc, pc.v_key, pc.v)
            m = valid
            for lo, hi, x in ((min(q.cu - q.half[0] for q in group), max(q.cu + q.half[0] for q in group), a),
                              (min(q.cv - q.half[1] for q in group), max(q.cv + q.half[1] for q in group), b)):
                tol = 1e-9 * (1.0 + abs(lo) + abs(hi))  # (the exact test below rounds)
                m = m & (x >= lo - tol) & (x <= hi + tol)
            idx = np.flatnonzero(m)
            hit = self._cache[key] = (idx, t[idx], a[idx], b[idx])
        return hit


def _inside(pc: _Piece, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Whether in-plane offsets ``(a, b)`` from the piece's centre are on it."""
    a, b = a - pc.cu, b - pc.cv
    if pc.disk:
        return a * a + b * b <= pc.half[0] ** 2
    return (np.abs(a) <= pc.half[0]) & (np.abs(b) <= pc.half[1])


def _hit_t(surf: SceneSurfaces, k: int, origin: np.ndarray, direction: np.ndarray,
           dots: _RayDots | None = None) -> np.ndarray:
    """Ray parameter of the hit with surface ``k`` (inf where missed)."""
    dots = dots or _RayDots(origin, direction)
    pc = _plan(surf)[k]
    t, _, valid = dots.plane(pc)
    inside = _inside(pc, dots.along(pc, pc.u_key, pc.u), dots.along(pc, pc.v_key, pc.v))
    return np.where(inside & valid, t, np.inf)


def cast_rays(surf: SceneSurfaces, origin: np.ndarray, direction: np.ndarray, *, normals: bool = False,
              precise: bool = True):
    """First hit of each ray: ``(t, object_id)`` (t = inf and id 0 where nothing is hit); with
    ``normals=True`` also the (…, 3) unit normal there (a flat piece's, a mesh's interpolated shading
    normal, not turned to any side; zero where nothing is hit); ``precise=False``: meshes' hits in single
    precision (:meth:`MeshSet.first_hits`).

    Flat surfaces are tested in order (the first of equally near ones wins), each on the rays that meet
    the bounding box of the pieces sharing its plane; then the meshes (:class:`MeshSet`).
    """
    shape = direction.shape[:-1]
    d = direction.reshape(-1, 3)
    o = np.broadcast_to(origin, direction.shape).reshape(-1, 3)
    best = np.full(len(d), np.inf)
    oid = np.zeros(len(d), np.int32)
    dots = _RayDots(o, d)
    pieces = _plan(surf)
    for k, pc in enumerate(pieces):
        if pc is None:
            continue
        idx, t, a, b = dots.candidates(pieces, k)
        if not len(idx):
            continue
        t = np.where(_inside(pc, a, b), t, np.inf)
        hit = t < best[idx]
        best[idx] = np.where(hit, t, best[idx])
        oid[idx] = np.where(hit, k + 1, oid[idx])
    nrm = None
    if normals:
        nrm = np.zeros((len(d), 3))
        m = oid > 0
        nrm[m] = surf.normal[oid[m] - 1]
    ms = surf.meshes
    if ms is not None and len(d):
        t, tri, u, v = ms.first_hits(o, d, np.where(np.isfinite(best), best, np.inf) if np.any(oid) else None,
                                     precise=precise)
        hit = (tri >= 0) & (t < best)
        if np.any(hit):
            best[hit] = t[hit]
            oid[hit] = ms.oid[tri[hit]]
            if normals:
                nrm[hit] = ms.shading_normal(tri[hit], u[hit], v[hit])
    if normals:
        return best.reshape(shape), oid.reshape(shape), nrm.reshape(shape + (3,))
    return best.reshape(shape), oid.reshape(shape)


def occluded(surf: SceneSurfaces, points: np.ndarray, light_pos: np.ndarray, *,
             exclude: np.ndarray | None = None, eps: float = 1e-6) -> np.ndarray:
    """Whether the segment from each point to the light crosses a surface (other than the flat surface
    ``exclude``; a mesh may shadow itself, the mesh test starting :data:`MESH_EPS_REL` off the point)."""
    d = np.asarray(light_pos, float) - points
    dist = np.linalg.norm(d, axis=-1)
    d = d / np.maximum(dist, 1e-300)[..., None]
    blocked = np.zeros(points.shape[:-1], bool)
    dots = _RayDots(points, d)
    for k, pc in enumerate(_plan(surf)):
        if pc is None:
            continue
        t = _hit_t(surf, k, points, d, dots)
        b = (t > eps) & (t < dist - eps)
        if exclude is not None:
            b &= exclude != k + 1
        blocked |= b
    ms = surf.meshes
    if ms is not None and blocked.size:
        flat_b = blocked.reshape(-1)
        todo = np.flatnonzero(~flat_b)
        if todo.size:
            p = points.reshape(-1, 3)[todo]
            t, tri, _, _ = ms.first_hits(p, d.reshape(-1, 3)[todo], dist.reshape(-1)[todo] - eps)
            flat_b[todo] = tri >= 0
        blocked = flat_b.reshape(blocked.shape)
    return blocked
