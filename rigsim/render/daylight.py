"""Ambient daylight for the renderer: the scene's daylight field as Dr.Jit tables.

The field, its 1-nm resampling, the clip of its vertical K and the transport formulas (Duntley's
path radiance, the field's change with height) live in :mod:`rigsim.scene.daylight_field`, shared
with the fast engine; this module only converts :class:`~rigsim.scene.daylight_field.SceneDaylight`
into the arrays the daylight integrator (:mod:`rigsim.render.integrators.daylight`) reads, and
looks them up in Dr.Jit (nearest 1-nm node; bilinear between the field's bin centres in (θ, φ),
the same lookup as :meth:`SceneDaylight.radiance`).

What the renderer does with daylight
------------------------------------
A line of sight that meets no object sees ``L_amb`` of its direction (in equilibrium the
in-scattered source along any line of sight rebuilds exactly that radiance); one that meets an
object at distance ``t`` sees the field's path radiance (:func:`rigsim.scene.daylight_field.path_radiance`)
plus ``e^{−c t}`` times the object's radiance.  Surfaces reflect the sun beam (next-event
estimation with a shadow ray up to the sea surface, times the caustic pattern when the surface is
wavy) and the diffuse field, sampled by the BSDF (cosine) with the rule above for whatever the
sampled direction meets — so shadowing by other objects, the target's own orientation and
inter-reflections between objects (the bottom lighting a target from below) all follow.  Point
lights (strobes, video lights) are rendered by the volumetric path tracer as before.

Render passes: ``full`` as above; ``backscatter`` (black targets) keeps the path radiance of the
camera's line of sight; ``direct`` (albedo 0) keeps the targets lit by the same field but drops
that path radiance (so ``full = direct + backscatter`` for daylight); ``clear`` (no water) shows
the targets lit by the same field with nothing between them and the camera, and a black
background.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from rigsim.render.variant import mitsuba
from rigsim.scene.daylight_field import SceneDaylight, scene_daylight
from rigsim.scene.types import Scene
from rigsim.spectrum import MITSUBA_WAVELENGTH_RANGE_NM

__all__ = ["AmbientTables", "ambient_tables", "from_scene_daylight"]

mi, dr = mitsuba()

_LO, _HI = MITSUBA_WAVELENGTH_RANGE_NM
_N_WL = int(round(_HI - _LO)) + 1


@dataclasses.dataclass(eq=False)
class AmbientTables:
    """The field as the integrator reads it (Dr.Jit arrays, 1 nm over 360–830 nm; built by
    :func:`from_scene_daylight`)."""

    field: object  # the AngularField of the model run
    n_theta: int
    n_phi: int
    diffuse: object  # Float, (471, n_theta, n_phi) flattened
    beam: object  # Float (471): beam irradiance normal to it at y0
    c: object  # Float (471)
    k_diffuse: object
    k_beam: object
    sun_dir: tuple  # propagation direction (scene frame)
    sun_azimuth_rad: float
    y0: float  # height of the camera (where the field holds)
    y_surface: float  # height of the sea surface
    caustics: list  # [(y_level, Float texture res², res, extent)]
    meta: dict

    # -- lookups (Dr.Jit) -------------------------------------------------------------------
    @staticmethod
    def index(wavelengths):
        return [mi.UInt32(dr.clip(dr.round(wavelengths[j] - _LO), 0, _N_WL - 1)) for j in range(4)]

    @staticmethod
    def spec(table, idx):
        return mi.Spectrum(*[dr.gather(mi.Float, table, idx[j]) for j in range(4)])

    def radiance(self, v, idx):
        """Diffuse radiance seen looking along unit ``v`` at y0 (bilinear in the bin centres)."""
        nt, nph = self.n_theta, self.n_phi
        th = dr.acos(dr.clip(v.y, -1.0, 1.0))
        sp, cp = np.sin(self.sun_azimuth_rad), np.cos(self.sun_azimuth_rad)
        h = dr.sqrt(dr.maximum(v.x * v.x + v.z * v.z, 1e-20))
        ph = dr.acos(dr.clip((v.x * sp + v.z * cp) / h, -1.0, 1.0))
        tt = dr.clip(th * (nt / np.pi) - 0.5, 0.0, nt - 1.0)
        tp = dr.clip(ph * (nph / np.pi) - 0.5, 0.0, nph - 1.0)
        i0 = mi.UInt32(dr.minimum(dr.floor(tt), nt - 2)) if nt > 1 else mi.UInt32(0)
        j0 = mi.UInt32(dr.minimum(dr.floor(tp), nph - 2)) if nph > 1 else mi.UInt32(0)
        ft = tt - mi.Float(i0)
        fp = tp - mi.Float(j0) if nph > 1 else mi.Float(0.0)
        j1 = j0 + 1 if nph > 1 else j0
        out = []
        for j in range(4):
            base = idx[j] * (nt * nph)
            a = dr.gather(mi.Float, self.diffuse, base + i0 * nph + j0)
            b = dr.gather(mi.Float, self.diffuse, base + i0 * nph + j1)
            c = dr.gather(mi.Float, self.diffuse, base + (i0 + 1) * nph + j0)
            d = dr.gather(mi.Float, self.diffuse, base + (i0 + 1) * nph + j1)
            top = dr.lerp(a, b, fp)
            bot = dr.lerp(c, d, fp)
            out.append(dr.lerp(top, bot, ft))
        return mi.Spectrum(*out)

    def caustic(self, p):
        """Relative sun-beam irradiance (mean 1) at points ``p`` (1 without waves)."""
        if not self.caustics:
            return mi.Float(1.0)
        # nearest tabulated level in height
        val = mi.Float(1.0)
        best = mi.Float(np.inf)
        for y_lev, tex, res, ext in self.caustics:
            u = p.x / ext + 0.5
            w = p.z / ext + 0.5
            u = u - dr.floor(u)
            w = w - dr.floor(w)
            iu = mi.UInt32(dr.minimum(u * res, res - 1))
            iw = mi.UInt32(dr.minimum(w * res, res - 1))
            v = dr.gather(mi.Float, tex, iw * res + iu)
            dist = dr.abs(p.y - y_lev)
            take = dist < best
            val = dr.select(take, v, val)
            best = dr.select(take, dist, best)
        return val


def ambient_tables(scene: Scene, band_lo_nm: float, band_hi_nm: float, *, seed: int | None = None) -> AmbientTables:
    """The daylight field of ``scene`` (:func:`rigsim.scene.daylight_field.scene_daylight`; ``seed``
    None: the scene's :attr:`~rigsim.scene.types.Daylight.field_seed`) as Dr.Jit tables."""
    return from_scene_daylight(scene_daylight(scene, band_lo_nm, band_hi_nm, seed=seed))


def from_scene_daylight(sd: SceneDaylight) -> AmbientTables:
    """Convert :class:`~rigsim.scene.daylight_field.SceneDaylight` to the integrator's Dr.Jit arrays."""
    f32 = lambda a: mi.Float(np.asarray(a, np.float32).ravel())  # noqa: E731
    caustics = [(c.y_m, f32(c.pattern), int(c.pattern.shape[0]), float(c.extent_m)) for c in sd.caustics]
    return AmbientTables(sd.field, sd.n_theta, sd.n_phi, f32(sd.diffuse), f32(sd.beam), f32(sd.c),
                         f32(sd.k_diffuse), f32(sd.k_beam), sd.sun_direction, sd.sun_azimuth_rad, sd.y0,
                         sd.y_surface, caustics, sd.meta)
