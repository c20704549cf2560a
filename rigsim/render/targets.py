"""Target surfaces as Mitsuba shapes.

The geometry and reflectances of targets are defined once, in
:mod:`rigsim.scene.targets` (``target_surfaces(target, camera)``: placement,
ColorChecker layout, reflectance data, object ids), so that the renderer, the
preview and the metrics' target layouts agree.  This module only turns those
surfaces into Mitsuba ``rectangle``/``disk``/``obj``/``ply`` shapes and numbers them
across all targets (object id 1… in scene order; 0 = nothing).

If :mod:`rigsim.scene.targets` is not available, a minimal built-in version with the
same conventions is used (right = forward × up; chart 279.4 × 215.9 mm, 40 mm
patches at 45 mm, 4 % black body; disks 90 % / 4 %; bottom ``distance_m`` below
the pupil, normal +y).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rigsim.errors import ConfigError
from rigsim.render.camera import camera_frame
from rigsim.render.variant import mitsuba
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


def _scene_target_surfaces():
    try:
        from rigsim.scene.targets import target_surfaces
    except ImportError:
        return None
    return target_surfaces


def mitsuba_surfaces(camera: Camera, targets) -> list[MitsubaSurface]:
    """The Mitsuba shapes of all targets; object id ``k`` is ``result[k-1]``."""
    out: list[MitsubaSurface] = []
    scene_surfaces = _scene_target_surfaces()
    for ti, t in enumerate(targets):
        _check_target(t, ti)
        pieces = scene_surfaces(t, camera) if scene_surfaces is not None else _builtin_surfaces(t, camera)
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


# ---------------------------------------------------------------------------------------
# Built-in fallback (same conventions as rigsim.scene.targets)
# ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Piece:
    name: str
    shape: str
    to_world: np.ndarray
    wavelength_nm: np.ndarray
    reflectance: np.ndarray
    mesh_path: str | None = None


_WL = np.array([360.0, 830.0])


def _flat(v: float) -> np.ndarray:
    return np.array([v, v])


def _affine(centre, ax, ay, az) -> np.ndarray:
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = ax, ay, az, centre
    return m


def _builtin_surfaces(t: Target, camera: Camera) -> list[_Piece]:
    fwd, right, up = camera_frame(camera)
    pupil = np.asarray(camera.position_m, float)
    toward = -fwd
    a = np.radians(t.tilt_deg)
    u = np.cos(a) * right + np.sin(a) * up
    v = -np.sin(a) * right + np.cos(a) * up
    c = pupil + t.distance_m * fwd
    s = float(t.size_m)

    def refl(default):
        if t.reflectance:
            wl = np.asarray(t.reflectance_wavelength_nm, float)
            r = np.asarray(t.reflectance, float)
            return (wl, r) if wl.size > 1 else (_WL, np.full(2, r[0]))
        return _WL, _flat(default)

    def rect(name, centre, w, h, wl_r):
        return _Piece(name, "rectangle", _affine(centre, w / 2 * u, h / 2 * v, toward), *wl_r)

    if t.kind == "colorchecker":
        import colour

        k = s / 0.2794
        out = [rect("chart", c, s, 0.2159 * k, (_WL, _flat(0.04)))]
        sds = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
        for i, (name, sd) in enumerate(sds.items()):
            r, col = divmod(i, 6)
            pc = c + k * ((col - 2.5) * 0.045 * u + (1.5 - r) * 0.045 * v) + 0.0005 * toward
            out.append(rect(name, pc, 0.04 * k, 0.04 * k, (np.asarray(sd.wavelengths, float),
                                                           np.asarray(sd.values, float))))
        return out
    if t.kind in ("white-disk", "black-disk"):
        wl, r = refl(0.9 if t.kind == "white-disk" else 0.04)
        return [_Piece("disk", "disk", _affine(c, s / 2 * u, s / 2 * v, toward), wl, r)]
    if t.kind == "slanted-edge":
        return [rect("black", c - s / 4 * u, s / 2, s, (_WL, _flat(0.04))),
                rect("white", c + s / 4 * u, s / 2, s, (_WL, _flat(0.9)))]
    if t.kind == "bottom":
        wu = np.array([0.0, 1.0, 0.0])
        bu = right - wu * np.dot(right, wu)
        bu = bu / np.linalg.norm(bu) if np.linalg.norm(bu) > 1e-6 else np.array([1.0, 0.0, 0.0])
        bv = np.cross(wu, bu)
        wl, r = refl(0.3)
        return [_Piece("bottom", "rectangle", _affine(pupil - t.distance_m * wu, s / 2 * bu, s / 2 * bv, wu),
                       wl, r)]
    if t.kind == "mesh":
        if not t.mesh_path or not Path(t.mesh_path).is_file():
            raise ConfigError("mesh file not found", file=t.mesh_path, field="target.mesh_path")
        raw = mi.load_dict({"type": Path(t.mesh_path).suffix.lower()[1:], "filename": str(t.mesh_path)})
        bb = raw.bbox()
        lo, hi = np.array(bb.min, float), np.array(bb.max, float)
        k = s / float(np.max(hi - lo))
        rot = np.stack([u, v, toward], axis=1)
        m = np.eye(4)
        m[:3, :3] = k * rot
        m[:3, 3] = c - k * rot @ ((lo + hi) / 2)
        wl, r = refl(0.18)
        return [_Piece("mesh", "mesh", m, wl, r, str(t.mesh_path))]
    raise ConfigError(f"unknown target kind {t.kind!r}", field="target.kind",
                      allowed="colorchecker, black-disk, white-disk, slanted-edge, bottom, mesh")
