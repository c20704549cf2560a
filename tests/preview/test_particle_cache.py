"""The fast engine keeps the particles' geometry between images that differ only in their lights: the
images are the same as without the cache, and a different camera or target is not served from it."""

from __future__ import annotations

import numpy as np

import rigsim.preview.particles as P
from rigsim.config.rigdoc import RigDoc
from rigsim.preview import render_preview
from rigsim.scene.build import build_scene
from rigsim.water import preset
from rigsim.water.model import with_particles
from rigsim.water.particles import particle_level

WATER = with_particles(preset("coastal"), particle_level("coastal"))
LAYERS = ("range_m", "object_id", "particles", "particle_id")


def _image(doc: RigDoc, distance_m: float = 1.5):
    scene = build_scene(doc.rig(), WATER, "colorchecker", distance_m, size_m=0.8)
    return render_preview(scene, width=64, height=43, wavelengths_nm=[450.0, 550.0, 650.0], layers=LAYERS,
                          multiple=False)


def _same(a, b):
    for k in ("flash", "flash_particles", "particle_id"):
        assert np.array_equal(a.layers[k], b.layers[k]), k


def test_moving_a_light_reuses_the_geometry_and_changes_nothing_else():
    doc = RigDoc.load("rigs/twin-strobes-45-wide.toml")
    moved = doc.edit_light(0, "arm_length_m", 0.7)
    P._GEOMETRY.clear()
    fresh_moved = _image(moved)
    P._GEOMETRY.clear()
    first = _image(doc)
    assert len(P._GEOMETRY) == 1
    cached_moved = _image(moved)  # the same camera, particles and targets: from the cache
    assert len(P._GEOMETRY) == 1
    _same(cached_moved, fresh_moved)
    assert not np.array_equal(first.layers["flash_particles"], cached_moved.layers["flash_particles"])
    again = _image(doc)
    _same(again, first)
    again.layers["particle_id"][:] = -1  # a caller's change does not reach the cache
    _same(_image(doc), first)


def test_another_target_distance_is_not_served_from_the_cache():
    doc = RigDoc.load("rigs/twin-strobes-45-wide.toml")
    P._GEOMETRY.clear()
    _image(doc, 1.5)
    far = _image(doc, 2.5)
    assert len(P._GEOMETRY) == 2
    P._GEOMETRY.clear()
    _same(_image(doc, 2.5), far)
