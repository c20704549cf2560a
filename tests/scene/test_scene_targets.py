"""Target reflectances, geometry and image layout."""

import numpy as np
import pytest

from rigsim.scene.build import build_scene
from rigsim.scene.layout import target_layout
from rigsim.scene.reflectances import REFLECTANCE_WAVELENGTHS_NM, reflectance_benthic_Maritorena1994, reflectance_colorchecker_Ohta
from rigsim.scene.surfaces import COLORCHECKER_HEIGHT_M, COLORCHECKER_WIDTH_M, target_surfaces
from rigsim.scene.optics import pixel_rays, project_points
from rigsim.scene.types import Camera, Port, Rig


@pytest.fixture
def rig():
    return Rig(name="r", camera=Camera(focal_length_mm=24.0))


def test_colorchecker_reflectances():
    cc = reflectance_colorchecker_Ohta()
    assert len(cc) == 24 and list(cc)[0] == "dark skin" and list(cc)[-1].startswith("black")
    for r in cc.values():
        assert r.shape == REFLECTANCE_WAVELENGTHS_NM.shape and np.all((r >= 0) & (r <= 1))
    white = cc["white 9.5 (.05 D)"]
    assert 0.85 < white[np.searchsorted(REFLECTANCE_WAVELENGTHS_NM, 550)] < 0.95
    # edge-held outside 380–780 nm
    assert white[0] == white[REFLECTANCE_WAVELENGTHS_NM.tolist().index(380.0)]
    assert white[-1] == white[REFLECTANCE_WAVELENGTHS_NM.tolist().index(780.0)]


def test_the_bottom_is_the_measured_coral_sand(rig):
    """The ``bottom`` plane wears Maritorena et al.'s (1994) coral sand (data/targets/benthic_maritorena_1994.csv:
    0.281 at 400 nm, 0.394 at 500 nm, as their table), unless the target gives its own."""
    sc = build_scene(rig, None, "bottom", 1.0)
    (bottom,) = target_surfaces(sc.targets[0], sc.camera)
    wl = np.asarray(bottom.wavelength_nm)
    np.testing.assert_allclose(bottom.reflectance, reflectance_benthic_Maritorena1994(wl)["coral_sand"])
    assert np.interp([400.0, 500.0], wl, bottom.reflectance) == pytest.approx([0.281, 0.394], abs=1e-9)


def test_colorchecker_geometry(rig):
    sc = build_scene(rig, None, "colorchecker", 1.0)
    surfaces = target_surfaces(sc.targets[0], sc.camera)
    assert len(surfaces) == 25 and surfaces[0].name == "chart"
    assert surfaces[0].size_m == pytest.approx((COLORCHECKER_WIDTH_M, COLORCHECKER_HEIGHT_M))
    # top-left patch (dark skin) is left (image right = -x) and up, and 0.5 mm proud of the body
    ds = surfaces[1]
    assert ds.name == "dark skin"
    assert ds.center_m[0] > 0 and ds.center_m[1] > 0 and ds.center_m[2] == pytest.approx(0.9995)
    m = ds.matrix()
    corner = m @ np.array([1.0, 1.0, 0.0, 1.0])
    assert np.linalg.norm(corner[:3] - np.asarray(ds.center_m)) == pytest.approx(0.02 * np.sqrt(2))


def test_layout_colorchecker_patches_in_order(rig):
    sc = build_scene(rig, None, "colorchecker", 1.0)
    lay = target_layout(sc, 600, 400)
    cols = [lay.centers[n][0] for n in list(reflectance_colorchecker_Ohta())[:6]]
    rows = [lay.centers[n][1] for n in list(reflectance_colorchecker_Ohta())[::6]]
    assert np.all(np.diff(cols) > 0) and np.all(np.diff(rows) > 0)    # left→right, top→bottom
    for name in ("dark skin", "cyan", "black 2 (1.5 D)"):
        c, r = np.round(lay.centers[name]).astype(int)
        assert lay.label_map[r, c] == lay.mask(name).max() * [s.name for s in lay.surfaces].index(name) + 1
    # patch of 40 mm at 1 m with a 24 mm lens on a 36 mm sensor imaged 600 px wide: 40e-3 * 24/36e-3 * 600/36 ≈ 16 px
    assert lay.mask("dark skin").sum() == pytest.approx(16.0 ** 2, rel=0.15)
    poly = lay.polygons["dark skin"]
    assert poly[:, 0].max() - poly[:, 0].min() == pytest.approx(16.0, rel=0.01)


