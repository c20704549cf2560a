"""Assemble a :class:`~rigsim.scene.types.Scene` from a rig, a water, a target and a distance.

Placement conventions are in :mod:`rigsim.scene.surfaces`, reflectances in
:mod:`rigsim.scene.reflectances`; the engines get the explicit geometry with
:func:`rigsim.scene.surfaces.target_surfaces`.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from rigsim.errors import ConfigError, unknown_name_error
from rigsim.scene.meshes import MESH_SUFFIXES, mesh_vertices
from rigsim.scene.optics import port_reach_m
from rigsim.scene.reflectances import REFLECTANCE_WAVELENGTHS_NM, reflectance_from_csv
from rigsim.scene.surfaces import DEFAULT_SIZE_M, DEFAULT_TILT_DEG, TARGET_KINDS
from rigsim.scene.types import Daylight, Rig, Scene, Target
from rigsim.water.model import Water

__all__ = ["build_scene", "make_target"]

_MESH_SUFFIXES = MESH_SUFFIXES


def _reflectance(reflectance) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Normalise a reflectance argument: None, a number (flat), a CSV path, or (wavelengths, values)."""
    if reflectance is None:
        return (), ()
    wl = REFLECTANCE_WAVELENGTHS_NM
    if isinstance(reflectance, (int, float)) and not isinstance(reflectance, bool):
        r = float(reflectance)
        if not (0.0 <= r <= 1.0):
            raise ConfigError(f"must be within 0–1, got {r:g}", field="reflectance", allowed="0 <= r <= 1")
        return tuple(wl.tolist()), tuple(np.full(wl.shape, r).tolist())
    if isinstance(reflectance, (str, Path)):
        return tuple(wl.tolist()), tuple(reflectance_from_csv(reflectance).tolist())
    try:
        w, v = (np.asarray(x, float) for x in reflectance)
    except (TypeError, ValueError):
        raise ConfigError("cannot read reflectance", field="reflectance",
                          allowed="a number 0–1, a CSV path or (wavelength_nm, values)") from None
    if w.shape != v.shape or w.ndim != 1 or w.size < 2 or np.any(np.diff(w) <= 0) \
            or np.any((v < 0) | (v > 1)) or w[0] > 400 or w[-1] < 700:
        raise ConfigError("reflectance table must have increasing wavelengths covering 400–700 nm and values 0–1",
                          field="reflectance", allowed="(wavelength_nm, values) with 0 <= values <= 1")
    return tuple(wl.tolist()), tuple(np.interp(wl, w, v).tolist())


def make_target(target: str | Path, distance_m: float, *, size_m: float | None = None,
                tilt_deg: float | None = None, reflectance=None) -> Target:
    """A :class:`Target` by kind name or mesh path (no placement checks; see :func:`build_scene`).

    Parameters
    ----------
    target
        ``colorchecker``, ``black-disk``, ``white-disk``, ``slanted-edge``, ``bottom``,
        or a path to an ``.obj``/``.ply`` mesh.
    distance_m
        Distance along the axis to the target's centre (m); for ``bottom``, the
        camera's altitude above the bottom.
    size_m
        Chart width / disk diameter / edge-target side / bottom side / mesh's
        largest extent (m); default per kind (mesh: its own size).
    tilt_deg
        Rotation about the optical axis (deg); default 5° for the slanted edge, else 0.
    reflectance
        Optional override for disks, the bottom and meshes: a number 0–1, a CSV
        path (``wavelength_nm, reflectance``) or ``(wavelengths_nm, values)``.

    Raises
    ------
    ConfigError
        Unknown kind (with suggestions), unreadable mesh, a reflectance outside
        0–1 or for a chart, and whatever :class:`Target` refuses (``size_m`` or
        ``distance_m`` not > 0).
    """
    text = str(target)
    if text.lower().endswith(_MESH_SUFFIXES):
        path = Path(text).expanduser()
        verts = mesh_vertices(path)  # raises a clear error if missing or unreadable
        own = float(np.max(verts.max(axis=0) - verts.min(axis=0)))
        kind, mesh_path = "mesh", str(path.resolve())
        size = own if size_m is None else size_m
        if not size > 0:
            raise ConfigError("mesh has zero extent", file=path)
    elif text in TARGET_KINDS:
        kind, mesh_path = text, None
        size = DEFAULT_SIZE_M[kind] if size_m is None else size_m
    else:
        raise unknown_name_error("target", text, (*TARGET_KINDS, "<mesh.obj|mesh.ply>"), field="target")
    if reflectance is not None and kind in ("colorchecker", "slanted-edge"):
        raise ConfigError(f"a {kind} has fixed reflectances", field="reflectance",
                          allowed="reflectance only for black-disk, white-disk, bottom, mesh")
    wl, refl = _reflectance(reflectance)
    tilt = DEFAULT_TILT_DEG.get(kind, 0.0) if tilt_deg is None else float(tilt_deg)
    # Target checks distance_m, size_m (> 0, finite) and the reflectance table itself
    return Target(kind=kind, distance_m=distance_m, size_m=size, mesh_path=mesh_path,
                  reflectance_wavelength_nm=wl, reflectance=refl, tilt_deg=tilt)


