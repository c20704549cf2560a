"""Discrete particles (marine snow) in the fast engine: each particle an analytic splat.

The particles are the scene's own (:func:`rigsim.scene.particles.scene_particles`, the same the
renderer draws as spheres).  For each particle of diameter ``d`` at distance ``r`` from the pupil:

* **Lighting** — each light gives the irradiance ``I(λ) f(θ) / r_l² · e^{−κ r_l}`` on the beam's
  cross-section (``f`` the beam pattern, ``r_l`` the distance from the light, ``κ = c − b F`` the
  attenuation with the small-angle forward-scattered light kept in the beam, as the analytic image
  model's target lighting before its blur; :mod:`rigsim.preview.model`); daylight gives the sun beam
  (× the caustic pattern) and the diffuse field, each × its height factor (the scene's daylight
  field, :mod:`rigsim.scene.daylight_field`).  No shadows from targets.
* **Scattering towards the camera** — a diffuse sphere: ``I = E · π d²/4 · ρ · p(θ)`` with the
  Lambert-sphere phase function at the angle between the light's path and the line of sight
  (:func:`rigsim.water.particles.lambert_sphere_intensity`); for the diffuse daylight, the phase
  function integrated over the field's bins for the line of sight of each part of the image; for
  the lights' multiply scattered light (where the image has it, :mod:`rigsim.preview.multiple`), the
  tracer's ``∫ L(ω) p(ω) dω`` in the particle's cell of the water, its flights weighted by that phase
  function towards the camera (:attr:`~rigsim.preview.multiple.MultipleScattering.fluence`).
* **To the camera** — ``I e^{−κ_speck s} / r²`` at the entrance pupil (``s`` the water path from the
  port; the light scattered by less than :data:`rigsim.preview.model.PARTICLE_SPECK_DEG` kept in the
  speck; the rest of the forward-scattered light, ``e^{−κ s} − e^{−κ_speck s}``, a wide glow about it:
  a Gaussian of the RMS angle of the phase function between those angles, light spread beyond the
  frame lost), spread uniformly over the particle's image: a disc whose angular radius combines the particle's own (``d / 2r``) and the
  defocus disc's (:func:`rigsim.scene.optics.defocus_blur_rad`) in quadrature, laid out in the
  image through the local Jacobian of :func:`rigsim.scene.optics.project_points` (the port's
  distortion included; :func:`rigsim.scene.particles.particle_footprints`) and sampled by a fixed
  spiral of points (more for larger discs); each point's share is radiance ``÷`` its pixel's solid
  angle (:func:`rigsim.scene.optics.cell_solid_angles`).
* **Occlusion** — a particle is hidden where a target is nearer than it (the pixel's range); it
  hides what lies behind it in proportion to the solid angle it covers, spread like its light
  (``coverage``, and per point of its image the fraction it hides: the fast engine takes that of the
  pixel's light less the lights' veil in front of the particle,
  :meth:`rigsim.preview.model._Group.veil_in_front`; the daylight path radiance in front of it is
  hidden too, a small excess).

The result: the particles' radiance (continuous lights and daylight) and flash layers, the
coverage, and ``particle_id`` — the instance mask of the ground truth
(:func:`rigsim.scene.particles.particle_id_image`, geometry only, the same in both engines).
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from rigsim.preview.backscatter import beam_angle
from rigsim.scene.optics import cell_solid_angles, port_reach_m
from rigsim.scene.particles import ParticleSet, footprint_samples, particle_footprints, particle_id_image
from rigsim.scene.types import Scene, unit
from rigsim.spectrum import band_average
from rigsim.water.particles import lambert_sphere_phase

__all__ = ["ParticleLayers", "particle_layers"]
#: Film grid (per side) on which the diffuse daylight's phase integral is tabulated.
_DAY_GRID = 9
#: Images whose particle geometry (footprints, their samples, the particle-id image) is kept: it depends
#: on the camera, the particles and the targets' ranges but not on the lights, so a search that moves
#: only the lights (:mod:`rigsim.optimise`, the rig designer) computes it once (0.3 of 0.65 s per
#: 96×64 image of coastal marine snow).
_GEOMETRY_CACHE_SIZE = 2
_GEOMETRY: OrderedDict = OrderedDict()
_GEOMETRY_LOCK = threading.Lock()


@dataclass(frozen=True, eq=False)
class _Geometry:
    fp: object
    samples: tuple
    particle_id: np.ndarray


def _digest(*arrays) -> bytes:
    h = hashlib.blake2b(digest_size=16)
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str((a.dtype, a.shape)).encode())
        h.update(a.tobytes())
    return h.digest()


def _geometry(scene: Scene, ps: ParticleSet, width: int, height: int, range_m: np.ndarray) -> _Geometry:
    """The lights-independent geometry of the particles' image (cached, :data:`_GEOMETRY_CACHE_SIZE`)."""
    key = (scene.camera, int(width), int(height),
           _digest(np.asarray(ps.position_m, float), np.asarray(ps.diameter_m, float), np.asarray(range_m)))
    with _GEOMETRY_LOCK:
        hit = _GEOMETRY.get(key)
        if hit is not None:
            _GEOMETRY.move_to_end(key)
            return hit
    fp = particle_footprints(scene, ps, width, height)
    geo = _Geometry(fp=fp, samples=tuple(footprint_samples(fp, width, height, range_m)),
                    particle_id=particle_id_image(scene, ps, width, height, range_m))
    with _GEOMETRY_LOCK:
        _GEOMETRY[key] = geo
        while len(_GEOMETRY) > _GEOMETRY_CACHE_SIZE:
            _GEOMETRY.popitem(last=False)
    return geo


