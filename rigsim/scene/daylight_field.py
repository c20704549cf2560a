"""The daylight field of a scene as both engines use it: numpy tables and the transport formulas.

A scene with a :class:`~rigsim.scene.types.Daylight` is lit by the daylight field at the
camera's depth, :class:`~rigsim.daylight.field.AngularField` — the Monte Carlo meter
(``model="monte-carlo"``) or the Kd shortcut (``model="kd"``), as ``rigsim ambient`` — an
unscattered sun beam plus a tabulated diffuse radiance ``L_amb(θ, φ; λ)`` that already holds
every order of scattering in the water column.  :func:`scene_daylight` resamples it to 1 nm
over 360–830 nm (:class:`SceneDaylight`); the Monte Carlo renderer
(:mod:`rigsim.render.daylight`) only converts those tables to Dr.Jit, the fast engine
(:mod:`rigsim.preview`) reads them directly, and both apply the *same* transport formulas,
written once here over an array namespace (numpy, or Dr.Jit inside the renderer's kernels):

* :func:`path_radiance` — Duntley's law for the water between an eye and what it sees: a line
  of sight from ``x`` along ``v`` that meets an object at distance ``t`` collects
  ``L_amb(v; y_x) (1 − e^{−(c − K v_y) t})``, with ``L_amb(v; y) = L_amb(v; y₀) e^{K (y − y₀)}``
  (the exact sloped-path form for a field that varies as ``e^{K y}`` with height; for a
  horizontal line of sight the exponent is ``c t``); a line of sight that meets nothing
  (``t = ∞``) sees all of ``L_amb``.  So a black object's apparent contrast against the water
  behind it is ``−e^{−c t}`` along a horizontal line of sight whatever the field's angular
  shape (Duntley 1963; Zaneveld & Pegau 2003);
* :func:`height_factor` — the field's change over the scene, ``e^{K (y − y₀)}`` for the
  diffuse radiances (``K`` = :attr:`SceneDaylight.k_diffuse`) and the beam
  (``K`` = :attr:`SceneDaylight.k_beam` = ``c/μ_w``, exact).

``k_diffuse`` is clipped once, to ``[−0.5 c, 0.9 c]``, so that ``c − K v_y ≥ 0.1 c > 0`` for
every direction: a field that grows upward faster than the water attenuates would make
Duntley's path radiance grow without bound along a line of sight going up (the Monte Carlo
meter's local K can be noisy or, near the surface, negative).

Neglected (documented limits, the same in both engines): the scattering by the water of the
*change* an object makes to the field — its shadow volume in the water, the forward-scattered
halo of light reflected by a target — second order in ``b × object size``.

References
----------
Duntley, S. Q. (1963). Light in the sea. *J. Opt. Soc. Am.* 53(2), 214–233.
Mobley, C. D. (1994). *Light and Water*, §§ 5.10, 10 (the apparent contrast law).
Zaneveld, J. R. V. & Pegau, W. S. (2003). Robust underwater visibility parameter.
*Opt. Express* 11(23), 2997–3009.
"""

from __future__ import annotations

import dataclasses
import weakref
from dataclasses import dataclass

import numpy as np

from rigsim.errors import ConfigError
from rigsim.scene.types import Daylight, Scene
from rigsim.spectrum import MITSUBA_WAVELENGTH_RANGE_NM

__all__ = ["SceneDaylight", "Caustic", "scene_daylight", "daylight_from_options", "path_radiance", "height_factor",
           "FIELD_STEP_NM", "CAUSTIC_EXTENT_M", "CAUSTIC_RESOLUTION", "K_DIFFUSE_CLIP"]

#: Largest spacing of the wavelengths at which the Monte Carlo field is computed (nm).
FIELD_STEP_NM = 20.0
#: Side (m) and resolution (cells) of each caustic texture (periodic beyond).
CAUSTIC_EXTENT_M = 4.0
CAUSTIC_RESOLUTION = 128
#: Command-line option of each :class:`Daylight` field, for messages.
_OPTION_OF_FIELD = {"depth_m": "depth", "sun_zenith_deg": "sun-zenith", "model": "daylight-model"}
#: ``k_diffuse`` is clipped to ``[lo·c, hi·c]`` (see the module docstring).
K_DIFFUSE_CLIP = (-0.5, 0.9)
_LO, _HI = MITSUBA_WAVELENGTH_RANGE_NM
_N_WL = int(round(_HI - _LO)) + 1


