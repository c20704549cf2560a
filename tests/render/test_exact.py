"""Renders against exact solutions: Beer–Lambert, point strobes, white furnace, preset ratios.

Tolerances: each check compares the mean over the pixels entirely on the target
with the exact value; the allowed error is 4 Monte Carlo standard errors (from the
per-pixel scatter) plus 0.2 % for the 1-nm resampling of spectra, and never more
than the stated physical tolerance (1 % for the strobe law).
"""

from __future__ import annotations

import numpy as np
import pytest

from rigsim.render import render
from rigsim.render.mitsuba_scene import MitsubaScene, water_medium_dict
from rigsim.render.renderer import band_edges, render_pass
from rigsim.render.variant import mitsuba
from rigsim.scene.types import BeamPattern
from rigsim.water import preset
from rigsim.water.model import Spectrum1D, TabulatedWater
from rigsim.water.phase import HenyeyGreenstein
from tests.render.helpers import (
    disk_scene,
    make_camera,
    make_light,
    reference_direct,
    relative_error,
)

pytestmark = pytest.mark.render
mi, dr = mitsuba()

WL = [450.0, 550.0, 650.0]
BW = 10.0  # nm: narrow bands (the default width is the 100-nm spacing)


def _absorbing_water():
    """Non-scattering water with a strongly wavelength-dependent c(λ) (1/m)."""
    wl = np.array([360.0, 450.0, 550.0, 650.0, 830.0])
    a = np.array([0.05, 0.08, 0.2, 0.45, 0.9])
    return TabulatedWater("absorbing", Spectrum1D(a, wl, "a"), Spectrum1D.constant(0.0), HenyeyGreenstein(0.8))


def test_beer_lambert_continuous_light_off_axis():
    """(a) albedo 0: L = ρ I f(θ) cos θ_i / (π r²) · exp(−c (r + s)), a light aimed 20° off the patch."""
    beam = BeamPattern(beam_angle_deg=60.0, edge_exponent=2.0)
    light = make_light("continuous", position=(0.4, 0.2, 0.0), aim=(np.sin(np.radians(20)), 0, np.cos(np.radians(20))),
                       intensity=3.0, beam=beam)
    scene = disk_scene(_absorbing_water(), [light], distance=1.5, size=2.0, reflectance=0.8)
    w, h = 30, 20
    img = render(scene, width=w, height=h, spp=96, seed=3, wavelengths_nm=WL, bandwidth_nm=BW, layers=())
    wl, bw = band_edges(WL, BW)
    ref, inside = reference_direct(scene, w, h, wl, bw)
    rel, se = relative_error(img.radiance, ref, inside)
    assert np.all(np.abs(rel) < 4 * se + 2e-3), (rel, se)
    assert np.all(np.abs(rel) < 0.01)
    assert "flash" not in img.layers


