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


class _RayDots:
    """Per-ray dot products with the scene's few distinct directions (surfaces share normals and axes)."""

    def __init__(self, origin: np.ndarray, direction: np.ndarray):
        self.o, self.d = origin, direction
        self._cache: dict = {}

    def dots(self, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        key = tuple(np.round(axis, 15))
        hit = self._cache.get(key)
        if hit is None:
            hit = self._cache[key] = (self.o @ axis, self.d @ axis)
        return hit


def _hit_t(surf: SceneSurfaces, k: int, origin: np.ndarray, direction: np.ndarray,
           dots: _RayDots | None = None) -> np.ndarray:
    """Ray parameter of the hit with surface ``k`` (inf where missed)."""
    dots = dots or _RayDots(origin, direction)
    c, n, u, v = surf.center[k], surf.normal[k], surf.u[k], surf.v[k]
    on, dn = dots.dots(n)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(np.abs(dn) > 1e-12, (c @ n - on) / dn, np.inf)
    tt = np.where(np.isfinite(t), t, 0.0)
    ou, du = dots.dots(u)
    ov, dv = dots.dots(v)
    a = ou + tt * du - c @ u
    b = ov + tt * dv - c @ v
    if surf.is_disk[k]:
        inside = a * a + b * b <= surf.half_size[k, 0] ** 2
    else:
        inside = (np.abs(a) <= surf.half_size[k, 0]) & (np.abs(b) <= surf.half_size[k, 1])
    return np.where(inside & (t > 0) & np.isfinite(t), t, np.inf)


def cast_rays(surf: SceneSurfaces, origin: np.ndarray, direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First hit of each ray: ``(t, object_id)`` (t = inf and id 0 where nothing is hit)."""
    shape = direction.shape[:-1]
    best = np.full(shape, np.inf)
    oid = np.zeros(shape, np.int32)
    dots = _RayDots(np.broadcast_to(origin, direction.shape), direction)
    for k in range(len(surf)):
        t = _hit_t(surf, k, origin, direction, dots)
        hit = t < best
        best = np.where(hit, t, best)
        oid = np.where(hit, k + 1, oid)
    return best, oid


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
