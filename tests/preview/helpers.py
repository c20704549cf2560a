"""Shared helpers for the preview tests: small scenes, independent references, region masks."""

from __future__ import annotations

import numpy as np

from rigsim.preview.geometry import cast_rays, scene_surfaces
from rigsim.scene.optics import camera_rays, outside_index
from rigsim.scene.types import BeamPattern, Camera, Light, Port, Rig, Scene, Target
from rigsim.water.model import Spectrum1D, TabulatedWater
from rigsim.water.phase import HenyeyGreenstein

WL_ENDS = (360.0, 830.0)


def make_light(kind="strobe", position=(0.0, 0.0, 0.0), aim=(0.0, 0.0, 1.0), intensity=1.0, beam=None,
               wavelength_nm=WL_ENDS, name="light") -> Light:
    vals = np.broadcast_to(np.asarray(intensity, float), (len(wavelength_nm),))
    return Light(name=name, kind=kind, position_m=tuple(float(x) for x in position), aim=tuple(aim),
                 beam=beam or BeamPattern(beam_angle_deg=100.0),
                 wavelength_nm=tuple(float(w) for w in wavelength_nm),
                 axial_intensity=tuple(float(v) for v in vals))


def dome_camera(focal_length_mm=35.0, sensor=(24.0, 24.0), radius=0.1, thickness=0.008) -> Camera:
    return Camera(focal_length_mm=focal_length_mm, sensor_width_mm=sensor[0], sensor_height_mm=sensor[1],
                  port=Port(kind="dome", radius_m=radius, thickness_m=thickness))


def absorbing_water() -> TabulatedWater:
    """Non-scattering water with a strongly wavelength-dependent c(λ) (1/m)."""
    wl = np.array([360.0, 450.0, 550.0, 650.0, 830.0])
    a = np.array([0.05, 0.08, 0.2, 0.45, 0.9])
    return TabulatedWater("absorbing", Spectrum1D(a, wl, "a"), Spectrum1D.constant(0.0), HenyeyGreenstein(0.8))


def disk_scene(water, lights, *, distance=1.5, size=2.0, reflectance=0.8, camera=None) -> Scene:
    t = Target("white-disk", distance, size_m=size, reflectance_wavelength_nm=WL_ENDS,
               reflectance=(reflectance, reflectance))
    return Scene(Rig("test", camera or dome_camera(), tuple(lights)), water, (t,))


def pinhole_dome_ray(camera: Camera, px: float, py: float) -> tuple[np.ndarray, np.ndarray]:
    """A dome-port camera ray written out from scratch (camera looking along +z, up +y)."""
    assert camera.forward == (0.0, 0.0, 1.0) and camera.up == (0.0, 1.0, 0.0)
    tx = camera.sensor_width_mm / (2 * camera.focal_length_mm)
    ty = camera.sensor_height_mm / (2 * camera.focal_length_mm)
    # right = forward × up = (0,0,1) × (0,1,0) = (−1, 0, 0)
    d = np.array([-(2 * px - 1) * tx, (1 - 2 * py) * ty, 1.0])
    d /= np.linalg.norm(d)
    o = np.asarray(camera.position_m, float) + d * (camera.port.radius_m + camera.port.thickness_m)
    return o, d


