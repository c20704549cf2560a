"""Scene → Mitsuba scene (dict and loaded object), one render pass at a time.

The water is a Mitsuba ``homogeneous`` medium with spectral ``sigma_t = c(λ)`` and
``albedo = b(λ)/c(λ)`` (resampled every 1 nm over 360–830 nm, ends held, ``c``
floored at :data:`C_FLOOR_PER_M`) and the rigsim phase plugin.  It fills a sphere of
radius :func:`rigsim.scene.optics.world_radius_m` around the camera whose boundary is a ``null``
interface: rays that leave it travel on in vacuum and see black.  The camera rays
start inside the water; every target surface has the water as its exterior.

Render passes (``mode``):

* ``"full"`` — water as it is;
* ``"clear"`` — no medium (the same view and lights without water);
* ``"direct"`` — albedo 0 with σ_t = c: only light that was never scattered by water;
* ``"backscatter"`` — the targets black (still occluding): only light scattered by
  the water without reaching a surface.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rigsim.errors import ConfigError
from rigsim.render.emitter_plugin import make_emitter
from rigsim.render.phase_plugin import WaterPhaseFunction, make_phase
from rigsim.render.spectra import regular_dict, spectrum_dict
from rigsim.render.targets import MESH_TYPE, MitsubaSurface, mitsuba_surfaces
from rigsim.render.variant import mitsuba
from rigsim.scene.optics import WATER_INDEX, outside_index, world_radius_m
from rigsim.scene.types import Scene

__all__ = [
    "C_FLOOR_PER_M",
    "MODES",
    "MitsubaScene",
    "build_mitsuba_scene",
    "water_medium_dict",
]

mi, dr = mitsuba()

MODES = ("full", "clear", "direct", "backscatter")
#: Smallest beam attenuation given to Mitsuba (1/m): c = 0 would make NaNs.
C_FLOOR_PER_M = 1e-6
WATER_KEY = "water_volume"


@dataclass
class MitsubaScene:
    """A loaded Mitsuba scene and what the renderer needs to know about it."""

    scene: object
    medium: object | None
    surfaces: list[MitsubaSurface]
    shape_ids: dict[str, int] = field(default_factory=dict)  # Mitsuba shape id → object id
    mode: str = "full"
    n_outside: float = WATER_INDEX  # refractive index outside the port (rigsim.scene.optics.outside_index)


_PHASE_CACHE: dict[int, tuple[object, WaterPhaseFunction]] = {}


def _phase_for(water) -> WaterPhaseFunction:
    key = id(water)
    hit = _PHASE_CACHE.get(key)
    if hit is not None and hit[0] is water:
        return hit[1]
    ph = make_phase(water.phase, water.wavelength_range_nm)
    if len(_PHASE_CACHE) > 16:
        _PHASE_CACHE.clear()
    _PHASE_CACHE[key] = (water, ph)
    return ph


def water_medium_dict(water, *, albedo_zero: bool = False, phase=None) -> dict:
    """Mitsuba ``homogeneous`` medium dict for a :class:`~rigsim.water.model.Water`."""
    rng = water.wavelength_range_nm
    c_dict, _, c = regular_dict(water.c_per_m, rng, floor=C_FLOOR_PER_M)
    if albedo_zero:
        a_dict = {"type": "uniform", "value": 0.0}
    else:
        a_dict, _, _ = regular_dict(lambda wl: np.clip(water.b_per_m(wl) / np.maximum(water.c_per_m(wl),
                                                                                       C_FLOOR_PER_M), 0, 1),
                                    rng)
    if not np.all(np.isfinite(c)):
        raise ConfigError(f"water {water.name!r} has non-finite attenuation", field="water")
    return {"type": "homogeneous", "sigma_t": c_dict, "albedo": a_dict,
            "phase": phase if phase is not None else _phase_for(water)}


def _mesh(key: str, spec: dict, bsdf, medium):
    """A ``mi.Mesh`` from a :data:`~rigsim.render.targets.MESH_TYPE` spec, with its BSDF and
    (if not None) exterior medium; the vertices live in memory, not in the kernels."""
    V = np.asarray(spec["vertex_positions"], np.float32)
    F = np.asarray(spec["faces"], np.uint32)
    N = spec.get("vertex_normals")  # optional (meshes from files): smooth shading normals
    props = mi.Properties()
    props["bsdf"] = bsdf
    if medium is not None:
        props["exterior"] = medium
    mesh = mi.Mesh(key, len(V), len(F), props=props, has_vertex_normals=N is not None)
    params = mi.traverse(mesh)
    params["vertex_positions"] = mi.Float(V.ravel())
    params["faces"] = mi.UInt32(F.ravel())
    if N is not None:
        params["vertex_normals"] = mi.Float(np.asarray(N, np.float32).ravel())
    params.update()
    return mesh


def build_mitsuba_scene(scene: Scene, *, lights, mode: str = "full", max_depth: int = -1,
                        rr_depth: int = 5, phase=None, integrator: str = "rigsim",
                        ambient=None, backscatter_aov: bool = False, flat_shapes: str = "mesh") -> MitsubaScene:
    """Load the Mitsuba scene of one render pass.

    Parameters
    ----------
    scene
        The rigsim scene.
    lights
        The lights of this pass (a subset of ``scene.lights``: strobes and
        continuous lights are rendered in separate passes).
    mode
        One of :data:`MODES`.
    max_depth, rr_depth
        Path length limit (−1: none) and the depth at which Russian roulette starts.
    phase
        Replace the water's phase function by this Mitsuba phase (dict or object),
        e.g. ``{"type": "hg", "g": 0.9}`` for comparisons.
    integrator
        ``"rigsim"`` (equiangular sampling toward the lights, :mod:`rigsim.render.integrators`)
        or ``"volpath"`` (Mitsuba's stock volumetric path tracer).
    backscatter_aov
        The rigsim integrator also returns each path's backscatter (its light before it first
        meets a surface) as AOVs: the ``backscatter`` pass from the same paths.
    ambient
        Daylight field tables (:func:`rigsim.render.daylight.ambient_tables`) lighting this
        pass as well (rigsim integrator only), or None.
    flat_shapes
        ``"mesh"`` (default) or ``"mitsuba"``: see :func:`rigsim.render.targets.mitsuba_surfaces`.
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}")
    R = world_radius_m(scene)
    surfaces = mitsuba_surfaces(scene.camera, scene.targets, flat_shapes=flat_shapes)
    from rigsim.render.integrators import integrator_dict  # registers the rigsim plugins

    d: dict = {"type": "scene", "integrator": integrator_dict(integrator, max_depth=max_depth, rr_depth=rr_depth,
                                                               backscatter_aov=backscatter_aov)}
    has_water = scene.water is not None and mode != "clear"
    medium_obj = None
    try:
        if has_water:
            # one medium object, the interior of the water sphere and the exterior of every target
            medium_obj = mi.load_dict(water_medium_dict(scene.water, albedo_zero=(mode == "direct"), phase=phase))
            d[WATER_KEY] = {"type": "sphere", "center": [float(x) for x in scene.camera.position_m], "radius": R,
                            "bsdf": {"type": "null"}, "interior": medium_obj}
        for s in surfaces:
            if mode == "backscatter":
                refl = {"type": "uniform", "value": 0.0}
            else:
                refl = spectrum_dict(s.wavelength_nm, s.reflectance, name=s.label)
            bsdf = {"type": "twosided", "material": {"type": "diffuse", "reflectance": refl}}
            if s.shape["type"] == MESH_TYPE:
                d[s.key] = _mesh(s.key, s.shape, mi.load_dict(bsdf), medium_obj)
                continue
            sd = dict(s.shape)
            sd["bsdf"] = bsdf
            if has_water:
                sd["exterior"] = medium_obj
            d[s.key] = sd
        for i, light in enumerate(lights):
            if np.any(np.asarray(light.axial_intensity, float) > 0):
                d[f"light{i}"] = make_emitter(light)
        loaded = mi.load_dict(d, optimize=False)  # keep one shape per target piece (object ids)
    except ConfigError:
        raise
    except Exception as e:  # noqa: BLE001 - turn Mitsuba's parser errors into one line
        raise ConfigError(f"cannot build the Mitsuba scene: {str(e).splitlines()[0][:300]}") from None
    if ambient is not None:
        integ = loaded.integrator()
        if not hasattr(integ, "set_ambient"):
            raise ConfigError("daylight is rendered by the rigsim integrator only", field="integrator",
                              allowed="rigsim")
        integ.set_ambient(ambient, R)
    shape_ids = {s.key: i + 1 for i, s in enumerate(surfaces)}
    return MitsubaScene(scene=loaded, medium=medium_obj, surfaces=surfaces, shape_ids=shape_ids, mode=mode,
                        n_outside=outside_index(scene))
