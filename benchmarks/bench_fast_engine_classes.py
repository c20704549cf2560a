"""Benchmark: the fast engine's two parts, each against its own share of the Monte Carlo image.

The fast engine (:mod:`rigsim.preview`) splits the light into class A — paths with no surface and at most
one turn by more than ψ_c (:data:`rigsim.preview.model.MS_CUTOFF_DEG`), computed by the analytic model —
and class B, the rest, estimated by the photon tracer of :mod:`rigsim.preview.multiple`.  The renderer
labels each of its own paths the same way (``rigsim_vol``'s ``class_split_deg``: the turns at the water
vertices, the one towards the light included; a surface makes a path class B) and returns class A as an
AOV beside the image, so Monte Carlo gives both shares unbiased.  This prints, for the open water of each
case (the pixels that see no target; ``--region target``: the target's pixels), per colour group:

* the Monte Carlo class-A share of the veil;
* analytic class A / Monte Carlo class A;
* fast engine's class B (its image minus its analytic part) / Monte Carlo class B;
* the whole fast image / Monte Carlo;

with standard errors from the independent renders and the engine's seeds (both shown).  Each case takes
about a minute per 16 renders of 96 x 64 at 64 paths per pixel on 2 cores.

    python benchmarks/bench_fast_engine_classes.py [--rig twin-strobes-edge-lighting --waters jerlov-9C
        --distances 0.5 --target black-disk --renders 16 --seeds 8]

Measured 2026-12-06 with the same split by probe scripts (``twin-strobes-edge-lighting``, Jerlov 9C, black disk at
0.5 m, ψ_c = 30 deg; 48 x 32,
48 renders of 64 paths per pixel; the engine's tracer as the fast engine runs it, 3 seeds of 600 000 photons,
48 cells): Monte Carlo's class A is 48 / 50 / 58 % of the open water's veil (blue / green / red); the analytic
class A / Monte Carlo's 0.998 / 1.001 / 1.004 (+- 0.7 / 0.5 / 0.2 %, 96 x 64, 16 renders): the analytic model
is right.  Class B is what is low: tracer / Monte Carlo 0.942 / 0.917 / 0.943 (+- 1.6 / 1.4 / 0.5 % of
Monte Carlo), with the exact estimators (collision estimator, no δ-truncation, every band) 0.961 / 0.942 /
0.937 (+- 1.5 %): not the class-B estimators but the model they share, most likely the quasi-single camera leg
``e^{-(c - bF) s}`` (light scattered by up to ψ_c on the way to the camera taken as not scattered), which shrinks
with ψ_c: at ψ_c = 10 deg (class B
then 71-83 % of the veil) tracer / Monte Carlo is 0.961 / 0.973 / 0.995 and the whole veil 0.972 / 0.982 /
0.999, against 0.959 / 0.948 / 0.969 at 30 deg.  The fast engine's own class B (100 000 photons, 16 cells)
is the same in expectation (96 x 64, 16 renders: 0.937 / 0.926 / 0.944 with 400 000 photons, engine SE 0.3 %;
0.949 / 0.929 / 0.946 with 100 000) but its seeds scatter: 8 seeds of the default 98 304 photons read 0.906 / 0.906 /
0.922 (their own SE says 0.6 %; the estimate is heavy-tailed: seeds with a vertex near the port).
With this benchmark (96 x 64, 16 renders, 8 seeds; ``--distances 0.5,3``): edge-lit 9C at 0.5 m class A 0.997 /
0.997 / 1.007, at 3 m 0.982 / 0.983 / 0.988, class B 0.949 / 0.949 / 0.977; 7C at 0.5 m A 0.999 / 1.001 / 1.010,
B 0.928 / 0.932 / 0.952, at 3 m A 0.982-0.988, B 0.997 / 0.985 / 1.027; ``twin-strobes-45-wide`` 9C at 1 m A
0.991-0.994, B 0.972 / 0.974 / 0.995: class B is low in the rig whose beams lie just outside the field of view,
over the whole image (9C at 0.5 m, blue, 4 seeds of 400 000 photons: 0.89-0.95 by 12-pixel column group, no trend
towards the sides); without the disk (``--target none``, 9C, 0.5 m, 400 000 photons) B 0.960 / 0.964 / 1.000 and A
0.979 / 0.978 / 0.981.

Where it comes from (``--truncated``, 2026-12-06): in the same water without its scatterings below ψ_c
(:func:`truncated_water`; the transport the fast engine's δ-truncation and quasi-single camera leg assume) the fast
engine is right — 9C, black disk at 0.5 m, 48 x 32, 24 renders, 3 seeds of 400 000 photons: analytic A / Monte Carlo
A 1.002 / 1.007 / 1.010, class B 0.976 / 0.966 / 0.987 (+- 1.0-1.4 %), the whole 0.989 / 0.987 / 1.001 — while
Monte Carlo's own veil in the real water is brighter than in the truncated one (48 renders against 24, the same
scene and size): the whole 1.057 / 1.053 / 1.037 (+- 1.1 / 0.8 / 0.3 %), class A 1.054 / 1.033 / 1.021, class B
1.061 / 1.073 / 1.060 (+- 0.5-1.6 %).  So the estimators are right and the deficit is the model of small-angle
scattering: taken as no scattering (δ-truncation at ψ_c = 30 deg keeps b (1 − F) but not the transport
coefficient b (1 − g): many turns of 5-30 deg add up to wide ones), on the light legs and on the camera leg alike
(the tracer without δ-truncation, its camera leg still quasi-single, was still 4-6 % low).  The analytic class A
recovers its share through its small-angle beam spread; class B has nothing that does.  The same truncated check, 7C
at 0.5 m: class B 0.971 / 0.961 / 0.995, whole 0.989 / 0.988 / 1.007; twin-strobes-45-wide, 9C at 1 m: B 0.986 /
0.982 / 1.003, whole 0.993 / 0.994 / 1.000 (the estimators' own residual: ~3.5 % of class B in green, edge-lit).

The fix (968afd3, :class:`rigsim.preview.multiple.ConeTurns`): the truncated scatterings come back as turns of the
photons' directions along their flights.  With it (``--size 48x32 --renders 48 --seeds 6 --photons 100000 --cache
DIR``, 2026-12-06; logs in the commit's note), class B / Monte Carlo class B and the whole / Monte Carlo in the open
water (blue / green / red; without the turns in brackets, same renders):

* edge-lit 9C 0.5 m: B 0.982 / 0.944 / 0.968 (0.941 / 0.906 / 0.940), whole 0.988 / 0.972 / 0.991 (0.967 / 0.953 /
  0.980); 3 m: whole 0.973 / 0.968 / 0.993 (0.963 / 0.953 / 0.982);
* edge-lit 7C 0.5 m: whole 0.980 / 0.976 / 0.997 (0.969 / 0.967 / 0.990); 3 m 0.988 / 0.985 / 1.008 (0.978 / 0.973
  / 0.998); 5C 0.5 m 0.987 / 0.979 / 1.004 (0.970 / 0.966 / 0.994); 3 m 0.984 / 0.977 / 1.002 (unchanged); III 0.5
  and 3 m unchanged (0.985-1.008);
* twin-strobes-45-wide 9C 1 m: whole 0.991 / 0.986 / 0.992 (0.979 / 0.980 / 0.990); 9C 3 m, 3C 1 and 3 m, coastal 1
  and 3 m unchanged within 0.5 % (0.973-1.002).

The class-B share left low is largest in green (Monte Carlo's own noise there is 1.0-1.3 %); the red class B at
3 m reads 1.01-1.09 where it is 18-40 % of the veil.  With 400 000 photons (6 seeds) the edge-lit 9C case at 0.5 m
reads B 0.977 / 0.934 / 0.960, whole 0.986 / 0.967 / 0.988.

What the class-B deficit left after the camera leg's turns (692f13b) is not (2026-12-06, ``--size 48x32 --renders 48
--cache DIR``, the same renders; class B / Monte Carlo class B, blue / green / red; edge-lit 9C at 0.5 m and 45-wide 9C
at 1 m): not the photon count — 24 seeds of 25 000 photons, 8 of 400 000 and 4 of 1 600 000 read alike (edge-lit
0.960 / 0.919 / 0.944, 0.961 / 0.926 / 0.955, 0.961 / 0.926 / 0.956; 45-wide 0.979 / 0.979 / 1.004, 0.973 / 0.968 /
0.992, 0.978 / 0.969 / 0.989; the 6 seeds of 100 000 above read 1-2 % lower, a draw of the heavy tail); not the
estimators — the plain collision estimator (``track_points=0``: no track length, no near zone) 0.966 / 0.933 / 0.964
and 0.982 / 0.976 / 1.003 (+- 1-3 %), the near zone at 0.3 m instead of 1 m 0.956 / 0.918 / 0.949 and 0.978 / 0.970 /
0.989; nor the kernel in the water (0.05 m), a 32-cell grid or no roulette (each within 1 % at 100 000 photons); nor
the bent paths' sideways spread (points at p + t (d + d_t) / 2 instead of p + t d: within +- 1.5 %, no trend).
Photons carrying every band instead of 8 spectral nodes move class B between the colour groups by 1-2 % (400 000
photons, 8 seeds: edge-lit 0.965 / 0.935 / 0.935, 45-wide 0.987 / 0.980 / 0.979), not up as a whole.  The whole veil:
edge-lit 0.986 / 0.970 / 0.992, 45-wide 0.992 / 0.992 / 0.999 (400 000 photons, 8 seeds).
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
from rigsim.metrics.agreement import colour_groups  # noqa: E402
from rigsim.preview import render_preview  # noqa: E402
from rigsim.preview.model import MS_CUTOFF_DEG  # noqa: E402
from rigsim.render.mitsuba_scene import build_mitsuba_scene  # noqa: E402
from rigsim.render.renderer import render_pass  # noqa: E402
from rigsim.scene.build import build_scene  # noqa: E402
from rigsim.scene.types import Scene  # noqa: E402
from rigsim.scene.phase_tables import phase_tables  # noqa: E402
from rigsim.water import preset  # noqa: E402
from rigsim.water.model import Spectrum1D, TabulatedWater  # noqa: E402
from rigsim.water.phase import MixturePhase, TabulatedPhase  # noqa: E402
from rigsim.spectrum import band_edges  # noqa: E402

WAVELENGTHS_NM = np.arange(400.0, 701.0, 10.0)


def truncated_water(water, cutoff_deg: float):
    """``water`` without its scatterings by less than ``cutoff_deg``: the photon tracer's δ-truncation
    (:meth:`rigsim.scene.phase_tables.PhaseTables.without_forward`) made a water, ``b (1 − F)``, ``a`` unchanged.
    The fast engine's approximations of small-angle scattering (δ-truncation, the quasi-single camera leg) are
    exact in it."""
    full = phase_tables(water.phase, water.wavelength_range_nm)
    tab, Fk = full.without_forward(np.radians(cutoff_deg))
    comps = [TabulatedPhase(m, tab.grid, name=f"truncated-{cutoff_deg:g}") for m in tab.masses]

    def weights(wl):
        return tab.weights_at(wl).reshape(np.shape(wl) + (len(Fk),))

    lo, hi = water.wavelength_range_nm
    wl = np.linspace(lo, hi, int(round(hi - lo)) + 1)
    F = full.weights_at(wl) @ Fk
    return TabulatedWater(f"{water.name} without scatterings below {cutoff_deg:g} deg",
                          Spectrum1D(values=water.a_per_m(wl), wavelength_nm=wl, label="a"),
                          Spectrum1D(values=water.b_per_m(wl) * (1.0 - F), wavelength_nm=wl, label="b"),
                          MixturePhase(comps, weights, name=f"truncated-{cutoff_deg:g}"))


def _se(x: np.ndarray) -> float:
    """Relative standard error of the mean of independent estimates ``x``."""
    return float(x.std(ddof=1) / np.sqrt(len(x)) / abs(x.mean())) if len(x) > 1 else float("nan")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rig", default="twin-strobes-edge-lighting", help="a shipped rig (rigs/<name>.toml)")
    ap.add_argument("--waters", default="jerlov-9C")
    ap.add_argument("--distances", default="0.5", help="target distances (m)")
    ap.add_argument("--target", default="black-disk", help="a target of build_scene, or none (open water only)")
    ap.add_argument("--size", default="96x64", help="image size of both engines (px)")
    ap.add_argument("--renders", type=int, default=16, help="independent Monte Carlo renders per case")
    ap.add_argument("--spp", type=int, default=64, help="paths per pixel of each render")
    ap.add_argument("--seeds", type=int, default=8, help="seeds of the fast engine per case")
    ap.add_argument("--photons", default="", help="the fast engine's photons, comma-separated counts to compare "
                    "(default: its own)")
    ap.add_argument("--cutoff", type=float, default=MS_CUTOFF_DEG, help="ψ_c of both (deg)")
    ap.add_argument("--truncated", action="store_true",
                    help="the waters without their scatterings below ψ_c (truncated_water): the fast engine's own "
                         "transport, to tell its estimators' error from that of its small-angle approximations")
    ap.add_argument("--region", choices=("open", "target"), default="open",
                    help="the pixels compared: the open water (no target) or the target's (all its pieces; there only "
                         "the whole image compares: the renderer labels a target's reflected light class B, the "
                         "analytic model computes its direct part)")
    ap.add_argument("--cache", default="", help="a directory where each case's Monte Carlo renders are kept "
                    "(and read back by a later run with the same case, size, renders and spp)")
    a = ap.parse_args(argv)
    rig_path = ROOT / "rigs" / f"{a.rig}.toml"
    if not rig_path.is_file():
        ap.error(f"--rig: no rigs/{a.rig}.toml")
    try:
        W, H = (int(x) for x in a.size.lower().split("x"))
        distances = [float(x) for x in a.distances.split(",")]
        photon_counts = [int(x) for x in a.photons.split(",")] if a.photons else [None]
    except ValueError:
        ap.error("--size WxH (e.g. 96x64), --distances comma-separated metres")
    if a.renders < 2 or a.seeds < 2:
        ap.error("--renders and --seeds must be >= 2 (standard errors)")
    if not 0.0 < a.cutoff <= 90.0:
        ap.error("--cutoff must be in (0, 90] deg")
    rig = load_rig(rig_path)
    try:  # names checked before any render: a usage line, not a traceback
        for water in a.waters.split(","):
            preset(water)
            if a.target != "none":
                build_scene(rig, water, a.target, distances[0])
    except ConfigError as e:
        ap.error(str(e))
    wl = WAVELENGTHS_NM
    centre, bw = band_edges(wl, None)
    lo = centre - bw / 2
    groups = colour_groups(wl)
    print(f"rig {a.rig}, target {a.target}, {W}x{H}, psi_c {a.cutoff:g} deg; Monte Carlo {a.renders} x {a.spp} spp, "
          f"fast engine {a.seeds} seeds; {'open water' if a.region == 'open' else 'the target'}; ratios +- combined "
          f"relative SE")
    print(f"{'water':>16s} {'m':>4s} {'group':>6s} {'MC A share':>10s} {'analytic A/MC A':>16s} {'engine B/MC B':>14s} "
          f"{'whole/MC':>9s}  (SE MC / engine)")
    for water in a.waters.split(","):
        for dist in distances:
            t0 = time.perf_counter()
            wat = truncated_water(preset(water), a.cutoff) if a.truncated else preset(water)
            scene = (Scene(rig=rig, water=wat, targets=()) if a.target == "none"
                     else build_scene(rig, wat, a.target, dist))
            # the rig's strobes (the fast engine's flash layer), or its continuous lights where it has no strobes
            # (its radiance: these scenes have no daylight)
            strobes = [li for li in scene.lights if li.kind == "strobe"] or list(scene.lights)

            def light_of(im):
                return np.asarray(im.layers["flash"] if "flash" in im.layers else im.radiance, float)
            key = (f"{a.rig}_{water}{'-truncated' if a.truncated else ''}_{dist:g}m_{a.target}_{W}x{H}_"
                   f"{a.renders}x{a.spp}_psi{a.cutoff:g}.npz")
            kept = Path(a.cache) / key if a.cache else None
            if kept is not None and kept.is_file():
                with np.load(kept) as z:
                    M, A_mc = list(z["whole"]), list(z["class_a"])
            else:
                ms = build_mitsuba_scene(scene, lights=strobes, class_split_deg=a.cutoff)
                M, A_mc = [], []
                for i in range(a.renders):
                    aov: dict = {}
                    img, _ = render_pass(ms, scene.camera, width=W, height=H, spp=a.spp, seed=9100 + 7919 * i,
                                         band_lo=lo, band_w=bw, aov_out=aov)
                    M.append(img)
                    A_mc.append(aov["class_a"])
                if kept is not None:  # written whole or not at all
                    kept.parent.mkdir(parents=True, exist_ok=True)
                    tmp = kept.with_suffix(".tmp.npz")
                    np.savez_compressed(tmp, whole=np.array(M, np.float32), class_a=np.array(A_mc, np.float32))
                    tmp.replace(kept)
            t1 = time.perf_counter()
            kw = dict(width=W, height=H, wavelengths_nm=wl, layers=("object_id",), forward_cutoff_deg=a.cutoff)
            an = render_preview(scene, multiple=False, **kw)
            oid = np.asarray(an.layers["object_id"])
            ow = oid == 0 if a.region == "open" else oid > 0
            if not ow.any():
                ap.error(f"--region {a.region}: no such pixels in {water} at {dist:g} m")
            A = light_of(an)[ow].mean(0)
            M = np.array(M)[:, ow].mean(1)
            A_mc = np.array(A_mc)[:, ow].mean(1)
            B_mc = M - A_mc
            for photons in photon_counts:
                E = np.array([light_of(render_preview(scene, multiple=True, seed=s, photons=photons, **kw))[ow].mean(0)
                              for s in range(a.seeds)])
                if len(photon_counts) > 1:
                    print(f"{'':>16s} fast engine with {photons} photons")
                for name, idx in groups.items():
                    m, am, bm, e = (x[:, idx].mean(1) for x in (M, A_mc, B_mc, E))
                    a_an = A[idx].mean()
                    eb = e - a_an
                    if a.region == "open":
                        parts = (f"{am.mean() / m.mean():10.3f} {a_an / am.mean():9.3f} ± {_se(am):.3f} "
                                 f"{eb.mean() / bm.mean():7.3f} ± {np.hypot(_se(bm), _se(eb)):.3f}")
                    else:  # the renderer labels light reflected by a target class B, the analytic model computes
                        # the target's direct light: on a target only the whole compares
                        parts = f"{'-':>10s} {'-':>17s} {'-':>15s}"
                    print(f"{water:>16s} {dist:4g} {name:>6s} {parts} "
                          f"{e.mean() / m.mean():6.3f} ± {np.hypot(_se(m), _se(e)):.3f}  ({_se(m):.3f} / {_se(e):.3f})")
            print(f"{'':>16s} ({t1 - t0:.0f} s Monte Carlo, {time.perf_counter() - t1:.0f} s fast engine)", flush=True)


if __name__ == "__main__":
    main()