@dataclass(frozen=True, eq=False)
class ParticleLayers:
    """The particles' part of an image (see the module docstring).

    Attributes
    ----------
    radiance, flash
        (rows, cols, bands) float32: continuous lights + daylight, W/(m² sr nm); strobes, J/(m² sr nm).
    coverage
        (rows, cols) float32: fraction of each pixel's view the particles hide (0 … 1).
    hiders
        ``(pixel, range_m, share)``: for every point of the particles' images, its flat pixel index, its
        particle's distance from the pupil and the fraction of that pixel's view it hides (they sum to
        ``coverage``): what is in front of each particle stays in view.
    particle_id
        (rows, cols) int32: :func:`rigsim.scene.particles.particle_id_image` (the nearest particle whose
        image reaches into the pixel; 0: none).
    visible
        Number of particles that put light into the image.
    """

    radiance: np.ndarray
    flash: np.ndarray
    coverage: np.ndarray
    hiders: tuple
    particle_id: np.ndarray
    visible: int


def _diffuse_phase_table(day, diffuse: np.ndarray, cam, n_out: float) -> np.ndarray:
    """(g, g, B): ``π ∫ L p(θ) dΩ`` over the diffuse field (``diffuse`` (B, T, P) at the bands) for the
    line of sight of each cell of a film grid: a particle's intensity is this × ``d²/4 · ρ``."""
    from rigsim.scene.optics import camera_rays

    g = _DAY_GRID
    t = (np.arange(g) + 0.5) / g
    PX, PY = np.meshgrid(t, t)
    _, d = camera_rays(cam, PX, PY, n_outside=n_out)  # camera → water; towards the camera: −d
    dirs, dw = day.field.bin_directions(3)  # (T, P, S, 3) looking into each bin: light travels along −dir
    out = np.empty((g, g, diffuse.shape[0]))
    for i in range(g):
        for j in range(g):
            cos_s = np.einsum("tpsk,k->tps", dirs, d[i, j])  # (−dir) · (−d)
            pbin = lambert_sphere_phase(cos_s).sum(axis=-1) * dw  # (T, P)
            out[i, j] = np.pi * np.einsum("btp,tp->b", diffuse, pbin)
    return out


#: Pixels per cell of the grid on which the particles' glow is spread.
_GLOW_CELL_PX = 8


