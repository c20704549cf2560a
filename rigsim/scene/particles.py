"""The particles of a scene: a seeded Poisson process in the part of the water the camera sees.

A water with a :class:`~rigsim.water.particles.ParticleField` (marine snow) gets its particles
placed here, once per scene, and both engines draw these same particles (the renderer as spheres,
:mod:`rigsim.render.mitsuba_scene`; the fast engine as splats, :mod:`rigsim.preview.particles`):
the same scene and ``Scene.particle_seed`` give the same particles, whatever the render's seed.

Where particles are placed
--------------------------
Only where they can show: in the camera's field of view in the water (a frustum bounding the chief
rays of the film's edges, widened by the largest particle and its defocus disc), outside the port
and the housing, from the port out to :func:`placement_depth_m`.  That depth is where a particle
lit by the rig's lights is 10⁻³ as bright as one at :data:`REFERENCE_DEPTH_M` (the lights' inverse
square and the water's attenuation on both legs, in the clearest visible band) or, with daylight
only, where the water between it and the camera leaves 1 % of its light; at most
:data:`MAX_DEPTH_M`.  If that volume would hold more than :data:`MAX_PARTICLES` particles on
average, the depth is reduced until it holds that many (``ParticleSet.truncated``; the report says
so).  Within the volume the process is a homogeneous Poisson process: the count is Poisson with
mean ``N·V``, the points uniform, the diameters drawn independently from the field's size
distribution (:meth:`~rigsim.water.particles.ParticleField.diameters_mm`).
"""

from __future__ import annotations

import functools
import hashlib
from dataclasses import dataclass

import numpy as np

from rigsim.scene.optics import (aperture_diameter_water_m, camera_rays, defocus_blur_rad, outside_index,
                                 port_reach_m, project_points)
from rigsim.scene.types import Scene
from rigsim.water.particles import ParticleField

__all__ = ["ParticleSet", "scene_particles", "placement_depth_m", "placement_frustum", "MAX_PARTICLES",
           "MAX_DEPTH_M", "REFERENCE_DEPTH_M", "particle_field_of", "Footprints", "particle_footprints",
           "footprint_samples", "particle_id_image", "SPLAT_POINTS_MAX", "length_inside", "Frustum"]

#: At most this many particles on average in a scene's placement volume.
MAX_PARTICLES = 300_000
#: Particles are placed at most this deep (m).
MAX_DEPTH_M = 30.0
#: Depth (m) of the particles the far limit is measured against (lit ones just beyond the port).
REFERENCE_DEPTH_M = 0.3
#: A lit particle is left out where it is below this fraction of one at REFERENCE_DEPTH_M.
LIT_FRACTION = 1e-3
#: With daylight only: left out where the water leaves less than this fraction of its light.
DAYLIGHT_FRACTION = 1e-2
#: Wavelengths (nm) over which the clearest band is looked for.
_VISIBLE_NM = np.arange(400.0, 701.0, 10.0)


def particle_field_of(scene: Scene) -> ParticleField | None:
    """The scene's particle field (its water's), or None."""
    return getattr(scene.water, "particles", None) if scene.water is not None else None


@dataclass(frozen=True, eq=False)
class ParticleSet:
    """Particles placed in a scene.

    Attributes
    ----------
    position_m
        (N, 3) centres in world coordinates (m).
    diameter_m
        (N,) diameters (m).
    field
        The particle field they were drawn from (reflectance, size law).
    seed
        ``Scene.particle_seed``.
    depth_range_m
        Nearest and farthest depth ahead of the pupil of the placement volume (m).
    volume_m3, expected
        Volume of the placement region (m³) and the mean count ``N·V`` of the Poisson process.
    truncated
        True if :data:`MAX_PARTICLES` shortened the placement depth.
    """

    position_m: np.ndarray
    diameter_m: np.ndarray
    field: ParticleField
    seed: int
    depth_range_m: tuple[float, float]
    volume_m3: float
    expected: float
    truncated: bool

    def __len__(self) -> int:
        return int(self.diameter_m.shape[0])

    def reflectance(self, wavelength_nm) -> np.ndarray:
        """ρ(λ) of every particle (the field's; (bands,))."""
        return self.field.reflectance_at(wavelength_nm)

    def describe(self) -> dict:
        return {"count": len(self), "expected": self.expected, "seed": self.seed,
                "depth_range_m": list(self.depth_range_m), "volume_m3": self.volume_m3, "truncated": self.truncated,
                "field": self.field.describe()}


