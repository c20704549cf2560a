"""A procedural seabed: a height field of sand with ripples, undulating relief and a slope, as a
triangle mesh (the kind ``seabed`` of :class:`~rigsim.scene.types.Target`).

Heights (m, y up; x and z horizontal in the seabed's own frame, centred on the patch):

* **slope**: a plane rising ``tan(slope_deg)`` per metre towards ``slope_direction_deg``;
* **relief**: the sum of :data:`RELIEF_MODES` cosine waves with seeded directions and phases and
  wavelengths spread log-uniformly over ``relief_scale_m`` × [0.5, 2], scaled to an rms height of
  ``relief_m`` (dunes, hummocks, scour);
* **ripples**: wave-formed sand ripples of wavelength ``ripple_wavelength_m`` and crest-to-trough
  height ``ripple_height_m``, crests at ``ripple_direction_deg``, with the sharp crests and broad
  troughs of oscillation ripples (the profile ``|sin(φ/2)|^1.5``) and crests that wander
  (a slow phase modulation) — the look of ripple fields at 2–20 m depth (typical wave ripples: 5–50 cm
  long, height about 0.15 × length: Wiberg & Harris 1994, J. Geophys. Res. 99(C4) 775–789).

The mesh is a regular grid of ``cells`` × ``cells`` squares (two triangles each) over an
``extent_m`` square; :func:`seabed_mesh_file` writes it once as a binary PLY in the cache
(``$RIGSIM_CACHE_DIR`` or ``~/.cache/rigsim``/seabeds, named by the parameters' hash, written
atomically) — both engines then read it like any mesh target (:func:`rigsim.scene.meshes.read_mesh`).
:func:`height_at` gives the same heights anywhere, to rest objects on the seabed.

Beyond the patch the seabed goes on to ``far_m`` (:func:`seabed_skirt`, written beside the patch as
``…-far.ply``, :func:`skirt_path`): rings of vertices growing by :data:`SKIRT_GROWTH` per ring from the
patch's own boundary vertices (the seam is watertight), the slope continuing and the relief fading out
over one extent, without ripples (at that range they are below a pixel and the water hides them) — so
that a camera looking towards the horizon sees sand fade into the water, not the end of a 12 m patch.
It is a surface of its own (the same target and object), so the fine patch keeps its own texture cells
for the multiply scattered light.

Placement (:func:`rigsim.scene.surfaces.target_surfaces`): level (mean height 0) ``distance_m``
below the entrance pupil, its x along the camera's right projected on the horizontal, its centre
:data:`AHEAD_FRACTION` of the extent ahead of the camera along its horizontal forward direction (and
:data:`SIDE_SHIFT` of it to the right).
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import math
import os
from dataclasses import asdict
from pathlib import Path
from typing import Annotated

import numpy as np
from pydantic import Field, model_validator

from rigsim.schema import Int, Real, Unit, frozen_type, invalid

__all__ = ["SeabedSpec", "height_at", "seabed_mesh", "seabed_skirt", "seabed_mesh_file", "skirt_path", "seabed_points",
           "AHEAD_FRACTION", "SIDE_SHIFT", "RELIEF_MODES", "SKIRT_GROWTH"]

#: Cosine modes of the relief.
RELIEF_MODES = 24
#: The patch's centre lies this fraction of its extent ahead of the camera (horizontally).
AHEAD_FRACTION = 0.3
#: ... and this fraction of its extent to the camera's right (1.7 mm for 12 m: off the grid lines).
SIDE_SHIFT = 1e-4 * math.sqrt(2.0)
#: Each ring of the far seabed is this much farther out than the one inside it (a square ring scaled
#: about the patch's centre: 20 rings from a 12 m patch to 200 m).
SKIRT_GROWTH = 1.15


def _range(lo: float, hi: float, unit: str = "m"):
    return Annotated[Real, Field(ge=lo, le=hi), Unit(unit)]


@frozen_type
class SeabedSpec:
    """Parameters of a seabed patch (lengths in m, angles in deg); a bad one is a one-line ConfigError."""

    seed: Annotated[Int, Field(ge=0)] = 0
    extent_m: _range(0.5, 200.0) = 12.0
    cells: Annotated[Int, Field(ge=4, le=2048)] = 384
    ripple_wavelength_m: _range(0.01, 10.0) = 0.25
    ripple_height_m: _range(0.0, 1.0) = 0.03
    ripple_direction_deg: Annotated[Real, Unit("deg")] = 0.0
    relief_m: _range(0.0, 10.0) = 0.12
    relief_scale_m: _range(0.05, 100.0) = 2.5
    slope_deg: _range(0.0, 45.0, "deg") = 0.0
    slope_direction_deg: Annotated[Real, Unit("deg")] = 0.0
    far_m: _range(0.0, 5000.0) = 200.0

    @model_validator(mode="after")
    def _check(self) -> "SeabedSpec":
        if self.extent_m / self.cells > self.ripple_wavelength_m / 4 and self.ripple_height_m > 0:
            raise invalid(f"{self.cells} cells over {self.extent_m:g} m cannot draw ripples "
                          f"{self.ripple_wavelength_m:g} m long", field="cells",
                          allowed=f">= {math.ceil(4 * self.extent_m / self.ripple_wavelength_m)} "
                                  "(four per ripple wavelength)")
        if 0 < self.far_m <= self.extent_m:
            raise invalid(f"the far seabed ({self.far_m:g} m) must reach beyond the patch ({self.extent_m:g} m)",
                          field="far_m", allowed=f"0 (none) or > {self.extent_m:g}")
        return self

    def key(self) -> str:
        return hashlib.blake2b(json.dumps(asdict(self), sort_keys=True).encode(), digest_size=10).hexdigest()


@functools.lru_cache(maxsize=64)
def _modes(spec: SeabedSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The relief's wave vectors (K, 2) (rad/m), phases, amplitudes; the ripples' wander phase scale."""
    rng = np.random.default_rng([int(spec.seed), 0x5EABED])
    lam = spec.relief_scale_m * np.exp(rng.uniform(np.log(0.5), np.log(2.0), RELIEF_MODES))
    ang = rng.uniform(0.0, 2 * np.pi, RELIEF_MODES)
    k = (2 * np.pi / lam)[:, None] * np.stack([np.cos(ang), np.sin(ang)], 1)
    ph = rng.uniform(0.0, 2 * np.pi, RELIEF_MODES)
    amp = lam / lam.sum()  # longer waves higher (a red spectrum), then scaled to the rms below
    amp = amp * spec.relief_m * math.sqrt(2.0) / math.sqrt(np.sum(amp ** 2))
    return k, ph, amp, float(rng.uniform(0, 2 * np.pi))


