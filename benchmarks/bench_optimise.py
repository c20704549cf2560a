"""Benchmark: the strobe-placement optimiser — time to the optimum and how much better it is.

For each case (a rig, a water, a subject distance; default: ``twin-strobes-45-wide`` with its
``[limits]`` — two strobes, the diffuser on or off — in the demo's coastal and Jerlov 3C waters at
1.5 m) the search (:func:`rigsim.optimise.search.optimise`, default budget, seed 0) is timed on this
machine, and its result is compared with two alternatives measured in the same run:

* the starting rig, and every shipped twin-strobe placement transplanted onto the same camera and
  strobes (their score at the same fidelity);
* a pure random search (the same Sobol sequence, no local refinement) given the same number of
  placements as the optimiser imaged.

Printed per case: wall time to the optimum (target ≤ 60 s on 2 cores), placements imaged, the score
of start, optimum, best shipped placement and random search, and the ratios
``optimum / start``, ``optimum / best shipped`` and ``optimum / random`` (below 1 = the optimiser wins).

    python benchmarks/bench_optimise.py
    python benchmarks/bench_optimise.py --cases twin-strobes-close-to-port:clear:1.0
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import warnings  # noqa: E402

import numpy as np  # noqa: E402

from rigsim.config.rigdoc import RigDoc  # noqa: E402
from rigsim.optimise.objective import REPORT, SEARCH, Setting  # noqa: E402
from rigsim.optimise.search import Evaluator, optimise  # noqa: E402
from rigsim.optimise.space import Space, limits_for  # noqa: E402

SHIPPED = ("twin-strobes-45-wide", "twin-strobes-close-to-port", "twin-strobes-edge-lighting")


def shipped_scores(doc: RigDoc, ev: Evaluator) -> dict[str, float]:
    out = {}
    for name in SHIPPED:
        other = RigDoc.load(ROOT / "rigs" / f"{name}.toml")
        moves = {i: {k: other.light_view(i)[k] for k in ("arm_length_m", "arm_angle_deg", "arm_forward_m", "yaw_deg",
                                                           "pitch_deg", "beam_angle_deg")} for i in range(2)}
        out[name] = ev.evaluation(doc.place_lights(moves), REPORT).score(ev.weights)
    return out


def random_search(space: Space, ev: Evaluator, n: int, seed: int) -> float:
    from scipy.stats import qmc

    with warnings.catch_warnings():  # the same budget as the optimiser, not a power of two
        warnings.simplefilter("ignore")
        pts = qmc.Sobol(d=space.dim, scramble=True, seed=seed).random(n)
    best_u, best_s = None, np.inf
    for u in pts:
        s = ev(space.from_unit(u))
        if s < best_s:
            best_u, best_s = u, s
    doc = space.apply(space.from_unit(best_u))
    return ev.evaluation(doc, REPORT).score(ev.weights)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="twin-strobes-45-wide:coastal:1.5,twin-strobes-45-wide:jerlov-3C:1.5",
                    help="RIG:WATER:DISTANCE,... (rigs from rigs/)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    print(f"cores: {os.cpu_count()}, load average: {os.getloadavg()[0]:.2f}")
    for case in args.cases.split(","):
        rig, water, dist = case.split(":")
        doc = RigDoc.load(ROOT / "rigs" / f"{rig}.toml")
        setting = Setting(water=water, distance_m=float(dist))
        t0 = time.perf_counter()
        opt = optimise(doc, setting, seed=args.seed)
        t_opt = time.perf_counter() - t0
        ev = Evaluator(Space.of(doc, limits=limits_for(doc)), setting, opt.weights, SEARCH, args.seed)
        shipped = shipped_scores(doc, ev)
        t1 = time.perf_counter()
        rnd = random_search(ev.space, ev, opt.evaluations, args.seed + 1)
        t_rnd = time.perf_counter() - t1
        s0, s1 = opt.start.score(opt.weights), opt.best.score(opt.weights)
        best_shipped = min(shipped, key=shipped.get)
        print(f"\n{rig} in {water} at {dist} m")
        print(f"  optimiser: {t_opt:.1f} s to the optimum (target <= 60 s), {opt.evaluations} placements imaged")
        print(f"  score (lower is better): start {s0:.4f}, optimum {s1:.4f}, best shipped ({best_shipped}) "
              f"{shipped[best_shipped]:.4f}, random search of {opt.evaluations} placements {rnd:.4f} ({t_rnd:.1f} s)")
        for name, v in shipped.items():
            print(f"    shipped placement {name}: {v:.4f}")
        print(f"  ratios: optimum/start {s1 / s0:.3f}, optimum/best shipped {s1 / shipped[best_shipped]:.3f}, "
              f"optimum/random {s1 / rnd:.3f}")
        print(f"  optimum: {opt.space.describe_doc(opt.best_doc)}")


if __name__ == "__main__":
    main()
