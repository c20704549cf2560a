"""The fast engine's speed-ups leave its answers unchanged, and its blur kernel cannot overflow.

The reference is ``tests/preview/reference`` — the engine as it was before the speed-ups (whole-image
float64 arrays, the full-size FFT, no caches, no threads), frozen.  The fast engine shades in tiles
on threads, in float32 where that is exact to ~1e-6, and blurs band by band; every layer must stay
within 1e-4 of the reference's, element by element.
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from rigsim.config.rig import load_rig
from rigsim.preview import render_preview as _render_preview
import rigsim.preview.model as preview_model
import rigsim.preview.tiles as preview_tiles
from rigsim.preview.forward import SmallAngle, unit_kernel
from rigsim.scene.build import build_scene
from rigsim.scene.phase_tables import phase_tables
from rigsim.scene.types import BeamPattern, Daylight, Port
from rigsim.water import preset
from tests.preview.helpers import absorbing_water, disk_scene, make_light
from tests.preview.reference.model import render_preview as reference_preview

RIGS = "rigs/"
WL3 = dict(wavelengths_nm=[450.0, 550.0, 650.0], bandwidth_nm=10.0)


def render_preview(scene, **kw):
    """The analytic model (the frozen reference has no multiply scattered light)."""
    return _render_preview(scene, **{"multiple": False, "edge_samples": 1, **kw})


def _lights():
    return [make_light(position=(0.4, 0.2, 0.0), aim=(np.sin(np.radians(20)), 0.0, np.cos(np.radians(20))),
                       intensity=3.0, beam=BeamPattern(beam_angle_deg=60.0), name="a"),
            make_light(position=(-0.3, 0.1, 0.05), intensity=(1.0, 2.0), name="b"),
            make_light("continuous", position=(0, 0.3, 0), name="v")]


def _case(name):
    rig = load_rig(RIGS + "twin-strobes-45-wide.toml")
    if name == "strobes-daylight-thick-water":  # the benchmark's scene, small
        return build_scene(rig, "jerlov-3C", "colorchecker", 2.0, size_m=0.8, daylight=Daylight(depth_m=10.0)), \
            dict(width=64, height=43, split=True)
    if name == "chart-every-layer":
        return build_scene(rig, "coastal", "colorchecker", 2.0), \
            dict(width=48, height=32, split=True, layers=("range_m", "clear", "object_id", "direct", "backscatter"))
    if name == "three-lights-shadows":
        return disk_scene(preset("coastal"), _lights(), distance=2.0, size=0.6), \
            dict(width=20, height=20, split=True, shadows=True, layers=("clear",))
    if name == "pixel-samples-2-one-sub-band":
        return build_scene(rig, "coastal", "colorchecker", 1.5), \
            dict(width=36, height=24, split=True, pixel_samples=2, sub_bands=1)
    if name == "no-water":
        return disk_scene(None, _lights(), distance=1.5, size=0.9), \
            dict(width=16, height=16, split=True, layers=("clear",), **WL3)
    if name == "single-scattering-every-ray":
        return build_scene(rig, "coastal", "colorchecker", 3.0), \
            dict(width=36, height=24, split=True, forward_scatter=False, backscatter_grid=None)
    if name == "flat-port-bottom-waves":  # several range bins in the blur, caustics
        flat = dataclasses.replace(rig, camera=dataclasses.replace(rig.camera, port=Port(kind="flat")))
        return build_scene(flat, "coastal", "bottom", 1.5, daylight=Daylight(depth_m=6.0, waves="sines")), \
            dict(width=48, height=32, split=True)
    if name == "pure-water-close-daylight":  # short lines of sight: the float64 path radiance
        return build_scene(load_rig(RIGS + "video-lights-pair.toml"), "pure-water", "white-disk", 0.4,
                           daylight=Daylight(depth_m=3.0)), dict(width=36, height=24, split=True)
    if name == "absorbing-water":
        return disk_scene(absorbing_water(), _lights()[:2], distance=1.5, size=0.9), \
            dict(width=16, height=16, split=True, **WL3)
    if name == "small-cut-off":
        return build_scene(rig, "coastal", "slanted-edge", 2.0), \
            dict(width=36, height=24, split=True, forward_cutoff_deg=5.0)
    if name == "turbid-far-pixel-samples-3":
        return build_scene(rig, "turbid-lake", "colorchecker", 10.0,
                           daylight=Daylight(depth_m=4.0, sun_zenith_deg=50.0)), \
            dict(width=36, height=24, split=True, pixel_samples=3)
    raise KeyError(name)


CASES = ["strobes-daylight-thick-water", "chart-every-layer", "three-lights-shadows", "pixel-samples-2-one-sub-band",
         "no-water", "single-scattering-every-ray", "flat-port-bottom-waves", "pure-water-close-daylight",
         "absorbing-water", "small-cut-off", "turbid-far-pixel-samples-3"]


def _all_layers(img):
    return dict(img.layers, radiance=img.radiance)


def _assert_same(new, ref, rtol=1e-4):
    """Every layer: same keys, dtype and shape; integers and ranges equal; values within ``rtol`` of the
    reference element by element (plus 1e-7 of the layer's largest value, for the zeros)."""
    assert set(new) == set(ref)
    for k, a in ref.items():
        b = new[k]
        assert b.dtype == a.dtype and b.shape == a.shape, k
        if a.dtype.kind != "f" or k == "range_m":
            np.testing.assert_array_equal(b, a, err_msg=k)
            continue
        assert np.all(np.isfinite(b)), k
        scale = float(np.abs(a).max())
        np.testing.assert_allclose(b, a, rtol=rtol, atol=1e-7 * scale, err_msg=k)


@pytest.mark.parametrize("name", CASES)
def test_layers_are_those_of_the_straightforward_model(name, monkeypatch):
    """Each layer of the fast engine within 1e-4 of the reference, in tiles of a few rows (many tiles)."""
    scene, kw = _case(name)
    monkeypatch.setattr(preview_tiles, "TILE_SAMPLES", 200)
    # three refinements came after the reference was frozen, each checked against Monte Carlo: daylight
    # sub-bands, the veil of every sample of a pixel (tests/preview/test_daylight_bands.py), the veil from
    # behind a target (tests/preview/test_preview_vs_render.py)
    monkeypatch.setattr(preview_model, "DAYLIGHT_MAX_SUB", 1)
    monkeypatch.setattr(preview_model, "SAMPLE_VEILS", False)
    monkeypatch.setattr(preview_model, "VEIL_BEHIND", False)
    monkeypatch.setattr(preview_model, "SPREAD_PHASE", False)
    monkeypatch.setattr(preview_model, "BLUR_PORT", False)
    monkeypatch.setattr(preview_model, "BLUR_EQUIDISTANT", False)
    monkeypatch.setattr(preview_model, "VEIL_SHADOWS", False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the reference's expm1 overflows in thick water; aspect warnings
        ref = _all_layers(reference_preview(scene, **kw))
        new = _all_layers(render_preview(scene, **kw))
    _assert_same(new, ref)


def test_threads_and_tiles_do_not_change_the_image(monkeypatch):
    scene, kw = _case("strobes-daylight-thick-water")
    a = _all_layers(render_preview(scene, threads=1, **kw))
    b = _all_layers(render_preview(scene, threads=3, **kw))
    monkeypatch.setattr(preview_tiles, "TILE_SAMPLES", 10_000_000)  # one tile
    c = _all_layers(render_preview(scene, threads=2, **kw))
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)
        np.testing.assert_allclose(c[k], a[k], rtol=1e-6, atol=0, err_msg=k)


def test_threads_follow_omp_num_threads_as_a_dask_worker_sets_it(monkeypatch):
    """A dask worker's nanny sets OMP_NUM_THREADS=1 (one process per core): the per-pixel passes then use one
    thread; unset or unreadable, every core this process may use."""
    import os

    cores = len(os.sched_getaffinity(0))
    monkeypatch.delenv("OMP_NUM_THREADS", raising=False)
    assert preview_tiles.default_threads() == cores
    monkeypatch.setenv("OMP_NUM_THREADS", "1")
    assert preview_tiles.default_threads() == 1
    monkeypatch.setenv("OMP_NUM_THREADS", str(cores + 5))
    assert preview_tiles.default_threads() == cores  # never more threads than cores
    monkeypatch.setenv("OMP_NUM_THREADS", "4,2")
    assert preview_tiles.default_threads() == cores


def test_huge_page_advice_is_restored():
    try:
        from numpy._core.multiarray import _get_madvise_hugepage
    except ImportError:
        pytest.skip("numpy without the huge-page switch")
    before = _get_madvise_hugepage()
    scene, kw = _case("no-water")
    render_preview(scene, **kw)
    assert _get_madvise_hugepage() == before


# --------------------------------------------------------------------------- the blur kernel
def _old_kernel(q, tau, F):
    """The kernel as the engine wrote it before: ``expm1(qτ)/expm1(τF)`` (overflows beyond τF ≈ 709)."""
    with np.errstate(over="ignore", invalid="ignore"):
        return np.expm1(q * tau) / np.expm1(tau * F)


@pytest.mark.parametrize("water", ["coastal", "jerlov-3C", "turbid-lake"])
def test_stable_kernel_is_finite_and_matches_the_old_form_where_that_is_finite(water):
    w = preset(water)
    comps = phase_tables(w.phase, w.wavelength_range_nm)
    wl = np.array([400.0, 550.0, 700.0])
    sa = SmallAngle(comps, np.pi / 2, w.b_per_m(wl), comps.weights_at(wl))
    nu = np.concatenate([[0.0], np.geomspace(1e-2, 2e5, 400)])
    q = sa.q(nu)  # (n, B)
    for r in [1e-7, 1e-3, 0.1, 1.0, 10.0, 100.0, 1e3, 1e4, 1e5]:
        tau = sa.b * r
        k = sa.kernel(nu, tau, q)
        assert np.all(np.isfinite(k)), r
        assert np.all(k >= 0.0) and np.all(k <= 1.0 + 1e-12), r
        np.testing.assert_allclose(k[0], 1.0, rtol=1e-12)  # ν = 0: unit mass
        old = _old_kernel(q, tau, sa.F)
        finite = np.isfinite(old) & (tau * sa.F < 700.0)[None, :]  # the old form did not overflow
        if r <= 1e3:
            assert finite.any()
        np.testing.assert_allclose(k[finite], old[finite], rtol=1e-9, atol=1e-12)
        # the float32 evaluation the blur uses where τF > 1/2, from the components' Q_k − F_k: within ~1e-6
        # of the float64 kernel (|τ(Q − F)| ≤ 100: beyond, the kernel is below e^{-100} at that frequency)
        big = tau * sa.F > 0.5
        if np.any(big):
            dk = (sa.q_components(nu) - sa.q_components(np.zeros(1))).astype(np.float32)  # (K, n): Q_k − F_k
            qmf = np.einsum("kn,bk->nb", dk, sa.w[big].astype(np.float32))
            k32 = unit_kernel(None, tau[big], sa.F[big], q_minus_F=qmf)
            assert k32.dtype == np.float32
            np.testing.assert_allclose(k32, k[:, big], rtol=1e-5, atol=2e-7)


def test_thick_water_at_tens_of_metres_gives_a_finite_image(monkeypatch):
    """Jerlov 3C at 50 m: the old kernel overflowed (τF > 709 in the beam tables, world radius 5 km) and
    turned whole bands of the flash and its backscatter to NaN; the stable form is finite and equals the
    old image wherever that was finite."""
    scene = build_scene(load_rig(RIGS + "twin-strobes-45-wide.toml"), "jerlov-3C", "colorchecker", 50.0)
    kw = dict(width=24, height=16, split=True)
    monkeypatch.setattr(preview_model, "SPREAD_PHASE", False)  # (came after the reference was frozen)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = _all_layers(reference_preview(scene, **kw))
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # no overflow warning either
        new = _all_layers(render_preview(scene, **kw))
    assert not np.all(np.isfinite(ref["flash"]))  # the defect this guards against
    for k, a in ref.items():
        if a.dtype.kind == "f" and k != "range_m":
            assert np.all(np.isfinite(new[k])), k
            fin = np.isfinite(a)
            np.testing.assert_allclose(new[k][fin], a[fin], rtol=1e-4, atol=1e-7 * np.abs(a[fin]).max())