def path_radiance(l_look, c, k, v_y, dy_origin, t, exp):
    """Duntley's path radiance along a line of sight (see the module docstring).

    Parameters
    ----------
    l_look
        ``L_amb(v; y₀)``: the diffuse radiance seen looking along ``v`` at the field's height
        (W·m⁻²·sr⁻¹·nm⁻¹).
    c, k
        Beam attenuation and the diffuse field's vertical K (1/m).
    v_y
        Vertical component of the unit line of sight (up positive).
    dy_origin
        Height of the line of sight's origin above the field's height, ``y_x − y₀`` (m).
    t
        Length of the line of sight to what it meets (m); ``inf`` if it meets nothing.
    exp
        The exponential of the array namespace (``numpy.exp``, ``drjit.exp``).
    """
    return l_look * exp(k * dy_origin) * (1.0 - exp(-(c - k * v_y) * t))


def height_factor(k, dy, exp):
    """``e^{K (y − y₀)}``: how a field quantity changes ``dy = y − y₀`` metres above the field's height."""
    return exp(k * dy)


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


@dataclass(frozen=True, eq=False)
class Caustic:
    """Relative sun-beam irradiance (mean 1) under a wavy surface at one height.

    Attributes
    ----------
    y_m
        Height (scene frame) the pattern was computed at (m).
    pattern
        (res, res) relative irradiance on the horizontal square of side ``extent_m`` centred
        on x = z = 0 (cell (i, j): z index i, x index j), periodic beyond.
    extent_m
        Side of the square (m).
    """

    y_m: float
    pattern: np.ndarray
    extent_m: float

    def at(self, p) -> np.ndarray:
        """Pattern value at points ``p`` (…, 3) (nearest cell, periodic)."""
        p = np.asarray(p, float)
        res = self.pattern.shape[0]
        u = p[..., 0] / self.extent_m + 0.5
        w = p[..., 2] / self.extent_m + 0.5
        iu = np.minimum(((u - np.floor(u)) * res).astype(np.int64), res - 1)
        iw = np.minimum(((w - np.floor(w)) * res).astype(np.int64), res - 1)
        return self.pattern[iw, iu]


#: Wavelengths per band at which :meth:`SceneDaylight.band_means` averages the tables.
_BAND_SAMPLES = 64


