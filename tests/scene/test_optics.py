"""The one camera and port model (rigsim.scene.optics) against exact geometry and optics.

Snell's law at both faces of a flat port (n sin θ is the same in air, glass and water, measured
from the axis), where the ray leaves the window, the dome's normal incidence, the projection as
the exact inverse of the rays, the field of view, and the port's Fresnel transmittance against
the closed form at normal incidence and the reciprocity of the two surfaces.
"""

from __future__ import annotations

import numpy as np
import pytest

from rigsim.scene.optics import (
    air_directions,
    air_radiance_factor,
    angular_pitch_rad,
    camera_rays,
    fov_water_deg,
    port_transmittance,
    project_points,
)
from rigsim.scene.types import Camera, Port
from rigsim.water.refraction import WATER_INDEX

FLAT = Port(kind="flat", standoff_m=0.03, thickness_m=0.012, glass_index=1.52)
DOME = Port(kind="dome", radius_m=0.1, thickness_m=0.008, glass_index=1.49)
PX = np.array([0.0, 0.13, 0.5, 0.92, 1.0, 0.3])
PY = np.array([0.5, 0.9, 0.5, 0.02, 1.0, 0.31])


def _camera(port):
    return Camera(focal_length_mm=14.0, forward=(0.2, -0.1, 1.0), up=(0.0, 1.0, 0.1), position_m=(0.1, -0.2, 0.3),
                  port=port)


@pytest.mark.parametrize("n_out", [WATER_INDEX, 1.0])
def test_flat_port_obeys_snell_at_both_faces_and_leaves_the_outer_face(n_out):
    cam = _camera(FLAT)
    r, u, f = cam.frame()
    d_air = air_directions(cam, PX, PY)
    o, d = camera_rays(cam, PX, PY, n_outside=n_out)
    sin_air = np.linalg.norm(np.cross(d_air, f), axis=-1)
    sin_out = np.linalg.norm(np.cross(d, f), axis=-1)
    np.testing.assert_allclose(n_out * sin_out, sin_air, rtol=1e-12, atol=1e-15)
    # same plane of incidence: the tangential parts are parallel
    t_air = d_air - (d_air @ f)[:, None] * f
    t_out = d - (d @ f)[:, None] * f
    np.testing.assert_allclose(np.cross(t_air, t_out), 0.0, atol=1e-14)
    # the origin is on the outer face, shifted sideways by standoff·tan θ_a + thickness·tan θ_g
    rel = o - np.asarray(cam.position_m)
    np.testing.assert_allclose(rel @ f, FLAT.standoff_m + FLAT.thickness_m, rtol=1e-12)
    th_a = np.arcsin(sin_air)
    th_g = np.arcsin(sin_air / FLAT.glass_index)
    lateral = np.linalg.norm(rel - (rel @ f)[:, None] * f, axis=-1)
    np.testing.assert_allclose(lateral, FLAT.standoff_m * np.tan(th_a) + FLAT.thickness_m * np.tan(th_g),
                               rtol=1e-12, atol=1e-15)


def test_dome_keeps_directions_and_starts_on_the_outer_surface():
    cam = _camera(DOME)
    o, d = camera_rays(cam, PX, PY, n_outside=WATER_INDEX)
    np.testing.assert_allclose(d, air_directions(cam, PX, PY), atol=1e-15)
    np.testing.assert_allclose(np.linalg.norm(o - np.asarray(cam.position_m), axis=-1),
                               DOME.radius_m + DOME.thickness_m, rtol=1e-12)


def test_image_axes_and_film_edges():
    cam = Camera(focal_length_mm=18.0, port=DOME)  # forward +z, up +y: image right is −x
    d = air_directions(cam, np.array([1.0, 0.5, 0.5]), np.array([0.5, 0.0, 0.5]))
    assert d[0, 0] < 0 and d[1, 1] > 0
    np.testing.assert_allclose(np.arctan2(-d[0, 0], d[0, 2]), np.arctan(36.0 / 36.0), rtol=1e-12)
    np.testing.assert_allclose(np.arctan2(d[1, 1], d[1, 2]), np.arctan(24.0 / 36.0), rtol=1e-12)
    np.testing.assert_allclose(d[2], [0.0, 0.0, 1.0], atol=1e-15)


