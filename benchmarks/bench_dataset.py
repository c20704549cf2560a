"""Benchmark: dataset throughput — photograph-sized seabed samples per hour per core, fast engine
against Monte Carlo, and what a cluster of such machines makes overnight.

Runs ``datasets/seabed.toml`` (640 x 480, every format of :mod:`rigsim.dataset.formats`) for
``--n`` samples on this machine's embedded dask cluster (the way ``rigsim dataset`` runs), from a
cold start (the workers' start-up is included), and the same spec with ``engine = "mitsuba"`` at
``--mc-spp`` paths per pixel for ``--mc-n`` samples (the same first samples).  Prints samples per
hour per core of both, their ratio, and the projection to a 100-node cluster of machines like this
one and of 32-core nodes (throughput scales with workers: samples are independent, and the test
``tests/parallel/test_cluster.py`` shows a killed worker's samples are redone).

    python benchmarks/bench_dataset.py                 # 16 fast samples, 1 Monte Carlo sample at 64 spp
    python benchmarks/bench_dataset.py --n 32 --mc-n 0
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

ROOT = Path(__file__).resolve().parents[1]


def _run(spec, n: int, out: Path) -> tuple[float, list[float]]:
    from rigsim.dataset import run_dataset

    t0 = time.perf_counter()
    run_dataset(spec, n, out, seed=0, progress=True)
    wall = time.perf_counter() - t0
    per = [json.loads(f.read_text())["wall_time_s"] for f in sorted(out.glob("samples/*/record.json"))]
    return wall, per


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=16, help="fast-engine samples")
    ap.add_argument("--mc-n", type=int, default=1, help="Monte Carlo samples (0: skip)")
    ap.add_argument("--mc-spp", type=int, default=64)
    ap.add_argument("--spec", default=str(ROOT / "datasets" / "seabed.toml"))
    a = ap.parse_args(argv)
    import dataclasses

    from rigsim.dataset import load_dataset_spec

    spec = load_dataset_spec(a.spec)
    cores = os.cpu_count() or 1
    print(f"machine: {cores} cores; spec {Path(a.spec).name}: {spec.width}x{spec.height}, engine {spec.engine}, "
          f"{len(spec.wavelengths_nm)} bands")
    with tempfile.TemporaryDirectory() as tmp:
        wall, per = _run(spec, a.n, Path(tmp) / "fast")
        fast_rate = a.n / wall * 3600 / cores
        print(f"fast engine: {a.n} samples in {wall:.1f} s wall (with the workers' start-up); per sample in a "
              f"worker {min(per):.1f}-{max(per):.1f} s (mean {sum(per) / len(per):.1f} s)")
        print(f"  = {fast_rate:.0f} samples per hour per core")
        if a.mc_n > 0:
            mc = dataclasses.replace(spec, engine="mitsuba", spp=a.mc_spp)
            wall_mc, per_mc = _run(mc, a.mc_n, Path(tmp) / "mc")
            mc_rate = a.mc_n / wall_mc * 3600 / cores
            print(f"Monte Carlo ({a.mc_spp} spp): {a.mc_n} samples in {wall_mc:.1f} s wall "
                  f"(per sample {sum(per_mc) / len(per_mc):.1f} s) = {mc_rate:.1f} samples per hour per core")
            print(f"  ratio fast / Monte Carlo: {fast_rate / mc_rate:.0f}x the samples per hour")
    for nodes, per_node, what in ((100, cores, "machines like this one"), (100, 32, "32-core nodes")):
        rate = fast_rate * nodes * per_node
        print(f"projection, {nodes} {what} ({nodes * per_node} cores): {rate:,.0f} samples per hour; "
              f"10 000 samples in {10_000 / rate * 60:.1f} min")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
