"""Benchmark: the fast engine against Monte Carlo over waters × distances × rigs (and daylight).

The whole error table of issue 18: for every water (the original write-up's six named waters and
Jerlov's types by default), distance, shipped strobe rig and target (ColorChecker, black disk) — and
for daylight at 5 and 15 m (the ``ambient-only`` rig) — the fast engine's region means (each chart
patch, the disk, the open-water veil; blue / green / red bands) against the mean of ``--seeds``
independent Monte Carlo renders — more, up to ``--max-seeds``, where those leave the reference too
noisy (a two-stage reference: :class:`rigsim.study.spec.CheckSettings`) — with its standard error.  It runs as a study (the
same machinery, :mod:`rigsim.metrics.agreement`, that checks every fast-engine study: every case
checked), so it is parallel on dask, shows progress and resumes: run it again with the same
``--out`` after an interruption.

Prints, per water: the worst deviation of each kind of region and per colour group, with its
standard error and the tolerance (3 % clear water, 5 % elsewhere); then the worst cells overall
and the count of cells beyond tolerance + the difference's 95 % half-width (Student's t · SE for the seeds; the SE
holds the reference's noise and the fast engine's own, from its photon batches).  Everything is in ``<out>/*/agreement.csv``.
The range ends where the chart can no longer be seen: the patches of a chart case whose contrast is below 1 % in both
engines are listed (verdict "beyond visibility", the published table's ``beyond_visibility``) but not judged
(:func:`rigsim.metrics.agreement.chart_beyond_visibility`).

    python benchmarks/bench_fast_engine_agreement.py                       # everything: hours on 2 cores
    python benchmarks/bench_fast_engine_agreement.py --quick               # 3 waters, 2 distances, 1 rig
    python benchmarks/bench_fast_engine_agreement.py --waters jerlov-7C --distances 1,3 --rigs twin-strobes-45-wide
    python benchmarks/bench_fast_engine_agreement.py --multiple-scattering off --quick    # without the multiply scattered light
    python benchmarks/bench_fast_engine_agreement.py --quick --out out/b --renders-from out/a   # a fast-engine change
                                                                  # against the Monte Carlo renders a run into out/a kept
    python benchmarks/bench_fast_engine_agreement.py --status   # the published table: which rows this engine measured
    python benchmarks/bench_fast_engine_agreement.py --rejudge --publish   # a changed fast engine against the kept
                                                                  # cells of the published rows (fast images only)
    python benchmarks/bench_fast_engine_agreement.py --verify-unchanged --publish   # rows of earlier engines whose
                                                                  # fast images this checkout makes bit for bit
    python benchmarks/bench_fast_engine_agreement.py --remake --hours 3   # rows of earlier engines made again, one
                                                                  # distance per run, each published as it ends

Each Monte Carlo render is kept as it finishes (``<out>/<lighting>/mc-renders``, keyed by the scene's contents, seed,
bands and render settings, the renderer's default sampling options among them — not by where the checkout is, nor by
the fast engine): a run asked for more renders (``--max-seeds``) renders only the new ones, and ``--renders-from``
checks a changed fast engine against the same references without rendering them again (renders a sampler since changed
drew are not reused: :func:`rigsim.render.integrators.integrator_key`).

``--publish`` writes the per-water, per-rig summary to ``data/fast_engine/agreement.csv`` (what the rig designer and
``--status`` read) and each row's every cell to
``data/fast_engine/cells/<lighting>__<water>__<rig>__<distances>.csv.gz``
(fast and reference values, each one's standard error, the reference's tail, the verdict; headed by the settings and
the command): the table's numbers with what they came from, for reading cell by cell and for judging a later change of
the fast engine against the same references.  Rows published before 2026-12-07 have cells only where their run was
still on disk then (14 of 118).  ``--rejudge`` makes each such row's fast images again with this checkout (the same
study settings and seeds: :func:`rigsim.study.case.fast_check_images`) and compares them with the kept reference numbers
(:func:`rigsim.metrics.agreement.compare_to_cells`): about 1.5 min per row on 2 cores, and it prints how far the fast
values moved (0.00 % for an unchanged engine: Jerlov II 45-wide, 2026-12-07, 324 cells).  A row of an earlier engine
can be made again one distance at a time (``--distances 3``, each run published as it ends: a turbid row's hybrid
references cost hours, and a run cut off loses what it had not published); the earlier row goes with the run that
brings its last distance (``write_published``'s ``current``), and ``--status`` says which of its distances are in.

``--reference hybrid``: the chart cases lit by strobes or by continuous lights are referenced by hybrid images
instead (:mod:`rigsim.render.hybrid`: the renders' veil plus the chart's light traced from the lights and seen
through the water by a camera pass; kept beside the renders), where the renders' chart patches are
heavy-tailed (Jerlov III, 5C-9C); the disk and daylight cases stay renders.

    python benchmarks/bench_fast_engine_agreement.py --waters jerlov-7C,jerlov-9C --distances 1,3 \
        --rigs twin-strobes-edge-lighting --depths '' --spp 32 --seeds 4 --max-seeds 32 --hybrid-max-seeds 8 \
        --reference hybrid --hybrid-photons 2000000 --hybrid-spp 128 --out out/agree-hybrid
"""

from __future__ import annotations

import argparse
import csv
import functools
import math
import os
import shlex
import signal
import sys
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

#: The per-water summary the rig designer shows beside its numbers (``--publish``).
PUBLISHED = ROOT / "data" / "fast_engine" / "agreement.csv"
#: Each published row's every cell (``--publish``; rigsim.metrics.agreement.write_cells).
CELLS = ROOT / "data" / "fast_engine" / "cells"

STROBE_RIGS = ("twin-strobes-45-wide", "twin-strobes-close-to-port", "twin-strobes-edge-lighting",
               "single-strobe-short-arm", "video-lights-pair")

STUDY = """[study]
name = "{name}"
seed = 1

[sweep]
rigs = {rigs}
sensors = ["sony_ilce-7rm2"]
waters = {waters}
distances_m = {distances}
targets = ["colorchecker", "black-disk"]
target_fill = 0.4
extend_visibility = false
{depth}

[render]
engine = "fast"
width = {width}
height = {height}
wavelengths = "400:700:10"
check_with_mitsuba = 10000
multiple_scattering = "{ms}"

[check]
width = {width}
height = {height}
spp = {spp}
seeds = {seeds}
max_seeds = {max_seeds}
target_se = {target_se}
reference = "{reference}"
hybrid_photons = {hybrid_photons}
hybrid_spp = {hybrid_spp}
hybrid_veil_renders = {hybrid_veil}
hybrid_veil_sigma_px = {hybrid_sigma}
fast_noise_seeds = {fast_noise}
{hybrid_order}{hybrid_max}{hybrid_veil_max}"""


def _list(text: str) -> list[str]:
    return [x.strip() for x in text.split(",") if x.strip()]


def _fraction(text: str) -> float:
    """A relative standard error on the command line: a number in (0, 1] (else argparse's usage line)."""
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not 0.0 < x <= 1.0:
        raise argparse.ArgumentTypeError(f"{text} is not in (0, 1]")
    return x