@dataclass(frozen=True, eq=False)
class SceneDaylight:
    """The daylight field of a scene, every 1 nm over 360–830 nm (see module docstring).

    Attributes
    ----------
    field
        The model run it came from (:class:`~rigsim.daylight.field.AngularField`, at its own
        wavelengths).
    wavelength_nm
        (471,) 360…830 nm.
    diffuse
        (471, n_theta, n_phi) diffuse radiance seen looking into each bin at ``y0``, W/(m² sr nm).
    theta_edges_rad, phi_edges_rad
        Bin edges: zenith angle from straight up; azimuth from the direction towards the sun.
    beam
        (471,) sun-beam irradiance normal to the beam at ``y0``, W/(m² nm).
    c, k_diffuse, k_beam
        (471,) beam attenuation and the vertical K of the diffuse field (clipped, see the module
        docstring) and of the beam (c/μ_w), 1/m.
    sun_direction
        Propagation direction of the refracted sun beam (scene frame, unit).
    sun_azimuth_rad
        The sun's azimuth (scene frame).
    y0, y_surface
        Height of the camera, where the field holds, and of the sea surface (m).
    caustics
        Sun-beam patterns at the heights of the camera and of each target (empty: flat sea).
    meta
        JSON-ready description of the field (model, depth, sky, photons, seed, …).
    """

    field: object
    wavelength_nm: np.ndarray
    diffuse: np.ndarray
    theta_edges_rad: np.ndarray
    phi_edges_rad: np.ndarray
    beam: np.ndarray
    c: np.ndarray
    k_diffuse: np.ndarray
    k_beam: np.ndarray
    sun_direction: tuple[float, float, float]
    sun_azimuth_rad: float
    y0: float
    y_surface: float
    caustics: tuple[Caustic, ...]
    meta: dict

    @property
    def n_theta(self) -> int:
        return self.diffuse.shape[1]

    @property
    def n_phi(self) -> int:
        return self.diffuse.shape[2]

    def band_index(self, wavelength_nm) -> np.ndarray:
        """Row of the tables for each wavelength: on the 1-nm grid the nearest node (the renderer's lookup,
        ``rint``); on a field of band means (:meth:`band_means`) the nearest band centre."""
        wl = np.asarray(wavelength_nm, float)
        nodes = np.asarray(self.wavelength_nm, float)
        if nodes.size == _N_WL and nodes[0] == _LO and nodes[-1] == _HI:
            return np.clip(np.rint(wl - _LO), 0, _N_WL - 1).astype(np.int64)
        return np.abs(wl[..., None] - nodes).argmin(axis=-1).astype(np.int64)

    def band_means(self, wavelength_nm, bandwidth_nm) -> "SceneDaylight":
        """This field whose table rows at the bands' centres hold the means over each band.

        The renderer draws wavelengths uniformly in each band and looks the 1-nm tables up at each
        (:meth:`band_index`), so its images hold band means; an engine that reads one row per band
        reads this.  Deep in turbid water the field falls steeply with wavelength in the red (Jerlov
        3C at 15 m: e^{−K_d z} with K_d rising by about 0.01 /m per nm), and the row at the centre is
        below the band's mean (it is convex): the fast engine's red chart patches were 8–10 % darker
        than Monte Carlo's.

        The result's tables have one row per band (its ``wavelength_nm`` are the band centres, looked up
        by :meth:`band_index` as the nearest centre).  Until 2026-12-04 the means were written into the
        1-nm rows at the centres, and bands 1 nm wide or narrower share rows (``rint`` of 580.5 and of 581.5 — banker's
        rounding — are 220 and 222, of 582.5 222 again): every other band read its neighbour's mean, and
        at 15 m in Jerlov I the fast engine's open water in 1-nm bands was 6 % below Monte Carlo's.
        """
        u = (np.arange(_BAND_SAMPLES) + 0.5) / _BAND_SAMPLES - 0.5
        wl = np.atleast_1d(np.asarray(wavelength_nm, float))
        bw = np.broadcast_to(np.asarray(bandwidth_nm, float), wl.shape)
        rows = self.band_index(wl[:, None] + bw[:, None] * u[None, :])  # (B, n)
        out = {name: np.asarray(getattr(self, name))[rows].mean(axis=1)
               for name in ("diffuse", "beam", "c", "k_diffuse", "k_beam")}
        return dataclasses.replace(self, wavelength_nm=wl.copy(), **out)

    def radiance(self, view_dirs, wavelength_nm) -> np.ndarray:
        """Diffuse radiance seen looking along ``view_dirs`` (…, 3) at ``y0``: (…, n_wl).

        Bilinear between bin centres in (θ, φ), ends clamped (the renderer's lookup).
        """
        fld = dataclasses.replace(self.field, diffuse=self.diffuse[self.band_index(wavelength_nm)],
                                  wavelength_nm=np.atleast_1d(np.asarray(wavelength_nm, float)))
        return fld.radiance(view_dirs, interpolate=True)

    def caustic(self, p) -> np.ndarray:
        """Relative beam irradiance at points ``p`` (…, 3): the nearest level's pattern (1 without waves)."""
        p = np.asarray(p, float)
        if not self.caustics:
            return np.ones(p.shape[:-1])
        ys = np.array([c.y_m for c in self.caustics])
        nearest = np.argmin(np.abs(p[..., 1:2] - ys), axis=-1)
        out = np.ones(p.shape[:-1])
        for i, c in enumerate(self.caustics):
            m = nearest == i
            if np.any(m):
                out[m] = c.at(p[m])
        return out