@pytest.mark.parametrize("port", [FLAT, DOME], ids=["flat", "dome"])
@pytest.mark.parametrize("n_out", [WATER_INDEX, 1.0])
def test_projection_inverts_the_rays(port, n_out):
    cam = _camera(port)
    o, d = camera_rays(cam, PX, PY, n_outside=n_out)
    for s in (0.3, 2.0, 40.0):
        px = project_points(cam, o + s * d, 300, 200, n_outside=n_out)
        np.testing.assert_allclose(px[:, 0], 300 * PX, atol=1e-6)
        np.testing.assert_allclose(px[:, 1], 200 * PY, atol=1e-6)


def test_field_of_view_in_water():
    flat, dome = Camera(focal_length_mm=14.0, port=FLAT), Camera(focal_length_mm=14.0, port=DOME)
    half_air = np.arctan(36.0 / 28.0)
    assert fov_water_deg(dome) == pytest.approx(np.degrees(2 * half_air), rel=1e-12)
    assert fov_water_deg(flat) == pytest.approx(np.degrees(2 * np.arcsin(np.sin(half_air) / WATER_INDEX)), rel=1e-12)
    assert fov_water_deg(flat, 1.0) == pytest.approx(np.degrees(2 * half_air), rel=1e-12)
    # the centre pixel pitch of a flat port in water: d θ_w = cos θ_a /(n cos θ_w) d θ_a = 1/n at the axis
    ax, ay = angular_pitch_rad(flat, 3000, 2000, n_outside=WATER_INDEX)
    assert ax == pytest.approx(np.arctan(36.0 / 28.0 / 1500) / WATER_INDEX, rel=1e-4)
    assert ay == pytest.approx(np.arctan(24.0 / 28.0 / 1000) / WATER_INDEX, rel=1e-4)


def test_port_transmittance_closed_forms():
    for cam in (Camera(port=FLAT), Camera(port=DOME)):
        ng = cam.port.glass_index
        t0 = (1 - ((WATER_INDEX - ng) / (WATER_INDEX + ng)) ** 2) * (1 - ((ng - 1) / (ng + 1)) ** 2)
        assert float(port_transmittance(cam, np.array(0.5), np.array(0.5), n_outside=WATER_INDEX)) == \
            pytest.approx(t0, rel=1e-12)
        assert float(air_radiance_factor(cam, np.array(0.5), np.array(0.5), n_outside=WATER_INDEX)) == \
            pytest.approx(t0 / WATER_INDEX**2, rel=1e-12)
    # dome: the same everywhere (normal incidence); flat: falls off axis
    dome = port_transmittance(Camera(port=DOME), PX, PY, n_outside=WATER_INDEX)
    np.testing.assert_allclose(dome, dome[2], rtol=1e-12)
    flat = port_transmittance(Camera(focal_length_mm=14.0, port=FLAT), np.array([0.5, 0.75, 1.0]),
                              np.array([0.5, 0.5, 0.5]), n_outside=WATER_INDEX)
    assert flat[0] > flat[1] > flat[2] > 0.8


def test_port_transmittance_at_an_angle_against_born_wolf():
    """Fresnel's formulas written with the angles (Born & Wolf §1.5.3), not the cosines' ratios."""
    cam = Camera(focal_length_mm=14.0, port=FLAT)
    t = float(port_transmittance(cam, np.array(1.0), np.array(0.5), n_outside=WATER_INDEX))
    th_a = np.arctan(36.0 / 28.0)
    th_g = np.arcsin(np.sin(th_a) / FLAT.glass_index)
    th_w = np.arcsin(np.sin(th_a) / WATER_INDEX)

    def transmit(ti, tt):
        rs = np.sin(ti - tt) ** 2 / np.sin(ti + tt) ** 2
        rp = np.tan(ti - tt) ** 2 / np.tan(ti + tt) ** 2
        return 1 - (rs + rp) / 2

    assert t == pytest.approx(transmit(th_w, th_g) * transmit(th_g, th_a), rel=1e-10)
