"""Target surfaces as Mitsuba shapes.

The geometry and reflectances of targets are defined once, in
:mod:`rigsim.scene.targets` (``target_surfaces(target, camera)``: placement,
ColorChecker layout, reflectance data, object ids), so that the renderer, the
preview and the metrics' target layouts agree.  This module only turns those
surfaces into Mitsuba ``rectangle``/``disk``/``obj``/``ply`` shapes and numbers them
across all targets (object id 1… in scene order; 0 = nothing).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigsim.errors import ConfigError
from rigsim.render.variant import mitsuba
from rigsim.scene.targets import target_surfaces
from rigsim.scene.types import Camera, Target

__all__ = ["MitsubaSurface", "mitsuba_surfaces"]

mi, dr = mitsuba()


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


def _check_target(t: Target, i: int) -> None:
    if not (np.isfinite(t.distance_m) and t.distance_m > 0):
        raise ConfigError(f"distance must be > 0 m, got {t.distance_m}", field=f"targets[{i}].distance_m",
                          allowed="> 0")
    if not (np.isfinite(t.size_m) and t.size_m > 0):
        raise ConfigError(f"size must be > 0 m, got {t.size_m}", field=f"targets[{i}].size_m", allowed="> 0")


def mitsuba_surfaces(camera: Camera, targets) -> list[MitsubaSurface]:
    """The Mitsuba shapes of all targets; object id ``k`` is ``result[k-1]``."""
    out: list[MitsubaSurface] = []
    for ti, t in enumerate(targets):
        _check_target(t, ti)
        pieces = target_surfaces(t, camera)
        for p in pieces:
            if p.shape in ("rectangle", "disk"):
                shape = {"type": p.shape, "to_world": _transform(p.to_world)}
            elif p.shape == "mesh":
                ext = Path(p.mesh_path).suffix.lower()[1:]
                if ext not in ("obj", "ply"):
                    raise ConfigError(f"mesh must be .obj or .ply, got {p.mesh_path!r}",
                                      field=f"targets[{ti}].mesh_path", allowed=".obj, .ply")
                shape = {"type": ext, "filename": str(p.mesh_path), "to_world": _transform(p.to_world)}
            else:
                raise ConfigError(f"unknown surface shape {p.shape!r}", field=f"targets[{ti}]")
            key = f"t{ti}_{len(out) + 1:03d}"
            out.append(MitsubaSurface(key, shape, np.asarray(p.wavelength_nm, float),
                                      np.asarray(p.reflectance, float), f"target {ti} {t.kind}: {p.name}", ti))
    return out
