"""Benchmark: the heavy tail of the Monte Carlo reference in turbid, high-albedo water, before and after.

A chart case of the agreement table (``twin-strobes-edge-lighting``, ColorChecker 40 % of the field) is
rendered by the renderer's own camera paths (:func:`rigsim.render.renderer.render_pass`, one band of
10 nm) with two sets of ``rigsim_vol`` options, in the same run, alternating chunks so that load from
other processes hits both alike:

* **before**: ``--before`` (default: the light-directed share 0.4 at every vertex, Russian roulette from
  depth 5, the options until 2026-12-05);
* **after**: the integrator's defaults (:data:`rigsim.render.integrators.strobe.DEFAULT_LIGHT_DIRECTED_DEEP`
  from :data:`~rigsim.render.integrators.strobe.DEFAULT_LIGHT_DIRECTED_DEPTH`, roulette from
  :data:`~rigsim.render.integrators.strobe.DEFAULT_RR_DEPTH`, ...) with ``--after``'s options over them.

Over the image's pixels (``--region chart``: the chart's) it prints, for the image (``full``) and for the backscatter layer (``veil``,
the AOV of the same paths): the mean (and the two means' difference over its standard error, from the
chunks' scatter: both are unbiased, so |z| should be small), the share of the sum held by the largest
pixel sample and the largest 100, the relative variance per path ``relvar = n_paths · Σv² / (Σv)²``
(v: a pixel's mean over its ``--spp`` paths, times ``--spp``; the between-pixel spread adds the same to
both) and the time, and the ratio of ``relvar × time`` before / after: how many times less time the
reference needs for the same noise.  Heavy tails make single runs erratic: use ≥ 10 000 000 paths.

    python benchmarks/bench_reference_tail.py                       # 5 cases, ~45 min on 2 cores
    python benchmarks/bench_reference_tail.py --cases jerlov-9C:1 --paths 2000000
    # one option against another (here the equiangular continuation share before 2026-12-07):
    python benchmarks/bench_reference_tail.py --region chart --paths 8000000 --before equiangular_vertex=0.2

Measured 2026-12-05 (2 cores, 12 000 000 paths per setting and case, 450 nm, every pixel;
``--cases jerlov-9C:1,jerlov-7C:3,jerlov-III:3``), relvar × time before / after, image and veil:

* Jerlov 9C at 1 m: 4.1× and 5.5× (largest sample's share of the sum 0.48 → 0.13 % and 0.54 → 0.14 %);
* Jerlov 7C at 3 m: 4.0× and 4.2× (0.41 → 0.11 %);
* Jerlov III at 3 m: 2.5× and 4.7× (0.37 → 0.08 %, 0.41 → 0.07 %);
* Jerlov 5C at 3 m (run alone after): 1.9× and 1.7× (0.09 → 0.05 %, 0.08 → 0.04 %); its veil's means
  after / before 1.0056, z +2.14 (a heavy-tailed estimate's mean from fewer effective samples tends to sit
  low: the before's);
* the means agree (after / before 0.994–1.006, |z| ≤ 0.93 in the three cases above); a path costs 1.5–1.7×
  the time (longer paths before the roulette);
* coastal-regions at 1 m (albedo ~0.1: the roulette still starts at depth 5; 3 000 000 paths): the same
  numbers and time (1.0×).

Measured 2026-12-07, ``--region chart --paths 8000000 --before equiangular_vertex=0.2 --after
equiangular_vertex=0.05`` (the share adopted that day; 35 min on 2 cores beside a niced benchmark), relvar × time
before / after, image and veil: Jerlov 9C at 1 m 1.3× and 1.7×; 7C at 3 m 1.5× and 1.5×; 5C at 3 m 0.9× and
1.1×; III at 3 m 2.0× and 1.3× (largest sample 0.55 → 0.23 % of the image's sum); coastal at 1 m 0.9× and 0.9×
(the same relvar, 9 % more time); means after / before 0.983–1.006, |z| ≤ 1.31.

With single-path probes over the chart alone (6 000 000 paths, 450 nm) the old options' relvar × time had been
10–45× the new ones' in 9C at 1 m and 7C at 3 m: a heavy tail's sample variance grows with the sample, so a
single run's ratio is a floor more than a number.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rigsim.config.rig import load_rig  # noqa: E402
from rigsim.errors import ConfigError  # noqa: E402
from rigsim.preview import render_preview  # noqa: E402
from rigsim.render.integrators import integrator_dict, with_integrator  # noqa: E402
from rigsim.render.mitsuba_scene import build_mitsuba_scene  # noqa: E402
from rigsim.render.renderer import render_pass  # noqa: E402
from rigsim.scene.build import build_scene  # noqa: E402
from rigsim.scene.optics import field_width_m  # noqa: E402
from rigsim.water import preset  # noqa: E402

#: The options before 2026-12-05 (light-directed share 0.4 at every depth, roulette from depth 5).
BEFORE = {"light_directed_depth": 1 << 30, "rr_depth": 5, "rr_depth_max": 5}
CASES = "jerlov-9C:1,jerlov-7C:3,jerlov-5C:3,jerlov-III:3,coastal:1"


def _stats(v: np.ndarray, spp: int) -> dict:
    v = np.where(np.isfinite(v), v, 0.0).ravel()
    s = np.sort(v)[::-1]
    tot = v.sum()
    return {"mean": v.mean(), "top1": s[0] / tot, "top100": s[:100].sum() / tot,
            "relvar": spp * len(v) * (v ** 2).sum() / tot ** 2}


def parse_options(text: str) -> dict:
    """``key=value,...`` -> rigsim_vol properties (ints, floats; ``BEFORE``: :data:`BEFORE`)."""
    if text.strip() == "BEFORE":
        return dict(BEFORE)
    out = {}
    for item in filter(None, (t.strip() for t in text.split(","))):
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"{item!r} is not key=value")
        try:
            out[key.strip()] = int(value)
        except ValueError:
            out[key.strip()] = float(value)  # ValueError names the value
    return out


def run_case(water: str, distance_m: float, *, paths: int, spp: int, width: int, height: int,
             wavelength_nm: float, region: str = "all", before: dict | None = None,
             after: dict | None = None) -> dict:
    rig = load_rig(ROOT / "rigs" / "twin-strobes-edge-lighting.toml")
    scene = build_scene(rig, preset(water), "colorchecker", distance_m,
                        size_m=0.4 * field_width_m(rig.camera, distance_m))
    strobes = [light for light in scene.lights if light.kind == "strobe"]
    ms = build_mitsuba_scene(scene, lights=strobes, mode="full", backscatter_aov=True)
    base = integrator_dict("rigsim", backscatter_aov=True)
    settings = {"before": with_integrator(ms, {**base, **(BEFORE if before is None else before)}),
                "after": with_integrator(ms, {**base, **(after or {})})}
    if region == "chart":  # the chart's pixels: the fast engine's object ids (no Monte Carlo needed for them)
        chart = np.asarray(render_preview(scene, width=width, height=height, wavelengths_nm=[wavelength_nm],
                                          multiple=False, layers=("object_id",)).layers["object_id"]) > 0
    else:
        chart = np.ones((height, width), bool)
    lo, bw = np.array([wavelength_nm - 5.0]), np.array([10.0])
    per_chunk = spp * width * height
    n_chunks = max(2, -(-paths // per_chunk))
    out = {k: {"full": [], "veil": [], "sec": 0.0} for k in settings}
    for k, m in settings.items():  # compile outside the timing
        render_pass(m, scene.camera, width=width, height=height, spp=spp, seed=1, band_lo=lo, band_w=bw,
                    aov_out={})
    for i in range(n_chunks):
        for k, m in settings.items():
            aov: dict = {}
            t0 = time.perf_counter()
            img, _ = render_pass(m, scene.camera, width=width, height=height, spp=spp, seed=1000 + i,
                                 band_lo=lo, band_w=bw, aov_out=aov)
            out[k]["sec"] += time.perf_counter() - t0
            out[k]["full"].append(img[..., 0][chart])
            out[k]["veil"].append(aov["backscatter"][..., 0][chart])
    res = {"paths": n_chunks * spp * int(chart.sum()), "chunks": n_chunks}
    for k in settings:
        res[k] = {"sec": out[k]["sec"]}
        for part in ("full", "veil"):
            a = np.stack(out[k][part])
            st = _stats(a, spp)
            st["chunk_means"] = a.mean(axis=1)
            res[k][part] = st
    return res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", default=CASES, help="water:distance_m, comma-separated")
    ap.add_argument("--paths", type=int, default=12_000_000, help="paths per setting per case over the whole image")
    ap.add_argument("--spp", type=int, default=16, help="paths per pixel per chunk")
    ap.add_argument("--width", type=int, default=96)
    ap.add_argument("--height", type=int, default=64)
    ap.add_argument("--wavelength", type=float, default=450.0, help="band centre, nm (10 nm wide)")
    ap.add_argument("--region", choices=("all", "chart"), default="all",
                    help="pixels whose samples are pooled: the whole image or the chart's")
    ap.add_argument("--before", default="BEFORE",
                    help="rigsim_vol options of the 'before' setting, key=value,... (default: BEFORE, the options "
                         "until 2026-12-05)")
    ap.add_argument("--after", default="",
                    help="rigsim_vol options of the 'after' setting over the integrator's defaults, key=value,...")
    a = ap.parse_args(argv)
    try:
        before, after = parse_options(a.before), parse_options(a.after)
    except ValueError as e:
        ap.error(f"--before/--after: {e}")
    cases = []
    for c in a.cases.split(","):
        try:
            w, d = c.split(":")
            cases.append((w, float(d)))
        except ValueError:
            ap.error(f"--cases: {c!r} is not water:distance_m")
        try:
            preset(w)
        except ConfigError as e:  # an unknown water: a one-line usage error, not a traceback
            ap.error(f"--cases: {e}")
        if not float(d) > 0:
            ap.error(f"--cases: distance {d} m must be > 0")
    if a.paths < 1 or a.spp < 1:
        ap.error("--paths and --spp must be >= 1")
    print(f"twin-strobes-edge-lighting, ColorChecker 0.4 of the field, {a.width}x{a.height}, {a.wavelength:g} nm; "
          f"before = {before}, after = the integrator's defaults + {after}; pixels: {a.region}")
    print(f"{'case':>16s} {'part':>4s} {'setting':>7s} {'mean':>10s} {'top1':>7s} {'top100':>7s} {'relvar':>9s} "
          f"{'time s':>7s} {'relvar*t':>10s}")
    for w, d in cases:
        r = run_case(w, d, paths=a.paths, spp=a.spp, width=a.width, height=a.height, wavelength_nm=a.wavelength,
                     region=a.region, before=before, after=after)
        for part in ("full", "veil"):
            eff = {}
            for k in ("before", "after"):
                s = r[k][part]
                eff[k] = s["relvar"] * r[k]["sec"]
                print(f"{w + ' ' + format(d, 'g') + ' m':>16s} {part:>4s} {k:>7s} {s['mean']:10.4g} {s['top1']:7.4f} "
                      f"{s['top100']:7.4f} {s['relvar']:9.1f} {r[k]['sec']:7.1f} {eff[k]:10.0f}")
            ca, cb = r["before"][part]["chunk_means"], r["after"][part]["chunk_means"]
            z = (cb.mean() - ca.mean()) / np.sqrt(ca.var(ddof=1) / len(ca) + cb.var(ddof=1) / len(cb))
            print(f"{'':>16s} {part:>4s} after/before mean {cb.mean() / ca.mean():.4f} (z {z:+.2f}); "
                  f"relvar x time before/after = {eff['before'] / eff['after']:.1f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
