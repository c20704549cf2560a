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

Discrete particles (marine snow, :func:`rigsim.scene.particles.scene_particles`) are one
triangle mesh of icospheres (:func:`_particles_shape`) with a diffuse BSDF of the particles' reflectance and the water outside, in every pass with water (black in
``backscatter`` and ``direct``: those layers hold no light of the particles, only their shadow);
the ``clear`` pass, without water, has none.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from rigsim.errors import ConfigError
from rigsim.render.emitter_plugin import make_emitter
from rigsim.render.phase_plugin import WaterPhaseFunction, make_phase
from rigsim.render.spectra import regular_dict, spectrum_dict
from rigsim.render.targets import MESH_TYPE, MitsubaSurface, mitsuba_surfaces
from rigsim.render.variant import mitsuba
from rigsim.scene.optics import WATER_INDEX, outside_index, world_radius_m
from rigsim.scene.particles import scene_particles
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
PARTICLES_KEY = "particles"


@dataclass
class MitsubaScene:
    """A loaded Mitsuba scene and what the renderer needs to know about it."""

    scene: object
    medium: object | None
    surfaces: list[MitsubaSurface]
    shape_ids: dict[str, int] = field(default_factory=dict)  # Mitsuba shape id → object id
    mode: str = "full"
    n_outside: float = WATER_INDEX  # refractive index outside the port (rigsim.scene.optics.outside_index)
    has_particles: bool = False


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
    def flat(a, kind, dt):  # numpy (n, 3), or already a flat Dr.Jit array (shared between loads)
        return a if isinstance(a, kind) else kind(np.asarray(a, dt).ravel())

    V = flat(spec["vertex_positions"], mi.Float, np.float32)
    F = flat(spec["faces"], mi.UInt32, np.uint32)
    N = spec.get("vertex_normals")  # optional (meshes from files): smooth shading normals
    props = mi.Properties()
    props["bsdf"] = bsdf
    if medium is not None:
        props["exterior"] = medium
    mesh = mi.Mesh(key, dr.width(V) // 3, dr.width(F) // 3, props=props, has_vertex_normals=N is not None)
    params = mi.traverse(mesh)
    params["vertex_positions"] = V
    params["faces"] = F
    if N is not None:
        params["vertex_normals"] = flat(N, mi.Float, np.float32)
    params.update()
    return mesh


#: Most triangles of the particles' mesh: icospheres of 320 faces up to 93 750 particles, then 80 (the
#: 300 000 particles a scene may hold: 24 million triangles, 3.3 GB and 20 s to build and render at 64×43),
#: then 20.
PARTICLE_TRIANGLES_MAX = 30_000_000


@functools.lru_cache(maxsize=3)
def _unit_icosphere(nsub: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Vertices (on the unit sphere), triangles and the circumradius giving the sphere's mean projected area
    (Cauchy: a convex body's mean projected area is its surface area / 4) of PyVista's icosphere."""
    import pyvista as pv

    ico = pv.Icosphere(radius=1.0, nsub=nsub)
    V = np.asarray(ico.points, np.float64)
    V /= np.linalg.norm(V, axis=1, keepdims=True)
    F = np.asarray(ico.faces, np.int64).reshape(-1, 4)[:, 1:]
    area = 0.5 * np.linalg.norm(np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]]), axis=1).sum()
    return V, F, float(np.sqrt(4.0 * np.pi / area))


def _particles_shape(ps, *, black: bool, medium):
    """The particles as one triangle mesh of smooth-shaded icospheres (Mitsuba's ``ellipsoids`` shape gave
    spheres of a few millimetres 4× too bright; one ``sphere`` shape each made every render seconds slower per
    10 000 particles).  Each icosphere keeps the sphere's mean projected area; measured against Mitsuba's
    exact sphere (one point light, three geometries): 320 faces within 0.3 %, 80 faces 1.5–2.6 % low,
    20 faces 6–9 % low (:data:`PARTICLE_TRIANGLES_MAX` decides)."""
    geo = _particle_geometry(ps)
    f = ps.field
    if black:
        refl = {"type": "uniform", "value": 0.0}
    elif len(f.reflectance):
        refl = spectrum_dict(np.asarray(f.reflectance_wavelength_nm), np.asarray(f.reflectance), name="particles")
    else:
        refl = {"type": "uniform", "value": float(f.albedo)}
    spec = {"vertex_positions": geo[1], "faces": geo[2], "vertex_normals": geo[3]}
    return _mesh(PARTICLES_KEY, spec, mi.load_dict({"type": "diffuse", "reflectance": refl}), medium)


#: The particles' mesh arrays of the last particle set (the full pass and the black one of a render,
#: and the next seed's, share them: building them took ~4 s of each load for 35 000 particles).
_PARTICLE_GEOMETRY: list = []


def _particle_geometry(ps) -> tuple:
    """(ps, Dr.Jit positions, faces, normals: flat) of :func:`_particles_shape`'s mesh."""
    if _PARTICLE_GEOMETRY:
        last = _PARTICLE_GEOMETRY[0][0]
        if last is ps or (len(last) == len(ps) and np.array_equal(last.position_m, ps.position_m)
                          and np.array_equal(last.diameter_m, ps.diameter_m)):  # (each pass draws the set anew)
            return _PARTICLE_GEOMETRY[0]
    n = len(ps)
    nsub = next(k for k in (2, 1, 0) if k == 0 or n * 20 * 4 ** k <= PARTICLE_TRIANGLES_MAX)
    V, F, scale = _unit_icosphere(nsub)
    r = (0.5 * np.asarray(ps.diameter_m, np.float64) * scale).astype(np.float32)
    pos = np.asarray(ps.position_m, np.float32)[:, None, :] + r[:, None, None] * V[None].astype(np.float32)
    faces = (F[None].astype(np.uint32) + (np.arange(n, dtype=np.uint32) * np.uint32(len(V)))[:, None, None])
    normals = np.broadcast_to(V[None].astype(np.float32), (n,) + V.shape)
    geo = (ps, mi.Float(pos.ravel()), mi.UInt32(faces.ravel()), mi.Float(np.ascontiguousarray(normals).ravel()))
    _PARTICLE_GEOMETRY[:] = [geo]
    return geo


#: Most recently loaded passes of the last scene kept for its next render (another seed: a study's
#: Monte Carlo check renders each case up to 16 times, and with marine snow loading the particles'
#: mesh took ~4 s of a 6.6 s render).
SCENE_CACHE_SIZE = 3
_SCENE_CACHE: list[tuple[tuple, tuple, "MitsubaScene"]] = []


def forget_scenes() -> None:
    """Let every kept scene go (:data:`SCENE_CACHE_SIZE`)."""
    _SCENE_CACHE.clear()


def forget_scenes_except(scene: Scene) -> None:
    """Let the loaded scenes of any other scene go.  Dr.Jit compiles the ids of the loaded shapes and
    emitters into its kernels and reuses an id only once it is freed: kept alive while another scene is
    loaded, they made every distance of a sweep compile its kernels anew (~5 s each;
    tests/render/test_render_api.py::test_one_compiled_kernel_serves_every_target_distance).  A render
    calls this before it makes any Mitsuba object."""
    if _SCENE_CACHE and _SCENE_CACHE[-1][0][0] is not scene:
        _SCENE_CACHE.clear()


def build_mitsuba_scene(scene: Scene, *, lights, mode: str = "full", max_depth: int = -1,
                        rr_depth: int | None = None, phase=None, integrator: str = "rigsim",
                        ambient=None, backscatter_aov: bool = False, class_split_deg: float | None = None,
                        flat_shapes: str = "mesh",
                        particles: bool = True) -> MitsubaScene:
    """Load the Mitsuba scene of one render pass (or reuse the one loaded last time for the same
    objects and options: :data:`SCENE_CACHE_SIZE`; a loaded scene is not changed by rendering it).

    Parameters are those of :func:`_load_mitsuba_scene`.
    """
    lights = list(lights)
    if phase is not None:  # (comparisons with a replaced phase function: not kept)
        return _load_mitsuba_scene(scene, lights=lights, mode=mode, max_depth=max_depth, rr_depth=rr_depth,
                                   phase=phase, integrator=integrator, ambient=ambient,
                                   backscatter_aov=backscatter_aov, class_split_deg=class_split_deg, flat_shapes=flat_shapes,
                                   particles=particles)
    refs = (scene, tuple(lights), ambient)
    key = (id(scene), tuple(id(x) for x in lights), id(ambient), mode, max_depth, rr_depth, integrator,
           backscatter_aov, class_split_deg, flat_shapes, particles)
    for i, (r, k, ms) in enumerate(_SCENE_CACHE):
        if k == key and r[0] is scene and r[2] is ambient and all(a is b for a, b in zip(r[1], lights)):
            _SCENE_CACHE.append(_SCENE_CACHE.pop(i))
            return ms
    forget_scenes_except(scene)
    ms = _load_mitsuba_scene(scene, lights=lights, mode=mode, max_depth=max_depth, rr_depth=rr_depth,
                             integrator=integrator, ambient=ambient, backscatter_aov=backscatter_aov,
                             class_split_deg=class_split_deg, flat_shapes=flat_shapes, particles=particles)
    _SCENE_CACHE.append((refs, key, ms))
    del _SCENE_CACHE[:-SCENE_CACHE_SIZE]
    return ms


def _load_mitsuba_scene(scene: Scene, *, lights, mode: str = "full", max_depth: int = -1,
                        rr_depth: int | None = None, phase=None, integrator: str = "rigsim",
                        ambient=None, backscatter_aov: bool = False, class_split_deg: float | None = None,
                        flat_shapes: str = "mesh",
                        particles: bool = True) -> MitsubaScene:
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
        Path length limit (−1: none) and the depth at which Russian roulette starts (None: the
        integrator's own default).
    phase
        Replace the water's phase function by this Mitsuba phase (dict or object),
        e.g. ``{"type": "hg", "g": 0.9}`` for comparisons.
    integrator
        ``"rigsim"`` (equiangular sampling toward the lights, :mod:`rigsim.render.integrators`)
        or ``"volpath"`` (Mitsuba's stock volumetric path tracer).
    backscatter_aov
        The rigsim integrator also returns each path's backscatter (its light before it first
        meets a surface) as AOVs: the ``backscatter`` pass from the same paths.
    class_split_deg
        The rigsim integrator also returns the light of the fast engine's class A (ψ_c in degrees;
        :class:`~rigsim.render.integrators.strobe.RigsimVolIntegrator`) as AOVs; None: not.
    ambient
        Daylight field tables (:func:`rigsim.render.daylight.ambient_tables`) lighting this
        pass as well (rigsim integrator only), or None.
    flat_shapes
        ``"mesh"`` (default) or ``"mitsuba"``: see :func:`rigsim.render.targets.mitsuba_surfaces`.
    particles
        Include the water's discrete particles (False: the scene without them).
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}")
    R = world_radius_m(scene)
    surfaces = mitsuba_surfaces(scene.camera, scene.targets, flat_shapes=flat_shapes)
    from rigsim.render.integrators import integrator_dict  # registers the rigsim plugins

    d: dict = {"type": "scene", "integrator": integrator_dict(integrator, max_depth=max_depth, rr_depth=rr_depth,
                                                               backscatter_aov=backscatter_aov,
                                                               class_split_deg=class_split_deg)}
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
        ps = scene_particles(scene) if has_water and particles else None
        if ps is not None and len(ps):
            d[PARTICLES_KEY] = _particles_shape(ps, black=mode in ("backscatter", "direct"), medium=medium_obj)
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
                        n_outside=outside_index(scene), has_particles=PARTICLES_KEY in d)
