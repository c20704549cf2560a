"""Benchmark: a 24 MP capture (noise + WB + demosaic + CCM + sRGB) beside rawpy ``postprocess()``.

Run ``python benchmarks/bench_sensor.py [--demosaic NAME] [--rows 4000 --cols 6000]``.
Prints wall times, their ratio (target ≤ 1.5×) and peak memory (tracemalloc, and the
process's max RSS).  rawpy develops the very DNG our capture wrote, with its default
AHD demosaicing, camera white balance and sRGB output.
"""

from __future__ import annotations

import argparse
import resource
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=4000)
    ap.add_argument("--cols", type=int, default=6000)
    ap.add_argument("--demosaic", default="OpenCV-EA")
    ap.add_argument("--sensor", default="sony_ilce-7rm2")
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args(argv)

    import colour
    import rawpy

    from rigsim.sensor import DevelopOptions, auto_exposure, capture, load_sensor, save_dng
    from rigsim.sensor.ccm import colorchecker_reflectances
    from rigsim.spectral_image import SpectralImage

    # a small ColorChecker render (31 bands), resampled to the 24 MP mosaic by capture(shape=)
    wl = np.arange(400.0, 701.0, 10.0)
    e = np.interp(wl, colour.SDS_ILLUMINANTS["D65"].wavelengths, colour.SDS_ILLUMINANTS["D65"].values) / 100
    refl = colorchecker_reflectances(wl)
    p = 50
    rad = np.zeros((4 * p, 6 * p, len(wl)), np.float32)
    for i in range(24):
        r, c = divmod(i, 6)
        rad[r * p:(r + 1) * p, c * p:(c + 1) * p] = refl[i] * e / np.pi
    si = SpectralImage(rad, wl, np.full_like(wl, 10.0))
    sensor = load_sensor(args.sensor)
    ex = auto_exposure(si, sensor)
    opts = DevelopOptions(demosaic=args.demosaic, white_balance="grayworld")
    shape = (args.rows, args.cols)

    capture(si, sensor, ex, shape=(64, 96), develop=opts)  # warm-up (imports, LUTs, CCM cache)
    ours = []
    tracemalloc.start()
    for k in range(args.repeat):
        t0 = time.perf_counter()
        cap = capture(si, sensor, ex, seed=k, shape=shape, develop=opts)
        ours.append(time.perf_counter() - t0)
        if k < args.repeat - 1:
            del cap
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    timing = cap.meta["timing_s"]

    with tempfile.TemporaryDirectory() as d:
        dng = save_dng(cap, Path(d) / "raw.dng")
        theirs = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            with rawpy.imread(str(dng)) as raw:
                rgb = raw.postprocess(use_camera_wb=True)
            theirs.append(time.perf_counter() - t0)
    t_ours, t_theirs = min(ours), min(theirs)
    rss_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"mosaic {args.rows}x{args.cols} ({args.rows * args.cols / 1e6:.1f} MP), sensor {sensor.name}, "
          f"demosaic {args.demosaic}")
    print(f"rigsim capture+develop: first run {ours[0]:.2f} s (makes the camera's PRNU/DSNU maps), "
          f"best {t_ours:.2f} s  (of {args.repeat}; stages: "
          + ", ".join(f"{k} {v:.2f}" for k, v in timing.items()) + ")")
    print(f"rawpy postprocess (LibRaw AHD, 8-bit sRGB): {t_theirs:.2f} s  -> {rgb.shape}")
    print(f"ratio rigsim / rawpy: {t_ours / t_theirs:.2f}x best, {ours[0] / t_theirs:.2f}x first run"
          f"  (target <= 1.5x)")
    print(f"peak traced memory (rigsim capture): {peak / 2**20:.0f} MiB; "
          f"process max RSS: {rss_mb:.0f} MiB; output arrays: raw {cap.raw.nbytes / 2**20:.0f} MiB, "
          f"electrons {cap.electrons.nbytes / 2**20:.0f} MiB, linear {cap.linear_rgb.nbytes / 2**20:.0f} MiB")
    return t_ours / t_theirs


if __name__ == "__main__":
    main()
