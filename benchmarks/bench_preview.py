"""Benchmark: the preview (Jaffe–McGlamery model) against the Mitsuba renderer — speed and agreement.

Scene: the ``twin-strobes-45-wide`` rig's two strobes (0.45 m arms, 110° beams) with a
50 mm lens on a 24 × 24 mm sensor (so that 256 × 256 pixels are square and each
ColorChecker patch covers ~10 × 10 pixels), in ``coastal`` water, ColorChecker at 2 m
(add ``--water``/``--distance`` for other cases; ``--chart-scale`` keeps its angular size).

* **Speed**: the same 256 × 256 image (``split=True``: full, direct and backscatter
  layers) from the preview (best of ``--repeats``) and from the renderer at
  ``--spp`` paths per pixel; prints both times and their ratio (target ≥ 100×).
* **Agreement**: the renderer is run with ``--seeds`` independent seeds; for each
  region (each patch's interior pixels — those whose whole footprint sees that patch —
  the chart body, the open water) the region mean of every seed is taken, and the
  reference is the mean over seeds with its standard error (spread of the seed means
  / √n).  Strobe-lit scattering water gives the renderer heavy-tailed noise
  ("fireflies"), so the median of the seed means is printed too; a difference is
  significant only beyond ~3 standard errors.  Printed per region and band group
  (blue 400–490, green 500–590, red 600–700 nm): preview/renderer − 1 for the full
  image (``flash``), the direct layer and the backscatter layer, and ±SE.

    python benchmarks/bench_preview.py [--size 256 --spp 256 --seeds 4 --water coastal --distance 2]
    python benchmarks/bench_preview.py --quick          # 96 × 96, 128 spp, 2 seeds: a smoke run
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from rigsim.config.rig import load_rig  # noqa: E402
from rigsim.preview import render_preview  # noqa: E402
from rigsim.preview.geometry import cast_rays, scene_surfaces  # noqa: E402
from rigsim.scene.optics import camera_rays, outside_index  # noqa: E402
from rigsim.scene.build import build_scene  # noqa: E402

BANDS = {"blue": (400, 495), "green": (495, 595), "red": (595, 705)}
KEYS = ("flash", "flash_direct", "flash_backscatter")


def bench_scene(water: str, distance_m: float, chart_scale: bool):
    rig = load_rig(Path(__file__).resolve().parents[1] / "rigs" / "twin-strobes-45-wide.toml")
    cam = dataclasses.replace(rig.camera, focal_length_mm=50.0, sensor_width_mm=24.0, sensor_height_mm=24.0)
    size = 0.2794 * distance_m / 2.0 if chart_scale else None
    return build_scene(dataclasses.replace(rig, camera=cam), water, "colorchecker", distance_m, size_m=size)


def interior_ids(scene, width: int, height: int, n: int = 4) -> np.ndarray:
    """Object id of pixels whose whole footprint sees one object (−1 elsewhere)."""
    surf = scene_surfaces(scene)
    g = np.linspace(0.0, 1.0, n)
    X, Y = np.meshgrid((np.arange(width)[:, None] + g).ravel() / width, (np.arange(height)[:, None] + g).ravel() / height)
    o, d = camera_rays(scene.camera, X, Y, n_outside=outside_index(scene))
    oid = cast_rays(surf, o, d)[1].reshape(height, n, width, n)
    first = oid[:, :1, :, :1]
    return np.where(np.all(oid == first, axis=(1, 3)), first[:, 0, :, 0], -1)


def regions(ii: np.ndarray, legend: dict) -> dict[str, np.ndarray]:
    from scipy.ndimage import binary_erosion

    out = {}
    for k, label in legend.items():
        m = ii == int(k)
        if m.sum() >= 4:
            out[label.split(": ", 1)[1]] = m
    out["all patches"] = ii >= 2
    out["open water"] = binary_erosion(ii == 0, iterations=3)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--water", default="coastal")
    ap.add_argument("--distance", type=float, default=2.0)
    ap.add_argument("--chart-scale", action="store_true", help="scale the chart with distance (same angular size)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--save", type=Path, default=None, help="write the per-region table as .npz")
    args = ap.parse_args(argv)
    if args.quick:
        args.size, args.spp, args.seeds = 96, 128, 2

    scene = bench_scene(args.water, args.distance, args.chart_scale)
    W = H = args.size
    wl = np.arange(400.0, 701.0, 10.0)
    print(f"{W}x{H}, {len(wl)} bands 400-700 nm, {args.water} water, twin strobes, ColorChecker at "
          f"{args.distance:g} m; renderer {args.spp} spp x {args.seeds} seeds")

    render_preview(scene, width=W, height=H, wavelengths_nm=wl, split=True)  # warm caches
    t_prev = np.inf
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        prev = render_preview(scene, width=W, height=H, wavelengths_nm=wl, split=True)
        t_prev = min(t_prev, time.perf_counter() - t0)

    from rigsim.render import render

    render(scene, width=16, height=16, spp=1, wavelengths_nm=wl, split=True)  # compile kernels
    refs = {k: [] for k in KEYS}
    times = []
    for s in range(args.seeds):
        t0 = time.perf_counter()
        img = render(scene, width=W, height=H, spp=args.spp, seed=s, wavelengths_nm=wl, split=True,
                     layers=("object_id",))
        times.append(time.perf_counter() - t0)
        for k in KEYS:
            refs[k].append(img.layers[k].astype(np.float64))
        print(f"  renderer seed {s}: {times[-1]:.1f} s", flush=True)
    t_ren = float(np.median(times))
    print(f"\npreview  {t_prev:8.3f} s   (best of {args.repeats})")
    print(f"renderer {t_ren:8.1f} s   (median of {args.seeds}; {args.spp} spp)")
    print(f"speed-up {t_ren / t_prev:8.0f} x   (target >= 100 x)\n")

    ii = interior_ids(scene, W, H)
    regs = regions(ii, prev.meta["object_ids"])
    bands = {name: (wl >= lo) & (wl < hi) for name, (lo, hi) in BANDS.items()}
    table = {}
    for k in KEYS:
        name = {"flash": "full image (flash)", "flash_direct": "direct layer",
                "flash_backscatter": "backscatter layer"}[k]
        print(f"== {name}: preview/renderer - 1  [± SE of the renderer mean | median-of-seeds variant]")
        print(f"{'region':28s} {'px':>5s}  " + "  ".join(f"{b:>26s}" for b in bands))
        for rname, m in regs.items():
            if m.sum() == 0:
                continue
            cells = []
            for bname, bm in bands.items():
                per_seed = np.array([r[m][:, bm].mean() for r in refs[k]])
                mean, med = per_seed.mean(), np.median(per_seed)
                se = per_seed.std(ddof=1) / np.sqrt(len(per_seed)) if len(per_seed) > 1 else np.nan
                pv = prev.layers[k][m][:, bm].mean()
                if mean <= 0:
                    cells.append(f"{'-':>26s}")
                    continue
                table[(k, rname, bname)] = (pv / mean - 1, se / mean, pv / med - 1)
                cells.append(f"{pv / mean - 1:+7.1%} ±{se / mean:5.1%} | {pv / med - 1:+7.1%}")
            print(f"{rname[:28]:28s} {int(m.sum()):5d}  " + "  ".join(cells))
        print()
    patch = [v for (k, r, b), v in table.items() if k == "flash" and r not in ("all patches", "open water", "chart")]
    if patch:
        rel = np.array([v[0] for v in patch])
        se = np.array([v[1] for v in patch])
        print(f"patches, full image: |error| median {np.median(np.abs(rel)):.1%}, max {np.max(np.abs(rel)):.1%}; "
              f"{np.mean(np.abs(rel) <= 0.10):.0%} within 10 %, "
              f"{np.mean(np.abs(rel) <= 0.10 + 3 * se):.0%} within 10 % + 3 SE")
    if args.save:
        np.savez(args.save, keys=np.array([f"{k}|{r}|{b}" for (k, r, b) in table]),
                 values=np.array(list(table.values())), preview_s=t_prev, renderer_s=t_ren)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