def build_scene(rig: Rig, water: Water | str | None, target: str | Path | Target, distance_m: float | None = None,
                *, daylight: Daylight | None = None, size_m: float | None = None,
                tilt_deg: float | None = None, reflectance=None) -> Scene:
    """A scene: the rig, in ``water``, looking at ``target`` ``distance_m`` away.

    Parameters
    ----------
    rig
        From :func:`rigsim.config.load_rig`.
    water
        A :class:`Water`, a preset name (:func:`rigsim.water.preset`), or None for
        no water (the clear ground truth).
    target
        A kind name, a mesh path (see :func:`make_target`), or a ready :class:`Target`.
    distance_m
        Entrance pupil → target centre along the axis (m); for ``bottom`` the
        altitude above it.  Required unless ``target`` is a :class:`Target`.
    daylight
        Ambient daylight at depth, or None.
    size_m, tilt_deg, reflectance
        Passed to :func:`make_target`.

    Raises
    ------
    ConfigError
        Target behind the camera (``distance_m <= 0``), closer than the port's outer
        surface, bottom above the housing, unknown target, missing or unreadable mesh.

    Examples
    --------
    >>> from rigsim.scene.types import Camera
    >>> sc = build_scene(Rig(name="r", camera=Camera()), None, "colorchecker", 1.5)
    >>> sc.targets[0].kind, sc.targets[0].distance_m
    ('colorchecker', 1.5)
    """
    if isinstance(water, str):
        from rigsim.water import preset

        water = preset(water)
    if isinstance(target, Target):
        tgt = target
        if distance_m is not None and float(distance_m) != tgt.distance_m:
            raise ConfigError("distance_m disagrees with the Target's own distance", field="distance_m")
    else:
        if distance_m is None:
            raise ConfigError("missing distance", field="distance_m", allowed="a distance in m")
        d = float(distance_m)
        if not math.isfinite(d) or d <= 0:
            raise ConfigError(f"target is behind the camera (distance {d:g} m)", field="distance_m",
                              allowed="> 0 m, in front of the port")
        tgt = make_target(target, d, size_m=size_m, tilt_deg=tilt_deg, reflectance=reflectance)
    d = tgt.distance_m  # > 0: a Target cannot be built behind the camera
    reach = port_reach_m(rig.camera)
    if tgt.kind in ("bottom", "seabed"):
        floor = max(reach, rig.camera.housing_radius_m)
        if d <= floor:
            raise ConfigError(f"bottom at {d:g} m below the pupil cuts through the housing/port",
                              field="distance_m", allowed=f"> {floor:g} m (housing/port size)")
    elif d <= reach:
        raise ConfigError(f"target at {d:g} m is closer than the port's outer surface at {reach:g} m",
                          field="distance_m", allowed=f"> {reach:g} m")
    return Scene(rig=rig, water=water, targets=(tgt,), daylight=daylight)
