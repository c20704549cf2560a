"""Geometry of the preview: ray casting against target surfaces, shadow tests.

Pure numpy, no Mitsuba.  Camera rays come from :mod:`rigsim.scene.optics` (the one
camera and port model, shared with the renderer).  The surfaces are those of
:func:`rigsim.scene.surfaces.target_surfaces`, numbered 1… across all targets in scene
order, as the renderer numbers them; they are two-sided Lambertian reflectors.

Mesh targets are not supported by the preview (it has no triangle intersector).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigsim.errors import ConfigError
from rigsim.scene.surfaces import target_surfaces, Surface
from rigsim.scene.types import Scene

__all__ = ["SceneSurfaces", "scene_surfaces", "cast_rays", "occluded"]


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
        (S, 2) half extents along u and v (rectangles), radius in column 0 (disks).
    is_disk
        (S,) bool.
    """

    surfaces: tuple[Surface, ...]
    labels: tuple[str, ...]
    center: np.ndarray
    u: np.ndarray
    v: np.ndarray
    normal: np.ndarray
    half_size: np.ndarray
    is_disk: np.ndarray

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
            if p.shape == "mesh":
                raise ConfigError("the preview cannot draw mesh targets; use the renderer",
                                  field=f"targets[{ti}]", allowed="colorchecker, disks, slanted-edge, bottom")
            pieces.append(p)
            labels.append(f"target {ti} {t.kind}: {p.name}")
    S = len(pieces)

    def arr(name):
        return np.array([getattr(p, name) for p in pieces], float).reshape(S, 3)

    half = np.array([p.size_m for p in pieces], float).reshape(S, 2) / 2.0
    return SceneSurfaces(tuple(pieces), tuple(labels), arr("center_m"), arr("u_axis"), arr("v_axis"),
                         arr("normal"), half, np.array([p.shape == "disk" for p in pieces], bool))


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


def _plan(surf: SceneSurfaces) -> list[_Piece]:
    """The :class:`_Piece` of each surface, kept on ``surf``."""
    plan = surf.__dict__.get("_plan")
    if plan is None:
        plan = []
        for k in range(len(surf)):
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
            group = [q for q in pieces if (q.plane_key, q.u_key, q.v_key) == (pc.plane_key, pc.u_key, pc.v_key)]
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


def cast_rays(surf: SceneSurfaces, origin: np.ndarray, direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First hit of each ray: ``(t, object_id)`` (t = inf and id 0 where nothing is hit).

    Surfaces are tested in order (the first of equally near ones wins), each on the rays that meet
    the bounding box of the pieces sharing its plane.
    """
    shape = direction.shape[:-1]
    d = direction.reshape(-1, 3)
    o = np.broadcast_to(origin, direction.shape).reshape(-1, 3)
    best = np.full(len(d), np.inf)
    oid = np.zeros(len(d), np.int32)
    dots = _RayDots(o, d)
    pieces = _plan(surf)
    for k, pc in enumerate(pieces):
        idx, t, a, b = dots.candidates(pieces, k)
        if not len(idx):
            continue
        t = np.where(_inside(pc, a, b), t, np.inf)
        hit = t < best[idx]
        best[idx] = np.where(hit, t, best[idx])
        oid[idx] = np.where(hit, k + 1, oid[idx])
    return best.reshape(shape), oid.reshape(shape)


def occluded(surf: SceneSurfaces, points: np.ndarray, light_pos: np.ndarray, *,
             exclude: np.ndarray | None = None, eps: float = 1e-6) -> np.ndarray:
    """Whether the segment from each point to the light crosses a surface (other than ``exclude``)."""
    d = np.asarray(light_pos, float) - points
    dist = np.linalg.norm(d, axis=-1)
    d = d / np.maximum(dist, 1e-300)[..., None]
    blocked = np.zeros(points.shape[:-1], bool)
    dots = _RayDots(points, d)
    for k in range(len(surf)):
        t = _hit_t(surf, k, points, d, dots)
        b = (t > eps) & (t < dist - eps)
        if exclude is not None:
            b &= exclude != k + 1
        blocked |= b
    return blocked