def height_at(spec: SeabedSpec, x, z) -> np.ndarray:
    """Seabed height (m) at horizontal positions ``(x, z)`` of its own frame (any equal shapes; on the
    patch — the far seabed beyond it has no ripples and its relief fades out)."""
    x, z = np.asarray(x, float), np.asarray(z, float)
    k, ph, amp, ph0 = _modes(spec)
    h = np.zeros(np.broadcast(x, z).shape)
    for j in range(len(ph)):
        h += amp[j] * np.cos(k[j, 0] * x + k[j, 1] * z + ph[j])
    s = math.radians(spec.slope_direction_deg)
    h += math.tan(math.radians(spec.slope_deg)) * (x * math.cos(s) + z * math.sin(s))
    if spec.ripple_height_m > 0:
        r = math.radians(spec.ripple_direction_deg)
        across = x * math.cos(r) + z * math.sin(r)
        along = -x * math.sin(r) + z * math.cos(r)
        wander = 0.6 * np.sin(2 * np.pi * along / (7.0 * spec.ripple_wavelength_m) + ph0)
        phi = 2 * np.pi * across / spec.ripple_wavelength_m + wander
        prof = np.abs(np.sin(phi / 2)) ** 1.5  # sharp crests at φ = π, broad troughs
        h += spec.ripple_height_m * (prof - 0.6)  # (mean of |sin|^1.5 ≈ 0.6: level on average)
    return h


def seabed_mesh(spec: SeabedSpec) -> tuple[np.ndarray, np.ndarray]:
    """``(vertices (n, 3), faces (m, 3))`` of the height field, m, y up, centred on x = z = 0."""
    n = spec.cells + 1
    g = np.linspace(-spec.extent_m / 2, spec.extent_m / 2, n)
    X, Z = np.meshgrid(g, g, indexing="ij")
    V = np.stack([X, height_at(spec, X, Z), Z], -1).reshape(-1, 3)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    # wound so that the normals point up (+y): (x, z) → a right-handed turn about +y is x → −z
    F = np.concatenate([np.stack([a, c, b], 1), np.stack([a, d, c], 1)])
    return V, F


