"""The fast engine's daylight is the band mean of the field, as the renderer's.

Deep in turbid water the daylight falls steeply with wavelength in the red (Jerlov 3C at 15 m:
``e^{−K_d z}`` with ``K_d`` rising by about 0.01 /m per nm), and its value at a band's centre is
below the band's mean.  The renderer draws wavelengths across each band; the fast engine read the
centre: the open water was 5.5 % and the red chart patches 8–10 % darker than Monte Carlo.
"""

from __future__ import annotations

import pytest

from rigsim.config.rig import load_rig
from rigsim.preview import render_preview
from rigsim.scene.build import build_scene
from rigsim.scene.daylight_field import daylight_from_options

pytestmark = pytest.mark.render

WL = [450.0, 550.0, 650.0]


def test_deep_turbid_daylight_agrees_with_monte_carlo_in_the_red():
    from rigsim.metrics.agreement import compare_renders
    from rigsim.render import render

    rig = load_rig("rigs/ambient-only.toml")
    scene = build_scene(rig, "jerlov-3C", "black-disk", 1.0, size_m=0.35,
                        daylight=daylight_from_options(15.0, sun_zenith_deg=30.0, model="kd"))
    kw = dict(width=48, height=32, wavelengths_nm=WL, bandwidth_nm=10.0, layers=("object_id", "backscatter"))
    refs = [render(scene, spp=32, seed=3 + 7919 * i, **kw) for i in range(3)]
    fast = render_preview(scene, **kw)
    regions, _ = compare_renders(fast, refs, "black-disk")
    red = [r for r in regions if r.group == "red" and r.region in ("open water", "disk")]
    assert len(red) == 2
    for r in red:
        assert abs(r.deviation) < 0.02 + 3 * r.deviation_se, (r.region, r.deviation, r.deviation_se)


def test_deep_clear_daylight_band_products_and_rim_veil_agree_with_monte_carlo():
    """Deep in clear water the field and the water's transmission fall together across a red band
    (Jerlov I at 15 m): the band mean of their product is not the product of their band means — the
    fast engine's black disk at 3 m was +12.8 ± 0.8 % over Monte Carlo in the red with one row per band,
    within 0.5 % with sub-bands.  And the pixels on the disk's rim see the water beyond it with part of
    their box: the veil of a rim pixel is the mean of its sample rays' veils (the backscatter share of
    the target was −4.4 ± 0.3 % with the centre's veil alone)."""
    from rigsim.metrics.agreement import compare_renders
    from rigsim.render import render

    rig = load_rig("rigs/ambient-only.toml")
    scene = build_scene(rig, "jerlov-I", "black-disk", 3.0, size_m=0.9,
                        daylight=daylight_from_options(15.0, sun_zenith_deg=30.0, model="kd"))
    kw = dict(width=48, height=32, wavelengths_nm=[float(x) for x in range(550, 701, 10)], bandwidth_nm=10.0,
              layers=("object_id", "backscatter"))
    refs = [render(scene, spp=32, seed=3 + 7919 * i, **kw) for i in range(3)]
    fast = render_preview(scene, **kw)
    regions, metrics = compare_renders(fast, refs, "black-disk")
    disk = [r for r in regions if r.region == "disk" and r.group == "red"]
    share = [m for m in metrics if m.metric == "backscatter_share"]
    assert len(disk) == 1 and len(share) == 1
    for name, dev, se in (("disk red", disk[0].deviation, disk[0].deviation_se),
                          ("backscatter share", share[0].deviation, share[0].deviation_se)):
        assert abs(dev) < 0.02 + 3 * se, (name, dev, se)


def test_deep_clear_daylight_takes_each_sub_bands_own_reflectance():
    """At 15 m in Jerlov I the field falls by e^{2–3} across a red band while the red and magenta patches'
    reflectance rises steeply (580–620 nm): the band value is the mean of field × reflectance, not the band's
    mean field × the reflectance at its centre.  The fast engine's 10-nm bands against the mean of its own
    1-nm bands (where neither changes much across a band): before the sub-bands took their own reflectance the
    moderate red patch read 8 % high here (the agreement benchmark: +8.5 ± 1.1 % against 64 Monte Carlo
    renders in the red, magenta +6.8 ± 1.6 % in Jerlov IA).  And bands 1 nm wide read their own band means: the
    field of band means had written them into its 1-nm rows at the band centres, where 1-nm bands share rows
    (the open water here was 6 % low in 1-nm bands, against Monte Carlo's and the 10-nm bands' alike)."""
    import numpy as np

    from rigsim.metrics.agreement import comparison_regions

    rig = load_rig("rigs/ambient-only.toml")
    scene = build_scene(rig, "jerlov-I", "colorchecker", 1.0, size_m=0.9,
                        daylight=daylight_from_options(15.0, sun_zenith_deg=30.0, model="kd"))
    kw = dict(width=72, height=48, layers=("object_id",))
    coarse = render_preview(scene, wavelengths_nm=[585.0, 595.0, 605.0, 615.0, 625.0], bandwidth_nm=10.0, **kw)
    fine = render_preview(scene, wavelengths_nm=list(np.arange(580.5, 630.0, 1.0)), bandwidth_nm=1.0, **kw)
    regions = comparison_regions(np.asarray(coarse.layers["object_id"]), coarse.meta["object_ids"], "colorchecker")
    exact = np.asarray(fine.radiance, float).reshape(48, 72, 5, 10).mean(axis=-1)  # each 10-nm band's mean
    got = np.asarray(coarse.radiance, float)
    checked = 0
    for name in ("patch:moderate red", "patch:magenta", "patch:red", "patch:orange", "patch:green", "open water"):
        m = regions[name]
        assert m.sum() >= 4, name
        for b in range(5):
            want = exact[m][:, b].mean()
            assert abs(got[m][:, b].mean() / want - 1.0) < 0.01, (name, 585 + 10 * b, got[m][:, b].mean() / want - 1)
            checked += 1
    assert checked == 30
