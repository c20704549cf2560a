"""Benchmark: the spectral phase plugin against Mitsuba's stock ``hg`` phase function.

A coastal-water twin-strobe scene (ColorChecker at 1.5 m) is rendered twice at the
same size and spp through the same camera/wavelength machinery and Mitsuba's ``volpath``:

* with rigsim's wavelength-dependent phase plugin (the real Kopelevich mixture);
* with Mitsuba's built-in ``homogeneous`` + ``hg`` medium of the same σ_t(λ) and
  albedo(λ), g = the mixture's mean cosine averaged over the bands.

Each is run once to compile the kernels, then timed over ``--repeats`` interleaved
runs (best of); the script prints paths per second (each path carries four
wavelengths) of each and the ratio (target: plugin overhead ≤ 25 %).  The two
differ physically (HG is not the Kopelevich mixture), so their radiances differ.

    python benchmarks/bench_render.py [--width 240 --height 160 --spp 32 --repeats 3]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from rigsim.render.mitsuba_scene import build_mitsuba_scene
from rigsim.render.renderer import band_edges, render_pass
from rigsim.render.variant import mitsuba, variant
from rigsim.scene.types import BeamPattern, Camera, Light, Port, Rig, Scene, Target
from rigsim.spectrum import DEFAULT_WAVELENGTHS_NM
from rigsim.water import preset

mi, dr = mitsuba()


def coastal_twin_strobe_scene() -> Scene:
    """Twin strobes 0.3 m either side of a dome-port camera, aimed 10° outwards, coastal water."""
    wl = tuple(np.arange(360.0, 831.0, 10.0).tolist())
    flash = tuple(np.full(len(wl), 0.05).tolist())  # J/(sr nm) per flash, flat (a plain daylight-ish strobe)
    beam = BeamPattern(kind="soft-cone", beam_angle_deg=100.0, edge_exponent=2.0)
    lights = tuple(
        Light(name=f"strobe-{side}", kind="strobe", position_m=(0.3 * s, 0.05, 0.05),
              aim=(np.sin(np.radians(10)) * s, 0.0, np.cos(np.radians(10))), beam=beam,
              wavelength_nm=wl, axial_intensity=flash)
        for side, s in (("left", -1), ("right", 1)))
    cam = Camera(focal_length_mm=24.0, port=Port(kind="dome", radius_m=0.1))
    rig = Rig("bench twin strobes", cam, lights)
    return Scene(rig, preset("coastal"), (Target("colorchecker", 1.5, size_m=0.2794),))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--width", type=int, default=240)
    ap.add_argument("--height", type=int, default=160)
    ap.add_argument("--spp", type=int, default=32)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--threads", type=int, default=0, help="Dr.Jit worker threads (0: all cores)")
    args = ap.parse_args(argv)
    if args.threads:
        dr.set_thread_count(args.threads)

    scene = coastal_twin_strobe_scene()
    wl, bw = band_edges(DEFAULT_WAVELENGTHS_NM)
    g = float(np.mean(scene.water.phase.mean_cosine(wl)))
    variants = {
        # both with Mitsuba's volpath, so that only the phase function differs (rigsim's own
        # integrator builds extra tables for its phase plugin and none for hg)
        "rigsim phase plugin": build_mitsuba_scene(scene, lights=scene.lights, integrator="volpath"),
        f"stock hg (g={g:.3f})": build_mitsuba_scene(scene, lights=scene.lights, phase={"type": "hg", "g": g},
                                                     integrator="volpath"),
    }
    n_paths = args.width * args.height * args.spp
    print(f"variant {variant()}, {args.width}x{args.height}, {args.spp} spp, {len(wl)} bands, "
          f"coastal water, twin strobes, ColorChecker at 1.5 m")
    kw = dict(width=args.width, height=args.height, spp=args.spp, band_lo=wl - bw / 2, band_w=bw)
    first = {}
    wall = {k: np.inf for k in variants}
    kern = {k: np.inf for k in variants}
    medians = {k: [] for k in variants}
    for name, ms in variants.items():  # compile every kernel once
        t0 = time.perf_counter()
        render_pass(ms, scene.camera, seed=0, **kw)
        first[name] = time.perf_counter() - t0
    for r in range(args.repeats):  # interleaved, so that load from other processes hits both alike
        for name, ms in variants.items():
            dr.kernel_history()  # clear
            with dr.scoped_set_flag(dr.JitFlag.KernelHistory, True):
                t0 = time.perf_counter()
                img, _ = render_pass(ms, scene.camera, seed=r + 1, **kw)
                t = time.perf_counter() - t0
            hist = dr.kernel_history([dr.KernelType.JIT])
            wall[name] = min(wall[name], t)
            kern[name] = min(kern[name], sum(h["execution_time"] for h in hist) / 1e3)
            medians[name].append(float(np.median(img)))
    print("  (wall: whole render_pass incl. tracing the Python code; kernel: the compiled path-tracing "
          "kernels only; best of each)")
    for name in variants:
        print(f"  {name:24s} first {first[name]:5.2f} s | wall {wall[name]:5.2f} s = "
              f"{n_paths / wall[name] / 1e6:6.3f} M paths/s | kernel {kern[name]:5.2f} s = "
              f"{n_paths / kern[name] / 1e6:6.3f} M paths/s | median radiance {np.mean(medians[name]):.4g}")
    ours = next(k for k in variants if k.startswith("rigsim"))
    stock = next(k for k in variants if k.startswith("stock"))
    for what, t in (("kernel", kern), ("wall", wall)):
        print(f"{what:6s} ratio plugin/stock = {t[stock] / t[ours]:.3f} "
              f"(overhead {100 * (t[ours] / t[stock] - 1):+.1f} %; target <= +25 %)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