def _field_key(scene: Scene, lo: float, hi: float, seed: int) -> tuple:
    return (dataclasses.astuple(scene.daylight), lo, hi, int(seed), float(scene.camera.position_m[1]))


def _caustic_key(scene: Scene) -> tuple:
    return (tuple(float(x) for x in scene.camera.frame()[2]), tuple((t.kind, t.distance_m) for t in scene.targets))


#: water → {key: SceneDaylight}, at most _PER_WATER entries each, kept while the water lives.  The
#: field does not depend on the targets (only the caustic patterns, computed at their heights, do):
#: a sweep over distances reuses one field.
_CACHE: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
_PER_WATER = 6


def _field_grid(lo: float, hi: float, wl_range) -> np.ndarray:
    lo_c, hi_c = max(lo, wl_range[0]), min(hi, wl_range[1])
    n = max(2, int(np.ceil((hi_c - lo_c) / FIELD_STEP_NM)) + 1)
    return np.linspace(lo_c, hi_c, n)


def _caustic_waves(daylight: Daylight):
    from rigsim.daylight.waves import sine_waves, waves_PiersonMoskowitz1964

    kind = daylight.waves
    if kind == "flat":
        return None
    if kind == "sines":
        return sine_waves(daylight.wave_amplitude_m, daylight.wave_length_m, daylight.wave_direction_deg)
    if kind == "pierson-moskowitz":
        return waves_PiersonMoskowitz1964(daylight.wind_speed_m_s, wind_direction_deg=daylight.wave_direction_deg)
    raise ConfigError(f"unknown waves {kind!r}", field="daylight.waves", allowed="flat, sines, pierson-moskowitz")


