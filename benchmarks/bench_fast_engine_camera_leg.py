"""Benchmark: the fast engine's camera leg alone against Mitsuba's — a chart emitting the fast engine's own light.

The fast engine sees a target through the water by its camera leg: the unscattered image, its small-angle blur
(:mod:`rigsim.preview.forward`) and the light the water scatters back after it left the target (the class-B
``veil_surf_cum`` of :mod:`rigsim.preview.multiple`).  Here the chart's pieces emit ``ρ/π E`` with ``E`` the fast
engine's own irradiance on them (analytic direct + small-angle-lit light, and the traced class-B light, on each
piece's texture cells), and Mitsuba's ``volpath`` renders them through the same water
(:func:`rigsim.render.hybrid.emissive_camera_pass`): every order of scattering on the way to the camera, exactly.
Against it, the fast engine's light of the chart (its image minus its ``flash_backscatter`` layer: what left the
chart) — so that only the camera leg differs.  Printed: each patch's fast / Monte Carlo − 1 (median, mean, the
passes' standard error), the whole image's, and the water beside the chart by distance from it (the halo).

Waters: a preset's name, or ``petzold:a:b`` (Petzold's average particle phase function, constant ``a``, ``b`` in
1/m) or ``petzold30:a:b`` (the same cut off at 30°: all its scattering is the small-angle blur's, none is left to
the class-B tracer).  One band (``--wavelength``); a few tens of seconds per case on 2 cores.

    python benchmarks/bench_fast_engine_camera_leg.py --water jerlov-7C --distance 1
    python benchmarks/bench_fast_engine_camera_leg.py --water petzold30:0.05:2.35 --distance 3

Measured 2026-12-05 (``single-strobe-short-arm``, the chart 40 % of the field, 4 passes of 256 paths per pixel, 550
nm, the fast engine of 6727d85: its blur from the port on, on the azimuthal equidistant grid): Jerlov 7C at 1 m
patches mean −0.8 %, −3.2 … +1.5 % (Monte Carlo SE 0.8 %); 7C at 3 m +3.1 ± 2.1 %; III at 1 m −0.4 ± 0.7 %;
``petzold30:0.05:2.35`` at 3 m the chart +1.4 %, the water 0.5–2 / 4–8 / 8–16 / 16–64 px beside it −0.4 / −2.6 /
−3.9 / −8.8 %.  Before those two changes (a first version of this comparison, whose irradiance took other seeds of the
class-B light than the image: ±1 %): 7C at 1 m patches −5.4 … +4.7 % (the bright ones low, the dark ones high: too
much light exchanged between neighbours), mean −0.9 %; ``petzold30:0.05:2.35`` at 3 m the water beside the chart
−2 / −11 / −23 / −51 %, ``petzold30:0.05:0.3`` −8 / −17 / −31 / −63 % (0.5–2 … 16–64 px): the halo laid out on the
pixels with the centre's pitch, where a pinhole's pixels off the axis are cos² θ narrower along the radius.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from rigsim.config.rig import load_rig  # noqa: E402
from rigsim.errors import ConfigError  # noqa: E402
from rigsim.metrics.agreement import comparison_regions  # noqa: E402
from rigsim.preview import render_preview  # noqa: E402
from rigsim.preview.geometry import scene_surfaces  # noqa: E402
from rigsim.preview.model import MS_CUTOFF_DEG  # noqa: E402
from rigsim.preview.multiple import DEFAULT_GRID, default_photons, trace_multiple  # noqa: E402
from rigsim.render.hybrid import CELLS, emissive_camera_pass  # noqa: E402
from rigsim.scene.build import build_scene  # noqa: E402
from rigsim.scene.optics import field_width_m  # noqa: E402
from rigsim.scene.phase_tables import phase_tables  # noqa: E402
from rigsim.scene.surfaces import target_surfaces  # noqa: E402
from rigsim.water import preset  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_fast_engine_split import analytic_irradiance  # noqa: E402


def water_of(name: str):
    """A preset, or ``petzold:a:b`` / ``petzold30:a:b`` (see the module docstring)."""
    if ":" not in name:
        return preset(name)
    from rigsim.water.model import Spectrum1D, TabulatedWater
    from rigsim.water.phase import TabulatedPhase, petzold_average_particle

    parts = name.split(":")
    try:
        kind, a, b = parts[0], float(parts[1]), float(parts[2])
        if len(parts) != 3 or not (0 < a <= 100 and 0 <= b <= 100):
            raise ValueError
    except (ValueError, IndexError):
        raise ConfigError(f"water {name!r}: expected a preset, petzold:a:b or petzold30:a:b", field="--water",
                          allowed="0 < a <= 100, 0 <= b <= 100 (1/m)") from None
    ph = petzold_average_particle()
    if kind == "petzold30":
        ph = TabulatedPhase(np.where(ph.grid.psi_edges[:-1] < np.radians(30.0) - 1e-9, ph.masses, 0.0), ph.grid,
                            name="petzold-below-30deg")
    elif kind != "petzold":
        raise ConfigError(f"unknown water kind {kind!r}", field="--water", allowed="a preset, petzold:a:b, petzold30:a:b")
    return TabulatedWater(name, Spectrum1D.constant(a), Spectrum1D.constant(b), ph)


def fast_irradiance(scene, wl, photons: int, seeds: int) -> np.ndarray:
    """(S, CELLS, CELLS) the fast engine's irradiance on each piece's cells: the analytic direct + small-angle-lit
    light at the cell centres (:func:`bench_fast_engine_split.analytic_irradiance`) and the traced class-B light there
    (mean of ``seeds`` seeds)."""
    water = scene.water
    tab = phase_tables(water.phase, water.wavelength_range_nm)
    w = tab.weights_at(wl)
    c, b = water.c_per_m(wl), water.b_per_m(wl)
    cut = np.radians(MS_CUTOFF_DEG)
    F = w @ tab.forward_fraction(cut)
    surf = scene_surfaces(scene)
    pieces = target_surfaces(scene.targets[0], scene.camera)
    g = (np.arange(CELLS) + 0.5) / CELLS * 2 - 1
    kw = dict(c=c, b=b, kappa_cam=c - b * F, tables=tab, weights=w, width=96, height=64, cutoff_rad=cut,
              grid=DEFAULT_GRID)
    traced = [trace_multiple(scene, surf, list(scene.lights), wl, photons=photons, seed=s, **kw) for s in range(seeds)]
    E = np.zeros((len(pieces), CELLS, CELLS))
    cam = np.asarray(scene.camera.position_m, float)
    for k, p in enumerate(pieces):
        u, v, cen = (np.asarray(x, float) for x in (p.u_axis, p.v_axis, p.center_m))
        nrm = np.cross(u, v)
        nrm = nrm if nrm @ (cam - cen) > 0 else -nrm
        pts = cen + p.size_m[0] / 2 * g[:, None, None] * u + p.size_m[1] / 2 * g[None, :, None] * v
        E[k] = analytic_irradiance(scene, pts, nrm, tab, wl, cut)[..., 0]
        flat = pts.reshape(-1, 3)
        E[k] += np.mean([t.irradiance_at(surf, np.full(len(flat), k + 1), flat, np.broadcast_to(nrm, flat.shape))[:, 0]
                         for t in traced], axis=0).reshape(CELLS, CELLS)
    return E


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rig", default="single-strobe-short-arm", help="a shipped rig (rigs/<name>.toml)")
    ap.add_argument("--water", default="jerlov-7C", help="a preset, petzold:a:b or petzold30:a:b")
    ap.add_argument("--distance", type=float, default=1.0, help="the chart's distance (m)")
    ap.add_argument("--wavelength", type=float, default=550.0, help="the one band (nm)")
    ap.add_argument("--passes", type=int, default=4, help="Monte Carlo camera passes (>= 2)")
    ap.add_argument("--spp", type=int, default=256, help="paths per pixel of each pass")
    ap.add_argument("--seeds", type=int, default=4, help="seeds of the fast engine")
    a = ap.parse_args(argv)
    rig_path = Path(__file__).resolve().parents[1] / "rigs" / f"{a.rig}.toml"
    if not rig_path.is_file():
        ap.error(f"--rig: no rigs/{a.rig}.toml")
    if a.passes < 2 or a.spp < 1 or a.seeds < 1 or not 0.2 <= a.distance <= 50 or not 360 <= a.wavelength <= 830:
        ap.error("--passes >= 2, --spp >= 1, --seeds >= 1, 0.2 <= --distance <= 50, 360 <= --wavelength <= 830")
    try:
        water = water_of(a.water)
        rig = load_rig(rig_path)
        scene = build_scene(rig, water, "colorchecker", a.distance, size_m=0.4 * field_width_m(rig.camera, a.distance))
    except (ConfigError, ValueError) as e:
        ap.error(str(e))
    wl = np.array([a.wavelength])
    W, H = 96, 64
    t0 = time.perf_counter()
    E = fast_irradiance(scene, wl, default_photons(W, H), a.seeds)
    mc = np.array([emissive_camera_pass(scene, E[..., None], wl, None, width=W, height=H, spp=a.spp, seed=100 + i)[..., 0]
                   for i in range(a.passes)])
    t_mc = time.perf_counter() - t0
    fast = [render_preview(scene, width=W, height=H, wavelengths_nm=wl, split=True, layers=("object_id",), seed=s)
            for s in range(a.seeds)]
    left = np.mean([(f.layers["flash"] - f.layers["flash_backscatter"])[..., 0] for f in fast], axis=0)
    oid = fast[0].layers["object_id"]
    regions = comparison_regions(oid, fast[0].meta["object_ids"], "colorchecker")
    names = [k for k in regions if k.startswith("patch:")]
    fp = np.array([left[regions[k]].mean() for k in names])
    mp = np.array([[p[regions[k]].mean() for k in names] for p in mc])
    dev = fp / mp.mean(axis=0) - 1
    se = mp.std(axis=0, ddof=1) / np.sqrt(len(mp)) / mp.mean(axis=0)
    m = mc.mean(axis=0)
    print(f"{a.rig}, {a.water}, chart at {a.distance:g} m, {a.wavelength:g} nm; {a.passes} passes x {a.spp} spp, "
          f"{a.seeds} fast seeds ({t_mc:.0f} s)")
    print(f"patches, fast / Monte Carlo - 1: median {np.median(dev):+.1%}, mean {dev.mean():+.1%}, "
          f"{dev.min():+.1%} ... {dev.max():+.1%}; Monte Carlo SE per patch median {np.median(se):.1%}")
    print(np.array2string(100 * dev.reshape(4, 6), precision=1, suppress_small=True), "(%, chart rows)")
    print(f"whole image {left.sum() / m.sum() - 1:+.1%}; the chart's pixels {left[oid > 0].sum() / m[oid > 0].sum() - 1:+.1%}")
    import cv2

    dist = cv2.distanceTransform((oid == 0).astype(np.uint8), cv2.DIST_L2, 3)
    for lo, hi in [(0.5, 2), (2, 4), (4, 8), (8, 16), (16, 64)]:
        ring = (dist > lo) & (dist <= hi)
        if ring.any():
            print(f"  water {lo:g}-{hi:g} px beside the chart: {left[ring].sum() / m[ring].sum() - 1:+.1%}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
