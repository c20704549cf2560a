"""The targets' irradiance by light tracing in the renderer's Mitsuba scene (:mod:`rigsim.render.light_trace`).

* against the exact direct irradiance of a strobe in purely absorbing water
  (``E = I(λ) f(θ) cos θᵢ e^{−c r} / r²``, averaged over each texture cell and band), with and without the
  flights aimed at the targets (both estimators are unbiased: Z-tests per cell and over the disk);
* against the fast engine's numpy light tracer (:func:`rigsim.preview.multiple.trace_multiple`,
  ``classes="irradiance"``) in scattering water: two independent implementations of the same transport.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rigsim.render.light_trace import trace_target_irradiance
from rigsim.scene.types import BeamPattern
from rigsim.water.model import Spectrum1D, TabulatedWater
from rigsim.water.phase import HenyeyGreenstein
from tests.render.helpers import disk_scene, light_geometry, make_light

pytestmark = pytest.mark.render

ROOT = Path(__file__).resolve().parents[2]
CENTRES = np.array([450.0, 550.0, 650.0])  # three contiguous 100-nm bands over 400–700 nm


def _absorbing_water():
    wl = np.array([360.0, 450.0, 550.0, 650.0, 830.0])
    a = np.array([0.05, 0.08, 0.2, 0.45, 0.9])
    return TabulatedWater("absorbing", Spectrum1D(a, wl, "a"), Spectrum1D.constant(0.0), HenyeyGreenstein(0.8))


def _exact_cells(scene, cells: int, sub: int = 12, lam_sub: int = 41):
    """(cells, cells, B) exact direct irradiance averaged over each cell's part of the disk, and that part's
    share of the cell."""
    t = scene.targets[0]
    from rigsim.scene.surfaces import target_surfaces

    (p,) = target_surfaces(t, scene.camera)
    c0, u, v, n = (np.asarray(x, float) for x in (p.center_m, p.u_axis, p.v_axis, p.normal))
    R = p.size_m[0] / 2
    g = (np.arange(cells * sub) + 0.5) / (cells * sub) * 2 - 1
    A, Bv = np.meshgrid(g, g, indexing="ij")
    inside = A ** 2 + Bv ** 2 <= 1
    pts = c0 + R * (A[..., None] * u + Bv[..., None] * v)
    lam = CENTRES[:, None] + 100.0 * ((np.arange(lam_sub) + 0.5) / lam_sub - 0.5)[None, :]
    c = scene.water.c_per_m(lam)
    E = np.zeros(A.shape + (len(CENTRES),))
    for light in scene.lights:
        geo, r = light_geometry(light, pts, n)
        I = np.interp(lam, light.wavelength_nm, light.axial_intensity)  # (B, lam_sub)
        att = np.exp(-c[None, None] * r[..., None, None])  # (.., B, lam_sub)
        E += geo[..., None] * (I[None, None] * att).mean(axis=-1)
    E = np.where(inside[..., None], E, 0.0)
    Ec = E.reshape(cells, sub, cells, sub, -1).sum(axis=(1, 3))
    k = inside.reshape(cells, sub, cells, sub).sum(axis=(1, 3))
    return Ec / np.maximum(k, 1)[..., None], k / sub ** 2


@pytest.mark.parametrize("nee", [True, False])
def test_direct_irradiance_of_a_strobe_in_absorbing_water_is_exact(nee):
    beam = BeamPattern(beam_angle_deg=60.0, edge_exponent=2.0)
    light = make_light("strobe", position=(0.3, 0.15, 0.0),
                       aim=(np.sin(np.radians(15)), 0, np.cos(np.radians(15))), beam=beam,
                       wavelength_nm=(360.0, 830.0), intensity=(1.0, 3.0))
    scene = disk_scene(_absorbing_water(), [light], distance=1.0, size=1.0)
    cells = 4
    r = trace_target_irradiance(scene, wavelength_nm=CENTRES, bandwidth_nm=100.0, photons=400_000 if nee else 1_200_000, seed=3,
                                batches=16, cells=cells, nee=nee)
    exact, share = _exact_cells(scene, cells)
    full = share > 0.999  # cells entirely on the disk
    assert full.sum() >= 4
    per = r.batches[:, 0][:, full]  # (batches, cells, B)
    mean, se = per.mean(axis=0), per.std(axis=0, ddof=1) / np.sqrt(per.shape[0])
    z = (mean - exact[full]) / se
    assert np.all(np.abs(z) < 4.5), z
    assert 0.3 < np.mean(z ** 2) < 2.5, z  # χ²/dof of the cells × bands
    assert np.all(se / exact[full] < 0.02), se / exact[full]  # the test has the power to see a 5 % error
    # over the whole disk (area-weighted): exact within 4 SE, and within 1 %
    whole = (exact * share[..., None]).sum(axis=(0, 1)) / share.sum()
    m, s = r.piece_mean(0), r.piece_standard_error(0)
    assert np.all(np.abs(m - whole) < 4 * s + 1e-3 * whole), (m / whole - 1, s / whole)
    assert np.all(np.abs(m / whole - 1) < 0.01), m / whole - 1


def test_irradiance_in_scattering_water_agrees_with_the_fast_engines_light_tracer():
    from rigsim.config.rig import load_rig
    from rigsim.preview.geometry import scene_surfaces
    from rigsim.preview.multiple import _cell_areas, trace_multiple
    from rigsim.scene.build import build_scene
    from rigsim.scene.phase_tables import phase_tables
    from rigsim.water import preset

    water = preset("jerlov-III")  # albedo 0.9+: most of the light on the disk has scattered
    scene = build_scene(load_rig(ROOT / "rigs" / "twin-strobes-45-wide.toml"), water, "white-disk", 2.0, size_m=1.0)
    wl = np.arange(400.0, 701.0, 20.0)
    surf = scene_surfaces(scene)
    tab = phase_tables(water.phase, water.wavelength_range_nm)
    strobes = [l for l in scene.lights if l.kind == "strobe"]
    lt = trace_multiple(scene, surf, strobes, wl, c=water.c_per_m(wl), b=water.b_per_m(wl),
                        kappa_cam=water.c_per_m(wl), tables=tab, weights=tab.weights_at(wl), width=48, height=32,
                        cutoff_rad=np.radians(30.0), photons=120_000, classes="irradiance", spectral_nodes=None,
                        seed=1, batches=8)
    r = trace_target_irradiance(scene, wavelength_nm=wl, photons=1_000_000, seed=2, batches=8)
    a = np.where(np.isfinite(_cell_areas(surf)[0]), _cell_areas(surf)[0], 0.0)[..., None]
    np_per = np.array([(lt.batch(j).irradiance[0] * a).sum((0, 1)) / a.sum() for j in range(lt.n_batches)])
    dj_per = np.array([r.piece_mean(0, j) for j in range(r.batches.shape[0])])
    for lo, hi in ((0, 5), (5, 10), (10, 16)):  # blue, green, red
        x, y = np_per[:, lo:hi].mean(axis=1), dj_per[:, lo:hi].mean(axis=1)
        sx, sy = x.std(ddof=1) / np.sqrt(len(x)), y.std(ddof=1) / np.sqrt(len(y))
        assert sx / x.mean() < 0.01 and sy / y.mean() < 0.01, (sx / x.mean(), sy / y.mean())
        z = (y.mean() - x.mean()) / np.hypot(sx, sy)
        assert abs(z) < 4.0, (lo, y.mean() / x.mean() - 1, z)
    # most of the light is scattered light here: a check of the transport, not of the direct light alone
    direct = trace_target_irradiance(scene, wavelength_nm=wl, photons=200_000, seed=4, batches=4, mode="direct")
    assert np.all(direct.piece_mean(0) < 0.6 * r.piece_mean(0)), direct.piece_mean(0) / r.piece_mean(0)
