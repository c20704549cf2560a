"""Duntley's black-disk law in both daylight models and both engines.

For a black target seen along a horizontal line of sight at depth, radiative transfer gives an
apparent contrast against the water behind it of ``C(t) = −exp(−c t)`` (t the path through the
water), whatever the angular distribution of daylight (Duntley 1963; Zaneveld & Pegau 2003, Opt.
Express 11:2997).  The contrast is taken per pixel against the same pixel of the image without the
target (the water behind it in the same direction: against a background from other directions an
anisotropic field — the Monte Carlo one — biases it), over pixels wholly on the disk, and fitted as
``ln(−C) = ln C₀ − c t`` with ``t`` the range minus the port's reach.  The law then holds to a few
parts in a thousand; the CI bounds are the issue's (5 % on c, |C₀| within 5 % of 1).

A grey target is lit by the same field in both engines (sun beam, the diffuse field integrated
over its hemisphere) and seen through the same path radiance: their images of it agree.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import binary_erosion

from rigsim.config.rig import load_rig
from rigsim.preview import render_preview
from rigsim.render import render
from rigsim.scene.build import build_scene
from rigsim.scene.optics import port_reach_m
from rigsim.scene.types import Daylight, Scene
from rigsim.water.model import Spectrum1D, TabulatedWater
from rigsim.water.phase import petzold_average_particle

pytestmark = pytest.mark.render

A, B = 0.1, 0.4  # 1/m: c = 0.5
W, H = 42, 28


_WATER = TabulatedWater("a=0.1,b=0.4,petzold", Spectrum1D.constant(A), Spectrum1D.constant(B),
                        petzold_average_particle(), wavelength_nm=[550.0])
#: Photons of the Monte Carlo field: the law holds for any field, so a coarse one will do
PHOTONS = 4000


def _water():
    return _WATER  # one object: the daylight field is cached per water


def _daylight(model):
    return Daylight(depth_m=10.0, sun_zenith_deg=30.0, model=model, photons=PHOTONS)


def _image(engine, scene, spp=4):
    kw = dict(width=W, height=H, wavelengths_nm=[550.0], bandwidth_nm=1.0)
    if engine == "preview":
        return render_preview(scene, **kw)
    return render(scene, spp=spp, seed=5, **kw)


def _contrast_samples(engine, model, reflectance, distances, spp=4):
    rig = load_rig("rigs/ambient-only.toml")
    water = _water()
    dl = _daylight(model)
    open_water = _image(engine, Scene(rig=rig, water=water, targets=(), daylight=dl), spp)
    L0 = open_water.radiance[..., 0].astype(float)
    reach = port_reach_m(rig.camera)
    t_all, c_all = [], []
    for r in distances:
        sc = build_scene(rig, water, "black-disk", r, size_m=0.45 * r, reflectance=reflectance, daylight=dl)
        im = _image(engine, sc, spp)
        inside = binary_erosion(im.layers["object_id"] == 1, iterations=1)  # pixels wholly on the disk
        assert inside.sum() >= 20
        t_all.append(im.layers["range_m"][inside].astype(float) - reach)
        c_all.append(im.radiance[..., 0][inside] / L0[inside] - 1.0)
    return np.concatenate(t_all), np.concatenate(c_all)


@pytest.mark.parametrize("engine", ["render", "preview"])
@pytest.mark.parametrize("model", ["kd", "monte-carlo"])
def test_black_disk_contrast_is_minus_exp_minus_c_t(engine, model):
    t, C = _contrast_samples(engine, model, 0.0, (1.0, 2.0, 3.0, 4.0))
    assert np.all(C < 0)
    slope, icpt = np.polyfit(t, np.log(-C), 1)
    c_fit, c0 = -slope, np.exp(icpt)
    assert c_fit == pytest.approx(A + B, rel=0.05), (c_fit, c0)
    assert c0 == pytest.approx(1.0, abs=0.05), (c_fit, c0)


@pytest.mark.parametrize("model", ["kd", "monte-carlo"])
def test_a_grey_plate_looks_the_same_in_both_engines(model):
    """A 30 % grey plate lit by the same field (its sun beam, diffuse light and Duntley's path
    radiance in front of it): the fast engine's mean radiance over the plate equals the renderer's
    (measured: within 0.25 %; the renderer's sampling of the diffuse light on the plate is its noise)."""
    rig = load_rig("rigs/ambient-only.toml")
    dl = _daylight(model)
    for r in (1.5, 3.0):
        sc = build_scene(rig, _water(), "black-disk", r, size_m=0.45 * r, reflectance=0.3, daylight=dl)
        ims = {e: _image(e, sc, 64) for e in ("preview", "render")}
        inside = binary_erosion(ims["render"].layers["object_id"] == 1, iterations=1)
        lp, lr = (ims[e].radiance[..., 0][inside].astype(float) for e in ("preview", "render"))
        assert lp.mean() == pytest.approx(lr.mean(), rel=0.02), (model, r, lp.mean() / lr.mean() - 1)