def _engine_id() -> str:
    """The checkout's commit ("commit 692f13b", "-dirty" if anything of :data:`ENGINE_PATHS` differs from it: the
    package, its data, the rigs); "" without git."""
    import subprocess

    try:
        head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                              text=True, timeout=30, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--", *ENGINE_PATHS],
                               capture_output=True, text=True, timeout=30, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""
    return f"commit {head}{'-dirty' if dirty else ''}" if head else ""


#: What makes and compares the two images of a check: a change here since a row's commit makes it a row of an earlier
#: engine (``--status``); the rigs are the scenes'.  The study's runner, the sensor, datasets, the UI and the report are
#: not among them.
ENGINE_PATHS = ("rigsim/preview", "rigsim/water", "rigsim/light", "rigsim/scene", "rigsim/render", "rigsim/daylight",
                "rigsim/metrics", "rigsim/config", "rigsim/spectrum.py", "rigsim/spectral_image.py",
                "rigsim/environment.py", "rigsim/data.py", "rigsim/study/case.py", "rigsim/study/spec.py", "data", "rigs",
                ":(exclude)data/fast_engine")


#: Commits that changed only how the checks judge their cells or size their references — not the fast engine, nor
#: the scenes and renders it is compared with: a row measured before them is still this engine's measurement (its
#: ``beyond_visibility`` is blank where it was judged before the visibility rule: every cell judged, the stricter way).
CHECK_ONLY_COMMITS: dict[str, str] = {
    "6441541": "the visibility rule: chart cells of cases beyond the chart's visibility listed, not judged",
    "db334ac": "two-stage references sized on the regions that will be judged",
    "4bf50e6": "the published line names the cells not judged",
    "fcec5ec": "each chart's patches pooled per colour group (printed only)",
    "b23ae01": "the hybrid reference's chart fit of order 4 (the references of later runs, not the fast engine)",
    "053c838": "the fast engine's noise per region moderated over a case's regions (the check's SE, not the image)",
    "b7e6fc4": "the fast engine's noise from further renders' photon batches (the check's SE, not the image)",
    "332b096": "a hybrid image averages 16 renders' veil by default (the study's reference, not the fast engine)",
    "30b92db": "tidying of the check's code (same behaviour)",
    "65cfdf0": "the hybrid reference's renders per image chosen from its pilot (the reference, not the fast engine)",
    "67fa609": "tidying of the hybrid check's code (same behaviour)",
    "5fadf90": "each published row's cells written beside the table (the writer of the table, not the engine)",
    "026c64c": "the check's fast side and comparison split for --rejudge (same images and numbers: a re-judge of an "
               "unchanged row reproduced its fast values to 0.00 %)",
    "67724fa": "tidying (__all__ reflowed; same behaviour)",
    "1c7e58f": "the visibility rule factored out (same behaviour)",
    "9da4a16": "docstrings of rigsim/preview/multiple.py only (same behaviour)",
    "18c7c4c": "the per-pixel passes' thread count in dask workers (the image does not depend on it)",
    "f038c33": "the published table's writer shared with --verify-unchanged's restamping (same table)",
    "8aaeb70": "the single-scattering veil grid reused by renders that differ in their traced light alone (the same "
               "images bit for bit: fast_snapshot.py of 3 rows at ce2fa2b and at 8aaeb70, 360 arrays identical)",
    "5f0421c": "the published line of a restamped row names both engines (text only)",
    "f09dcee": "marine snow checks: the particle-free pass for the pilot's renders alone (no benchmark water has "
               "particles; the fast engine unchanged)",
    "3344b67": "the particles' layer test moved to rigsim.metrics.specks (no behaviour change)",
    "96256fd": "the renderer's equiangular continuation share 0.05 (the references of later runs, not the fast engine)",
    "8b7da01": "the published table drops an earlier engine's row once this engine's rows cover its distances (the "
               "table's writer, not the engine)",
    "bbbf2d3": "rigsim.metrics.agreement's distance parser made public (a rename)",
    "b5ceef4": "the fast engine's noise target in multiple.py's docstring (no code)",
    "e4db511": "render_preview refuses a noise target outside (0, 1] (the images of every valid call unchanged)",
    "37ec992": "the tracer's batch-noise formula shared by a trace and a merge (same values; the images unchanged)",
}


def _same_engine(commit: str) -> bool:
    """Whether the fast engine and the check of ``commit`` are this checkout's: no change since in
    :data:`ENGINE_PATHS` (the working tree's edits included), or only the commits of :data:`CHECK_ONLY_COMMITS`."""
    import subprocess

    def git(*a):
        return subprocess.run(["git", "-C", str(ROOT), *a], capture_output=True, text=True, timeout=60)

    try:
        if git("diff", "--quiet", commit, "--", *ENGINE_PATHS).returncode == 0:
            return True
        if not CHECK_ONLY_COMMITS or git("diff", "--quiet", "HEAD", "--", *ENGINE_PATHS).returncode != 0:
            return False  # (uncommitted edits of the engine)
        since = git("rev-list", f"{commit}..HEAD", "--", *ENGINE_PATHS)
        return since.returncode == 0 and all(any(c.startswith(k) for k in CHECK_ONLY_COMMITS)
                                             for c in since.stdout.split())
    except (OSError, subprocess.SubprocessError):
        return False


@functools.lru_cache(maxsize=None)
def _engine_is_current(engine: str) -> bool:
    """Whether a published row's ``engine`` ("commit 692f13b") is this checkout's fast engine (:func:`_same_engine`;
    blank, from before the column, and "-dirty" never are)."""
    return bool(engine) and not engine.endswith("-dirty") and _same_engine(engine.removeprefix("commit "))


