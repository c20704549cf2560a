"""A :class:`~rigsim.scene.types.Scene` as a JSON-ready record, and back: the provenance of an image.

A :class:`~rigsim.spectral_image.SpectralImage` carries the typed scene that made it; saved
with the image (``scene.json``) and read back, it gives later stages (the sensor, the metrics,
a study) the camera, lens, port, water, lights, targets and daylight as typed objects again.

The water is recorded so that every engine sees the same water after a round trip:

* constituent waters (:class:`~rigsim.water.model.ConstituentWater`) by their constituents and
  model choices (rebuilt exactly);
* a named water (a Jerlov type) by its name, if the named water today has the recorded IOPs
  (rebuilt exactly); otherwise, and for explicit-IOP waters, by
* its tables: a(λ), b(λ) as given and the phase function as the shared decomposition
  (:func:`rigsim.scene.phase_tables.phase_tables`: component cell masses and the 1-nm weight
  table), rebuilt as a mixture of tabulated components with the same tables, so that the
  renderer, the fast engine and the daylight meter see exactly the phase function they saw.

Examples
--------
>>> from rigsim.config.rig import load_rig
>>> from rigsim.scene.build import build_scene
>>> sc = build_scene(load_rig("rigs/twin-strobes-45-wide.toml"), "coastal", "colorchecker", 2.0)
>>> back = scene_from_record(scene_record(sc))
>>> back.camera == sc.camera, back.lights == sc.lights, back.water == sc.water
(True, True, True)
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rigsim.errors import ConfigError
from rigsim.scene.phase_tables import phase_tables
from rigsim.scene.types import BeamPattern, Camera, Daylight, Light, Port, Rig, Scene, Target
from rigsim.water.model import ConstituentWater, Spectrum1D, TabulatedWater, Water, with_particles
from rigsim.water.particles import ParticleField
from rigsim.water.phase import LogAngleGrid, MixturePhase, TabulatedPhase

__all__ = ["scene_record", "scene_from_record", "water_record", "water_from_record", "RECORD_VERSION"]

#: Version of the record layout (bumped when it changes incompatibly).
RECORD_VERSION = 1


# ----------------------------------------------------------------------------- dataclasses
def _plain(obj):
    """dataclass → dict of JSON types (tuples → lists, numpy → Python)."""
    if dataclasses.is_dataclass(obj):
        return {f.name: _plain(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, (list, tuple)):
        return [_plain(x) for x in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    return obj


def _build(cls, d: dict, nested: dict | None = None):
    """``cls(**d)`` with lists turned back into tuples (and nested dataclasses built)."""
    nested = nested or {}
    kw = {}
    names = {f.name for f in dataclasses.fields(cls)}
    for k, v in d.items():
        if k not in names:
            raise ConfigError(f"unknown field {k!r} in a {cls.__name__} record", field=k)
        if k in nested and v is not None:
            kw[k] = nested[k](v)
        elif isinstance(v, list):
            kw[k] = _tuples(v)
        else:
            kw[k] = v
    return cls(**kw)


def _tuples(v):
    return tuple(_tuples(x) if isinstance(x, list) else x for x in v)


def _camera(d: dict) -> Camera:
    return _build(Camera, d, {"port": lambda p: _build(Port, p)})


def _light(d: dict) -> Light:
    return _build(Light, d, {"beam": lambda b: _build(BeamPattern, b)})


# ----------------------------------------------------------------------------- water
def _spectrum1d(s: Spectrum1D) -> dict:
    return {"wavelength_nm": None if s.wavelength_nm is None else np.asarray(s.wavelength_nm, float).tolist(),
            "values": np.asarray(s.values, float).tolist(), "label": s.label}


def _spectrum1d_from(d: dict) -> Spectrum1D:
    wl = d.get("wavelength_nm")
    return Spectrum1D(values=np.asarray(d["values"], float), wavelength_nm=None if wl is None else np.asarray(wl, float),
                      label=str(d.get("label", "spectrum")))


def water_record(water: Water | None) -> dict | None:
    """JSON-ready record of a water (see module docstring); None for no water."""
    if water is None:
        return None
    if isinstance(water, ConstituentWater):
        return {"kind": "constituents", **_plain(water)}  # its particles among its fields
    if isinstance(water, TabulatedWater):
        t = phase_tables(water.phase, water.wavelength_range_nm)
        g = t.grid
        return {"kind": "iop", "name": water.name, "source": water.source,
                "a": _spectrum1d(water._a), "b": _spectrum1d(water._b),
                "posed_wavelength_nm": None if water.posed_wavelength_nm is None
                else np.asarray(water.posed_wavelength_nm, float).tolist(),
                "extra": _plain(water.extra), "particles": _plain(water.particles),
                "phase": {"name": t.name, "grid": {"psi_min_rad": g.psi_min_rad, "n_log": g.n_log, "n_back": g.n_back},
                          "masses": t.masses.tolist(), "weight_wavelength_nm": t.weight_wavelength_nm.tolist(),
                          "weights": t.weights.tolist()}}
    raise ConfigError(f"cannot record a water of type {type(water).__name__}", field="water")


def _tables_phase(d: dict):
    grid = LogAngleGrid(**d["grid"])
    masses = np.asarray(d["masses"], float)
    comps = [TabulatedPhase(m, grid, name=f"{d['name']}[{k}]") for k, m in enumerate(masses)]
    if len(comps) == 1:
        comps[0].name = d["name"]
        return comps[0]
    nodes = np.asarray(d["weight_wavelength_nm"], float)
    w = np.asarray(d["weights"], float)

    def weights(wl, _nodes=nodes, _w=w):
        x = np.asarray(wl, float)
        return np.stack([np.interp(x, _nodes, _w[:, k]) for k in range(_w.shape[1])], axis=-1)

    return MixturePhase(comps, weights, name=d["name"])


def _same_iops(a: Water, b: Water) -> bool:
    if a.wavelength_range_nm != b.wavelength_range_nm:
        return False
    lo, hi = a.wavelength_range_nm
    wl = np.linspace(max(lo, 360.0), min(hi, 830.0), 47)
    return bool(np.allclose(a.a_per_m(wl), b.a_per_m(wl), rtol=1e-12, atol=0)
                and np.allclose(a.b_per_m(wl), b.b_per_m(wl), rtol=1e-12, atol=0))


def water_from_record(d: dict | None) -> Water | None:
    """The water of a :func:`water_record` (see module docstring)."""
    if d is None:
        return None
    kind = d.get("kind")
    particles = None if d.get("particles") is None else _build(ParticleField, d["particles"])
    if kind == "constituents":
        return with_particles(_build(ConstituentWater, {k: v for k, v in d.items() if k not in ("kind", "particles")}),
                              particles)
    if kind != "iop":
        raise ConfigError(f"unknown water record kind {kind!r}", field="water.kind", allowed="constituents, iop")
    posed = d.get("posed_wavelength_nm")
    tab = TabulatedWater(str(d["name"]), _spectrum1d_from(d["a"]), _spectrum1d_from(d["b"]), _tables_phase(d["phase"]),
                         source=str(d.get("source", "")), wavelength_nm=posed, extra=dict(d.get("extra") or {}))
    from rigsim.water.presets import preset, preset_names

    if posed is None and tab.name in preset_names():
        named = preset(tab.name)
        if _same_iops(named, tab):
            return with_particles(named, particles)
    return with_particles(tab, particles)


# ----------------------------------------------------------------------------- scene
def scene_record(scene: Scene) -> dict:
    """JSON-ready record of a scene (see module docstring)."""
    rig = scene.rig
    return {"version": RECORD_VERSION,
            "rig": {"name": rig.name, "source": rig.source, "description": rig.description,
                    "camera": _plain(rig.camera), "lights": [_plain(l) for l in rig.lights]},
            "water": water_record(scene.water),
            "targets": [_plain(t) for t in scene.targets],
            "daylight": None if scene.daylight is None else _plain(scene.daylight),
            "particle_seed": int(scene.particle_seed)}


def scene_from_record(d: dict) -> Scene:
    """The scene of a :func:`scene_record`; a record of another version or shape is a ConfigError."""
    try:
        if int(d.get("version", -1)) != RECORD_VERSION:
            raise ConfigError(f"scene record version {d.get('version')!r} is not {RECORD_VERSION}",
                              field="scene.version", allowed=str(RECORD_VERSION))
        r = d["rig"]
        rig = Rig(name=r["name"], camera=_camera(r["camera"]), lights=tuple(_light(x) for x in r["lights"]),
                  source=r.get("source", ""), description=r.get("description", ""))
        return Scene(rig=rig, water=water_from_record(d.get("water")),
                     targets=tuple(_build(Target, t) for t in d["targets"]),
                     daylight=None if d.get("daylight") is None else _build(Daylight, d["daylight"]),
                     particle_seed=int(d.get("particle_seed", 0)))
    except ConfigError:
        raise
    except (KeyError, TypeError, ValueError) as exc:
        raise ConfigError(f"malformed scene record: {exc}", field="scene") from None
