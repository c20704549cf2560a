"""Where a scene's target lands in an image: per-pixel object ids, outlines and the slanted edge.

Image coordinates: pixel ``(col, row)``, origin at the top-left corner of the image, col to
the right, row down, pixel centres at half-integers; the image's right is ``forward × up`` (as
Mitsuba renders).  Rays and projections through the port are those of
:mod:`rigsim.scene.optics` (the one camera and port model, the renderers' rays), also without
water (the clear ground truth keeps the in-water view).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigsim.errors import unknown_name_error
from rigsim.scene.optics import outside_index, pixel_rays, project_points
from rigsim.scene.surfaces import Surface, target_surfaces
from rigsim.scene.types import Scene

__all__ = ["TargetLayout", "target_layout"]


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
