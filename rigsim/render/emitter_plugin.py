"""A Mitsuba point emitter with a beam pattern and a spectral on-axis intensity.

The radiant intensity in direction ``ω`` from the light is
``I(λ, ω) = I_axis(λ) · f(θ)``, θ the angle between ω and the beam axis, ``f``
the :class:`~rigsim.scene.types.BeamPattern` (``f(0) = 1``).  The same code serves
strobes (``I`` in J/(sr·nm) per flash: the image is then radiant exposure per flash)
and continuous lights (W/(sr·nm)).

* ``sample_direction`` (next-event estimation): the light's position, pdf 1
  (delta), value ``I(λ) f(θ) / d²``;
* ``sample_ray`` (light tracing): wavelengths from the intensity spectrum,
  direction uniform over the sphere, weight ``I(λ) f(θ) 4π / pdf(λ)``;
* it can never be hit by a ray (``eval`` is zero).

``f`` is exact: ``soft-cone`` is evaluated analytically, a ``table`` profile by
linear interpolation of its own (angle, value) nodes.  The spectrum is Mitsuba's
``irregular`` spectrum through the light's own samples (exact piecewise linear).
"""

from __future__ import annotations

import numpy as np

from rigsim.render.spectra import spectrum_dict
from rigsim.render.variant import mitsuba
from rigsim.scene.types import BeamPattern, Light, unit
from rigsim.spectrum import MITSUBA_WAVELENGTH_RANGE_NM

__all__ = ["PLUGIN_NAME", "BeamPointEmitter", "make_emitter"]

mi, dr = mitsuba()

PLUGIN_NAME = "rigsim_beam_point"


