"""Typed provenance: a Scene survives its JSON record, and a SpectralImage its files, exactly."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from rigsim.config.rig import load_rig
from rigsim.errors import ConfigError
from rigsim.scene.build import build_scene
from rigsim.scene.phase_tables import phase_tables
from rigsim.scene.record import scene_from_record, scene_record, water_from_record, water_record
from rigsim.scene.types import Daylight
from rigsim.spectral_image import RenderInfo, SpectralImage
from rigsim.water import preset
from rigsim.water.model import Spectrum1D, TabulatedWater
from rigsim.water.phase import FournierForand, HenyeyGreenstein


def _round_trip(obj_record):
    return json.loads(json.dumps(obj_record))


@pytest.mark.parametrize("name", ["coastal", "lakes-and-rivers", "jerlov-II", "jerlov-7C"])
def test_named_waters_come_back_as_themselves(name):
    w = preset(name)
    back = water_from_record(_round_trip(water_record(w)))
    assert back == w or back is w
    wl = np.linspace(400, 700, 31)
    np.testing.assert_array_equal(back.c_per_m(wl), w.c_per_m(wl))


@pytest.mark.parametrize("phase", [HenyeyGreenstein(0.92), FournierForand.from_backscatter_fraction(0.012)])
def test_an_explicit_iop_water_keeps_its_tables(phase):
    wl = np.array([360.0, 450.0, 550.0, 650.0, 830.0])
    w = TabulatedWater("mine", Spectrum1D(np.array([0.5, 0.1, 0.07, 0.4, 2.0]), wl, "a.csv"),
                       Spectrum1D.constant(0.8), phase, source="test")
    back = water_from_record(_round_trip(water_record(w)))
    grid = np.linspace(360, 830, 95)
    np.testing.assert_array_equal(back.a_per_m(grid), w.a_per_m(grid))
    np.testing.assert_array_equal(back.b_per_m(grid), w.b_per_m(grid))
    t0 = phase_tables(w.phase, w.wavelength_range_nm)
    t1 = phase_tables(back.phase, back.wavelength_range_nm)
    np.testing.assert_allclose(t1.masses, t0.masses, rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(t1.weights, t0.weights, rtol=1e-12)


def test_a_mixture_water_not_named_keeps_its_wavelength_dependent_tables():
    """Kopelevich phase of a constituent water, recorded as tables under another name."""
    src = preset("coastal")
    w = TabulatedWater("custom-kopelevich", Spectrum1D.constant(0.2), Spectrum1D.constant(0.3), src.phase)
    back = water_from_record(_round_trip(water_record(w)))
    t0 = phase_tables(w.phase, w.wavelength_range_nm)
    t1 = phase_tables(back.phase, back.wavelength_range_nm)
    assert t1.n_components == 3
    np.testing.assert_allclose(t1.masses, t0.masses, rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(t1.weights, t0.weights, rtol=1e-12, atol=1e-15)
    mu = np.cos(np.radians([0.01, 1.0, 30.0, 150.0]))
    np.testing.assert_allclose(t1.eval(mu, 480.0), t0.eval(mu, 480.0), rtol=1e-12)


def test_scene_round_trip_with_daylight_and_strobes():
    rig = load_rig("rigs/twin-strobes-edge-lighting.toml")
    sc = build_scene(rig, "jerlov-II", "colorchecker", 1.7,
                     daylight=Daylight(depth_m=12.0, sun_zenith_deg=40.0, model="monte-carlo", photons=3000))
    back = scene_from_record(_round_trip(scene_record(sc)))
    assert back.rig == sc.rig and back.targets == sc.targets and back.daylight == sc.daylight
    assert back.water is sc.water or back.water == sc.water


def test_spectral_image_files_carry_the_scene(tmp_path):
    rig = load_rig("rigs/twin-strobes-45-wide.toml")
    sc = build_scene(rig, "coastal", "white-disk", 2.0)
    img = SpectralImage(np.ones((4, 6, 2), np.float32), np.array([450.0, 550.0]), np.array([10.0, 10.0]),
                        scene=sc, render=RenderInfo("mitsuba", seed=3, spp=64, integrator="rigsim"))
    img.save(tmp_path / "r")
    back = SpectralImage.load(tmp_path / "r")
    assert back.scene.camera == sc.camera and back.scene.camera.f_number == rig.camera.f_number
    assert back.render == img.render
    # an image of unknown origin has none
    bare = dataclasses.replace(img, scene=None, render=None)
    bare.save(tmp_path / "b")
    assert SpectralImage.load(tmp_path / "b").scene is None


def test_malformed_records_are_one_line_errors(tmp_path):
    sc = build_scene(load_rig("rigs/twin-strobes-45-wide.toml"), "clear", "black-disk", 1.0)
    rec = scene_record(sc)
    for bad in ({**rec, "version": 99}, {**rec, "rig": {"name": "x"}},
                {**rec, "water": {"kind": "soup"}}, {**rec, "targets": [{"kind": "black-disk", "bogus": 1}]}):
        with pytest.raises(ConfigError) as e:
            scene_from_record(bad)
        assert "\n" not in str(e.value)
    d = tmp_path / "r"
    SpectralImage(np.ones((2, 2, 1), np.float32), np.array([550.0]), np.array([10.0]), scene=sc).save(d)
    (d / "scene.json").write_bytes(b"\x00\xff garbage")
    with pytest.raises(ConfigError, match="scene.json"):
        SpectralImage.load(d)


def test_a_kept_render_with_marine_snow_loads_back_with_its_signed_particle_layers(tmp_path):
    """The particles' layers are their light less the light they hide: negative where they hide more (a Monte Carlo
    difference of two renders is negative in places).  Kept renders with them load back (until 2026-12-06 they were
    refused as corrupt, so every resumed study with marine snow rendered its checks again); a negative radiance, or a
    particles layer that is not finite, is still refused with one line naming the file."""
    wl, bw = np.array([450.0, 550.0]), np.array([10.0, 10.0])
    part = np.full((4, 6, 2), -0.1, np.float32)
    img = SpectralImage(np.ones((4, 6, 2), np.float32), wl, bw, layers={"flash": np.ones((4, 6, 2), np.float32),
                                                                        "flash_particles": part, "particles": part})
    img.save(tmp_path / "ok")
    back = SpectralImage.load(tmp_path / "ok")
    assert np.array_equal(back.layers["flash_particles"], part) and np.array_equal(back.layers["particles"], part)
    for name, bad in (("flash", -np.ones((4, 6, 2), np.float32)),
                      ("flash_particles", np.full((4, 6, 2), np.nan, np.float32))):
        d = tmp_path / name
        dataclasses.replace(img, layers={**img.layers, name: bad}).save(d)
        with pytest.raises(ConfigError, match=rf"spectral.npz.*corrupt: layer {name} has values"):
            SpectralImage.load(d)