def print_status(path: Path = PUBLISHED) -> int:
    """The published table as it stands: its rows, cells and cells beyond tolerance + t*SE by the fast engine
    that measured them — this checkout's (a commit since which the engine did not change) or an earlier one —
    and the rows of earlier engines, which a change of the engine left to be made again."""
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(ln for ln in fh if not ln.startswith("#")))
    same = {e: _engine_is_current(e) for e in {r.get("engine") or "" for r in rows}}
    n = lambda rs, k: sum(int(r.get(k) or 0) for r in rs)  # noqa: E731
    over = lambda rs: sum(abs(float(r["worst_deviation"])) > float(r["tolerance"]) for r in rs)  # noqa: E731
    cur = [r for r in rows if same[r.get("engine") or ""]]
    old = [r for r in rows if not same[r.get("engine") or ""]]
    shown = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
    print(f"{shown}: {len(rows)} rows, {n(rows, 'cells')} cells, {n(rows, 'beyond')} beyond tolerance "
          f"+ t*SE; {over(rows)} rows whose worst cell is beyond its tolerance (within the noise of the difference: "
          f"the reference's and the fast engine's); "
          f"{n(rows, 'beyond_visibility')} chart cells beyond the chart's visibility, not judged")
    verified = [r for r in cur if "fast images identical to those of" in (r.get("settings") or "")]
    engines = ", ".join(sorted({r['engine'].removeprefix('commit ') for r in cur if r not in verified}))
    print(f"  this checkout's fast engine{f' (measured at {engines})' if engines else ''}: {len(cur)} rows, "
          f"{n(cur, 'cells')} cells, {n(cur, 'beyond')} beyond, {over(cur)} rows with a worst cell beyond its tolerance")
    if verified:
        print(f"    of them measured by an earlier engine whose fast images this one makes bit for bit "
              f"(--verify-unchanged): {len(verified)} rows")
    before_rule = [r for r in cur if not (r.get("beyond_visibility") or "").strip()]
    if before_rule:
        print(f"    of them judged before the visibility rule (every chart cell judged, also where the chart cannot be "
              f"seen): {len(before_rule)} rows")
    print(f"  earlier engines (blank: before the column, 2026-12-06): {len(old)} rows, {n(old, 'cells')} cells, "
          f"{n(old, 'beyond')} beyond; to make again (--remake does, a distance per run):")
    groups: dict[tuple[str, str], list[str]] = defaultdict(list)
    from rigsim.metrics.agreement import distance_set

    remade: dict[tuple[str, str, str], set[float]] = defaultdict(set)  # distances this engine has re-made
    dists = lambda r: distance_set(r["distances_m"])  # noqa: E731
    for r in cur:
        remade[(r["lighting"], r["rig"], r["water"])] |= dists(r)
    for r in old:
        done = sorted(remade[(r["lighting"], r["rig"], r["water"])] & dists(r))
        part = f"; {', '.join(f'{d:g}' for d in done)} m re-made" if done else ""
        groups[(r["lighting"], r["rig"])].append(f"{r['water']} ({r['distances_m']} m{part})")
    for (light, rig), ws in sorted(groups.items()):
        print(f"    {light:<14} {rig:<28} {'; '.join(ws)}")
    beyond_bare = sorted((r for r in rows if abs(float(r["worst_deviation"])) > float(r["tolerance"])),
                         key=lambda r: -abs(float(r["worst_deviation"])))
    if beyond_bare:  # the rows that keep the table from its tolerances, largest first (what to make again first)
        print("  rows whose worst cell is beyond its bare tolerance, largest first (worst cell ± its SE; engine):")
        for r in beyond_bare:
            print(f"    {r['lighting']:<14} {r['rig']:<28} {r['water']:<11} ({r['distances_m']} m)  "
                  f"{100 * float(r['worst_deviation']):+.1f} ± {100 * float(r['worst_se']):.1f} %  {r['worst_where']}; "
                  f"{'this engine' if same[r.get('engine') or ''] else 'earlier engine'}")
    return 0


#: The settings a row of an earlier engine is made again with (``--remake``): the strobe rows' hybrid command and the
#: daylight rows' command of the README (what the table's current rows were measured with).
REMAKE_STROBES = ("--depths", "", "--spp", "32", "--seeds", "4", "--max-seeds", "32", "--hybrid-max-seeds", "8",
                  "--reference", "hybrid", "--hybrid-photons", "2000000", "--hybrid-spp", "128")
REMAKE_DAYLIGHT = ("--rigs", "", "--daylight-target-se", "0.0075")


def remake_plan(table: dict, current) -> list[tuple[str, str, str, float]]:
    """What ``--remake`` runs: ``(lighting, rig, water, distance_m)`` for each distance of each row of an earlier
    engine (``current(row)`` false) that no row of this engine covers yet — the rows whose worst cell is beyond its
    bare tolerance first (largest first: what keeps the table from its tolerances), then the clear waters' before
    the turbid ones' (tolerance 3 % before 5 %, the table's order within), each row's distances in its order.
    ``table``: :func:`rigsim.metrics.agreement.read_published`."""
    from rigsim.metrics.agreement import distance_set

    def dists(r) -> list[float]:
        return sorted(distance_set(r["distances_m"]))

    covered: dict[tuple[str, str, str], set[float]] = defaultdict(set)
    for r in table.values():
        if current(r):
            covered[(r["lighting"], r["rig"], r["water"])] |= set(dists(r))
    stale = [r for r in table.values() if not current(r)]

    def order(r):
        worst, tol = abs(float(r["worst_deviation"] or 0)), float(r["tolerance"] or 0.05)
        return (0, -worst) if worst > tol else (1, tol)

    plan: list[tuple[str, str, str, float]] = []
    for r in sorted(stale, key=order):
        key = (r["lighting"], r["rig"], r["water"])
        plan += [(*key, d) for d in dists(r) if d not in covered[key] and (*key, d) not in plan]
    return plan


def remake_command(item: tuple[str, str, str, float], out: Path) -> list[str]:
    """The benchmark's arguments that make ``item`` (:func:`remake_plan`) again and publish it, renders kept in
    ``out``/<lighting>__<water>__<rig> (a run cut off and started again renders only what it lacks)."""
    lighting, rig, water, d = item
    folder = out / f"{lighting}__{water}__{rig}"
    common = ["--waters", water, "--distances", f"{d:g}", "--publish", "--out", str(folder)]
    if lighting == "strobes":
        return ["--rigs", rig, *REMAKE_STROBES, *common]
    if lighting.startswith("daylight-") and lighting.endswith("m"):
        return [*REMAKE_DAYLIGHT, "--depths", lighting.removeprefix("daylight-").removesuffix("m"), *common]
    raise ValueError(f"{lighting!r}: not a lighting this benchmark makes (strobes, daylight-<depth>m)")


