"""``rigsim_daylight``: the daylight field at depth seen by the camera and reflected by the targets.

Daylight reaches the rig from tens of metres of water above it; tracing paths up to the surface
would be hopeless, and a directional light inside the renderer's 1 km water sphere would be
attenuated to nothing.  Instead this integrator treats the scene's daylight field
(:mod:`rigsim.scene.daylight_field`: the Monte Carlo meter or the Kd shortcut, tabulated by
direction, with the sun beam) as the light that arrives from far away, and follows a chain of
surface bounces only (the water's own scattering of daylight is already in the field):

* each segment from ``o`` along ``d`` that meets an object at ``t`` adds the field's path
  radiance (:func:`rigsim.scene.daylight_field.path_radiance`, Duntley's law: all of ``L_amb(d)``
  if it meets nothing), and the path's weight is attenuated by ``e^{−c t}``;
* each surface adds the sun beam by next-event estimation (shadow ray up to the sea surface; beam
  irradiance ``× e^{K_beam (y − y₀)}`` (:func:`~rigsim.scene.daylight_field.height_factor`) times
  the caustic pattern of a wavy surface) and continues by BSDF sampling, so the diffuse field,
  shadows by other objects and inter-reflections follow;
* Russian roulette from the third bounce (:func:`~rigsim.render.integrators.common.russian_roulette`,
  threshold 1), at most :data:`MAX_BOUNCES` surface bounces.

The camera segment carries path radiance only if the water scatters (not in the ``direct`` pass),
and no attenuation in the ``clear`` pass (no medium); its path radiance is also returned as the
backscatter estimate.  Run alone (``{"type": "rigsim_daylight"}``) it renders the daylight only;
:class:`~rigsim.render.integrators.strobe.RigsimVolIntegrator` runs it on its own camera rays
when the scene has daylight (:meth:`~rigsim.render.integrators.strobe.RigsimVolIntegrator.set_ambient`).
"""

from __future__ import annotations

from rigsim.errors import ConfigError
from rigsim.render.integrators.common import medium_interaction, russian_roulette
from rigsim.render.variant import mitsuba
from rigsim.scene.daylight_field import height_factor, path_radiance

__all__ = ["DaylightIntegrator", "PLUGIN_NAME", "MAX_BOUNCES", "ROULETTE_DEPTH"]

mi, dr = mitsuba()

#: Name under which the integrator is registered with Mitsuba.
PLUGIN_NAME = "rigsim_daylight"
#: Most surface bounces of a daylight path.
MAX_BOUNCES = 8
#: Russian roulette starts after this many bounces.
ROULETTE_DEPTH = 2


