"""Ambient daylight for the renderer: the field at the rig's depth as Dr.Jit tables.

What the renderer does with daylight
------------------------------------
A scene with a :class:`~rigsim.scene.types.Daylight` is lit by the daylight field at
the camera's depth, :class:`~rigsim.daylight.field.AngularField` — the same Monte
Carlo meter (``model="monte-carlo"``) or Kd shortcut (``model="kd"``) as
``rigsim ambient`` — an unscattered sun beam (a delta) plus a tabulated diffuse
radiance ``L_amb(θ, φ; λ)`` that already holds every order of scattering in the
water column.  Tracing paths tens of metres up to the surface would be hopeless,
and a directional light inside the renderer's 1 km water sphere would be
attenuated to nothing; instead, the integrator (:mod:`rigsim.render.integrator`)
treats the field as the light that arrives from far away, with Duntley's
contrast-transmittance law for what objects change:

* **open water** — a line of sight that meets no object sees ``L_amb`` of its
  direction (the field is the plane-parallel solution: in equilibrium the
  in-scattered source along any line of sight rebuilds exactly that radiance);
* **a line of sight from x in direction v that meets an object at distance t**
  sees ``L_amb(v; y_x) (1 − e^{−(c − K v_y) t}) + e^{−c t} L_object``: the water in
  front of the object contributes the path radiance of the field, the object's
  own radiance is attenuated by the beam attenuation c (Duntley 1963; the
  ``c − K v_y`` term is the exact sloped-path form for a field that varies as
  ``e^{K (y − y₀)}`` with height — for horizontal sight lines it is ``c``);
* **surfaces** reflect the sun beam (next-event estimation with a shadow ray up to
  the sea surface; beam irradiance ``E_beam e^{(c/μ_w)(y − y₀)}``, times the caustic
  pattern when the surface is wavy) and the diffuse field, sampled by the BSDF
  (cosine) with the rule above for whatever the sampled direction meets — so
  shadowing by other objects, the target's own orientation and inter-reflections
  between objects (the bottom lighting a target from below) all follow;
* the field's height dependence over the scene: diffuse radiances
  ``× e^{K_diff (y − y₀)}`` (K_diff the local attenuation of the diffuse downwelling
  irradiance from the meter, or Kd), the beam ``× e^{(c/μ_w)(y − y₀)}`` (exact).

Neglected (documented limits): the scattering by the water of the *change* an
object makes to the field — the object's shadow volume in the water (no light
shafts / "god rays"), the forward-scattered halo of light reflected by a target,
and the object's own light scattered back onto it; these are second order in
``b × object size`` and shrink with the object.  Point lights (strobes, video
lights) are rendered by the full volumetric path tracer as before.

Render passes: ``full`` as above; ``backscatter`` (black targets) keeps the path
radiance of the camera's line of sight (light scattered by the water that did
not reach the camera from a surface); ``direct`` (albedo 0) keeps the targets lit
by the same field but drops that path radiance (so ``full = direct +
backscatter`` for daylight); ``clear`` (no water) shows the targets lit by the
same field with nothing between them and the camera, and a black background.

Tables: every 1 nm over 360–830 nm (the rendered band range resampled, ends
held); the Monte Carlo field is run on a coarse grid (``≤ FIELD_STEP_NM``) and
resampled as its ratio to the Kd shortcut's Ed(λ), which carries the fine
spectral structure (solar lines, water absorption) at 1 nm.

References
----------
Duntley, S. Q. (1963). Light in the sea. *J. Opt. Soc. Am.* 53(2), 214–233.
Mobley, C. D. (1994). *Light and Water*, §§ 5.10, 10 (the apparent contrast law).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json

import numpy as np

from rigsim.daylight.field import DEFAULT_N_PHI, DEFAULT_N_THETA, AngularField, angular_field
from rigsim.daylight.shortcut import ambient_light_kd
from rigsim.errors import ConfigError
from rigsim.render.variant import mitsuba
from rigsim.scene.types import DAYLIGHT_MODELS, WAVE_KINDS, Daylight, Scene
from rigsim.spectrum import MITSUBA_WAVELENGTH_RANGE_NM

__all__ = ["AmbientTables", "ambient_tables", "daylight_from_options", "caustic_waves", "FIELD_STEP_NM",
           "DAYLIGHT_MODELS", "WAVE_KINDS"]

mi, dr = mitsuba()

#: Largest spacing of the wavelengths at which the Monte Carlo field is computed (nm).
FIELD_STEP_NM = 20.0
#: Command-line option of each :class:`Daylight` field, for messages.
_OPTION_OF_FIELD = {"depth_m": "depth", "sun_zenith_deg": "sun-zenith", "model": "daylight-model"}
#: Side (m) and resolution of the caustic texture (periodic beyond).
CAUSTIC_EXTENT_M = 4.0
CAUSTIC_RESOLUTION = 128
_LO, _HI = MITSUBA_WAVELENGTH_RANGE_NM
_N_WL = int(round(_HI - _LO)) + 1


def daylight_from_options(depth_m: float | None, *, sun_zenith_deg: float = 30.0, sun_azimuth_deg: float = 0.0,
                          model: str = "kd", sky: str = "cie", photons: int = 20_000, waves: str = "flat",
                          wind_speed_m_s: float = 5.0, wave_amplitude_m: float = 0.05,
                          wave_length_m: float = 1.0) -> Daylight | None:
    """A :class:`Daylight` from command-line values (None if ``depth_m`` is None).

    Parameters
    ----------
    depth_m
        Camera depth (m, > 0), or None for no daylight.
    sun_zenith_deg, sun_azimuth_deg
        Sun position (deg; zenith 0 <= z < 90).
    model, sky, photons, waves, wind_speed_m_s, wave_amplitude_m, wave_length_m
        As :class:`Daylight` (which checks them all).

    Raises
    ------
    ConfigError
        What :class:`Daylight` refuses, naming the command-line option (``depth``,
        ``sun-zenith``, ``daylight-model``, ``waves``, ``photons`` …).
    """
    if depth_m is None:
        return None
    try:
        return Daylight(depth_m=depth_m, sun_zenith_deg=sun_zenith_deg, sun_azimuth_deg=sun_azimuth_deg, model=model,
                        sky=sky, photons=photons, waves=waves, wind_speed_m_s=wind_speed_m_s,
                        wave_amplitude_m=wave_amplitude_m, wave_length_m=wave_length_m)
    except ConfigError as exc:
        key = exc.field.split(".", 1)[-1] if exc.field else ""
        raise ConfigError(exc.message, field=_OPTION_OF_FIELD.get(key, key.replace("_", "-")) or None,
                          allowed=exc.allowed) from None


def caustic_waves(daylight: Daylight):
    """The :class:`~rigsim.daylight.waves.WaveField` of the daylight's ``waves`` (None when flat)."""
    from rigsim.daylight.waves import sine_waves, waves_PiersonMoskowitz1964

    kind = getattr(daylight, "waves", "flat")
    if kind == "flat":
        return None
    if kind == "sines":
        return sine_waves(daylight.wave_amplitude_m, daylight.wave_length_m, daylight.wave_direction_deg)
    if kind == "pierson-moskowitz":
        return waves_PiersonMoskowitz1964(daylight.wind_speed_m_s, wind_direction_deg=daylight.wave_direction_deg)
    raise ConfigError(f"unknown waves {kind!r}", field="daylight.waves", allowed=", ".join(WAVE_KINDS))