def remake(out: Path, *, hours: float | None, dry_run: bool, waters: set | None, rigs: set | None) -> int:
    """``--remake``: the rows of earlier engines made again with this checkout, one distance per run of this script
    (a child process; :func:`remake_plan`'s order), each published as it ends, until none is left or ``hours`` have
    passed (no run starts after that; the one running ends).  The plan is read again from the table before every run,
    so a run started again (after a kill, on another day) goes on where the table stands; a distance whose run
    failed is not tried again in the same invocation.  Each run's output goes to ``out``/<item>.log; a line per run
    here.  Returns 0 when the plan is done or the time is up, 1 if a run failed or the checkout's engine has
    uncommitted edits (its rows could never count as this engine's)."""
    import subprocess

    from rigsim.metrics.agreement import distance_set, read_published

    engine = _engine_id()
    if not dry_run and (not engine or engine.endswith("-dirty")):
        print(f"this checkout's engine is {engine or 'unknown (no git)'}: commit it before --remake (its rows would "
              "never count as this engine's)", file=sys.stderr)
        return 1

    def plan() -> list:
        table = read_published(PUBLISHED)
        return [it for it in remake_plan(table, lambda r: _engine_is_current(r.get("engine") or ""))
                if (waters is None or it[2] in waters) and (rigs is None or it[1] in rigs)]

    todo = plan()
    print(f"{len(todo)} distances of rows of earlier engines to make again"
          + (" (only --waters / --rigs given)" if waters is not None or rigs is not None else ""), flush=True)
    if dry_run:
        for it in todo:
            print(f"  {it[0]:<13} {it[1]:<28} {it[2]:<17} {it[3]:g} m:  python benchmarks/bench_fast_engine_agreement.py "
                  + " ".join(shlex.quote(a) for a in remake_command(it, out)))
        return 0
    out.mkdir(parents=True, exist_ok=True)
    t0, failed, tried = time.monotonic(), 0, set()
    child: list[subprocess.Popen] = []

    def on_term(signum, frame):  # a kill of this process ends the running child too (its renders are kept)
        for c in child:
            c.terminate()
        raise KeyboardInterrupt

    old_term = signal.signal(signal.SIGTERM, on_term)
    try:
        while True:
            todo = [it for it in plan() if it not in tried]
            if not todo:
                print(f"done: nothing left to make again ({failed} runs failed)" if failed else
                      "done: nothing left to make again", flush=True)
                break
            if hours is not None and time.monotonic() - t0 > 3600 * hours:
                print(f"--hours {hours:g} passed: {len(todo)} distances left (run the same command again)", flush=True)
                break
            it = todo[0]
            tried.add(it)
            args = remake_command(it, out)
            log_path = out / f"{it[0]}__{it[2]}__{it[1]}__{it[3]:g}.log"
            t = time.monotonic()
            print(f"[{time.strftime('%H:%M')}] {it[0]} {it[1]} {it[2]} {it[3]:g} m ({len(todo)} left) ...", flush=True)
            with open(log_path, "w") as log:
                p = subprocess.Popen([sys.executable, str(Path(__file__).resolve()), *args], stdout=log,
                                     stderr=subprocess.STDOUT, cwd=ROOT)
                child[:] = [p]
                rc = p.wait()
                child.clear()
            row = next((r for r in read_published(PUBLISHED).values()
                        if (r["lighting"], r["rig"], r["water"]) == it[:3] and distance_set(r["distances_m"]) == {it[3]}
                        and _engine_is_current(r.get("engine") or "")), None)
            said = (f"worst {100 * float(row['worst_deviation']):+.1f} ± {100 * float(row['worst_se']):.1f} % "
                    f"({row['worst_where']}), {row['beyond']} of {row['cells']} beyond" if rc == 0 and row else
                    f"failed (exit {rc}): {log_path}" if rc != 0 else
                    f"ended, but no row of this engine for it is in the table: {log_path}")
            failed += rc != 0 or row is None
            print(f"    {(time.monotonic() - t) / 60:.0f} min: {said}", flush=True)
    except KeyboardInterrupt:
        print("interrupted: what was published stays; the same command goes on from there", file=sys.stderr)
        return 130
    finally:
        signal.signal(signal.SIGTERM, old_term)
    return 1 if failed else 0


