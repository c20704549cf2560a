"""Shared helpers for the renderer tests: exact (Beer–Lambert) references and statistics."""

from __future__ import annotations

import numpy as np
import pytest

from rigsim.scene.types import BeamPattern, Camera, Light, Port, Rig, Scene, Target

pytest.importorskip("mitsuba")

from rigsim.scene.optics import camera_rays, outside_index
from rigsim.render.variant import mitsuba

mi, dr = mitsuba()

WL_ENDS = (360.0, 830.0)


def make_light(kind="continuous", position=(0.0, 0.0, 0.0), aim=(0.0, 0.0, 1.0), intensity=2.0,
               beam=None, wavelength_nm=WL_ENDS, name="light") -> Light:
    vals = np.broadcast_to(np.asarray(intensity, float), (len(wavelength_nm),))
    return Light(name=name, kind=kind, position_m=tuple(position), aim=tuple(aim),
                 beam=beam or BeamPattern(beam_angle_deg=120.0),
                 wavelength_nm=tuple(float(w) for w in wavelength_nm),
                 axial_intensity=tuple(float(v) for v in vals))


def make_camera(port="dome", focal_length_mm=150.0, **kw) -> Camera:
    p = Port(kind=port, radius_m=1e-3, thickness_m=0.0, standoff_m=1e-3) if isinstance(port, str) else port
    return Camera(focal_length_mm=focal_length_mm, port=p, **kw)


def disk_scene(water, lights, *, distance=1.5, size=2.0, reflectance=1.0, camera=None) -> Scene:
    t = Target("white-disk", distance, size_m=size, reflectance_wavelength_nm=WL_ENDS,
               reflectance=(reflectance, reflectance))
    return Scene(Rig("test", camera or make_camera(), tuple(lights)), water, (t,))


def light_geometry(light: Light, points: np.ndarray, normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(f(θ) cos θᵢ / r², r)`` of a point light at ``points`` (…, 3) on a surface whose lit side faces ``normal``
    (3,) or (…, 3): the beam pattern at the angle from its aim, the cosine of incidence (0 from behind) and the
    distance (m).  Times ``I(λ) e^{−c r}`` it is the exact direct irradiance."""
    v = np.asarray(points, float) - np.asarray(light.position_m, float)
    r = np.linalg.norm(v, axis=-1)
    vhat = v / r[..., None]
    axis = np.asarray(light.aim, float) / np.linalg.norm(light.aim)
    f = light.beam.relative_intensity(np.arccos(np.clip(vhat @ axis, -1, 1)))
    cos_i = np.clip(-np.sum(vhat * np.asarray(normal, float), axis=-1), 0, None)
    return f * cos_i / r ** 2, r


def reference_direct(scene: Scene, width: int, height: int, wavelength_nm, bandwidth_nm, *,
                     sub: int = 6, lam_sub: int = 21) -> tuple[np.ndarray, np.ndarray]:
    """Exact unscattered radiance (Beer–Lambert) of a Lambertian disk facing the camera.

    ``L = ρ/π · Σ_lights I(λ) f(θ) cos θ_i / r² · exp(−c(λ) (r + s))`` with r the
    light–surface distance and s the in-water camera path, averaged over
    ``sub × sub`` points per pixel and ``lam_sub`` wavelengths per band.

    Returns
    -------
    (reference, inside)
        (height, width, bands) radiance and the mask of pixels entirely on the disk.
    """
    cam = scene.camera
    t = scene.targets[0]
    r, u, f = cam.frame()
    g = (np.arange(sub) + 0.5) / sub
    cols = (np.arange(width)[:, None] + g[None, :]).ravel() / width
    rows = (np.arange(height)[:, None] + g[None, :]).ravel() / height
    PX, PY = np.meshgrid(cols, rows)
    o, d = camera_rays(cam, PX.ravel(), PY.ravel(), n_outside=outside_index(scene))
    centre = np.asarray(cam.position_m) + t.distance_m * f
    n = -f
    tt = ((centre - o) @ n) / (d @ n)
    p = o + tt[:, None] * d
    hit = np.linalg.norm(p - centre, axis=1) <= t.size_m / 2
    wl = np.asarray(wavelength_nm, float)
    bw = np.broadcast_to(np.asarray(bandwidth_nm, float), wl.shape)
    lam = wl[:, None] + bw[:, None] * ((np.arange(lam_sub) + 0.5) / lam_sub - 0.5)[None, :]  # (B, S)
    c = np.zeros_like(lam) if scene.water is None else scene.water.c_per_m(lam)
    rho = np.interp(lam, t.reflectance_wavelength_nm, t.reflectance)
    L = np.zeros((len(p), len(wl)))
    for light in scene.lights:
        geo, rl = light_geometry(light, p, n)
        I = np.interp(lam, light.wavelength_nm, light.axial_intensity)
        att = np.exp(-c[None, :, :] * (rl + tt)[:, None, None])  # (N, B, S)
        L += ((rho * I)[None] * att).mean(axis=2) * (geo / np.pi)[:, None]
    L *= hit[:, None]
    L = L.reshape(height, sub, width, sub, len(wl)).mean(axis=(1, 3))
    inside = hit.reshape(height, sub, width, sub).all(axis=(1, 3))
    return L, inside


def relative_error(img: np.ndarray, ref: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per band: relative error of the mean over ``mask`` and its Monte Carlo standard error."""
    diff = (img - ref)[mask]  # (N, B)
    mean_ref = ref[mask].mean(axis=0)
    rel = diff.mean(axis=0) / mean_ref
    se = diff.std(axis=0, ddof=1) / np.sqrt(diff.shape[0]) / mean_ref
    return rel, se
