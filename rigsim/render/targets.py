"""Target surfaces as Mitsuba shapes.

The geometry and reflectances of targets are defined once, in
:mod:`rigsim.scene.surfaces` (``target_surfaces(target, camera)``: placement,
ColorChecker layout, reflectance data, object ids), so that the renderer, the
preview and the metrics' target layouts agree.  This module only turns those
surfaces into Mitsuba shapes and numbers them across all targets (object id 1… in scene
order; 0 = nothing).

Rectangles and disks become triangle meshes (:data:`MESH_TYPE`: vertex and face arrays, built
into a ``mi.Mesh`` by :func:`rigsim.render.mitsuba_scene.build_mitsuba_scene`), not Mitsuba's
``rectangle``/``disk`` shapes: those compile their placement into every kernel as constants, so
each target distance of a sweep compiled the renderer's kernels anew (2–9 s each); a mesh keeps
its vertices in memory and one kernel serves every distance.  A rectangle is exactly two
triangles; a disk is a regular polygon with :data:`DISK_SEGMENTS` sides whose area equals the
disk's.  User meshes (``obj``/``ply``) are read by :func:`rigsim.scene.meshes.read_mesh` — the
reader that places and scales them in the scene — and given to Mitsuba as the same arrays
(:func:`file_mesh`), not through Mitsuba's own ``obj``/``ply`` loaders, so the two cannot disagree.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rigsim.errors import ConfigError
from rigsim.render.variant import mitsuba
from rigsim.scene.meshes import placed_mesh
from rigsim.scene.surfaces import target_surfaces
from rigsim.scene.types import Camera, Target

__all__ = ["MitsubaSurface", "mitsuba_surfaces", "MESH_TYPE", "DISK_SEGMENTS", "flat_mesh", "file_mesh"]

mi, dr = mitsuba()

#: ``shape["type"]`` of a target piece given as vertex and face arrays.
MESH_TYPE = "rigsim_mesh"
#: Sides of the polygon that stands for a disk (area-preserving radius: its corners lie 0.005 %
#: outside the circle, the middles of its sides 0.0025 % inside).
DISK_SEGMENTS = 256


@dataclass(frozen=True)
class MitsubaSurface:
    """One Mitsuba shape of a target.

    Attributes
    ----------
    key
        Unique shape id in the Mitsuba scene.
    shape
        Mitsuba dict of the shape (without BSDF or media).
    wavelength_nm, reflectance
        Spectral reflectance samples (0…1).
    label
        Human-readable name for the object-id legend.
    target_index
        Index of the target in ``Scene.targets``.
    """

    key: str
    shape: dict
    wavelength_nm: np.ndarray
    reflectance: np.ndarray
    label: str
    target_index: int


def _transform(m) -> mi.ScalarTransform4f:
    return mi.ScalarTransform4f(np.asarray(m, float).tolist())


def flat_mesh(kind: str, to_world) -> dict:
    """Mesh shape spec of a ``"rectangle"`` (object space [−1, 1]², z = 0) or ``"disk"`` (unit
    disk, z = 0) placed by the 4×4 ``to_world``: ``{"type": MESH_TYPE, "vertex_positions":
    (n, 3), "faces": (m, 3)}``; faces wound so that their normal is +z of the object."""
    if kind == "rectangle":
        P = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float)
        F = np.array([[0, 1, 2], [0, 2, 3]], np.uint32)
    elif kind == "disk":
        n = DISK_SEGMENTS
        a = 2 * np.pi * np.arange(n) / n
        # polygon area (n/2) r² sin(2π/n) = π: same area as the unit disk
        r = np.sqrt(2 * np.pi / (n * np.sin(2 * np.pi / n)))
        P = np.vstack([[0.0, 0.0], r * np.c_[np.cos(a), np.sin(a)]])
        i = np.arange(n)
        F = np.c_[np.zeros(n), 1 + i, 1 + (i + 1) % n].astype(np.uint32)
    else:
        raise ValueError(f"no flat mesh for {kind!r}")
    M = np.asarray(to_world, float)
    V = np.c_[P, np.zeros(len(P)), np.ones(len(P))] @ M.T
    return {"type": MESH_TYPE, "vertex_positions": V[:, :3].copy(), "faces": F}


def file_mesh(path, to_world) -> dict:
    """Mesh shape spec of a mesh file placed by the 4×4 ``to_world``
    (:func:`rigsim.scene.meshes.placed_mesh`, the arrays the fast engine draws too):
    ``{"type": MESH_TYPE, "vertex_positions": (n, 3), "faces": (m, 3), "vertex_normals": (n, 3)}``
    (smooth shading by the file's or the angle-weighted vertex normals)."""
    V, F, N = placed_mesh(path, to_world)
    return {"type": MESH_TYPE, "vertex_positions": V, "faces": F.astype(np.uint32), "vertex_normals": N}


def _check_target(t: Target, i: int) -> None:
    if not (np.isfinite(t.distance_m) and t.distance_m > 0):
        raise ConfigError(f"distance must be > 0 m, got {t.distance_m}", field=f"targets[{i}].distance_m",
                          allowed="> 0")
    if not (np.isfinite(t.size_m) and t.size_m > 0):
        raise ConfigError(f"size must be > 0 m, got {t.size_m}", field=f"targets[{i}].size_m", allowed="> 0")


def mitsuba_surfaces(camera: Camera, targets, *, flat_shapes: str = "mesh") -> list[MitsubaSurface]:
    """The Mitsuba shapes of all targets; object id ``k`` is ``result[k-1]``.

    ``flat_shapes``: ``"mesh"`` (rectangles and disks as :func:`flat_mesh` meshes) or
    ``"mitsuba"`` (Mitsuba's own ``rectangle``/``disk``: for comparisons, see
    ``benchmarks/bench_sweep.py``).
    """
    if flat_shapes not in ("mesh", "mitsuba"):
        raise ValueError(f"flat_shapes must be 'mesh' or 'mitsuba', got {flat_shapes!r}")
    out: list[MitsubaSurface] = []
    for ti, t in enumerate(targets):
        _check_target(t, ti)
        pieces = target_surfaces(t, camera)
        for p in pieces:
            if p.shape in ("rectangle", "disk"):
                shape = (flat_mesh(p.shape, p.matrix()) if flat_shapes == "mesh"
                         else {"type": p.shape, "to_world": _transform(p.to_world)})
            elif p.shape == "mesh":
                shape = file_mesh(p.mesh_path, p.matrix())
            else:
                raise ConfigError(f"unknown surface shape {p.shape!r}", field=f"targets[{ti}]")
            key = f"t{ti}_{len(out) + 1:03d}"
            out.append(MitsubaSurface(key, shape, np.asarray(p.wavelength_nm, float),
                                      np.asarray(p.reflectance, float), f"target {ti} {t.kind}: {p.name}", ti))
    return out