def scene_daylight(scene: Scene, band_lo_nm: float = _LO, band_hi_nm: float = _HI, *,
                   seed: int | None = None) -> SceneDaylight:
    """The daylight field of ``scene`` for bands spanning ``band_lo_nm … band_hi_nm`` (see module docstring).

    Parameters
    ----------
    scene
        A scene with ``daylight`` and ``water``.
    band_lo_nm, band_hi_nm
        The rendered wavelength range (nm); the tables hold their end values beyond it.
    seed
        Seed of the Monte Carlo field (``model="monte-carlo"``) and of the caustics; None: the
        scene's own, :attr:`Daylight.field_seed` (an input of the scene, so that every render and
        the fast engine see the same field).

    Returns
    -------
    SceneDaylight
        Kept (while the water object lives) for its last few (daylight, camera, targets).
    """
    from rigsim.daylight.field import DEFAULT_N_PHI, DEFAULT_N_THETA, _beam, angular_field
    from rigsim.daylight.shortcut import ambient_light_kd
    from rigsim.daylight.sky import sky_model
    from rigsim.daylight.underwater import daylight_above_surface

    if scene.daylight is None:
        raise ConfigError("the scene has no daylight", field="daylight")
    if scene.water is None:
        raise ConfigError("daylight at depth needs water (the scene has none)", field="daylight")
    seed = scene.daylight.field_seed if seed is None else int(seed)
    fkey = _field_key(scene, float(band_lo_nm), float(band_hi_nm), seed)
    per_water = _CACHE.setdefault(scene.water, {})
    ckey = _caustic_key(scene) if scene.daylight.waves != "flat" else None
    hit = per_water.get(fkey)
    if hit is not None:
        if ckey is None or hit.caustics_key == ckey:
            return hit.daylight
        out = dataclasses.replace(hit.daylight, caustics=_caustics(scene, seed))
        per_water[fkey] = _Cached(out, ckey)
        return out
    dl, water = scene.daylight, scene.water
    wr = water.wavelength_range_nm
    nodes = np.linspace(_LO, _HI, _N_WL)
    wl_fine = np.clip(nodes, max(band_lo_nm, wr[0]), min(band_hi_nm, wr[1]))  # ends held
    uniq, inv = np.unique(wl_fine, return_inverse=True)
    n_theta, n_phi = DEFAULT_N_THETA, DEFAULT_N_PHI
    if dl.model == "kd":
        fld = angular_field(dl, water, uniq, seed=seed, n_theta=n_theta, n_phi=n_phi)
        diffuse = fld.diffuse[inv]
        k_diff = fld.k_diffuse[inv]
        field_wl = uniq
    else:
        grid = _field_grid(band_lo_nm, band_hi_nm, wr)
        fld = angular_field(dl, water, grid, seed=seed, n_theta=n_theta, n_phi=n_phi)
        # resampled as its ratio to the Kd shortcut's Ed (smooth in λ), which carries the fine
        # spectral structure (solar lines, water absorption) at 1 nm
        kw = dict(sun_zenith_deg=dl.sun_zenith_deg, sky=dl.sky)
        ed_g = ambient_light_kd(water, grid, [dl.depth_m], above=daylight_above_surface(dl, grid, dl.sky),
                                **kw)["Ed"][0]
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
    sky_m = sky_model(dl.sky, dl.sun_zenith_deg)
    sun, c_u, kb_u = _beam(dl, water, uniq, sky_m, daylight_above_surface(dl, uniq, sky_m))
    beam, c, k_beam = sun.irradiance_normal[inv], np.maximum(c_u[inv], 1e-6), kb_u[inv]
    k_diff = np.clip(k_diff, K_DIFFUSE_CLIP[0] * c, K_DIFFUSE_CLIP[1] * c)
    y0 = float(scene.camera.position_m[1])
    y_surf = y0 + float(dl.depth_m)
    caustics = _caustics(scene, seed)
    meta = {"model": dl.model, "depth_m": float(dl.depth_m), "sun_zenith_deg": float(dl.sun_zenith_deg),
            "sun_azimuth_deg": float(dl.sun_azimuth_deg), "sky": dl.sky, "seed": int(seed),
            "photons": int(dl.photons) if dl.model == "monte-carlo" else None,
            "field_wavelengths_nm": [float(x) for x in field_wl][:64], "n_theta": n_theta, "n_phi": n_phi,
            "waves": dl.waves, "field": fld.describe(),
            "transport": "field at depth + Duntley path radiance/attenuation (rigsim.scene.daylight_field)"}
    out = SceneDaylight(fld, nodes, diffuse, np.asarray(fld.theta_edges_rad), np.asarray(fld.phi_edges_rad),
                        beam, c, k_diff, k_beam, tuple(float(x) for x in sun.direction),
                        float(np.radians(dl.sun_azimuth_deg)), y0, y_surf, caustics, meta)
    if len(per_water) >= _PER_WATER:
        per_water.pop(next(iter(per_water)))
    per_water[fkey] = _Cached(out, ckey)
    return out


@dataclass(frozen=True, eq=False)
class _Cached:
    daylight: SceneDaylight
    caustics_key: tuple | None


def _caustics(scene: Scene, seed: int) -> tuple[Caustic, ...]:
    """The sun beam's caustic patterns at the camera's and each target's height (none for a flat sea)."""
    dl = scene.daylight
    waves = _caustic_waves(dl)
    if waves is None:
        return ()
    from rigsim.daylight.waves import caustic_pattern

    y0 = float(scene.camera.position_m[1])
    y_surf = y0 + float(dl.depth_m)
    fwd = scene.camera.frame()[2]
    levels = {round(y0, 3)}
    for t in scene.targets:  # one pattern at each target's centre height (focus changes with depth)
        levels.add(round(y0 - t.distance_m if t.kind in ("bottom", "seabed") else y0 + t.distance_m * float(fwd[1]), 3))
    out = []
    for y_lev in sorted(levels):
        depth = y_surf - y_lev
        if depth <= 0:
            continue
        pat = caustic_pattern(waves, sun_zenith_deg=dl.sun_zenith_deg, sun_azimuth_deg=dl.sun_azimuth_deg,
                              depth_m=depth, extent_m=CAUSTIC_EXTENT_M, resolution=CAUSTIC_RESOLUTION,
                              rays_per_cell=16, seed=seed)
        out.append(Caustic(float(y_lev), np.asarray(pat, float), CAUSTIC_EXTENT_M))
    return tuple(out)