def main(argv=None) -> int:
    from rigsim.water import JERLOV_TYPES, ORIGINAL_PRESETS

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--waters", default=",".join(list(ORIGINAL_PRESETS) + [f"jerlov-{t}" for t in JERLOV_TYPES]))
    ap.add_argument("--distances", default="0.5,1,2,4,6")
    ap.add_argument("--rigs", default=",".join(STROBE_RIGS))
    ap.add_argument("--depths", default="5,15", help="daylight cases (the ambient-only rig); '' for none")
    ap.add_argument("--size", default="96x64", help="image size of both engines (px)")
    ap.add_argument("--spp", type=int, default=64, help="paths per pixel of each Monte Carlo render")
    ap.add_argument("--seeds", type=int, default=4, help="independent Monte Carlo renders per case (the pilot)")
    ap.add_argument("--max-seeds", type=int, default=16,
                    help="two stages: as many more renders as bring the pilot's regions' relative SE (90th "
                         "percentile) to --target-se, up to this many in all (= --seeds: one stage)")
    ap.add_argument("--target-se", type=_fraction, default=0.015, help="the reference's relative SE aimed at")
    ap.add_argument("--daylight-target-se", type=_fraction, default=None,
                    help="the same for the daylight cases (default: --target-se).  Their renders are cheap (a 96x64 "
                         "render of 32 paths per pixel in 0.2 s against 2-4 s for strobes in turbid water): 0.005 gives "
                         "them 30-200 renders each")
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "bench-fast-engine-agreement")
    ap.add_argument("--serial", action="store_true")
    ap.add_argument("--multiple-scattering", choices=("off", "on", "auto"), default="auto",
                    help="the fast engine's multiply scattered light ([render] multiple_scattering; default auto, as studies)")
    ap.add_argument("--quick", action="store_true", help="clear, coastal-regions, jerlov-3C at 1 and 3 m, one rig")
    ap.add_argument("--renders-from", type=Path, default=None, metavar="DIR",
                    help="use (and add to) the Monte Carlo renders kept by an earlier run with --out DIR "
                         "(<DIR>/<lighting>/mc-renders): a change to the fast engine is checked against the same "
                         "references in minutes")
    ap.add_argument("--reference", choices=("monte-carlo", "hybrid"), default="monte-carlo",
                    help="hybrid: the chart cases' references are renders whose chart light is light-traced and seen "
                         "through the water by a camera pass (rigsim.render.hybrid; for turbid water, where the "
                         "renders' chart patches are heavy-tailed); the disk and daylight cases stay renders")
    ap.add_argument("--hybrid-photons", type=int, default=1_000_000, help="light-tracer photons per hybrid image")
    ap.add_argument("--hybrid-spp", type=int, default=64, help="camera-pass paths per pixel and band per hybrid image")
    ap.add_argument("--hybrid-veil-renders", type=int, default=16,
                    help="renders whose veil each hybrid image averages (the veil over a 30-pixel patch is the hybrid's "
                         "noisiest part: Jerlov 7C, edge-lit rig at 1 m, 32 renders of 32 spp left it 1-6 %% of a patch's "
                         "light, the camera passes 0.2-0.8 %%; a render costs ~3 s at 96x64, a camera pass ~170 s.  "
                         "Jerlov III, 45-wide, chart at 3 m: the worst patch cell -12.0 +- 13.7 %% with 4, -4.5 +- 3.1 %% "
                         "with 16; until 2026-12-06: 4)")
    ap.add_argument("--hybrid-veil-max-renders", type=int, default=64,
                    help="from the pilot's images, as many renders' veil per hybrid image as make the reference cheapest "
                         "for its noise, up to this many (rigsim.render.hybrid.veil_renders_for; = --hybrid-veil-renders: "
                         "that many always).  A chart 3-6 m into Jerlov II/III is 75-99 %% veil and one render's veil "
                         "varies 100-10^5 times as much as one camera pass's light; at 0.5-1 m the pass is most of it "
                         "(until 2026-12-07: --hybrid-veil-renders always)")
    ap.add_argument("--hybrid-veil-sigma-px", type=float, default=4.0,
                    help="kernel (px) of the local quadratic that pools each hybrid image's veil over the chart "
                         "(rigsim.render.hybrid.smooth_chart_veil; 0: each pixel's own)")
    ap.add_argument("--hybrid-order", type=int, default=None,
                    help="order of the polynomial fitted to the chart's light-traced irradiance (default "
                         "rigsim.render.hybrid.DEFAULT_FIT_ORDER, 4; until 2026-12-06: 2)")
    ap.add_argument("--hybrid-max-seeds", type=int, default=None,
                    help="--max-seeds for the hybrid cases alone (the disk and daylight cases keep --max-seeds)")
    ap.add_argument("--fast-noise-seeds", type=int, default=3,
                    help="further fast renders per case (other seeds) whose photon batches join the checked image's own "
                         "in its noise estimate (3 + 3 per render degrees of freedom; 0: the image's 4 batches alone, "
                         "as the tables before 2026-12-07)")
    ap.add_argument("--status", action="store_true",
                    help=f"print {PUBLISHED.relative_to(ROOT)} by the fast engine each row measured (this checkout's or "
                         "an earlier one) and the rows to make again; renders nothing")
    ap.add_argument("--rejudge", action="store_true",
                    help=f"judge this checkout's fast engine against the references the published rows kept "
                         f"({CELLS.relative_to(ROOT)}; --waters / --rigs select rows when given): the fast images "
                         "alone, "
                         "no Monte Carlo (minutes per row); with --publish those rows are re-made")
    ap.add_argument("--verify-unchanged", action="store_true",
                    help="rows of earlier engines (--status) whose fast images this checkout makes bit for bit: each "
                         "row's cases rendered by the fast engine of the row's commit (a temporary git worktree) and of "
                         "this checkout and compared array by array (--waters / --rigs select rows when given; 102 "
                         "rows in 15 min on 2 cores); with --publish such rows are stamped as this engine's")
    ap.add_argument("--publish", action="store_true",
                    help=f"write the per-water summary to {PUBLISHED.relative_to(ROOT)} (the rig designer shows it)")
    ap.add_argument("--remake", action="store_true",
                    help="make the rows of earlier engines (--status) again with this checkout, one distance per run, "
                         "each published as it ends (rows beyond their tolerance first; the settings of the README's "
                         "hybrid and daylight commands; renders kept in <--out>/remake; --waters / --rigs select rows "
                         "when given).  Started again, it goes on where the table stands.  The checkout must be "
                         "committed and stay as it is while it runs (a git worktree of it if you keep working)")
    ap.add_argument("--dry-run", action="store_true", help="with --remake: print what it would run, run nothing")
    ap.add_argument("--hours", type=float, default=None,
                    help="with --remake: start no run after this many hours (the one running ends)")
    args = ap.parse_args(argv)
    if (args.dry_run or args.hours is not None) and not args.remake:
        ap.error("--dry-run and --hours go with --remake")
    if args.hours is not None and not (math.isfinite(args.hours) and args.hours > 0):
        ap.error(f"--hours must be > 0, got {args.hours:g}")
    if args.status:
        return print_status()
    def picked(name: str) -> set | None:  # the rows asked for: all unless the option was given
        value = getattr(args, name)
        return set(_list(value)) if value != ap.get_default(name) else None

    if args.remake:
        if args.rejudge or args.verify_unchanged or args.publish:
            ap.error("--remake runs alone (its runs publish)")
        return remake(args.out / "remake", hours=args.hours, dry_run=args.dry_run, waters=picked("waters"),
                      rigs=picked("rigs"))
    if args.rejudge and args.verify_unchanged:
        ap.error("--rejudge and --verify-unchanged: one at a time")
    if args.rejudge:
        return rejudge(waters=picked("waters"), rigs=picked("rigs"), publish=args.publish,
                       command="python benchmarks/bench_fast_engine_agreement.py " + " ".join(
                           shlex.quote(a) for a in (sys.argv[1:] if argv is None else argv)))
    if args.verify_unchanged:
        return verify_unchanged(waters=picked("waters"), rigs=picked("rigs"), publish=args.publish)
    if args.quick:
        args.waters, args.distances, args.rigs, args.depths = "clear,coastal-regions,jerlov-3C", "1,3", \
            "twin-strobes-45-wide", ""
    w, h = (int(x) for x in args.size.lower().split("x"))
    waters, rigs = _list(args.waters), _list(args.rigs)
    distances = [float(x) for x in _list(args.distances)]
    runs = [("strobes", [str(ROOT / "rigs" / f"{r}.toml") for r in rigs], "")] if rigs else []  # --rigs '': daylight only
    runs += [(f"daylight-{d:g}m", [str(ROOT / "rigs" / "ambient-only.toml")], f"depth_m = {float(d)}")
             for d in (float(x) for x in _list(args.depths))]

    from rigsim.errors import ConfigError
    from rigsim.study import load_study, run_study
    from rigsim.study.runner import MC_RENDERS, agreement_rows, read_checks

    args.out.mkdir(parents=True, exist_ok=True)
    rows: list[dict] = []
    missing = False
    t0 = time.perf_counter()
    for name, rig_files, depth in runs:
        f = args.out / f"{name}.toml"
        f.write_text(STUDY.format(name=name, rigs=rig_files, waters=waters, distances=distances, depth=depth,
                                  width=w, height=h, spp=args.spp, seeds=args.seeds,
                                  max_seeds=max(args.seeds, args.max_seeds),
                                  target_se=args.target_se if name == "strobes" or args.daylight_target_se is None
                                  else args.daylight_target_se,
                                  ms=args.multiple_scattering, reference=args.reference,
                                  hybrid_photons=args.hybrid_photons, hybrid_spp=args.hybrid_spp,
                                  hybrid_veil=args.hybrid_veil_renders,
                                  hybrid_sigma=args.hybrid_veil_sigma_px, fast_noise=args.fast_noise_seeds,
                                  hybrid_order=(f"hybrid_order = {args.hybrid_order}\n"
                                                if args.hybrid_order is not None else ""),
                                  hybrid_max=(f"hybrid_max_seeds = {args.hybrid_max_seeds}\n"
                                              if args.hybrid_max_seeds is not None else ""),
                                  hybrid_veil_max=(f"hybrid_veil_max_renders = {args.hybrid_veil_max_renders}\n"
                                                   if args.hybrid_veil_max_renders != args.hybrid_veil_renders
                                                   else "")).replace("'", '"'))
        try:
            spec = load_study(f)
        except ConfigError as e:  # a flag out of range: the study file's field names it (e.g. check.hybrid_photons)
            ap.error(f"a setting is out of range: {e}")
        if args.renders_from is not None:
            src, dst = args.renders_from.resolve() / name / MC_RENDERS, args.out / name / MC_RENDERS
            if not src.is_dir():
                print(f"--renders-from: no kept renders in {src}; {name} renders its own")
            elif not dst.exists():
                dst.parent.mkdir(parents=True, exist_ok=True)
                dst.symlink_to(src, target_is_directory=True)
        out = run_study(spec, args.out / name, serial=args.serial)
        checks = read_checks(spec, out)
        if len(checks) < len(spec.check_cases()):  # failed, or computed by other code (the run's warnings say)
            print(f"{name}: {len(spec.check_cases()) - len(checks)} of {len(spec.check_cases())} checks missing: "
                  f"run the same command again to compute them", file=sys.stderr)
            missing = True
        for r in agreement_rows(checks):
            rows.append({**r, "lighting": name})
    print(f"\n{len(rows)} cells from {len({(r['lighting'], r['rig'], r['water'], r['target'], r['distance_m']) for r in rows})} "
          f"checked cases in {time.perf_counter() - t0:.0f} s; Monte Carlo: {args.seeds} x {args.spp} paths per pixel at "
          f"{w}x{h} (up to {max(args.seeds, args.max_seeds)} renders where the first {args.seeds} leave a relative SE "
          f"above {args.target_se:.1%} in a tenth of the regions"
          + (f"; daylight {args.daylight_target_se:.2%}" if args.daylight_target_se is not None and args.depths else "")
          + ")\n")
    print_table(rows)
    if missing:  # a partial table is printed, never published (a row would stand for cases it lacks)
        if args.publish:
            print("not published: some checks are missing (above)", file=sys.stderr)
        return 1
    if args.publish:
        from rigsim.metrics.agreement import write_published
        from rigsim.render.hybrid import DEFAULT_FIT_ORDER

        depths = ", ".join(f"{float(d):g}" for d in _list(args.depths))
        ms = "" if args.multiple_scattering == "off" else f", multiple scattering {args.multiple_scattering}"
        hyb = (f", charts lit by the rig's lights referenced by the hybrid estimate ({args.hybrid_photons} photons, "
               f"{args.hybrid_spp} spp per band, "
               f"{'' if args.hybrid_max_seeds is None else f'up to {args.hybrid_max_seeds} images, '}"
               f"the chart's irradiance fitted by a polynomial of order "
               f"{DEFAULT_FIT_ORDER if args.hybrid_order is None else args.hybrid_order}, "
               + (f"{args.hybrid_veil_renders} renders' veil per image" if args.hybrid_veil_max_renders ==
                  args.hybrid_veil_renders else f"{args.hybrid_veil_renders}-{args.hybrid_veil_max_renders} renders' "
                  "veil per image (as the pilot's noise and costs say)")
               + f", pooled over the "
               f"chart by a {args.hybrid_veil_sigma_px:g}-px local quadratic)"
               if args.reference == "hybrid" else "")
        noise = (f", the fast engine's noise from the photon batches of {1 + args.fast_noise_seeds} renders"
                 if args.fast_noise_seeds else "")
        settings = f"{w}x{h} px{ms}{noise}, Monte Carlo {args.seeds}-{max(args.seeds, args.max_seeds)} x {args.spp} spp{hyb}, " + "; ".join(
            x for x in (f"rigs {', '.join(rigs)}" if rigs else "",
                        f"daylight: ambient-only at {depths} m, sun at 30 deg" if depths else "") if x)
        command = "python benchmarks/bench_fast_engine_agreement.py " + " ".join(
            shlex.quote(a) for a in (sys.argv[1:] if argv is None else argv))
        # a row of an earlier engine goes once this engine's rows cover its distances (a run per distance can
        # re-make it piece by piece)
        write_published(rows, PUBLISHED, settings=settings, engine=_engine_id(), cells_dir=CELLS,
                        cells_header=command, current=lambda r: _engine_is_current(r.get("engine") or ""))
        print(f"\nper-water summary: {PUBLISHED}; each row's cells: {CELLS}")
    return 0