def _glow(scene, fp, idx, at_pupil: dict, glow_rad: float, width: int, height: int, n_outside: float) -> dict:
    """The particles' forward-scattered glow (``at_pupil``: irradiance at the pupil per particle, (n, B) per
    light group) as radiance images (rows, cols, B): each particle's on a coarse grid at its image
    position, spread by a Gaussian of ``glow_rad`` per axis-pair (σ = glow_rad/√2 each), what leaves the frame
    lost, then brought to every pixel (radiance = irradiance / solid angle of the coarse cell)."""
    import cv2
    from scipy.ndimage import gaussian_filter

    gc, gr = max(1, int(np.ceil(width / _GLOW_CELL_PX))), max(1, int(np.ceil(height / _GLOW_CELL_PX)))
    om = cell_solid_angles(scene.camera, gc, gr, n_outside=n_outside)  # (gr, gc) sr
    pitch = float(np.sqrt(np.median(om)))  # rad per coarse cell
    ic = np.clip((fp.uv[idx, 0] / width * gc).astype(np.int64), 0, gc - 1)
    ir = np.clip((fp.uv[idx, 1] / height * gr).astype(np.int64), 0, gr - 1)
    inside = (fp.uv[idx, 0] >= 0) & (fp.uv[idx, 0] < width) & (fp.uv[idx, 1] >= 0) & (fp.uv[idx, 1] < height)
    cell = (ir * gc + ic)[inside]
    sig = glow_rad / np.sqrt(2.0) / pitch
    out = {}
    for key, val in at_pupil.items():
        B = val.shape[1]
        g = np.stack([np.bincount(cell, weights=val[inside, j], minlength=gr * gc) for j in range(B)], -1)
        g = g.reshape(gr, gc, B)
        g = gaussian_filter(g, (sig, sig, 0), mode="constant") / om[..., None]  # energy beyond the frame is lost
        out[key] = cv2.resize(g.astype(np.float32), (width, height), interpolation=cv2.INTER_LINEAR).reshape(
            height, width, B) if (gr, gc) != (height, width) else g.astype(np.float32)
    return out