class BeamPointEmitter(mi.Emitter):
    """Point light with a beam pattern (see module docstring).

    Through Mitsuba: ``{"type": "rigsim_beam_point", "position": [x, y, z],
    "aim": [x, y, z], "beam_angle_deg": 100, "edge_exponent": 2,
    "intensity": <spectrum>}`` (a soft-cone beam); or :func:`make_emitter`.
    """

    def __init__(self, props=None):
        if props is None:
            props = mi.Properties(PLUGIN_NAME)
        mi.Emitter.__init__(self, props)
        self.m_flags = mi.EmitterFlags.DeltaPosition
        self.configured = False
        if "position" in props:
            beam = BeamPattern(kind="soft-cone",
                               beam_angle_deg=float(props.get("beam_angle_deg", 100.0)),
                               edge_exponent=float(props.get("edge_exponent", 2.0)))
            intensity = props.get("intensity", None)
            if intensity is None:
                intensity = mi.load_dict({"type": "uniform", "value": 1.0})
            self.configure(np.asarray(props["position"], float), np.asarray(props.get("aim", [0, 0, 1]), float),
                           beam, intensity)

    def configure(self, position, aim, beam: BeamPattern, intensity_texture) -> BeamPointEmitter:
        """Set position (m), beam axis, pattern and the intensity spectrum (a Mitsuba texture)."""
        p = np.asarray(position, float)
        a = unit(aim)
        self.p_scalar = p
        # opaque: a literal would be compiled into the kernel, and every rig or aim a new kernel
        self.pos = dr.opaque(mi.Point3f, [float(x) for x in p])
        self.axis = dr.opaque(mi.Vector3f, [float(x) for x in a])
        self.intensity = intensity_texture
        self.beam = beam
        if beam.kind == "soft-cone":
            self.half_rad = dr.opaque(mi.Float, float(np.radians(beam.beam_angle_deg) / 2))
            self.edge_p = dr.opaque(mi.Float, float(beam.edge_exponent))
            self.table = None
        else:
            ang = np.radians(np.asarray(beam.angle_deg, float))
            rel = np.asarray(beam.relative, float)
            # Exact piecewise-linear profile: nodes at the table's angles, zero beyond its end.
            ang = np.concatenate([ang, [ang[-1] + 1e-6, np.pi + 1e-3]])
            rel = np.concatenate([rel, [0.0, 0.0]])
            if ang[0] > 0:
                ang = np.concatenate([[0.0], ang])
                rel = np.concatenate([[rel[0]], rel])
            self.table_ang = mi.Float(ang.astype(np.float32))
            self.table_rel = mi.Float(rel.astype(np.float32))
            self.table_n = len(ang)
            self.table = True
        self.configured = True
        return self

    # -- beam pattern ---------------------------------------------------------------
    def beam_pattern(self, d_out):
        """f(θ) (f(0) = 1) for unit directions ``d_out`` leaving the light (Dr.Jit)."""
        return self._pattern(d_out)

    def intensity_at(self, wavelengths, active=True):
        """``I_axis(λ)`` (Spectrum) at ``wavelengths``."""
        return self._spectrum(wavelengths, active)

    def _pattern(self, d_out):
        """f(θ) for unit directions ``d_out`` leaving the light."""
        # θ = 2 atan2(|d − a|, |d + a|): accurate at all angles
        theta = 2.0 * dr.atan2(dr.norm(d_out - self.axis), dr.norm(d_out + self.axis))
        if self.table is None:
            f = dr.exp2(-dr.power(theta / self.half_rad, self.edge_p))
            return dr.select(theta < dr.pi / 2, f, 0.0)
        n = self.table_n
        i = dr.binary_search(0, n - 1, lambda j: dr.gather(mi.Float, self.table_ang, j) <= theta)
        i = mi.UInt32(dr.clip(mi.Int32(i) - 1, 0, n - 2))
        a0 = dr.gather(mi.Float, self.table_ang, i)
        a1 = dr.gather(mi.Float, self.table_ang, i + 1)
        r0 = dr.gather(mi.Float, self.table_rel, i)
        r1 = dr.gather(mi.Float, self.table_rel, i + 1)
        t = dr.clip((theta - a0) / dr.maximum(a1 - a0, 1e-12), 0.0, 1.0)
        return dr.maximum(dr.fma(t, r1 - r0, r0), 0.0)

    def _spectrum(self, wavelengths, active):
        si = dr.zeros(mi.SurfaceInteraction3f)
        si.wavelengths = wavelengths
        return self.intensity.eval(si, active)

    # -- Mitsuba interface ----------------------------------------------------------
    def sample_direction(self, it, sample, active=True):
        ds = dr.zeros(mi.DirectionSample3f)
        ds.p = mi.Point3f(self.pos)
        ds.n = mi.Normal3f(0.0)
        ds.time = it.time
        ds.pdf = mi.Float(1.0)
        ds.delta = mi.Bool(True)
        ds.emitter = mi.EmitterPtr(self)
        d = ds.p - it.p
        dist2 = dr.squared_norm(d)
        inv = dr.rsqrt(dist2)
        ds.d = d * inv
        ds.dist = dist2 * inv
        spec = self._spectrum(it.wavelengths, active) * (self._pattern(-ds.d) * dr.square(inv))
        return ds, spec

    def pdf_direction(self, it, ds, active=True):
        return mi.Float(0.0)

    def eval_direction(self, it, ds, active=True):
        d = ds.p - it.p
        dist2 = dr.squared_norm(d)
        return self._spectrum(it.wavelengths, active) * (self._pattern(-d * dr.rsqrt(dist2)) / dist2)

    def sample_ray(self, time, wavelength_sample, pos_sample, dir_sample, active=True):
        si = dr.zeros(mi.SurfaceInteraction3f)
        wavelengths, wweight = self.intensity.sample_spectrum(
            si, mi.sample_shifted(wavelength_sample), active)
        d = mi.warp.square_to_uniform_sphere(dir_sample)
        ray = mi.Ray3f(mi.Point3f(self.pos), d, time, wavelengths)
        return ray, wweight * (4.0 * dr.pi * self._pattern(d))

    def sample_position(self, time, sample, active=True):
        ps = dr.zeros(mi.PositionSample3f)
        ps.p = mi.Point3f(self.pos)
        ps.time = time
        ps.delta = mi.Bool(True)
        return ps, mi.Float(1.0)

    def sample_wavelengths(self, si, sample, active=True):
        return self.intensity.sample_spectrum(si, mi.sample_shifted(sample), active)

    def eval(self, si, active=True):
        return mi.Spectrum(0.0)

    def bbox(self):
        p = mi.ScalarPoint3f(*[float(x) for x in self.p_scalar])
        return mi.ScalarBoundingBox3f(p)

    def traverse(self, callback):
        pass

    def to_string(self):
        return f"BeamPointEmitter[p={self.p_scalar.tolist()}, beam={self.beam}]"


def make_emitter(light: Light, *, scale: float = 1.0) -> BeamPointEmitter:
    """A plugin instance for a rigsim :class:`~rigsim.scene.types.Light` (intensity × ``scale``)."""
    wl = np.asarray(light.wavelength_nm, float)
    vals = np.asarray(light.axial_intensity, float) * scale
    tex = mi.load_dict(spectrum_dict(wl, vals, *MITSUBA_WAVELENGTH_RANGE_NM))
    return BeamPointEmitter().configure(light.position_m, light.aim, light.beam, tex)


mi.register_emitter(PLUGIN_NAME, lambda props: BeamPointEmitter(props))