def seabed_skirt(spec: SeabedSpec) -> tuple[np.ndarray, np.ndarray]:
    """``(vertices, faces)`` of the seabed beyond the patch out to ``far_m`` (square rings about the centre,
    the first the patch's own boundary vertices; see the module docstring); empty for ``far_m = 0``."""
    if spec.far_m <= 0:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    n, half = spec.cells, spec.extent_m / 2
    g = np.linspace(-half, half, n + 1)  # (the patch's own grid coordinates: the seam's vertices coincide)
    lo, hi = np.full(n, -half), np.full(n, half)
    x0 = np.concatenate([g[:-1], hi, g[::-1][:-1], lo])  # the boundary, once round (4n vertices)
    z0 = np.concatenate([lo, g[:-1], hi, g[::-1][:-1]])
    rings = int(math.ceil(math.log(spec.far_m / spec.extent_m) / math.log(SKIRT_GROWTH)))
    scale = np.minimum(SKIRT_GROWTH ** np.arange(rings + 1), spec.far_m / spec.extent_m)
    X, Z = scale[:, None] * x0, scale[:, None] * z0
    Y = np.empty_like(X)
    Y[0] = height_at(spec, x0, z0)
    smooth = dataclasses.replace(spec, ripple_height_m=0.0)
    fade = np.clip(2.0 - scale[1:], 0.0, 1.0)[:, None]  # relief × 1 at the patch's edge, 0 one extent out
    flat = dataclasses.replace(spec, ripple_height_m=0.0, relief_m=0.0)
    Y[1:] = fade * height_at(smooth, X[1:], Z[1:]) + (1 - fade) * height_at(flat, X[1:], Z[1:])
    V = np.stack([X, Y, Z], -1).reshape(-1, 3)
    m = 4 * n
    i, j = np.meshgrid(np.arange(rings), np.arange(m), indexing="ij")
    a, b = i * m + j, i * m + (j + 1) % m
    c, d = b + m, a + m
    F = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    nrm = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    F = np.where((nrm[:, 1] < 0)[:, None], F[:, ::-1], F)  # wound with the normals up (+y), as the patch
    return V, F


def skirt_path(patch: str | Path) -> Path:
    """Where the far seabed of the patch mesh ``patch`` is (it may not exist: no far seabed)."""
    p = Path(patch)
    return p.with_name(p.stem + "-far.ply")


def _cache_dir() -> Path:
    root = os.environ.get("RIGSIM_CACHE_DIR") or str(Path.home() / ".cache" / "rigsim")
    return Path(root) / "seabeds"


def seabed_mesh_file(spec: SeabedSpec) -> Path:
    """The seabed as a binary PLY in the cache (written once, atomically); its path."""
    path = _cache_dir() / f"seabed-{spec.key()}.ply"
    if path.is_file():
        return path
    path.parent.mkdir(parents=True, exist_ok=True)
    if spec.far_m > 0:  # (first: the patch's file is the sign that both are there)
        _write_ply(skirt_path(path), *seabed_skirt(spec))
    _write_ply(path, *seabed_mesh(spec))
    return path


def _write_ply(path: Path, V: np.ndarray, F: np.ndarray) -> None:
    """A triangle mesh as a binary PLY, atomically."""
    import pyvista as pv

    mesh = pv.PolyData(V, np.c_[np.full(len(F), 3), F].ravel())
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp.ply")
    mesh.save(str(tmp), binary=True)
    os.replace(tmp, path)


def seabed_points(spec: SeabedSpec, to_world, origins: np.ndarray, directions: np.ndarray, *,
                  max_m: float = 40.0, step_m: float | None = None) -> np.ndarray:
    """Where rays (world origins and unit directions, (N, 3)) first meet the seabed placed by the 4×4
    ``to_world`` (world points (N, 3); NaN where a ray misses it within ``max_m`` or leaves the patch):
    marched in steps of a quarter ripple wavelength, then bisected."""
    M = np.asarray(to_world, float)
    R, t0 = M[:3, :3], M[:3, 3]
    o = (np.asarray(origins, float) - t0) @ R  # (R orthonormal: the inverse is its transpose)
    d = np.asarray(directions, float) @ R
    step = step_m or min(spec.ripple_wavelength_m / 4, spec.extent_m / spec.cells)
    ts = np.arange(0.0, max_m + step, step)
    out = np.full(o.shape, np.nan)
    half = spec.extent_m / 2
    for i in range(len(o)):
        p = o[i] + ts[:, None] * d[i]
        above = p[:, 1] - height_at(spec, p[:, 0], p[:, 2])
        cross = np.flatnonzero((above[:-1] > 0) & (above[1:] <= 0))
        if not cross.size:
            continue
        lo, hi = ts[cross[0]], ts[cross[0] + 1]
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            q = o[i] + mid * d[i]
            if q[1] - height_at(spec, q[0], q[2]) > 0:
                lo = mid
            else:
                hi = mid
        q = o[i] + hi * d[i]
        if abs(q[0]) <= half and abs(q[2]) <= half:
            out[i] = R @ q + t0
    return out
