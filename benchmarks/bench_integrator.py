"""Benchmark: ``rigsim_vol`` (equiangular + MIS) against Mitsuba's ``volpath`` at equal wall time.

Cases: clear, coastal and turbid (``coastal-regions``) water × twin strobes close
to the port (``rigs/twin-strobes-close-to-port.toml``) and far out
(``rigs/twin-strobes-edge-lighting.toml``), a black disk at 2 m (the image is
mostly backscatter, the study's hard case), the strobe pass (``flash``) through
rigsim's camera and band machinery (:func:`rigsim.render.renderer.render_pass`).

For each case

* a **reference**: ``rigsim_vol`` for ``--ref-factor`` × the budget, in independent
  chunks; the chunks' scatter gives the reference's own per-pixel variance, which
  is subtracted from the MSEs below (so they estimate the error against the exact
  image; ``volpath`` at the same time would be a far noisier reference);
* each integrator gets the **same wall time** (``--budget`` s; chunks of the two
  are interleaved so that load from other processes hits both alike; kernels are
  compiled before timing) and its image is compared with the reference: RMSE
  relative to the reference's mean, MSE ratio volpath/rigsim (> 1: rigsim wins),
  paths per second.

    python benchmarks/bench_integrator.py            # ~10 min on 2 cores
    python benchmarks/bench_integrator.py --quick    # ~2 min, smaller image, shorter budgets
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
from rigsim.render.integrators import with_integrator  # noqa: E402
from rigsim.render.mitsuba_scene import build_mitsuba_scene  # noqa: E402
from rigsim.render.renderer import band_edges, render_pass  # noqa: E402
from rigsim.render.variant import mitsuba, variant  # noqa: E402
from rigsim.scene.build import build_scene  # noqa: E402

mi, dr = mitsuba()

WATERS = {"clear": "clear", "coastal": "coastal", "turbid": "coastal-regions"}
RIGS = {"close": "rigs/twin-strobes-close-to-port.toml", "far": "rigs/twin-strobes-edge-lighting.toml"}
WAVELENGTHS = np.arange(400.0, 701.0, 10.0)  # the demo study's bands


def _timed_chunks(runs, budget_s, chunk_spp):
    """Interleave chunks of several renderers until each has used ``budget_s`` seconds.

    ``runs``: name → callable(spp, seed) → image.  Returns name → (mean image, spp, seconds).
    """
    acc = {k: None for k in runs}
    spent = {k: 0.0 for k in runs}
    n = {k: 0 for k in runs}
    seed = 1000
    while any(spent[k] < budget_s for k in runs):
        for k, f in runs.items():
            if spent[k] >= budget_s:
                continue
            seed += 1
            t0 = time.perf_counter()
            img = f(chunk_spp[k], seed)
            spent[k] += time.perf_counter() - t0
            acc[k] = img if acc[k] is None else acc[k] + img
            n[k] += 1
    return {k: (acc[k] / n[k], n[k] * chunk_spp[k], spent[k]) for k in runs}


def run_case(water: str, rig_path: str, *, width: int, height: int, budget_s: float, ref_factor: float,
             target: str, distance_m: float) -> dict:
    rig = load_rig(ROOT / rig_path)
    scene = build_scene(rig, water, target, distance_m)
    strobes = [l for l in scene.lights if l.kind == "strobe"]
    ms_v = build_mitsuba_scene(scene, lights=strobes, mode="full", integrator="volpath")
    ms_r = with_integrator(ms_v, "rigsim")
    # the two must really differ (build_mitsuba_scene's default integrator is rigsim's own)
    names = [type(m.scene.integrator()).__name__ for m in (ms_v, ms_r)]
    assert names[0] != names[1] and "RigsimVol" in names[1], names
    wl, bw = band_edges(WAVELENGTHS)
    kw = dict(width=width, height=height, band_lo=wl - bw / 2, band_w=bw)

    def renderer(ms):
        return lambda spp, seed: render_pass(ms, scene.camera, spp=spp, seed=seed, **kw)[0]

    runs = {"volpath": renderer(ms_v), "rigsim": renderer(ms_r)}
    # compile, then calibrate: spp per chunk so that a chunk takes ~budget/6
    rate = {}
    for k, f in runs.items():
        f(8, 1)
        t0 = time.perf_counter()
        f(16, 2)
        rate[k] = 16 * width * height / (time.perf_counter() - t0)
    chunk = {k: max(8, int(rate[k] * budget_s / 6 / (width * height)) // 8 * 8) for k in runs}
    # reference: rigsim, independent chunks → mean and its per-pixel variance
    ref_chunks = []
    t_end = time.perf_counter() + ref_factor * budget_s
    seed = 50_000
    while time.perf_counter() < t_end or len(ref_chunks) < 4:
        seed += 1
        ref_chunks.append(runs["rigsim"](chunk["rigsim"], seed))
    R = np.stack(ref_chunks)
    ref = R.mean(axis=0)
    ref_var = float(np.mean(R.var(axis=0, ddof=1) / len(R)))
    ref_spp = len(R) * chunk["rigsim"]
    out = _timed_chunks(runs, budget_s, chunk)
    scale = float(np.mean(ref))
    res = {"ref_spp": ref_spp, "ref_rel_se": np.sqrt(ref_var) / scale, "mean": scale}
    for k, (img, spp, sec) in out.items():
        mse = float(np.mean((img - ref) ** 2)) - ref_var
        res[k] = {"mse": mse, "rmse_rel": np.sqrt(max(mse, 0.0)) / scale, "spp": spp, "sec": sec,
                  "paths_per_s": spp * width * height / sec,
                  "max_over_mean": float(np.max(img.mean(axis=2)) / np.mean(img))}
    res["ratio"] = res["volpath"]["mse"] / res["rigsim"]["mse"] if res["rigsim"]["mse"] > 0 else np.inf
    return res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="48x32 px, 4 s budgets (~2 min)")
    ap.add_argument("--width", type=int, default=None)
    ap.add_argument("--height", type=int, default=None)
    ap.add_argument("--budget", type=float, default=None, help="seconds per integrator per case")
    ap.add_argument("--ref-factor", type=float, default=4.0, help="reference time / budget")
    ap.add_argument("--target", default="black-disk")
    ap.add_argument("--distance", type=float, default=2.0)
    ap.add_argument("--waters", default=",".join(WATERS), help="comma-separated: " + ", ".join(WATERS))
    ap.add_argument("--rigs", default=",".join(RIGS), help="comma-separated: " + ", ".join(RIGS))
    ap.add_argument("--threads", type=int, default=0, help="Dr.Jit worker threads (0: all cores)")
    args = ap.parse_args(argv)
    if args.threads:
        dr.set_thread_count(args.threads)
    width = args.width or (48 if args.quick else 96)
    height = args.height or (32 if args.quick else 64)
    budget = args.budget or (4.0 if args.quick else 15.0)

    print(f"variant {variant()}, {width}x{height} px, {len(WAVELENGTHS)} bands (400-700 nm), strobe pass, "
          f"{args.target} at {args.distance:g} m; equal wall time {budget:g} s per integrator; reference: "
          f"rigsim_vol for {args.ref_factor:g}x that (its variance subtracted from the MSEs)")
    head = (f"{'water':<8} {'strobes':<7} {'ref spp':>7} {'ref se%':>7} | {'volpath spp':>11} {'paths/s':>9} "
            f"{'RMSE%':>7} {'max/mean':>8} | {'rigsim spp':>10} {'paths/s':>9} {'RMSE%':>7} {'max/mean':>8} | "
            f"{'MSE ratio':>9}")
    print(head)
    print("-" * len(head))
    for wkey in args.waters.split(","):
        for rkey in args.rigs.split(","):
            r = run_case(WATERS[wkey], RIGS[rkey], width=width, height=height, budget_s=budget,
                         ref_factor=args.ref_factor, target=args.target, distance_m=args.distance)
            v, g = r["volpath"], r["rigsim"]
            print(f"{wkey:<8} {rkey:<7} {r['ref_spp']:>7d} {100 * r['ref_rel_se']:>7.3f} | "
                  f"{v['spp']:>11d} {v['paths_per_s']:>9.3g} {100 * v['rmse_rel']:>7.3f} {v['max_over_mean']:>8.1f} | "
                  f"{g['spp']:>10d} {g['paths_per_s']:>9.3g} {100 * g['rmse_rel']:>7.3f} {g['max_over_mean']:>8.1f} | "
                  f"{r['ratio']:>9.2f}", flush=True)
    print("RMSE%: root-mean-square error over pixels and bands / the reference's mean radiance; MSE ratio = "
          "MSE(volpath)/MSE(rigsim) at equal time (target: >= 5 in turbid water, >= 1 in clear); max/mean: "
          "brightest pixel / image mean (fireflies).")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