def direct_reference(scene: Scene, width: int, height: int, wavelength_nm, bandwidth_nm, *, lam_sub: int = 41):
    """Exact unscattered radiance at pixel centres of a disk facing a dome camera (Beer–Lambert).

    ``L = ρ/π Σ_l I(λ) f(θ) cos θ_i / r² · exp(−c(λ)(r + s))``, band-averaged with
    ``lam_sub`` midpoints per band.  Returns (reference, on_disk).
    """
    cam, t = scene.camera, scene.targets[0]
    wl = np.asarray(wavelength_nm, float)
    bw = np.broadcast_to(np.asarray(bandwidth_nm, float), wl.shape)
    lam = wl[:, None] + bw[:, None] * ((np.arange(lam_sub) + 0.5) / lam_sub - 0.5)
    c = np.zeros_like(lam) if scene.water is None else scene.water.c_per_m(lam)
    rho = np.interp(lam, t.reflectance_wavelength_nm, t.reflectance)
    out = np.zeros((height, width, len(wl)))
    on = np.zeros((height, width), bool)
    centre = np.asarray(cam.position_m) + np.array([0.0, 0.0, t.distance_m])
    for row in range(height):
        for col in range(width):
            o, d = pinhole_dome_ray(cam, (col + 0.5) / width, (row + 0.5) / height)
            s = (centre[2] - o[2]) / d[2]
            p = o + s * d
            if np.hypot(p[0] - centre[0], p[1] - centre[1]) > t.size_m / 2:
                continue
            on[row, col] = True
            for light in scene.lights:
                v = p - np.asarray(light.position_m)
                r = np.linalg.norm(v)
                axis = np.asarray(light.aim, float) / np.linalg.norm(light.aim)
                theta = np.arccos(np.clip(v @ axis / r, -1, 1))
                cos_i = max(v[2] / r, 0.0)  # disk normal −z (towards the camera): cos = (−z)·(l − p)/r
                I = np.interp(lam, light.wavelength_nm, light.axial_intensity)
                f = light.beam.relative_intensity(theta)
                out[row, col] += (rho * I * np.exp(-c * (r + s))).mean(axis=1) * f * cos_i / (np.pi * r * r)
    return out, on


def backscatter_brute_force(scene: Scene, px: float, py: float, wavelength_nm, *, n: int = 200_001,
                            s_end: float | None = None) -> np.ndarray:
    """Single-scattering backscatter along one dome-camera ray by a fine trapezoid rule in ln s.

    Uses the water's own ``phase.eval`` (not the preview's tables), ``e^{−c·}`` on both
    legs, up to the ray's hit with the (disk) target or ``s_end``.
    """
    cam, t = scene.camera, scene.targets[0]
    o, d = pinhole_dome_ray(cam, px, py)
    if s_end is None:
        s_hit = (cam.position_m[2] + t.distance_m - o[2]) / d[2]
        p = o + s_hit * d
        s_end = s_hit if np.hypot(p[0], p[1]) <= t.size_m / 2 else 1000.0
    u = np.linspace(np.log(1e-4), np.log(s_end + 1e-4), n)
    s = np.exp(u) - 1e-4
    water = scene.water
    out = []
    for lam in np.atleast_1d(wavelength_nm):
        c, b = float(water.c_per_m(lam)), float(water.b_per_m(lam))
        tot = np.zeros_like(s)
        for light in scene.lights:
            x = o + s[:, None] * d - np.asarray(light.position_m)
            r = np.linalg.norm(x, axis=1)
            xh = x / r[:, None]
            ax = np.asarray(light.aim, float) / np.linalg.norm(light.aim)
            th = np.arccos(np.clip(xh @ ax, -1, 1))
            I = float(np.interp(lam, light.wavelength_nm, light.axial_intensity))
            tot += b * water.phase.eval(-(xh @ d), lam) * I * light.beam.relative_intensity(th) \
                * np.exp(-c * (s + r)) / r ** 2
        g = tot * (s + 1e-4)
        out.append(np.sum(0.5 * (g[1:] + g[:-1]) * np.diff(u)))
    return np.array(out)


def interior_ids(scene: Scene, width: int, height: int, n: int = 4) -> np.ndarray:
    """Object id of each pixel whose whole footprint (n×n points, edges included) sees one object, else −1."""
    surf = scene_surfaces(scene)
    g = np.linspace(0.0, 1.0, n)
    PX = (np.arange(width)[:, None] + g[None, :]).ravel() / width
    PY = (np.arange(height)[:, None] + g[None, :]).ravel() / height
    X, Y = np.meshgrid(PX, PY)
    o, d = camera_rays(scene.camera, X, Y, n_outside=outside_index(scene))
    _, oid = cast_rays(surf, o, d)
    oid = oid.reshape(height, n, width, n)
    first = oid[:, :1, :, :1]
    return np.where(np.all(oid == first, axis=(1, 3)), first[:, 0, :, 0], -1)
