"""rigsim's Mitsuba integrators.

* :mod:`rigsim.render.integrators.strobe` — ``rigsim_vol``: the volumetric path tracer for
  strobe- and video-light-lit water (equiangular sampling toward the lights, spectral MIS,
  halo and target next-event estimation); with a daylight field it also runs
* :mod:`rigsim.render.integrators.daylight` — ``rigsim_daylight``: the daylight field at depth
  through Duntley's transport and surface bounces;
* :mod:`rigsim.render.integrators.common` — what both share: MIS weights, Russian roulette, light
  connections, sampling tables.

Importing this package registers both plugins with Mitsuba.
"""

from __future__ import annotations

import dataclasses

from rigsim.errors import ConfigError
from rigsim.render.integrators.common import (
    T_CAP_OPTICAL_DEPTH,
    equiangular_pdf,
    equiangular_sample,
    sample_target_point,
    target_table,
)
from rigsim.render.integrators.daylight import PLUGIN_NAME as DAYLIGHT_PLUGIN_NAME
from rigsim.render.integrators.daylight import DaylightIntegrator
from rigsim.render.integrators.strobe import PLUGIN_NAME, RigsimVolIntegrator, sampling_defaults
from rigsim.render.variant import mitsuba

__all__ = ["RigsimVolIntegrator", "DaylightIntegrator", "PLUGIN_NAME", "DAYLIGHT_PLUGIN_NAME", "INTEGRATORS",
           "integrator_dict", "integrator_key", "with_integrator", "equiangular_sample", "equiangular_pdf", "sample_target_point",
           "target_table", "T_CAP_OPTICAL_DEPTH"]

mi, dr = mitsuba()

#: Integrators ``rigsim render --integrator`` can choose: name → Mitsuba plugin.
INTEGRATORS = {"rigsim": PLUGIN_NAME, "volpath": "volpath"}


def integrator_dict(name: str = "rigsim", *, max_depth: int = -1, rr_depth: int | None = None,
                    backscatter_aov: bool = False, class_split_deg: float | None = None) -> dict:
    """Mitsuba dict of integrator ``name`` (a key of :data:`INTEGRATORS`).

    ``rr_depth``: the depth Russian roulette starts at (None: the integrator's own default — for
    rigsim from 5 to :data:`~rigsim.render.integrators.strobe.DEFAULT_RR_DEPTH_MAX` by the water's
    albedo, see its module docstring; 5 for volpath).

    ``backscatter_aov`` (rigsim only): the integrator also returns the backscatter estimate
    of each path as AOVs (see :meth:`RigsimVolIntegrator.aov_names`).

    ``class_split_deg`` (rigsim only): the integrator also returns the light of the fast engine's class A
    (paths with at most one turn by more than this angle and no surface) as AOVs (a check of the fast engine).
    """
    if name not in INTEGRATORS:
        raise ConfigError(f"unknown integrator {name!r}", field="integrator", allowed=", ".join(INTEGRATORS))
    d = {"type": INTEGRATORS[name], "max_depth": int(max_depth)}
    if rr_depth is not None or name == "volpath":
        d["rr_depth"] = int(5 if rr_depth is None else rr_depth)
    if backscatter_aov:
        if name != "rigsim":
            raise ConfigError("only the rigsim integrator returns backscatter AOVs", field="integrator",
                              allowed="rigsim")
        d["backscatter_aov"] = True
    if class_split_deg is not None:
        if name != "rigsim":
            raise ConfigError("only the rigsim integrator returns the class-A AOVs", field="integrator",
                              allowed="rigsim")
        if not 0.0 <= float(class_split_deg) <= 180.0:
            raise ConfigError(f"class_split_deg must be in [0, 180], got {class_split_deg}",
                              field="integrator.class_split_deg", allowed="0 <= angle <= 180")
        d["class_split_deg"] = float(class_split_deg)
    return d


def integrator_key(name: str = "rigsim") -> dict:
    """What a render of integrator ``name`` with :func:`integrator_dict`'s defaults depends on besides the scene,
    size, paths and seed: its plugin and default sampling options (rigsim: :func:`strobe.sampling_defaults`)."""
    if name not in INTEGRATORS:
        raise ConfigError(f"unknown integrator {name!r}", field="integrator", allowed=", ".join(INTEGRATORS))
    if name == "rigsim":
        return {"plugin": PLUGIN_NAME, **sampling_defaults()}
    return {"plugin": INTEGRATORS[name], "rr_depth": 5}


def with_integrator(ms, integrator):
    """The same loaded scene with another integrator (a :class:`MitsubaScene` copy).

    ``integrator`` is a Mitsuba dict, a name of :data:`INTEGRATORS` or an integrator
    object.  The shapes and emitters (with their BSDFs and media) are reused, not
    rebuilt; shape ids are kept.
    """
    if isinstance(integrator, str):
        integrator = integrator_dict(integrator)
    d = {"type": "scene", "integrator": integrator}
    for i, sh in enumerate(ms.scene.shapes()):
        d[sh.id() or f"shape{i}"] = sh
    for i, e in enumerate(ms.scene.emitters()):
        d[f"emitter{i}"] = e
    return dataclasses.replace(ms, scene=mi.load_dict(d, optimize=False))


mi.register_integrator(PLUGIN_NAME, lambda props: RigsimVolIntegrator(props))
mi.register_integrator(DAYLIGHT_PLUGIN_NAME, lambda props: DaylightIntegrator(props))
