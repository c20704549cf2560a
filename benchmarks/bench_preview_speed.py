"""Benchmark: the fast engine's analytic image model at photograph size — time, and against the old model.

Scene: the ``twin-strobes-45-wide`` rig (two strobes, 16 mm lens on a 36 × 24 mm sensor, dome port) in
Jerlov 3C water, a 0.8 m ColorChecker at 2 m, daylight at 10 m (the Kd field), 31 bands 400–700 nm,
``split=True`` (flash, its direct and backscatter layers, the daylight radiance and its layers:
eight float32 layers).  For each image size the fast engine (:func:`rigsim.preview.render_preview`)
and today's model before the speed-ups (the frozen copy in ``tests/preview/reference``, same inputs)
are timed in this process — wall and CPU time, best of ``--repeats`` after a warm-up — and every
layer of the two images is compared (largest difference relative to the element, and to the
layer's largest value).

Run it alone on the machine: it prints the core count and the load average before and after (the
other processes' CPU share), and warns when the machine was busy.

    python benchmarks/bench_preview_speed.py                   # 640x427, 1280x853, 1920x1280
    python benchmarks/bench_preview_speed.py --sizes 1280x853 --repeats 5
    python benchmarks/bench_preview_speed.py --no-reference    # the fast engine only
    python benchmarks/bench_preview_speed.py --monte-carlo none # without the Monte Carlo comparison

Against Monte Carlo (``--monte-carlo WxH``, default 64x43): ``rigsim render`` of the same scene,
31 bands, in batches of 16 paths per pixel until its noise (the 99th percentile over pixels of the
relative standard error, :func:`rigsim.render.renderer.relative_noise_p99`) is at most 5 %, or 4096
paths per pixel.  Its time per pixel at that noise, times the pixels of each size, is the time
Monte Carlo needs for that size (its cost is proportional to pixels × paths: the extrapolation is
stated, not hidden; rendering 1280×853 to 5 % would take hours), and the ratio to the fast engine
is printed.  If 4096 paths per pixel do not reach 5 % the ratio is a lower bound (printed ``≥``).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from rigsim.config.rig import load_rig  # noqa: E402
from rigsim.preview import render_preview  # noqa: E402
from rigsim.preview.tiles import default_threads  # noqa: E402
from rigsim.scene.build import build_scene  # noqa: E402
from rigsim.scene.types import Daylight  # noqa: E402
from tests.preview.reference.model import render_preview as reference_preview  # noqa: E402

SIZES = ((640, 427), (1280, 853), (1920, 1280))


def bench_scene():
    return build_scene(load_rig(ROOT / "rigs" / "twin-strobes-45-wide.toml"), "jerlov-3C", "colorchecker", 2.0,
                       size_m=0.8, daylight=Daylight(depth_m=10.0))


def load() -> tuple[float, float, float]:
    with open("/proc/loadavg") as f:
        return tuple(float(x) for x in f.read().split()[:3])


def busy_others() -> list[str]:
    """Other processes using CPU now (over 0.5 s), from two /proc samples 0.5 s apart."""
    def sample():
        out = {}
        for pid in os.listdir("/proc"):
            if not pid.isdigit() or int(pid) == os.getpid():
                continue
            try:
                with open(f"/proc/{pid}/stat") as f:
                    parts = f.read().rsplit(")", 1)[1].split()
                with open(f"/proc/{pid}/comm") as f:
                    name = f.read().strip()
                out[pid] = (name, int(parts[11]) + int(parts[12]))
            except (OSError, IndexError, ValueError):
                pass
        return out

    hz = os.sysconf("SC_CLK_TCK")
    a = sample()
    time.sleep(0.5)
    b = sample()
    busy = []
    for pid, (name, t) in b.items():
        if pid in a:
            share = (t - a[pid][1]) / hz / 0.5
            if share > 0.05:
                busy.append(f"{name}[{pid}] {100 * share:.0f}%")
    return busy


def timed(fn, repeats: int):
    """(best wall, CPU of that run, image of the last run)."""
    best = (np.inf, np.inf)
    img = None
    for _ in range(repeats):
        img = None  # let the previous image go first (its memory is reused)
        t, c = time.perf_counter(), time.process_time()
        img = fn()
        best = min(best, (time.perf_counter() - t, time.process_time() - c))
    return best[0], best[1], img


def compare(new, ref) -> tuple[float, float]:
    """Largest difference over all layers: relative to the element (where it is above 1e-6 of the layer's
    largest value) and relative to the layer's largest value."""
    worst_el, worst_max = 0.0, 0.0
    layers = dict(ref.layers, radiance=ref.radiance)
    for k, a in layers.items():
        b = new.radiance if k == "radiance" else new.layers[k]
        if a.dtype.kind != "f" or k == "range_m":
            assert np.array_equal(a, b), k
            continue
        scale = float(np.abs(a).max())
        if scale == 0:
            continue
        d = np.abs(b.astype(np.float64) - a)
        big = np.abs(a) > 1e-6 * scale
        worst_el = max(worst_el, float(np.max(d[big] / np.abs(a[big]))) if big.any() else 0.0)
        worst_max = max(worst_max, float(d.max()) / scale)
    return worst_el, worst_max


#: The Monte Carlo noise the comparison asks for (relative, 99th percentile over pixels).
MC_NOISE = 0.05