def test_layout_slanted_edge_is_tilted_5_deg(rig):
    sc = build_scene(rig, None, "slanted-edge", 1.0)
    assert sc.targets[0].tilt_deg == 5.0
    lay = target_layout(sc, 360, 240)   # square pixels on the 36 x 24 mm sensor
    (c0, r0), (c1, r1) = lay.edge
    angle = np.degrees(np.arctan2(c0 - c1, r0 - r1))   # lean of the edge from vertical
    assert angle == pytest.approx(5.0, abs=0.05)
    assert lay.mask("black").sum() > 0 and lay.mask("white").sum() > 0
    # black on the left of the image, white on the right
    row = lay.label_map[120]
    ids = row[row > 0]
    assert ids[0] == 1 and ids[-1] == 2


def test_layout_disk_area(rig):
    sc = build_scene(rig, None, "black-disk", 2.0)
    lay = target_layout(sc, 720, 480)
    # 0.3 m at 2 m: diameter on sensor 3.6 mm → 72 px; area π 36²
    assert lay.mask("disk").sum() == pytest.approx(np.pi * 36.0 ** 2, rel=0.03)


def test_flat_port_narrows_view_in_water():
    thin = Camera(focal_length_mm=24.0, port=Port(kind="flat", standoff_m=0.0, thickness_m=0.0))
    p = np.array([[0.3, 0.0, 1.0]])
    air = project_points(thin, p, 360, 240, n_outside=1.0)
    water = project_points(thin, p, 360, 240, n_outside=1.34)
    # image right is -x, so +x lands left of centre; in water it is further from the centre (magnified)
    assert air[0, 0] < 180 and water[0, 0] < air[0, 0]
    assert 180 - air[0, 0] == pytest.approx(360 / 36 * 24 * 0.3, rel=1e-9)
    sin_a = 1.34 * np.sin(np.arctan(0.3))
    assert 180 - water[0, 0] == pytest.approx(360 / 36 * 24 * np.tan(np.arcsin(sin_a)), rel=1e-9)


@pytest.mark.parametrize("kind", ["flat", "dome"])
def test_pixel_rays_and_projection_agree(kind):
    cam = Camera(focal_length_mm=16.0, forward=(0.2, -0.3, 1.0),
                 port=Port(kind=kind, standoff_m=0.03, thickness_m=0.012, glass_index=1.52))
    origins, dirs = pixel_rays(cam, 48, 32, n_outside=1.34)[:2]
    assert np.allclose(np.linalg.norm(dirs, axis=-1), 1.0)
    pts = origins + 2.5 * dirs
    px = project_points(cam, pts, 48, 32, n_outside=1.34)
    cols, rows = np.meshgrid(np.arange(48) + 0.5, np.arange(32) + 0.5)
    assert np.max(np.abs(px[..., 0] - cols)) < 1e-6 and np.max(np.abs(px[..., 1] - rows)) < 1e-6


def test_bottom_fills_lower_half(rig):
    sc = build_scene(rig, None, "bottom", 1.5)
    lay = target_layout(sc, 40, 30)
    frac = (lay.label_map > 0).mean(axis=1)
    assert np.all(frac[:15] == 0) and np.all(frac[16:] == 1)   # row 15 looks past the 50 m edge


def test_colorchecker_is_colours_ohta_data_edge_held():
    import colour

    sds = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    wl = np.arange(380.0, 781.0, 5.0)
    cc = reflectance_colorchecker_Ohta(wl)
    assert list(cc) == list(sds)
    for name, sd in sds.items():
        assert cc[name] == pytest.approx(sd.values, abs=1e-15)
    held = reflectance_colorchecker_Ohta(np.array([360.0, 830.0]))
    assert held["dark skin"].tolist() == [sds["dark skin"].values[0], sds["dark skin"].values[-1]]
