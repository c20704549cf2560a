"""The procedural seabed: its heights against its parameters (ripple wavelength and height, relief rms,
slope), the mesh against the height function, rays meeting it, objects resting on it, errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rigsim.errors import ConfigError
from rigsim.scene.seabed import SeabedSpec, height_at, seabed_mesh, seabed_points


def test_ripples_have_the_wavelength_and_height_asked_for():
    spec = SeabedSpec(seed=1, ripple_wavelength_m=0.3, ripple_height_m=0.04, ripple_direction_deg=30.0,
                      relief_m=0.0, slope_deg=0.0)
    r = math.radians(30.0)
    s = np.linspace(0.0, 6.0, 6001)  # across the crests, on a line where the wander is at a crest of its own
    h = height_at(spec, s * math.cos(r), s * math.sin(r))
    assert h.max() - h.min() == pytest.approx(0.04, rel=0.02)
    f = np.fft.rfftfreq(len(s), s[1] - s[0])
    peak = f[1 + np.argmax(np.abs(np.fft.rfft(h - h.mean()))[1:])]
    assert 1 / peak == pytest.approx(0.3, rel=0.02)
    # along the crests the height changes only through their slow wander (7 wavelengths)
    along = height_at(spec, -np.linspace(0, 0.05, 50) * math.sin(r), np.linspace(0, 0.05, 50) * math.cos(r))
    assert np.ptp(along) < 0.25 * 0.04


def test_relief_rms_and_slope_are_the_parameters():
    g = np.linspace(-30.0, 30.0, 601)
    X, Z = np.meshgrid(g, g)
    flat = SeabedSpec(seed=4, extent_m=60.0, cells=600, ripple_height_m=0.0, relief_m=0.2, relief_scale_m=2.0)
    assert height_at(flat, X, Z).std() == pytest.approx(0.2, rel=0.1)  # (24 modes over a 60 m square)
    tilted = SeabedSpec(seed=4, ripple_height_m=0.0, relief_m=0.0, slope_deg=10.0, slope_direction_deg=90.0)
    h = height_at(tilted, X, Z)
    gz = np.polyfit(Z.ravel(), h.ravel(), 1)[0]
    assert gz == pytest.approx(math.tan(math.radians(10.0)), rel=1e-9)
    assert np.ptp(np.gradient(h, g, axis=1)) < 1e-9  # no x-dependence: the slope rises towards +z only


def test_mesh_is_the_height_field_with_upward_normals_and_same_seed_same_bed():
    spec = SeabedSpec(seed=2, extent_m=4.0, cells=80, ripple_wavelength_m=0.2)
    V, F = seabed_mesh(spec)
    assert len(V) == 81 * 81 and len(F) == 2 * 80 * 80
    np.testing.assert_allclose(V[:, 1], height_at(spec, V[:, 0], V[:, 2]), atol=0)
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    assert np.all(n[:, 1] > 0)
    V2, _ = seabed_mesh(SeabedSpec(seed=2, extent_m=4.0, cells=80, ripple_wavelength_m=0.2))
    V3, _ = seabed_mesh(SeabedSpec(seed=3, extent_m=4.0, cells=80, ripple_wavelength_m=0.2))
    assert np.array_equal(V, V2) and not np.array_equal(V, V3)


def test_rays_meet_the_seabed_on_its_surface():
    spec = SeabedSpec(seed=5, extent_m=8.0, cells=200, ripple_wavelength_m=0.2, relief_m=0.2)
    M = np.eye(4)
    M[:3, 3] = (0.0, -1.5, 2.0)
    rng = np.random.default_rng(0)
    d = np.c_[rng.uniform(-0.5, 0.5, 200), -np.ones(200), rng.uniform(0.2, 1.5, 200)]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.zeros((200, 3))
    p = seabed_points(spec, M, o, d)
    ok = np.all(np.isfinite(p), axis=1)
    assert ok.mean() > 0.9
    local = p[ok] - M[:3, 3]
    np.testing.assert_allclose(local[:, 1], height_at(spec, local[:, 0], local[:, 2]), atol=1e-6)
    t = np.sum(p[ok] * d[ok], axis=1)
    np.testing.assert_allclose(p[ok], t[:, None] * d[ok], atol=1e-9)  # on the rays
    # first hit: no point of the ray before it is below the bed
    for k in np.flatnonzero(ok)[:20]:
        s = np.linspace(0.0, np.linalg.norm(p[k]) - 1e-4, 400)
        q = s[:, None] * d[k] - M[:3, 3]
        assert np.all(q[:, 1] > height_at(spec, q[:, 0], q[:, 2]))


def test_a_grid_too_coarse_for_the_ripples_is_refused():
    with pytest.raises(ConfigError, match="cannot draw ripples") as e:
        SeabedSpec(extent_m=12.0, cells=100, ripple_wavelength_m=0.2, ripple_height_m=0.02)
    assert "\n" not in str(e.value) and "seabed.cells" in str(e.value)
    with pytest.raises(ConfigError, match="slope_deg"):
        SeabedSpec(slope_deg=60.0)