def monte_carlo_per_pixel(scene, size: str):
    """Seconds per pixel ``rigsim render`` needs for :data:`MC_NOISE`: (s/px, spp, noise, s, (w, h))."""
    from rigsim.render import render

    w, h = (int(x) for x in size.lower().split("x"))
    render(scene, width=16, height=12, spp=4, seed=0)  # warm-up: kernels compiled
    t0 = time.perf_counter()
    img = render(scene, width=w, height=h, spp=16, seed=1, noise_target=MC_NOISE, max_spp=4096)
    t = time.perf_counter() - t0
    noise = max((v for v in (img.meta.get("noise_p99") or {}).values()), default=float("nan"))
    return t / (w * h), int(img.meta["spp"]), float(noise), t, (w, h)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default=",".join(f"{w}x{h}" for w, h in SIZES),
                    help="image sizes, WxH,… (default %(default)s)")
    ap.add_argument("--repeats", type=int, default=3, help="runs of the fast engine per size (best is kept)")
    ap.add_argument("--reference-repeats", type=int, default=1, help="runs of the old model per size")
    ap.add_argument("--no-reference", action="store_true", help="do not time the old model")
    ap.add_argument("--threads", type=int, default=None, help="threads of the fast engine (default: all cores)")
    ap.add_argument("--monte-carlo", default="64x43",
                    help="size of the Monte Carlo render to 5 %% noise (WxH), or 'none' (default %(default)s)")
    args = ap.parse_args(argv)
    sizes = [tuple(int(x) for x in s.lower().split("x")) for s in args.sizes.split(",")]

    cores = os.cpu_count()
    try:
        usable = len(os.sched_getaffinity(0))
    except AttributeError:
        usable = cores
    try:
        thp = Path("/sys/kernel/mm/transparent_hugepage/defrag").read_text().strip()
    except OSError:
        thp = "?"
    l0 = load()
    others = busy_others()
    print(f"machine: {cores} cores ({usable} usable by this process); fast engine threads: "
          f"{args.threads or default_threads()}; numpy {np.__version__}; THP defrag: {thp}")
    print(f"load average before: {l0[0]:.2f} {l0[1]:.2f} {l0[2]:.2f}; other processes using CPU: "
          f"{', '.join(others) if others else 'none'}")
    if l0[0] > 0.5 or others:
        print("WARNING: the machine is not idle: times below are slower than alone")
    scene = bench_scene()
    warnings.simplefilter("ignore")  # the old model's expm1 overflows in this water
    # warm-up: imports, the water's phase tables and SAA tables, the daylight field, blurred beams
    render_preview(scene, width=64, height=43, split=True, threads=args.threads)
    if not args.no_reference:
        reference_preview(scene, width=64, height=43, split=True)
    print("\nfast: the fast engine as studies run it (multiple scattering 'auto': on in Jerlov 3C, "
          "rigsim.preview.multiple.default_photons); single: without it, compared with the old model")
    print(f"\n{'size':>10} {'fast wall':>10} {'fast CPU':>9} {'single':>8} {'old wall':>9} {'old CPU':>8} "
          f"{'speed-up':>9} {'max rel. diff (element / layer max)':>36}")
    mc = None if args.monte_carlo.lower() == "none" else monte_carlo_per_pixel(scene, args.monte_carlo)
    fast_times = []
    for w, h in sizes:
        t_new, c_new, img = timed(lambda w=w, h=h: render_preview(scene, width=w, height=h, split=True,
                                                                   threads=args.threads), args.repeats)
        fast_times.append((w, h, t_new))
        line = f"{w:>5}x{h:<4} {t_new:9.2f}s {c_new:8.2f}s"
        if not args.no_reference:
            del img
            # like for like: the frozen model has neither the multiply scattered light nor the edge box filter
            t_one, _, img = timed(lambda w=w, h=h: render_preview(scene, width=w, height=h, split=True, multiple=False,
                                                                  edge_samples=1, threads=args.threads), args.repeats)
            t_old, c_old, ref = timed(lambda w=w, h=h: reference_preview(scene, width=w, height=h, split=True),
                                      args.reference_repeats)
            el, mx = compare(img, ref)
            line += f" {t_one:7.2f}s {t_old:8.2f}s {c_old:7.2f}s {t_old / t_one:8.1f}x {el:17.1e} / {mx:.1e}"
            del ref
        print(line, flush=True)
        del img
    if mc is not None:
        per_px, spp, noise, t_mc, (mw, mh) = mc
        bound = "≥ " if noise > MC_NOISE else ""
        print(f"\nMonte Carlo ({mw}x{mh}, 31 bands): {spp} paths per pixel for noise p99 {noise:.3f} "
              f"(target {MC_NOISE:g}) in {t_mc:.1f} s = {per_px * 1e3:.2f} ms per pixel")
        print(f"{'size':>10} {'fast wall':>10} {'Monte Carlo (per pixel x pixels)':>34} {'ratio':>10}")
        for w, h, t_new in fast_times:
            t = per_px * w * h
            print(f"{w:>5}x{h:<4} {t_new:9.2f}s {t:27.0f} s ({t / 3600:.1f} h) {bound}{t / t_new:8.0f}x")
        if bound:
            k = (noise / MC_NOISE) ** 2  # noise ∝ 1/√paths
            print(f"(4096 paths per pixel left the noise at {noise:.3f}: if it falls as 1/√paths, 5 % takes "
                  f"{k:.0f}x as long, and the ratios are {k:.0f}x the lower bounds above)")
    l1 = load()
    print(f"\nload average after: {l1[0]:.2f} {l1[1]:.2f} {l1[2]:.2f} (this benchmark adds up to "
          f"{args.threads or default_threads()})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