@dataclasses.dataclass(eq=False)
class AmbientTables:
    """The field as the integrator reads it (Dr.Jit arrays, 1 nm over 360–830 nm)."""

    field: AngularField
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


_CACHE: dict[str, AmbientTables] = {}


def _key(scene: Scene, lo: float, hi: float, seed: int) -> str:
    dl = dataclasses.asdict(scene.daylight)
    payload = {"daylight": dl, "water": scene.water.describe() if scene.water is not None else None,
               "water_id": id(scene.water), "cam": list(scene.camera.position_m), "lo": lo, "hi": hi,
               "seed": seed, "targets": [(t.kind, t.distance_m, t.size_m) for t in scene.targets]}
    return hashlib.sha256(json.dumps(payload, sort_keys=True, default=str).encode()).hexdigest()


def _field_grid(lo: float, hi: float, wl_range) -> np.ndarray:
    lo_c, hi_c = max(lo, wl_range[0]), min(hi, wl_range[1])
    n = max(2, int(np.ceil((hi_c - lo_c) / FIELD_STEP_NM)) + 1)
    return np.linspace(lo_c, hi_c, n)


def ambient_tables(scene: Scene, band_lo_nm: float, band_hi_nm: float, *, seed: int = 0) -> AmbientTables:
    """The daylight field of ``scene`` for bands spanning ``band_lo_nm … band_hi_nm`` (cached)."""
    if scene.daylight is None:
        raise ValueError("scene has no daylight")
    if scene.water is None:
        raise ConfigError("daylight at depth needs water (the scene has none)", field="daylight")
    key = _key(scene, float(band_lo_nm), float(band_hi_nm), int(seed))
    hit = _CACHE.get(key)
    if hit is not None:
        return hit
    dl, water = scene.daylight, scene.water
    wr = water.wavelength_range_nm
    nodes = np.linspace(_LO, _HI, _N_WL)
    wl_fine = np.clip(nodes, max(band_lo_nm, wr[0]), min(band_hi_nm, wr[1]))  # ends held
    n_theta, n_phi = DEFAULT_N_THETA, DEFAULT_N_PHI
    if dl.model == "kd":
        uniq, inv = np.unique(wl_fine, return_inverse=True)
        fld = angular_field(dl, water, uniq, seed=seed, n_theta=n_theta, n_phi=n_phi)
        diffuse = fld.diffuse[inv]
        k_diff = fld.k_diffuse[inv]
        field_wl = uniq
    else:
        grid = _field_grid(band_lo_nm, band_hi_nm, wr)
        fld = angular_field(dl, water, grid, seed=seed, n_theta=n_theta, n_phi=n_phi)
        # resample the Monte Carlo field as its ratio to the Kd shortcut's Ed (smooth in λ)
        kw = dict(sun_zenith_deg=dl.sun_zenith_deg, sky=dl.sky)
        from rigsim.daylight.underwater import daylight_above_surface

        ed_g = ambient_light_kd(water, grid, [dl.depth_m], above=daylight_above_surface(dl, grid, dl.sky),
                                **kw)["Ed"][0]
        uniq, inv = np.unique(wl_fine, return_inverse=True)
        ed_f = ambient_light_kd(water, uniq, [dl.depth_m], above=daylight_above_surface(dl, uniq, dl.sky),
                                **kw)["Ed"][0]
        ratio = fld.diffuse / ed_g[:, None, None]
        r_f = np.stack([np.interp(uniq, grid, ratio[:, i, j]) for i in range(n_theta) for j in range(n_phi)],
                       axis=-1).reshape(uniq.size, n_theta, n_phi)
        diffuse = (r_f * ed_f[:, None, None])[inv]
        kd_g = water.kd_per_m(grid, dl.sun_zenith_deg)
        kd_f = water.kd_per_m(uniq, dl.sun_zenith_deg)
        k_diff = (np.interp(uniq, grid, fld.k_diffuse - kd_g) + kd_f)[inv]
        field_wl = grid
    # beam and attenuation at 1 nm (exact)
    from rigsim.daylight.field import _beam
    from rigsim.daylight.sky import sky_model
    from rigsim.daylight.underwater import daylight_above_surface

    uniq, inv = np.unique(wl_fine, return_inverse=True)
    sky_m = sky_model(dl.sky, dl.sun_zenith_deg)
    sun, c_u, kb_u = _beam(dl, water, uniq, sky_m, daylight_above_surface(dl, uniq, sky_m))
    beam, c, k_beam = sun.irradiance_normal[inv], np.maximum(c_u[inv], 1e-6), kb_u[inv]
    k_diff = np.clip(k_diff, -0.5 * c, 0.9 * c)
    y0 = float(scene.camera.position_m[1])
    y_surf = y0 + float(dl.depth_m)
    caustics = []
    waves = caustic_waves(dl)
    if waves is not None:
        from rigsim.daylight.waves import caustic_pattern

        from rigsim.render.camera import camera_frame

        fwd = camera_frame(scene.camera)[0]
        levels = {round(y0, 3)}
        for t in scene.targets:  # one pattern at each target's centre height (focus changes with depth)
            levels.add(round(y0 - t.distance_m if t.kind == "bottom" else y0 + t.distance_m * float(fwd[1]), 3))
        for y_lev in sorted(levels):
            depth = y_surf - y_lev
            if depth <= 0:
                continue
            pat = caustic_pattern(waves, sun_zenith_deg=dl.sun_zenith_deg, sun_azimuth_deg=dl.sun_azimuth_deg,
                                  depth_m=depth, extent_m=CAUSTIC_EXTENT_M, resolution=CAUSTIC_RESOLUTION,
                                  rays_per_cell=16, seed=seed)
            caustics.append((float(y_lev), mi.Float(pat.astype(np.float32).ravel()), CAUSTIC_RESOLUTION,
                             CAUSTIC_EXTENT_M))
    meta = {"model": dl.model, "depth_m": float(dl.depth_m), "sun_zenith_deg": float(dl.sun_zenith_deg),
            "sun_azimuth_deg": float(dl.sun_azimuth_deg), "sky": dl.sky, "seed": int(seed),
            "photons": int(dl.photons) if dl.model == "monte-carlo" else None,
            "field_wavelengths_nm": [float(x) for x in field_wl][:64], "n_theta": n_theta, "n_phi": n_phi,
            "waves": getattr(dl, "waves", "flat"), "field": fld.describe(),
            "transport": "field at depth + Duntley path radiance/attenuation (rigsim.render.daylight)"}
    f32 = lambda a: mi.Float(np.asarray(a, np.float32).ravel())  # noqa: E731
    tab = AmbientTables(fld, n_theta, n_phi, f32(diffuse), f32(beam), f32(c), f32(k_diff), f32(k_beam),
                        tuple(float(x) for x in sun.direction), float(np.radians(dl.sun_azimuth_deg)), y0, y_surf,
                        caustics, meta)
    if len(_CACHE) > 8:
        _CACHE.clear()
    _CACHE[key] = tab
    return tab