def _settings_value(settings: str, pattern: str, default):
    import re

    m = re.search(pattern, settings)
    return m.group(1) if m else default


def verify_unchanged(*, waters: set | None, rigs: set | None, publish: bool) -> int:
    """The published rows of earlier engines (not this checkout's, :func:`_same_engine`) whose fast images this
    checkout makes bit for bit: for each such row's commit, a temporary git worktree of it renders the row's cases
    with its own fast engine and study template (``benchmarks/fast_snapshot.py``: the image at the check's size and
    each photon batch's, every layer), this checkout the same, and the arrays are compared — each row's first case
    first (a changed engine shows there: a row of the strobes in a water the engine traces costs ~10 s, not ~80 s),
    then every case of the rows it left identical.  A row whose arrays are
    all identical is the same measurement of this engine (the references it was compared with are Monte Carlo
    renders, which no commit since changed: :data:`ENGINE_PATHS` holds the renderer too, and a change there is
    not among :data:`CHECK_ONLY_COMMITS`); ``publish`` stamps it so (:func:`rigsim.metrics.agreement.restamp_published`:
    its engine column this checkout's, a note in its settings).  Rows of the blank engine (before the column) cannot
    be verified.  Returns 0; 1 where the rows asked for are all such rows, or for ``publish`` on uncommitted code."""
    import datetime
    import json
    import subprocess
    import tempfile

    from benchmarks.fast_snapshot import same_arrays
    from rigsim.metrics.agreement import read_published, restamp_published

    subprocess.run(["git", "-C", str(ROOT), "worktree", "prune"], check=False)  # (a killed run's, if any)
    table = read_published(PUBLISHED)
    engine = _engine_id()
    if publish and (not engine or engine.endswith("-dirty")):
        print(f"this checkout's engine is {engine or 'unknown (no git)'}: commit it before --publish", file=sys.stderr)
        return 1
    same: dict[str, bool] = {}
    todo: dict[str, list] = defaultdict(list)
    blank = 0
    for key, r in sorted(table.items()):
        if (waters is not None and r["water"] not in waters) or (rigs is not None and r["rig"] not in rigs):
            continue
        e = r.get("engine") or ""
        if not e.startswith("commit ") or e.endswith("-dirty"):
            blank += 1
            continue
        if e not in same:
            same[e] = _same_engine(e.removeprefix("commit "))
        if not same[e]:
            todo[e.removeprefix("commit ")].append((key, r))
    n_rows = sum(len(v) for v in todo.values())
    print(f"{n_rows} rows of earlier engines to verify ({len(todo)} commits)" +
          (f"; {blank} rows without a commit cannot be verified" if blank else ""), flush=True)
    if not n_rows:
        return 0 if blank == 0 else 1
    script = ROOT / "benchmarks" / "fast_snapshot.py"
    stamps, t0 = {}, time.perf_counter()

    def compare(wt: Path, items: list, out: Path, first_case: bool) -> list[tuple[bool, str]]:
        """Snapshots of ``items``' rows by the row's commit (worktree ``wt``) and by this checkout, compared."""
        rows_file = out.with_suffix(".json")
        rows_file.write_text(json.dumps([r for _, r in items]))
        for side, checkout in (("old", wt), ("new", ROOT)):
            done = subprocess.run([sys.executable, str(script), str(checkout), str(rows_file), str(out / side)]
                                  + (["--first-case"] if first_case else []), cwd=out.parent,
                                  env={**os.environ, "PYTHONPATH": str(checkout)})
            if done.returncode != 0:  # (its own line is above; each row then reads "not rendered")
                return [(False, f"not rendered: the {side} side's snapshot ended with exit {done.returncode}")] * len(items)
        res = []
        for i in range(len(items)):
            a, b = out / "old" / f"{i}.npz", out / "new" / f"{i}.npz"
            if a.is_file() and b.is_file():
                res.append(same_arrays(a, b))
            else:
                err = next((f for f in (a.with_suffix(".error"), b.with_suffix(".error")) if f.is_file()), None)
                res.append((False, "not rendered: " + (err.read_text().strip().splitlines()[-1] if err else "?")))
        return res

    def on_term(signum, frame):  # a kill stops like Ctrl-C: the worktree is removed on the way out
        raise KeyboardInterrupt

    old_term = signal.signal(signal.SIGTERM, on_term)
    try:
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            for commit, items in sorted(todo.items()):
                wt = tmp / f"wt-{commit}"
                subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "--quiet", str(wt), commit],
                               check=True)
                try:  # each row's first case (a changed engine shows there), then the whole of the rows it left identical
                    first = compare(wt, items, tmp / f"first-{commit}", True)
                    whole = [(k, r) for (k, r), (ok, _) in zip(items, first) if ok]
                    results = dict(zip([k for k, _ in whole], compare(wt, whole, tmp / f"all-{commit}", False))) \
                        if whole else {}
                finally:
                    subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(wt)], check=False)
                for (key, r), f in zip(items, first):
                    ok, why = results.get(key, (False, "not compared whole")) if f[0] else (False, f"first case: {f[1]}")
                    print(f"  {'identical' if ok else 'changed  '}  {r['lighting']:<13} {r['water']:<17} {r['rig']:<27} "
                          f"({r['distances_m']} m; commit {commit}): {why}", flush=True)
                    if ok:
                        stamps[key] = (engine, f"fast images identical to those of commit {commit} ({why}; "
                                               f"--verify-unchanged, {datetime.date.today().isoformat()})")
                print(f"  [{commit}: {time.perf_counter() - t0:.0f} s]", flush=True)
    finally:
        signal.signal(signal.SIGTERM, old_term)
    print(f"\n{len(stamps)} of {n_rows} rows: this checkout's fast engine makes their images bit for bit")
    if publish and stamps:
        n = restamp_published(PUBLISHED, stamps)
        print(f"stamped {n} rows of {PUBLISHED.relative_to(ROOT)} as {engine}'s")
    return 0


