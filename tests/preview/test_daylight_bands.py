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
