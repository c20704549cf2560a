"""Photons per second of the Monte Carlo ambient light meter (one core).

Run: ``python benchmarks/bench_ambient.py [PHOTONS]``.  Prints, per water and
wavelength, the wall time and photons/s (cost grows with the single-scattering
albedo: more collisions per photon).
"""

from __future__ import annotations

import sys
import time

from rigsim.config.water import load_water
from rigsim.daylight import ambient_light_monte_carlo


def main(photons: int = 50_000) -> None:
    for name, wl in (("jerlov-I", 450.0), ("jerlov-II", 550.0), ("coastal", 550.0), ("jerlov-5C", 550.0)):
        w = load_water(name)
        t = time.perf_counter()
        ambient_light_monte_carlo(w, [wl], [1.0, 5.0, 10.0, 20.0], sun_zenith_deg=30.0, photons=photons, seed=0)
        dt = time.perf_counter() - t
        print(f"{name:10s} {wl:5.0f} nm  albedo {float(w.albedo(wl)):.3f}  {dt:6.2f} s  {photons / dt:10.0f} photons/s")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 50_000)