def rejudge(*, waters: set | None, rigs: set | None, publish: bool, command: str) -> int:
    """Each published row that kept its cells (:data:`CELLS`), judged again with this checkout's fast engine:
    its cases' fast images made as the row's run made them (the same study settings and seeds:
    :func:`rigsim.study.case.fast_check_images`) and compared with the kept reference numbers
    (:func:`rigsim.metrics.agreement.compare_to_cells`); prints the table, how far the fast values moved, and
    with ``publish`` re-makes the rows (their settings say against which references)."""
    import tempfile

    from rigsim.metrics.agreement import (compare_to_cells, contrast_below_visibility, read_cells, read_cells_header,
                                         tolerance_for, write_published)
    from rigsim.study import load_study
    from rigsim.study.case import case_scene, fast_check_images
    from rigsim.study.runner import agreement_rows

    files = sorted(CELLS.glob("*.csv.gz"))
    picked = []
    for f in files:
        cells = read_cells(f)
        light, water, rig = cells[0]["lighting"], cells[0]["water"], cells[0]["rig"]
        if (waters is None or water in waters) and (rigs is None or rig in rigs):
            picked.append((f, light, water, rig, cells))
    if not picked:
        print(f"no kept cells for the rows asked for (in {CELLS.relative_to(ROOT)}: {len(files)} rows)")
        return 1
    out_rows, moved, published = [], [], []
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for k, (f, light, water, rig, cells) in enumerate(picked, 1):
            head = read_cells_header(f)
            settings = head[1] if len(head) > 1 else ""
            first = cells[0]
            depth = light.removeprefix("daylight-").removesuffix("m") if light.startswith("daylight-") else None
            rig_file = ROOT / "rigs" / f"{'ambient-only' if depth else rig}.toml"
            ms = _settings_value(settings, r"multiple scattering (\w+)", "off")
            batches = int(_settings_value(settings, r"photon batches of (\d+) renders", "1"))
            study = Path(tmp) / f"{light}.toml"
            study.write_text(STUDY.format(
                name=light, rigs=[str(rig_file)], waters=[water],
                distances=sorted({float(c["distance_m"]) for c in cells}),
                depth=f"depth_m = {float(depth)}" if depth else "", width=int(first["width"]),
                height=int(first["height"]), spp=int(first["spp"]), seeds=4, max_seeds=4, target_se=0.015, ms=ms,
                reference="monte-carlo", hybrid_photons=1_000_000, hybrid_spp=64, hybrid_veil=16, hybrid_sigma=4.0,
                fast_noise=max(0, batches - 1), hybrid_order="", hybrid_max="", hybrid_veil_max="").replace("'", '"'))
            spec = load_study(study)
            by_case = defaultdict(list)
            for c in cells:
                by_case[(c["target"], float(c["distance_m"]))].append(c)
            rows = []
            for case in spec.check_cases():
                scene, case_water, target_kind = case_scene(spec, case)
                target = target_kind if target_kind != "mesh" else case.target
                kept = by_case.get((target, float(case.distance_m)))
                if not kept:
                    continue
                fast, fb, nb = fast_check_images(spec, case, scene, case_water)
                regions, metrics = compare_to_cells(fast, kept, target_kind, fast_batches=fb, noise_batches=nb)
                seeds = int(kept[0]["seeds"])
                unseen = None
                if target == "colorchecker":
                    m = next((x for x in metrics if x.metric == "contrast_radiance"), None)
                    ref_c = next((c for c in kept if c["quantity"] == "contrast_radiance"), None)
                    unseen = m is not None and contrast_below_visibility(
                        m.fast, m.fast_se, None if ref_c is None else float(ref_c["monte_carlo"]),
                        float(ref_c["monte_carlo_se"] or "nan") if ref_c is not None else 0.0, seeds)
                rec = {"rig": rig, "water": water, "target": target, "distance_m": case.distance_m,
                       "c_550_per_m": first.get("c_550_per_m"), "tolerance": tolerance_for(water),
                       "width": first["width"], "height": first["height"], "spp": first["spp"], "seeds": seeds,
                       "reference": first["reference"], "beyond_visibility": unseen,
                       "regions": [r.record() for r in regions], "metrics": [m.record() for m in metrics]}
                rows += [{**r, "lighting": light} for r in agreement_rows([rec])]
                before = {(c["region"], c["group"]): float(c["fast"]) for c in kept if c["quantity"] == "radiance"}
                moved += [r.fast / before[r.region, r.group] - 1.0 for r in regions if before[r.region, r.group] > 0]
            n_kept = len({(c["target"], c["distance_m"]) for c in cells})
            n_done = len({(r["target"], r["distance_m"]) for r in rows})
            print(f"[{k}/{len(picked)}] {f.name}: {n_done} of {n_kept} cases in {time.perf_counter() - t0:.0f} s",
                  flush=True)
            if n_done != n_kept:
                print("  not all of its cases are in the study its settings make: not re-made", file=sys.stderr)
                continue
            out_rows += rows
            published.append((rows, light, water, rig, head, settings))
    print()
    print_table(out_rows)
    mv = sorted(abs(x) for x in moved)
    print(f"\nthe fast engine's region means against the kept ones (this checkout / the row's run - 1): median "
          f"{mv[len(mv) // 2]:.2%}, largest {mv[-1]:.2%} over {len(mv)} cells" if mv else "")
    if publish:
        for rows, light, water, rig, head, settings in published:
            was = "; ".join(head[:1])
            write_published(rows, PUBLISHED, settings=f"{settings}; re-judged against the kept cells of the run "
                            f"({was}): the fast images only", engine=_engine_id(), cells_dir=CELLS,
                            cells_header="\n".join([command, "the references from:"] + head))
        print(f"\nre-made {len(published)} rows of {PUBLISHED}")
    return 0