@dataclass(frozen=True)
class Frustum:
    """The placement region in camera coordinates: ``|x| <= x0 + tx z``, ``|y| <= y0 + ty z``, ``z0 <= z <= z1``."""

    x0: float
    tx: float
    y0: float
    ty: float
    z0: float
    z1: float

    def area(self, z):
        return 4.0 * (self.x0 + self.tx * z) * (self.y0 + self.ty * z)

    def volume(self, z1: float | None = None) -> float:
        """∫ area dz from z0 to z1 (exact: the area is quadratic in z)."""
        z1 = self.z1 if z1 is None else z1
        a, b = self.x0, self.tx
        c, d = self.y0, self.ty

        def prim(z):
            return 4.0 * (a * c * z + (a * d + b * c) * z * z / 2.0 + b * d * z ** 3 / 3.0)

        return float(prim(z1) - prim(self.z0))


def length_inside(fr: Frustum, camera, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Length (m) of the segments ``a → b`` ((…, 3) world points) inside the frustum ``fr`` of ``camera``
    (its six planes are linear in the segment's parameter: clip it to each)."""
    right, up, fwd = camera.frame()
    pupil = np.asarray(camera.position_m, float)
    A, Bp = np.asarray(a, float) - pupil, np.asarray(b, float) - pupil
    ax, ay, az = A @ right, A @ up, A @ fwd
    dx, dy, dz = Bp @ right - ax, Bp @ up - ay, Bp @ fwd - az
    lo = np.zeros(np.broadcast(ax, dx).shape)
    hi = np.ones_like(lo)
    # each constraint p + q t <= 0
    for p_, q_ in ((fr.z0 - az, -dz), (az - fr.z1, dz),
                   (ax - fr.x0 - fr.tx * az, dx - fr.tx * dz), (-ax - fr.x0 - fr.tx * az, -dx - fr.tx * dz),
                   (ay - fr.y0 - fr.ty * az, dy - fr.ty * dz), (-ay - fr.y0 - fr.ty * az, -dy - fr.ty * dz)):
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -p_ / q_
        lo = np.where(q_ < 0, np.maximum(lo, t), lo)
        hi = np.where(q_ > 0, np.minimum(hi, t), hi)
        lo = np.where((q_ == 0) & (p_ > 0), 1.0, lo)  # parallel and outside
    return np.maximum(hi - lo, 0.0) * np.linalg.norm(Bp - A, axis=-1)


def placement_frustum(scene: Scene, field: ParticleField, z1: float) -> Frustum:
    """The frustum bounding the film edges' chief rays, widened by the largest particle's radius and
    the largest defocus disc there (camera coordinates, depth ``z`` along the optical axis)."""
    cam = scene.camera
    n_out = outside_index(scene)
    t = np.linspace(0.0, 1.0, 33)
    px = np.concatenate([t, t, np.zeros_like(t), np.ones_like(t)])
    py = np.concatenate([np.zeros_like(t), np.ones_like(t), t, t])
    o, d = camera_rays(cam, px, py, n_outside=n_out)
    right, up, fwd = cam.frame()
    rel = o - np.asarray(cam.position_m, float)
    oz, dz = rel @ fwd, d @ fwd
    sx, sy = (d @ right) / dz, (d @ up) / dz  # slopes
    ix, iy = rel @ right - oz * sx, rel @ up - oz * sy  # where each ray line crosses depth 0
    tx, ty = float(np.max(np.abs(sx))), float(np.max(np.abs(sy)))
    x0, y0 = float(np.max(np.abs(ix))), float(np.max(np.abs(iy)))
    # widen by the largest particle and its defocus disc: half the aperture at the pupil, growing
    # as |z/s_f - 1| (the disc's linear radius at depth z); bounded linearly by 1/2 D (1 + z/s_f)
    r_p = 0.5e-3 * field.d_max_mm
    half_ap = 0.5 * aperture_diameter_water_m(cam) if cam.focus_distance_m is not None else 0.0
    grow = half_ap / float(cam.focus_distance_m) if cam.focus_distance_m is not None else 0.0
    z0 = port_reach_m(cam) + r_p
    return Frustum(x0=x0 + r_p + half_ap, tx=tx + grow, y0=y0 + r_p + half_ap, ty=ty + grow, z0=z0, z1=max(z1, z0))


def _clearest_c(scene: Scene) -> float:
    wl = _VISIBLE_NM
    lo, hi = scene.water.wavelength_range_nm
    wl = wl[(wl >= lo) & (wl <= hi)]
    if wl.size == 0:
        wl = np.array([0.5 * (lo + hi)])
    return float(np.min(scene.water.c_per_m(wl)))


def placement_depth_m(scene: Scene) -> float:
    """Depth (m) beyond which a scene's particles cannot show (module docstring), before the count cap."""
    c = max(_clearest_c(scene), 1e-6)
    if scene.lights:
        z_ref = max(REFERENCE_DEPTH_M, port_reach_m(scene.camera) + 0.05)

        def rel(z):  # brightness of a lit particle at depth z relative to one at z_ref
            return (z_ref / z) ** 4 * np.exp(-2.0 * c * (z - z_ref))

        lo, hi = z_ref, MAX_DEPTH_M
        if rel(hi) >= LIT_FRACTION:
            return MAX_DEPTH_M
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if rel(mid) >= LIT_FRACTION else (lo, mid)
        return float(hi)
    return float(min(MAX_DEPTH_M, -np.log(DAYLIGHT_FRACTION) / c))


def _rng(scene: Scene) -> np.random.Generator:
    h = hashlib.blake2b(f"rigsim-particles:{int(scene.particle_seed)}".encode(), digest_size=8).digest()
    return np.random.default_rng(int.from_bytes(h, "little"))


@functools.lru_cache(maxsize=16)
def scene_particles(scene: Scene) -> ParticleSet | None:
    """The scene's particles (None if its water has no particle field); cached per scene object.

    Deterministic in the scene and ``scene.particle_seed`` (module docstring).

    Examples
    --------
    >>> from rigsim.config.rig import load_rig
    >>> from rigsim.scene.build import build_scene
    >>> from rigsim.water import preset
    >>> from rigsim.water.model import with_particles
    >>> from rigsim.water.particles import particle_level
    >>> w = with_particles(preset("coastal"), particle_level("coastal"))
    >>> sc = build_scene(load_rig("rigs/twin-strobes-45-wide.toml"), w, "colorchecker", 1.5)
    >>> a, b = scene_particles(sc), scene_particles(build_scene(sc.rig, w, "colorchecker", 1.5))
    >>> len(a) > 100 and np.array_equal(a.position_m, b.position_m)
    True
    """
    field = particle_field_of(scene)
    if field is None or field.number_per_m3 <= 0:
        return None
    z1 = placement_depth_m(scene)
    fr = placement_frustum(scene, field, z1)
    n = float(field.number_per_m3)
    truncated = False
    if n * fr.volume() > MAX_PARTICLES:
        lo, hi = fr.z0, fr.z1
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if n * fr.volume(mid) <= MAX_PARTICLES else (lo, mid)
        fr = Frustum(fr.x0, fr.tx, fr.y0, fr.ty, fr.z0, lo)
        truncated = True
    vol = fr.volume()
    rng = _rng(scene)
    count = int(rng.poisson(n * vol))
    # depth by inverting the volume's cumulative distribution (tabulated: the area is quadratic in z)
    zs = np.linspace(fr.z0, fr.z1, 2049)
    cdf = np.array([fr.volume(z) for z in zs]) / max(vol, 1e-300)
    z = np.interp(rng.random(count), cdf, zs)
    x = (2.0 * rng.random(count) - 1.0) * (fr.x0 + fr.tx * z)
    y = (2.0 * rng.random(count) - 1.0) * (fr.y0 + fr.ty * z)
    d_m = field.diameters_mm(rng.random(count)) * 1e-3
    cam = scene.camera
    right, up, fwd = cam.frame()
    pupil = np.asarray(cam.position_m, float)
    pos = pupil + x[:, None] * right + y[:, None] * up + z[:, None] * fwd
    # not inside the port or the housing (a restriction of a Poisson process is one)
    dist = np.linalg.norm(pos - pupil, axis=1)
    keep = dist > float(cam.housing_radius_m) + 0.5 * d_m
    if cam.port.kind == "dome":
        keep &= dist > port_reach_m(cam) + 0.5 * d_m
    return ParticleSet(position_m=pos[keep], diameter_m=d_m[keep], field=field, seed=int(scene.particle_seed),
                       depth_range_m=(fr.z0, fr.z1), volume_m3=vol, expected=n * vol, truncated=truncated)


# --- the particles' images ------------------------------------------------------------------------
#: Most points a particle's image is sampled with (discs wider than ~9 pixels).
SPLAT_POINTS_MAX = 256
#: Most points all the particles' images are sampled with (a dense field of large particles gets fewer each).
SPLAT_POINTS_TOTAL = 4_000_000
#: Points (or candidate pixels) handled at once.
_CHUNK_POINTS = 1_000_000
#: A particle's image wider than this radius (pixels) is labelled only within it in ``particle_id``.
ID_RADIUS_MAX_PX = 64


@dataclass(frozen=True, eq=False)
class Footprints:
    """Where each particle's image lies in a ``width × height`` image.

    The image of a particle is a disc: the particle's own angular radius ``d / 2r`` and the defocus
    disc's (:func:`~rigsim.scene.optics.defocus_blur_rad`) combined in quadrature, i.e. a disc of radius
    ``radius_m`` across the line of sight, laid out in the image by the local Jacobian of
    :func:`~rigsim.scene.optics.project_points` (the port's distortion included).

    Attributes
    ----------
    uv
        (N, 2) image position of each centre (col, row in pixels; NaN: not imaged).
    jacobian
        (N, 2, 2) pixels per metre across the line of sight (image axes × the plane's two axes).
    radius_m, radius_px
        (N,) the disc's radius across the line of sight (m) and its largest extent in pixels.
    range_m, depth_m
        (N,) distance from the pupil and depth along the optical axis (m).
    to_camera
        (N, 3) unit directions from each particle to the pupil.
    imaged
        (N,) bool: the disc reaches the image and the particle is in front of the pupil.
    """

    uv: np.ndarray
    jacobian: np.ndarray
    radius_m: np.ndarray
    radius_px: np.ndarray
    range_m: np.ndarray
    depth_m: np.ndarray
    to_camera: np.ndarray
    imaged: np.ndarray


def particle_footprints(scene: Scene, ps: ParticleSet, width: int, height: int) -> Footprints:
    """The :class:`Footprints` of ``ps`` in a ``width × height`` image of ``scene``."""
    cam = scene.camera
    n_out = outside_index(scene)
    right, up, fwd = cam.frame()
    pupil = np.asarray(cam.position_m, float)
    P = np.asarray(ps.position_m, float)
    D = np.asarray(ps.diameter_m, float)
    rel = P - pupil
    rng = np.linalg.norm(rel, axis=1)
    to_cam = -rel / np.maximum(rng, 1e-12)[:, None]
    depth = rel @ fwd
    e1 = np.cross(to_cam, up)
    e1 /= np.maximum(np.linalg.norm(e1, axis=1, keepdims=True), 1e-12)
    e2 = np.cross(e1, to_cam)
    h = 1e-3 * rng[:, None]
    uv = project_points(cam, P, width, height, n_outside=n_out)
    u1 = project_points(cam, P + h * e1, width, height, n_outside=n_out)
    u2 = project_points(cam, P + h * e2, width, height, n_outside=n_out)
    J = np.stack([(u1 - uv) / h, (u2 - uv) / h], axis=-1)
    blur = defocus_blur_rad(cam, np.maximum(depth, 1e-9))
    R_m = np.sqrt((0.5 * D) ** 2 + (0.5 * blur * rng) ** 2)
    with np.errstate(invalid="ignore"):
        R_px = R_m * np.max(np.abs(J).sum(axis=2), axis=1)
        ok = np.all(np.isfinite(uv), axis=1) & np.all(np.isfinite(J.reshape(len(P), -1)), axis=1) & (depth > 0)
        ok &= (uv[:, 0] > -R_px - 1) & (uv[:, 0] < width + R_px + 1) & (uv[:, 1] > -R_px - 1) \
            & (uv[:, 1] < height + R_px + 1)
    return Footprints(uv=uv, jacobian=J, radius_m=R_m, radius_px=np.where(ok, R_px, 0.0), range_m=rng,
                      depth_m=depth, to_camera=to_cam, imaged=ok)


def _spiral(k: int) -> np.ndarray:
    """``k`` points (k, 2) evenly spread over the unit disc (Vogel's sunflower spiral)."""
    i = np.arange(k) + 0.5
    r = np.sqrt(i / k)
    a = i * np.pi * (3.0 - np.sqrt(5.0))
    return np.stack([r * np.cos(a), r * np.sin(a)], axis=-1)


def footprint_samples(fp: Footprints, width: int, height: int, range_m: np.ndarray):
    """Points spread evenly over each imaged particle's disc, batch by batch of equal point count.

    Yields ``(particle, pixel, weight)``: 1-D arrays over the points that fall inside the image and in
    front of the targets (``range_m``, (rows, cols), inf for open water): the particle's index, the flat
    pixel index (``row · width + col``) and the point's share of the particle's image (1/k of the disc's
    k points; points outside the image or behind a target carry their share away).  At least 4 points
    per disc, about 4 per pixel it covers, at most :data:`SPLAT_POINTS_MAX`.
    """
    idx = np.flatnonzero(fp.imaged)
    if idx.size == 0:
        return
    kpts = np.clip(np.ceil(np.pi * fp.radius_px[idx] ** 2 * 4.0), 4, SPLAT_POINTS_MAX)
    if kpts.sum() > SPLAT_POINTS_TOTAL:  # a dense field of large particles: fewer points each (at least 1)
        kpts = np.clip(np.floor(kpts * SPLAT_POINTS_TOTAL / kpts.sum()), 1, SPLAT_POINTS_MAX)
    kpts = (2 ** np.ceil(np.log2(kpts))).astype(int)
    for k in np.unique(kpts):
        for sel in np.array_split(idx[kpts == k], max(1, int(np.ceil((kpts == k).sum() * k / _CHUNK_POINTS)))):
            yield from _disc_points(fp, sel, int(k), width, height, range_m)


def _disc_points(fp: Footprints, sel: np.ndarray, k: int, width: int, height: int, range_m: np.ndarray):
    if sel.size:
        q = _spiral(int(k))
        pts = fp.uv[sel, None, :] + np.einsum("nij,kj->nki", fp.jacobian[sel], q) * fp.radius_m[sel, None, None]
        col = np.floor(np.clip(pts[..., 0], -1, width)).astype(np.int64)
        row = np.floor(np.clip(pts[..., 1], -1, height)).astype(np.int64)
        inside = (col >= 0) & (col < width) & (row >= 0) & (row < height)
        cc, rr = np.clip(col, 0, width - 1), np.clip(row, 0, height - 1)
        front = inside & (fp.range_m[sel, None] < range_m[rr, cc])
        if front.any():
            who = np.broadcast_to(sel[:, None], front.shape)[front]
            yield who, (rr * width + cc)[front], np.full(who.shape, 1.0 / k)


def particle_id_image(scene: Scene, ps: ParticleSet, width: int, height: int, range_m: np.ndarray) -> np.ndarray:
    """(rows, cols) int32: the 1-based index of the nearest particle whose image (its disc,
    :class:`Footprints`) reaches into the pixel in front of the targets (``range_m``), 0 where none
    does: the instance mask of the particles, from the geometry alone, the same for both engines.  A
    particle smaller than a pixel marks the pixel it lies in, so its light is inside its mask; one whose
    image is wider than :data:`ID_RADIUS_MAX_PX` marks only the pixels within that radius of its centre."""
    fp = particle_footprints(scene, ps, width, height)
    best = np.full(height * width, np.inf)
    out = np.zeros(height * width, np.int64)
    idx = np.flatnonzero(fp.imaged)
    if idx.size == 0:
        return out.reshape(height, width).astype(np.int32)
    idx = idx[np.argsort(fp.range_m[idx], kind="stable")]  # nearest first: once every pixel is labelled, stop
    half = np.ceil(np.minimum(fp.radius_px[idx], ID_RADIUS_MAX_PX)).astype(int)
    half = np.where(half < 1, 1, 2 ** np.ceil(np.log2(np.maximum(half, 1))).astype(int))
    cost = np.cumsum((2 * half + 1) ** 2)
    start = 0
    while start < idx.size:
        stop = max(start + 1, int(np.searchsorted(cost, cost[start] + _CHUNK_POINTS)))
        for m in np.unique(half[start:stop]):
            _mark(fp, idx[start:stop][half[start:stop] == m], int(m), width, height, range_m, best, out)
        start = stop
        if np.all(out > 0):
            break  # the rest are farther than every pixel's label
    return out.reshape(height, width).astype(np.int32)


def _mark(fp: Footprints, sel: np.ndarray, m: int, width: int, height: int, range_m: np.ndarray, best: np.ndarray,
          out: np.ndarray) -> None:
    """Label the pixels particles ``sel`` (discs within ``m`` pixels of their centre) reach into, nearest first."""
    if sel.size:
        Jinv = np.linalg.inv(fp.jacobian[sel])  # metres across the view per pixel
        o = np.arange(-m, m + 1)
        OX, OY = np.meshgrid(o, o)
        c0 = np.floor(fp.uv[sel, 0])[:, None] + OX.ravel()[None, :]
        r0 = np.floor(fp.uv[sel, 1])[:, None] + OY.ravel()[None, :]
        # the point of each pixel's square nearest the disc's centre (the centre itself if inside it)
        qx = np.clip(fp.uv[sel, 0:1], c0, c0 + 1.0)
        qy = np.clip(fp.uv[sel, 1:2], r0, r0 + 1.0)
        dx = np.stack([qx - fp.uv[sel, 0:1], qy - fp.uv[sel, 1:2]], axis=-1)  # (n, k, 2) pixels
        dm = np.einsum("nij,nkj->nki", Jinv, dx)
        inside = (np.sum(dm * dm, axis=-1) <= fp.radius_m[sel, None] ** 2) & (c0 >= 0) & (c0 < width) \
            & (r0 >= 0) & (r0 < height)
        cc = np.clip(c0, 0, width - 1).astype(np.int64)
        rr = np.clip(r0, 0, height - 1).astype(np.int64)
        inside &= fp.range_m[sel, None] < range_m[rr, cc]
        if not inside.any():
            return
        who = np.broadcast_to(sel[:, None], inside.shape)[inside]
        pix = (rr * width + cc)[inside]
        order = np.argsort(-fp.range_m[who], kind="stable")  # far first: the nearest is written last
        pix_o, who_o = pix[order], who[order]
        near = fp.range_m[who_o] < best[pix_o]
        out[pix_o[near]] = who_o[near] + 1
        np.minimum.at(best, pix_o, fp.range_m[who_o])