class DaylightIntegrator(mi.SamplingIntegrator):
    """Daylight field at depth through Duntley's transport and surface bounces (module docstring).

    Mitsuba properties: ``max_depth`` (int, −1: unlimited; as ``volpath``, 2 keeps one surface).
    The field is set with :meth:`set_ambient` (Mitsuba cannot pass the tables as properties).
    """

    def __init__(self, props=None, *, max_depth: int | None = None):
        if props is None:
            props = mi.Properties(PLUGIN_NAME)
        mi.SamplingIntegrator.__init__(self, props)
        md = int(props.get("max_depth", -1)) if max_depth is None else int(max_depth)
        if md < -1 or md == 0:
            raise ConfigError(f"max_depth must be -1 or >= 1, got {md}", field="integrator.max_depth")
        self.max_depth = md
        self.ambient = None
        self.world_radius_m = 1000.0

    def set_ambient(self, tables, world_radius_m: float = 1000.0) -> "DaylightIntegrator":
        """The daylight field (:class:`~rigsim.render.daylight.AmbientTables`) and the water sphere's radius (m)."""
        self.ambient = tables
        self.world_radius_m = float(world_radius_m)
        return self

    def sample(self, scene, sampler, ray, medium=None, active=True):
        if self.ambient is None:
            raise ConfigError("the daylight integrator has no daylight field (set_ambient)", field="integrator")
        L, _ = self.sample_ambient(scene, sampler, mi.Ray3f(ray), medium, mi.Bool(active))
        return L, mi.Bool(True), []

    def sample_ambient(self, scene, sampler, ray, medium, active):
        """``(L, L_backscatter)``: radiance from the daylight field along ``ray`` (module docstring).

        A chain of surface bounces only (the water's own scattering of daylight is in the
        field): each segment from o along d that meets an object at t adds the field's path
        radiance ``L_amb(d; y_o)(1 − e^{−(c − K d_y) t})`` (all of ``L_amb`` if it meets
        nothing), each surface the sun beam by next-event estimation (shadow ray to the sea
        surface, caustics), and the path goes on by BSDF sampling with weight ``e^{−c t}``.
        The camera segment carries path radiance only if the water scatters (not in the
        ``direct`` pass) and no attenuation in the ``clear`` pass (no medium).
        """
        A = self.ambient
        wavelengths = ray.wavelengths
        time = ray.time
        idx = A.index(wavelengths)
        c = A.spec(A.c, idx)
        kd = A.spec(A.k_diffuse, idx)
        kb = A.spec(A.k_beam, idx)
        e_beam = A.spec(A.beam, idx)
        y0, y_surf = A.y0, A.y_surface
        w_sun = mi.Vector3f(*[-x for x in A.sun_dir])  # towards the sun
        has_medium = medium is not None
        if has_medium:
            mei0 = medium_interaction(ray.o, ray.d, mi.Float(0.0), wavelengths, time, mi.MediumPtr(medium))
            sigma_s, _, _ = medium.get_scattering_coefficients(mei0, active)
            cam_scatters = dr.any(mi.Spectrum(sigma_s) > 0.0)
        else:
            cam_scatters = mi.Bool(False)
        max_depth = self.max_depth if self.max_depth >= 0 else 2**31
        max_bounce = MAX_BOUNCES
        r_max = 0.5 * self.world_radius_m
        bsdf_ctx = mi.BSDFContext()

        def cond(sampler, active, depth, o, d, beta, L, Lb):
            return active

        def body(sampler, active, depth, o, d, beta, L, Lb):
            first = depth == 0
            active, beta = russian_roulette(sampler, beta, depth, ROULETTE_DEPTH, 1.0, active)
            r = mi.Ray3f(o, d, time, wavelengths)
            si = scene.ray_intersect(r, active)
            bsdf = si.bsdf(r)
            hit = active & si.is_valid() & ~mi.has_flag(bsdf.flags(), mi.BSDFFlags.Null)
            t_s = dr.select(hit, si.t, dr.inf)
            # the field's path radiance along the segment (Duntley; t_s = ∞ if it meets nothing)
            l_path = path_radiance(A.radiance(d, idx), c, kd, d.y, o.y - y0, t_s, dr.exp)
            if has_medium:
                emit = active & (~first | cam_scatters)
            else:
                emit = active & ~first
            L += dr.select(emit, beta * l_path, 0.0)
            Lb += dr.select(emit & first, beta * l_path, 0.0)  # the camera segment: backscatter
            # surfaces: attenuation to the surface, sun beam by next-event estimation
            water_seg = mi.Bool(True) if has_medium else ~first
            beta = dr.select(water_seg, beta * dr.exp(-c * dr.select(hit, t_s, 0.0)), beta)
            surf = hit & (depth + 1 < max_depth)
            y = dr.minimum(si.p.y, y_surf)
            e_y = e_beam * height_factor(kb, y - y0, dr.exp) * A.caustic(si.p)
            sr = si.spawn_ray(w_sun)
            sr.maxt = dr.minimum((y_surf - y) / dr.maximum(w_sun.y, 1e-6), r_max)
            occluded = scene.ray_test(sr, surf)
            f = bsdf.eval(bsdf_ctx, si, si.to_local(w_sun), surf)
            L += dr.select(surf & ~occluded, beta * f * e_y, 0.0)
            # diffuse field: BSDF sampling, the next segment looks it up
            bs, bw = bsdf.sample(bsdf_ctx, si, sampler.next_1d(surf), sampler.next_2d(surf), surf)
            cont = surf & (bs.pdf > 0) & (depth + 1 < max_bounce)
            beta = dr.select(cont, beta * bw, beta)
            r_s = si.spawn_ray(si.to_world(bs.wo))
            o = dr.select(cont, r_s.o, o)
            d = dr.select(cont, r_s.d, d)
            depth = dr.select(cont, depth + 1, depth)
            active = cont & dr.any(beta != 0.0)
            return sampler, active, depth, o, d, beta, L, Lb

        state = (sampler, mi.Bool(active), mi.UInt32(0), mi.Point3f(ray.o), mi.Vector3f(ray.d),
                 mi.Spectrum(1.0), mi.Spectrum(0.0), mi.Spectrum(0.0))
        state = dr.while_loop(state, cond, body, labels=("sampler", "active", "depth", "o", "d", "beta", "L", "Lb"),
                              label="rigsim_daylight")
        return state[-2], state[-1]

    def to_string(self):
        return f"DaylightIntegrator[max_depth={self.max_depth}]"