def test_strobe_in_pure_sea_water_exact_within_one_percent():
    """(b) a point strobe facing a white Lambertian patch in pure-sea water.

    The unscattered (``flash_direct``) radiance is ρ I/(π d²) exp(−2cd) on the axis
    (exactly, per pixel, with the off-axis geometry); scattering in pure sea water
    only adds a little light on top (``flash`` ≥ direct, by < 3 %).
    """
    water = preset("pure-sea")
    # beside the camera (a strobe at the pupil would light the water in front of the port
    # at r → 0 and make the backscatter diverge)
    light = make_light("strobe", position=(0.25, 0.0, 0.0), aim=(-0.25, 0.0, 1.0), intensity=5.0,
                       beam=BeamPattern(kind="table", angle_deg=(0.0, 10.0, 40.0, 90.0),
                                        relative=(1.0, 1.0, 0.5, 0.0)))
    scene = disk_scene(water, [light], distance=1.0, size=1.0, reflectance=0.9)
    w, h = 24, 16
    img = render(scene, width=w, height=h, spp=96, seed=5, wavelengths_nm=WL, bandwidth_nm=BW, layers=(), split=True)
    assert np.all(img.radiance == 0)
    assert {"flash", "flash_direct", "flash_backscatter"} <= set(img.layers)
    wl, bw = band_edges(WL, BW)
    ref, inside = reference_direct(scene, w, h, wl, bw)
    # the law itself: centre pixel of the reference vs ρ I cos θ_i/(π d²) e^{−c (d + 1 m)} (band-averaged)
    d = np.hypot(0.25, 1.0)
    lam = np.array(WL)[:, None] + np.linspace(-BW / 2, BW / 2, 201)[None, :]
    law = 0.9 * 5.0 / (np.pi * d**2) * (1.0 / d) * np.exp(-water.c_per_m(lam) * (d + 1.0)).mean(axis=1)
    assert np.allclose(ref[h // 2 - 1:h // 2 + 1, w // 2 - 1:w // 2 + 1].mean(axis=(0, 1)), law, rtol=1e-3)
    rel, se = relative_error(img.layers["flash_direct"], ref, inside)
    assert np.all(np.abs(rel) < 4 * se + 2e-3), (rel, se)
    assert np.all(np.abs(rel) < 0.01)
    full = img.layers["flash"][inside].mean(axis=0)
    direct = img.layers["flash_direct"][inside].mean(axis=0)
    assert np.all(full >= direct * (1 - 3 * se.max())) and np.all(full < direct * 1.03)


def test_white_furnace_albedo_one_spectral_phase():
    """(c) albedo-1 water (wavelength-dependent phase and σ_t) inside black walls emitting L_e:
    the radiance everywhere inside is L_e (energy conservation of the phase sampler)."""
    coastal = preset("coastal")
    wl_b = np.array([360.0, 830.0])
    water = TabulatedWater("furnace", Spectrum1D.constant(0.0), Spectrum1D(np.array([1.0, 3.0]), wl_b, "b"),
                           coastal.phase)
    le = {"type": "irregular", "wavelengths": "360, 830", "values": "1, 2"}
    d = {"type": "scene", "integrator": {"type": "volpath", "max_depth": -1, "rr_depth": 50},
         "water": water_medium_dict(water),
         "walls": {"type": "sphere", "radius": 1.0, "flip_normals": True,
                   "bsdf": {"type": "diffuse", "reflectance": 0.0},
                   "emitter": {"type": "area", "radiance": le},
                   "interior": {"type": "ref", "id": "water"}}}
    loaded = mi.load_dict(d)
    medium = [s for s in loaded.shapes() if s.id() == "walls"][0].interior_medium()
    ms = MitsubaScene(scene=loaded, medium=medium, surfaces=[])
    wl, bw = band_edges(WL, BW)
    img, dropped = render_pass(ms, make_camera("dome", focal_length_mm=24.0), width=18, height=12, spp=64, seed=1,
                               band_lo=wl - bw / 2, band_w=bw)
    assert dropped == 0
    expected = 1.0 + (wl - 360.0) / 470.0
    mean = img.reshape(-1, 3).mean(axis=0)
    se = img.reshape(-1, 3).std(axis=0) / np.sqrt(18 * 12)
    assert np.all(np.abs(mean - expected) < 4 * se + 2e-3 * expected), (mean, expected, se)


def test_presets_differ_as_their_attenuation_predicts():
    """(d) direct radiance ratio of two presets = band average of exp(−Δc · path)."""
    light = make_light("continuous", position=(0.0, 0.0, 0.0), intensity=4.0)
    out = {}
    for name in ("clear", "coastal"):
        scene = disk_scene(preset(name), [light], distance=2.0, size=1.0)
        img = render(scene, width=18, height=12, spp=64, seed=7, wavelengths_nm=WL, bandwidth_nm=BW, layers=(), split=True)
        wl, bw = band_edges(WL, BW)
        ref, inside = reference_direct(scene, 18, 12, wl, bw)
        out[name] = (img.layers["direct"][inside].mean(axis=0), ref[inside].mean(axis=0))
    measured = out["coastal"][0] / out["clear"][0]
    predicted = out["coastal"][1] / out["clear"][1]
    c1, c2 = preset("clear").c_per_m(np.array(WL)), preset("coastal").c_per_m(np.array(WL))
    assert np.allclose(predicted, np.exp(-(c2 - c1) * 4.0), rtol=0.03)  # the law at the band centres
    assert np.allclose(measured, predicted, rtol=0.02), (measured, predicted)


def test_no_water_is_the_clear_layer_and_inverse_square_law():
    light = make_light("continuous", position=(0.0, 0.0, 0.0), intensity=1.0)
    scene = disk_scene(None, [light], distance=2.0, size=2.0)
    img = render(scene, width=18, height=12, spp=16, seed=1, wavelengths_nm=[550.0], layers=("clear",),
                 split=True)
    assert np.array_equal(img.layers["clear"], img.radiance)
    assert np.all(img.layers["backscatter"] == 0)
    wl, bw = band_edges([550.0])
    ref, inside = reference_direct(scene, 18, 12, wl, bw)
    # no medium and a single light: no noise at all on the disk
    assert np.allclose(img.radiance[inside], ref[inside], rtol=2e-3)
