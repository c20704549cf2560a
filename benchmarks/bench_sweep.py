"""Benchmark: a distance sweep, with one compiled kernel for every distance versus one per scene.

A study renders the same rig and water at many distances.  Dr.Jit compiles the rigsim
integrator's path-tracing kernel (~22 000 operations, several seconds of LLVM) whenever the
traced program differs, and constants in it make it differ.  rigsim builds rectangles and disks
as meshes (vertices in memory), passes light positions as opaque values and turns off Dr.Jit's
packet gathers (chosen per launch from buffer layout), so one kernel serves the whole sweep.  The
stock alternative is what Mitsuba does by itself: its ``rectangle``/``disk`` shapes compile
their placement into the kernel as constants, with packet gathers on.

Both sweeps render the same ColorChecker scenes (coastal water, twin strobes aimed outwards,
the chart filling 40 % of the frame) at the same distances, size and paths per pixel, one
render pass each as a study case does, in this process, with a fresh, empty kernel cache (the
script re-runs itself with ``HOME`` in a temporary folder, where Dr.Jit keeps its on-disk
cache).  It prints the wall time of each scene and the ratio of the totals.

    python benchmarks/bench_sweep.py [--width 84 --height 56 --spp 64]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

DISTANCES_M = (1.0, 1.5, 2.0, 3.0, 4.5, 6.0)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--width", type=int, default=84)
    ap.add_argument("--height", type=int, default=56)
    ap.add_argument("--spp", type=int, default=64)
    args = ap.parse_args(argv)
    if os.environ.get("RIGSIM_BENCH_FRESH_CACHE") != "1":
        # Dr.Jit caches compiled kernels in ~/.drjit: start from an empty one
        with tempfile.TemporaryDirectory() as home:
            env = dict(os.environ, HOME=home, RIGSIM_BENCH_FRESH_CACHE="1")
            return subprocess.call([sys.executable, __file__, *(argv if argv is not None else sys.argv[1:])],
                                   env=env)

    from rigsim.scene.optics import fov_water_deg
    from rigsim.render.mitsuba_scene import build_mitsuba_scene
    from rigsim.render.renderer import band_edges, render_pass
    from rigsim.render.variant import mitsuba, variant
    from rigsim.scene.types import BeamPattern, Camera, Light, Port, Rig, Scene, Target
    from rigsim.water import preset

    mi, dr = mitsuba()
    wl_l = tuple(np.arange(360.0, 831.0, 10.0).tolist())
    flash = tuple(np.full(len(wl_l), 0.05).tolist())  # J/(sr nm) per flash, flat
    beam = BeamPattern(kind="soft-cone", beam_angle_deg=100.0, edge_exponent=2.0)
    lights = tuple(Light(name=f"strobe-{side}", kind="strobe", position_m=(0.3 * s, 0.05, 0.05),
                         aim=(np.sin(np.radians(30)) * s, 0.0, np.cos(np.radians(30))), beam=beam,
                         wavelength_nm=wl_l, axial_intensity=flash)
                   for side, s in (("left", -1), ("right", 1)))
    cam = Camera(focal_length_mm=24.0, port=Port(kind="dome", radius_m=0.1))
    rig = Rig("bench twin strobes", cam, lights)
    water = preset("coastal")
    wl, bw = band_edges(np.arange(400.0, 701.0, 10.0), None)
    fov = np.radians(fov_water_deg(cam))

    def sweep(flat_shapes: str, packet_ops: bool) -> list[float]:
        dr.set_flag(dr.JitFlag.PacketOps, packet_ops)
        times = []
        for dist in DISTANCES_M:
            scene = Scene(rig, water, (Target("colorchecker", dist, size_m=0.4 * 2 * dist * np.tan(fov / 2)),))
            t = time.perf_counter()
            ms = build_mitsuba_scene(scene, lights=list(lights), mode="full", backscatter_aov=True,
                                     flat_shapes=flat_shapes)
            render_pass(ms, cam, width=args.width, height=args.height, spp=args.spp, seed=1,
                        band_lo=wl - bw / 2, band_w=bw, aov_out={})
            times.append(time.perf_counter() - t)
            del ms
        return times

    print(f"variant {variant()}, {args.width}x{args.height}, {args.spp} spp, {len(wl)} bands, coastal water, "
          f"ColorChecker at {', '.join(f'{d:g}' for d in DISTANCES_M)} m; empty kernel cache")
    stock = sweep("mitsuba", True)
    ours = sweep("mesh", False)
    for name, ts in (("stock (Mitsuba rectangles, packet ops)", stock), ("rigsim (meshes, opaque lights)", ours)):
        print(f"  {name:40s} " + " ".join(f"{t:6.2f}" for t in ts) + f" s | total {sum(ts):6.1f} s")
    print(f"sweep time ratio stock/rigsim = {sum(stock) / sum(ours):.2f} "
          f"(after the first scene: {sum(stock[1:]) / sum(ours[1:]):.2f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