KINDS = (("patches", lambda r: r["quantity"] == "radiance" and r["region"].startswith("patch:")),
         ("disk", lambda r: r["quantity"] == "radiance" and r["region"] == "disk"),
         ("open water", lambda r: r["quantity"] == "radiance" and r["region"] == "open water"),
         ("contrast", lambda r: r["quantity"] == "contrast_radiance"),
         ("backsc. share", lambda r: r["quantity"] == "backscatter_share"))


def _f(x) -> float:
    return float(x) if x not in (None, "") else float("nan")


def print_table(rows: list[dict]) -> None:
    """Per lighting and water: the worst deviation of each kind (and colour group), then the worst cells.  The
    chart cells of cases beyond the chart's visibility (verdict "beyond visibility") are counted, not judged."""
    from rigsim.metrics.agreement import (HEAVY_TAIL, MIN_CONTRAST, case_key, heavy_tailed, judged, noise_multiplier,
                                         pooled_patches, target_tails)

    unseen = [r for r in rows if not judged(r)]
    rows = [r for r in rows if judged(r)]
    by = defaultdict(list)
    for r in rows:
        by[(r["lighting"], r["water"])].append(r)
    head = f"{'lighting':14s} {'water':18s} {'tol':>4s} " + " ".join(f"{k:>20s}" for k, _ in KINDS) + "  beyond"
    print(head)
    print("-" * len(head))
    for (light, water), rs in by.items():
        cells = []
        for _, sel in KINDS:
            sub = [r for r in rs if sel(r)]
            if not sub:
                cells.append(f"{'-':>20s}")
                continue
            x = max(sub, key=lambda r: abs(_f(r["deviation"])))
            cells.append(f"{_f(x['deviation']):+7.1%} ±{_f(x['deviation_se']):4.1%} {x['group'][:1]}{_f(x['distance_m']):4.1f}m")
        bad = sum(r["verdict"] == "disagrees" for r in rs)
        print(f"{light:14s} {water:18s} {_f(rs[0]['tolerance']):4.0%} " + " ".join(cells) + f"  {bad}/{len(rs)}")
    worst = sorted(rows, key=lambda r: -abs(_f(r["deviation"])))[:15]
    print("\nworst cells (tail: the largest Monte Carlo render over the median, where heavy-tailed):")
    for r in worst:
        tail = f"  tail {_f(r.get('monte_carlo_tail')):.1f}" if heavy_tailed(r.get("monte_carlo_tail")) else ""
        print(f"  {_f(r['deviation']):+7.1%} ± {_f(r['deviation_se']):.1%}  {r['verdict']:12s} {r['lighting']}, {r['rig']}, "
              f"{r['water']}, {r['target']} at {_f(r['distance_m']):g} m: {r['quantity']} {r['region']} {r['group']}{tail}")
    rad = [r for r in rows if r["quantity"] == "radiance"]

    def quantiles(xs) -> str:
        xs = sorted(x for x in xs if math.isfinite(x))
        if not xs:
            return "not measured"
        return f"median {xs[len(xs) // 2]:.1%}, 90th percentile {xs[int(0.9 * (len(xs) - 1))]:.1%}"

    if rad:  # the difference's noise, and each engine's own part of it (relative SEs, radiance cells)
        print(f"\nnoise of the differences (SE of fast / reference - 1, radiance cells): "
              f"{quantiles(_f(r['deviation_se']) for r in rad)}; of it the reference's "
              f"{quantiles(_f(r['monte_carlo_se']) / _f(r['monte_carlo']) for r in rad if _f(r['monte_carlo']) > 0)}"
              f", the fast engine's own photon noise "
              f"{quantiles(_f(r['fast_se']) / _f(r['fast']) for r in rad if _f(r['fast']) > 0)}")
    n_bad = sum(r["verdict"] == "disagrees" for r in rows)
    per_case = {(r["lighting"], r["rig"], r["water"], r["target"], r["distance_m"]): int(r["seeds"]) for r in rows}
    by_water = defaultdict(list)
    for k, n in per_case.items():
        by_water[k[2]].append(n)
    print("Monte Carlo renders per case: " + ", ".join(f"{w} {min(v)}-{max(v)}" for w, v in by_water.items()))
    bad = [r for r in rows if r["verdict"] == "disagrees"]
    n_tail = sum(heavy_tailed(r.get("monte_carlo_tail")) for r in bad)
    tails = target_tails(rows)
    n_case = sum(heavy_tailed(tails.get(case_key(r))) for r in bad if r["region"] != "open water")
    print(f"cells beyond tolerance + t·SE (95 %, Student's t for each case's renders): {n_bad} of {len(rows)}; "
          f"{n_tail} of them with a heavy-tailed reference (one render >= {HEAVY_TAIL:g}x the median), {n_case} "
          f"target cells in a case whose target's reference is heavy-tailed in some region (that reference may "
          f"have missed the rare paths: bench_reference_convergence.py renders such a case until it converges)")
    pooled = pooled_patches(rows)
    if pooled:
        pooled.sort(key=lambda p: -abs(p["mean"]))
        off = [p for p in pooled if abs(p["mean"]) > float(p["tolerance"]) + noise_multiplier(p["seeds"]) * p["se"]]
        within = sum(abs(p["mean"]) <= float(p["tolerance"]) for p in pooled)
        ratio = sorted(p["chi2"] / p["dof"] for p in pooled if p["dof"] > 0)
        print(f"\neach chart's patches pooled per colour group (inverse-variance mean of their deviations): {len(pooled)} "
              f"charts x groups, {within} within tolerance, {len(off)} beyond tolerance + t*SE; the cells' scatter "
              f"about the mean, chi2/dof: median {ratio[len(ratio) // 2]:.2f}, 90th percentile "
              f"{ratio[int(0.9 * (len(ratio) - 1))]:.2f} (1: the cells differ by their noise alone)" if ratio else "")
        for p in pooled[:8]:
            print(f"  {p['mean']:+7.1%} ± {p['se']:.1%}  chi2/dof {p['chi2'] / max(p['dof'], 1):5.2f}  {p['lighting']}, "
                  f"{p['rig']}, {p['water']}, {p['target']} at {_f(p['distance_m']):g} m, {p['group']}")
    if unseen:
        cases = sorted({(r["lighting"], r["rig"], r["water"], _f(r["distance_m"])) for r in unseen})
        print(f"beyond the chart's visibility (its contrast below {MIN_CONTRAST:.0%} in both engines; listed in "
              f"agreement.csv, not judged): {len(unseen)} chart cells of {len(cases)} cases: "
              + "; ".join(f"{c[2]} {c[3]:g} m ({c[1]})" for c in cases))


def _main() -> int:
    """``main``, ending quietly where the reader of its output closed it early (``--status | head``), and with one
    line where it is stopped (Ctrl-C, or SIGTERM where the run turns it into one): the renders kept so far stay in
    ``--out`` for the next run; nothing is published."""
    from rigsim.errors import Interrupted

    try:
        return main()
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # (Python flushes stdout again at exit)
        return 1
    except (KeyboardInterrupt, Interrupted):
        print("interrupted: nothing published (the renders kept in --out are reused by the next run)", file=sys.stderr)
        return 130


if __name__ == "__main__":
    raise SystemExit(_main())