def particle_layers(scene: Scene, ps: ParticleSet, *, width: int, height: int, wl: np.ndarray, bw: np.ndarray,
                    kappa: np.ndarray, range_m: np.ndarray, n_outside: float, daylight=None,
                    multiple: dict | None = None, kappa_speck: np.ndarray | None = None,
                    glow_rad: float = 0.0) -> ParticleLayers:
    """The particles' layers of a ``width × height`` image at bands ``wl`` (nm, widths ``bw``).

    Parameters
    ----------
    kappa
        (B,) attenuation with the forward-scattered light kept (1/m) at the band centres (``c`` without
        forward scattering): the lights' way to the particles.
    kappa_speck, glow_rad
        On the way to the camera the light scattered by less than the speck's angle stays in the speck:
        ``e^{−κ_speck s}``; the rest of the forward-scattered light (``e^{−κ s} − e^{−κ_speck s}``) is a glow
        about it, a Gaussian of ``glow_rad`` (rad, the RMS angle of that part of the phase function; light
        spread beyond the frame leaves the image).  None: all of ``e^{−κ s}`` in the speck.
    range_m
        (rows, cols) range of the targets (inf: open water) from the pupil.
    daylight
        The scene's :class:`~rigsim.scene.daylight_field.SceneDaylight` as band means at ``wl``, or None.
    multiple
        ``{"continuous" | "strobe": MultipleScattering}`` of the light groups whose multiply scattered
        light the image has (:mod:`rigsim.preview.multiple`): its fluence lights the particles too.
    """
    B = len(wl)
    shape = (height, width, B)
    cam = scene.camera
    pg = _geometry(scene, ps, width, height, range_m)
    fp = pg.fp
    P = np.asarray(ps.position_m, float)
    D = np.asarray(ps.diameter_m, float)
    rng, to_cam = fp.range_m, fp.to_camera
    s_water = np.maximum(rng - port_reach_m(cam), 0.0)
    rho = ps.reflectance(wl)  # (B,)

    # --- intensity towards the camera (n, B) of the imaged particles, per light group
    idx = np.flatnonzero(fp.imaged)
    inten = {"continuous": np.zeros((len(idx), B)), "strobe": np.zeros((len(idx), B))}
    area = np.pi / 4.0 * D[idx] ** 2
    for light in scene.lights:
        if not np.any(np.asarray(light.axial_intensity, float) > 0):
            continue
        I_b = band_average(np.asarray(light.wavelength_nm, float), np.asarray(light.axial_intensity, float),
                           wl - bw / 2, wl + bw / 2)
        v = P[idx] - np.asarray(light.position_m, float)
        r_l = np.linalg.norm(v, axis=1)
        vh = v / np.maximum(r_l, 1e-12)[:, None]
        f = light.beam.relative_intensity(beam_angle(vh, unit(light.aim)))
        E = (f / np.maximum(r_l, 1e-9) ** 2)[:, None] * I_b[None, :] * np.exp(-np.outer(r_l, kappa))
        p = lambert_sphere_phase(np.sum(vh * to_cam[idx], axis=1))
        inten[light.kind] += E * (area * p)[:, None] * rho[None, :]
    for group, ms in (multiple or {}).items():  # the multiply scattered light
        if idx.size and getattr(ms, "fluence", None) is not None:
            phi = ms.fluence_at(fp.uv[idx, 0], fp.uv[idx, 1], rng[idx])  # (n, B): ∫ L p_L dω
            inten[group] += phi * area[:, None] * rho[None, :]
    if daylight is not None and idx.size:
        from rigsim.scene.daylight_field import height_factor

        dy = (P[idx, 1] - daylight.y0)[:, None]
        bi = daylight.band_index(wl)
        sun = np.asarray(daylight.sun_direction, float)
        e_sun = daylight.caustic(P[idx])[:, None] * daylight.beam[bi][None, :] * height_factor(daylight.k_beam[bi], dy,
                                                                                               np.exp)
        inten["continuous"] += e_sun * (area * lambert_sphere_phase(to_cam[idx] @ sun))[:, None] * rho[None, :]
        tab = _diffuse_phase_table(daylight, daylight.diffuse[bi], cam, n_outside)  # (g, g, B)
        g = tab.shape[0]
        gi = np.clip((fp.uv[idx, 1] / height * g).astype(int), 0, g - 1)
        gj = np.clip((fp.uv[idx, 0] / width * g).astype(int), 0, g - 1)
        inten["continuous"] += tab[gi, gj] * (area / np.pi)[:, None] * rho[None, :] \
            * height_factor(daylight.k_diffuse[bi], dy, np.exp)

    # --- to the pupil (irradiance there, W/(m² nm)), and the splats
    at_pupil = {}
    pos = np.full(len(P), -1)
    pos[idx] = np.arange(len(idx))
    k_sp = kappa if kappa_speck is None else kappa_speck
    T = np.exp(-np.outer(s_water[idx], k_sp)) / (rng[idx] ** 2)[:, None]
    glow_T = (np.exp(-np.outer(s_water[idx], kappa)) / (rng[idx] ** 2)[:, None] - T) if kappa_speck is not None else None
    for k, v in inten.items():
        at_pupil[k] = v * T
    solid = cell_solid_angles(cam, width, height, n_outside=n_outside).ravel()  # sr per pixel
    geo = np.zeros(len(P))
    geo[idx] = area / rng[idx] ** 2  # solid angle each particle hides (sr)
    out = {k: np.zeros(height * width * B) for k in inten}
    cover = np.zeros(height * width)
    hid_pix, hid_r, hid_w = [], [], []
    seen = np.zeros(len(P), bool)
    samples = list(pg.samples)
    for who, pix, share in samples:
        seen[who] = True
        hid_pix.append(pix)
        hid_r.append(rng[who])
        hid_w.append(geo[who] * (share / solid[pix]))  # (share / solid: radiance per unit irradiance at the pupil)
    if samples:  # every sample at once, binned over the pixels the particles cover (not the whole image)
        who = np.concatenate([s[0] for s in samples])
        pix = np.concatenate(hid_pix)
        w = np.concatenate([share / solid[p] for _, p, share in samples])
        upix, inv = np.unique(pix, return_inverse=True)
        bins = (inv[:, None] * B + np.arange(B)).ravel()
        for key, val in at_pupil.items():
            if np.any(val):
                acc = np.bincount(bins, weights=(val[pos[who]] * w[:, None]).ravel(), minlength=len(upix) * B)
                out[key].reshape(-1, B)[upix] += acc.reshape(-1, B)
        cover += np.bincount(pix, weights=geo[who] * w, minlength=height * width)
    if glow_T is not None and glow_rad > 0 and idx.size:
        glow = _glow(scene, fp, idx, {k: v * glow_T for k, v in inten.items()}, glow_rad, width, height, n_outside)
        for k in out:
            out[k] += glow[k].reshape(-1)
    return ParticleLayers(radiance=out["continuous"].reshape(shape).astype(np.float32),
                          flash=out["strobe"].reshape(shape).astype(np.float32),
                          coverage=np.clip(cover, 0.0, 1.0).reshape(height, width).astype(np.float32),
                          hiders=tuple(np.concatenate(x) if x else np.zeros(0) for x in (hid_pix, hid_r, hid_w)),
                          particle_id=pg.particle_id.copy(), visible=int(seen.sum()))
