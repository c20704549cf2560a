"""Running a study: cases on dask.distributed, atomic per-case results, resume, progress.

Layout of a study folder::

    study.json                 the validated study (inputs)
    cases/<case_id>/result.json  rows of one scene (one per sensor); written last, atomically:
                                 its presence means the case is finished
    cases/<case_id>/*.png        images of that scene (per-sensor sRGB, radiance preview)
    checks/<check_id>/check.json the Monte Carlo check of a fast-engine case (region by region;
                                 rigsim.metrics.agreement), with fast.png and monte-carlo.png
    mc-renders/<rig>__<water>__<target>__<distance>__<size>-<spp>spp-<integrator>__<key>/render-NNN/
                                 each Monte Carlo render of a check as it finishes (SpectralImage.save;
                                 96x64: 1.5 MB), keyed by the scene's contents: an interrupted check, or
                                 one asked for more renders, renders only the ones it lacks
    results.csv                one row per case × sensor with every input and metric
    visibility.csv             visibility range per rig × sensor × water × target
    agreement.csv              the checks: one row per checked case × region × colour group
    timings.csv                wall time per case (kept out of results.csv, which is reproducible)

Re-running the same study into the same folder skips finished cases (a case's id hashes
all of its inputs, so changing the study re-runs what changed).  A case or check counts as finished
only if the same code computed it: each record carries :func:`rigsim.code_version.code_version`
(``"code"``), and those of other code (an updated rigsim, an older record without it) are computed
again, not mixed into the tables (their Monte Carlo renders are kept: ``mc-renders/`` is keyed by
the scene, so a check of new code re-renders nothing but the fast image).

Visibility beyond the sweep: where a target's contrast (scene radiance or any sensor's image) is
still above the threshold at the sweep's largest distance, the study renders that rig, water and
target farther out with the fast engine — the distance × :data:`EXTENSION_FACTOR` per step, at
most :data:`MAX_EXTENSION_STEPS` steps — until the contrast falls below (rows with
``extension = True``; the report's distance plots show the sweep only).  The steps are decided by
the finished ones, so a resumed run replays them from the stored cases.
"""

from __future__ import annotations

import csv
import functools
import io
import json
import logging
import math
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

from rigsim.code_version import code_version, computed_here
from rigsim.fileio import (atomic_write_bytes, atomic_write_text, drop_unreadable_records, folder_lock,
                           remove_stale_temp_files)
from rigsim.study.spec import Case, StudySpec

log = logging.getLogger(__name__)

__all__ = ["run_study", "pending_cases", "assemble_tables", "read_results", "read_checks", "extension_cases",
           "EXTENSION_FACTOR", "MAX_EXTENSION_STEPS"]

#: Each step beyond the sweep multiplies the distance by this.
EXTENSION_FACTOR = 1.5
#: At most this many steps beyond the sweep (6 m × 1.5¹² ≈ 780 m).
MAX_EXTENSION_STEPS = 12
#: The steps stop when the contrast fell by less than 2 % over the last two steps (distance × 2.25):
#: a target's contrast falls as exp(−c·r) and nothing else, so a contrast that levels off is not the
#: target's — a black disk's contrast against the ring of water around it, where the strobes' veil
#: is brighter or darker than in front of the disk (edge lighting in turbid water), stays at a few
#: percent however far the disk is.  The visibility is then reported as not found (inf).
LEVEL_OFF = 0.98


def _case_dir(out: Path, spec: StudySpec, case: Case) -> Path:
    return out / "cases" / spec.case_id(case)


def _check_dir(out: Path, spec: StudySpec, case: Case) -> Path:
    return out / "checks" / spec.check_id(case)


def pending_cases(spec: StudySpec, out: Path) -> list[Case]:
    """Cases of ``spec`` without a finished ``result.json`` of this code in ``out``."""
    return [c for c in spec.cases() if _read_record(_case_dir(out, spec, c) / "result.json") is None]


def _read_record(f: Path, *, any_code: bool = False) -> dict | None:
    """The record in ``f`` if it was computed by this code (or by any, with ``any_code``); else None."""
    try:
        rec = json.loads(f.read_text()) if f.is_file() else None
    except (OSError, ValueError):
        return None
    if not isinstance(rec, dict) or (not any_code and not computed_here(rec)):
        return None
    return rec


def records_of_other_code(out: Path) -> list[Path]:
    """Finished cases' and checks' records in ``out`` that other code computed (or that predate the
    ``code`` field): a resumed run computes them again."""
    found = []
    for pattern in ("cases/*/result.json", "checks/*/check.json"):
        for f in sorted(out.glob(pattern)):
            rec = _read_record(f, any_code=True)
            if rec is not None and not computed_here(rec):
                found.append(f)
    return found


def _largest_contrast(rows: list[dict]) -> float:
    """The largest contrast (scene radiance or any sensor's image) of a case's rows (0 if none)."""
    vals = [r.get(k) for r in rows for k in ("contrast_radiance", "contrast_image")]
    return max((v for v in vals if v is not None and math.isfinite(v)), default=0.0)


def extension_cases(spec: StudySpec, out: Path) -> tuple[list[Case], list[Case]]:
    """The steps beyond the sweep: (finished extension cases in order, the next ones to compute).

    Replays the rule of the module docstring over the stored cases of ``out``.
    """
    if not spec.extend_visibility:
        return [], []
    groups: dict[tuple, list[Case]] = {}
    for c in spec.cases():
        groups.setdefault((c.rig, c.water, c.target), []).append(c)
    done, todo = [], []
    for cs in groups.values():
        last = max(cs, key=lambda c: c.distance_m)
        rec = _read_record(_case_dir(out, spec, last) / "result.json")
        seen: list[float] = []
        for _ in range(MAX_EXTENSION_STEPS):
            if rec is None or _largest_contrast(rec.get("rows", [])) < spec.contrast_threshold:
                break  # no longer visible (or not measurable)
            seen.append(_largest_contrast(rec.get("rows", [])))
            if len(seen) >= 3 and seen[-1] >= LEVEL_OFF * seen[-3]:
                break  # the contrast no longer falls with distance: it is not the target's (see LEVEL_OFF)
            nxt = replace(last, distance_m=round(last.distance_m * EXTENSION_FACTOR, 6), extension=True)
            rec = _read_record(_case_dir(out, spec, nxt) / "result.json")
            if rec is None:
                todo.append(nxt)
                break
            done.append(nxt)
            last = nxt
    return done, todo


def _store(out: Path, spec: StudySpec, case: Case, result: dict) -> None:
    d = _case_dir(out, spec, case)
    d.mkdir(parents=True, exist_ok=True)
    for name, data in result.get("files", {}).items():
        atomic_write_bytes(d / name, data)
    record = {"case_id": spec.case_id(case), "case": case.key(), "rows": result["rows"],
              "meta": result.get("meta", {})}
    atomic_write_text(d / "result.json", json.dumps(record, indent=1, default=float))  # completion marker


def _store_check(out: Path, spec: StudySpec, case: Case, result: dict) -> None:
    d = _check_dir(out, spec, case)
    d.mkdir(parents=True, exist_ok=True)
    for name, data in result.get("files", {}).items():
        atomic_write_bytes(d / name, data)
    atomic_write_text(d / "check.json", json.dumps(result["record"], indent=1, default=float))  # completion marker


#: Sub-folder of a study's folder where its Monte Carlo checks keep each render
#: (:func:`rigsim.study.case.cached_render_dir`).
MC_RENDERS = "mc-renders"


def _run_one(args: tuple[StudySpec, str, Case], out: str | None = None) -> dict:
    """Worker side: compute one case or check (imports inside so workers load only what they need)."""
    from rigsim.study.case import compute_case, compute_check

    spec, kind, case = args
    t0 = time.perf_counter()
    if kind == "check":
        res = compute_check(spec, case, render_cache=None if out is None else Path(out) / MC_RENDERS)
    else:
        res = compute_case(spec, case)
    res.setdefault("meta", {})["wall_time_s"] = time.perf_counter() - t0
    res["meta"]["code"] = code_version()  # the code that computed it (a resumed run of other code redoes it)
    if kind == "check":
        res["record"]["wall_time_s"] = res["meta"]["wall_time_s"]
        res["record"]["code"] = res["meta"]["code"]
    return res


def _is_done(out: Path, item: tuple[StudySpec, str, Case]) -> bool:
    spec, kind, case = item
    if kind == "check":
        return _read_record(_check_dir(out, spec, case) / "check.json") is not None
    return _read_record(_case_dir(out, spec, case) / "result.json") is not None


def _store_item(out: Path, item: tuple[StudySpec, str, Case], res: dict) -> None:
    spec, kind, case = item
    (_store_check if kind == "check" else _store)(out, spec, case, res)
    code = (res.get("meta") or {}).get("code")
    if code != code_version():  # a worker that loaded rigsim after its files changed: not this run's code
        log.warning("%s was computed by other rigsim code (%s, this run %s): rigsim's files changed while the "
                    "study ran; it is left out of the tables - run the study again to compute it with one code",
                    _item_key(item), code, code_version())


def _item_key(item: tuple[StudySpec, str, Case]) -> str:
    spec, kind, case = item
    return spec.check_id(case) if kind == "check" else spec.case_id(case)


def run_study(spec: StudySpec, out: str | Path, *, scheduler: str | None = None, workers: int | None = None,
              serial: bool = False, progress: bool = True,
              on_case_done: Callable[[Case], None] | None = None) -> Path:
    """Run every pending case of ``spec`` and write the tables.

    Parameters
    ----------
    spec
        A validated study (:func:`rigsim.study.load_study`).
    out
        Study folder (created; finished cases in it are skipped).
    scheduler
        Address of a running dask scheduler (``tcp://host:8786``); None: an embedded
        ``LocalCluster``.
    workers
        Worker processes of the embedded cluster (default :func:`rigsim.parallel.default_workers`).
    serial
        Compute in this process without dask (debugging; results are identical).
    progress
        Show a progress bar with ETA.
    on_case_done
        Called after each case is stored (e.g. for logging).

    Returns
    -------
    The study folder.
    """
    from rigsim.parallel import run_tasks

    out = Path(out)
    with folder_lock(out):  # one run per study folder; released however this process ends
        remove_stale_temp_files(out)  # what a killed run was writing
        for f in drop_unreadable_records(out, "cases/*/result.json", ("rows",)):
            log.warning("%s was damaged: computing that case again", f)
        for f in drop_unreadable_records(out, "checks/*/check.json", ("regions", "metrics")):
            log.warning("%s was damaged: computing that check again", f)
        other = records_of_other_code(out)
        if other:
            log.warning("%d finished case(s) or check(s) in %s were computed by other rigsim code (not %s): "
                        "computing them again", len(other), out, code_version())
        atomic_write_text(out / "study.json", json.dumps(spec.describe(), indent=1, default=str))
        # the Monte Carlo checks first: the longest items start while the fast cases fill the gaps
        items = [(spec, "check", c) for c in spec.check_cases()] + [(spec, "case", c) for c in spec.cases()]
        try:
            # visibility beyond the sweep: each step is run as soon as the case before it is stored,
            # on the same workers beside the rest of the sweep (2026-12-04: the steps had waited for the
            # whole sweep and then run one at a time in this process — the demo's 26 steps in five
            # rounds took 2 min 28 s of its 14 min 11 s on 2 cores)
            run_tasks(items, functools.partial(_run_one, out=str(out)), lambda it, res: _store_item(out, it, res),
                      is_done=lambda it: _is_done(out, it), key=_item_key, scheduler=scheduler, workers=workers,
                      serial=serial, progress=progress, label="study",
                      on_done=(lambda it: on_case_done(it[2])) if on_case_done else None,
                      more=lambda: [(spec, "case", c) for c in extension_cases(spec, out)[1]])
        finally:
            assemble_tables(spec, out)  # the finished cases' tables, also when some cases failed
    return out


def read_results(spec: StudySpec, out: Path) -> tuple[list[dict], list[dict]]:
    """Rows of all finished cases in study order (then the steps beyond the sweep), and their timings."""
    rows, timings = [], []
    for case in spec.cases() + extension_cases(spec, out)[0]:
        rec = _read_record(_case_dir(out, spec, case) / "result.json")
        if rec is None:
            continue
        rows.extend(rec["rows"])
        timings.append({"case_id": rec["case_id"], "wall_time_s": rec["meta"].get("wall_time_s")})
    for case in spec.check_cases():
        rec = _read_record(_check_dir(out, spec, case) / "check.json")
        if rec is not None:
            timings.append({"case_id": spec.check_id(case), "wall_time_s": rec.get("wall_time_s")})
    return rows, timings


def read_checks(spec: StudySpec, out: Path) -> list[dict]:
    """The finished Monte Carlo checks' records (``check.json``), in study order."""
    recs = [_read_record(_check_dir(out, spec, c) / "check.json") for c in spec.check_cases()]
    return [r for r in recs if r is not None]


def agreement_rows(checks: list[dict]) -> list[dict]:
    """One row per checked case × region (or metric) × colour group, for agreement.csv: the chart patches (and
    contrast) of a case beyond the chart's visibility (:func:`rigsim.metrics.agreement.chart_beyond_visibility`) with the verdict
    ``beyond visibility``; a contrast below :data:`~rigsim.metrics.agreement.MIN_CONTRAST` in Monte Carlo left
    out (its relative difference says nothing).  A record's own ``beyond_visibility`` (True / False), where it
    has one, says so instead (a re-judge against kept cells, whose contrast below that limit was left out)."""
    from rigsim.metrics.agreement import BEYOND_VISIBILITY, MIN_CONTRAST, chart_beyond_visibility, verdict

    rows = []
    for rec in checks:
        base = {k: rec.get(k) for k in ("rig", "water", "target", "distance_m", "c_550_per_m", "tolerance", "width",
                                        "height", "spp", "seeds")}
        base["reference"] = rec.get("reference", "monte-carlo")
        unseen = (bool(rec["beyond_visibility"]) if rec.get("beyond_visibility") is not None else
                  chart_beyond_visibility(rec.get("target"), rec["metrics"], rec.get("seeds")))
        for r in rec["regions"]:
            rows.append({**base, "quantity": "radiance", "region": r["region"], "group": r["group"],
                         "pixels": r["pixels"], "fast": r["fast"], "monte_carlo": r["reference"],
                         "monte_carlo_se": r["reference_se"], "fast_se": r.get("fast_se", 0.0),
                         "deviation": r["deviation"],
                         "deviation_se": r["deviation_se"], "monte_carlo_tail": r.get("reference_tail"),
                         "verdict": BEYOND_VISIBILITY if unseen and str(r["region"]).startswith("patch:") else
                         verdict(r["deviation"], r["deviation_se"], rec["tolerance"], rec.get("seeds"))})
        for m in rec["metrics"]:
            if m["metric"] == "contrast_radiance" and not float(m["reference"]) >= MIN_CONTRAST:
                continue
            # marine snow: the speck share is measured on the renders with the particles' light (compute_check)
            n = (rec.get("particle_renders") or rec.get("seeds")) if m["metric"] == "speck_share" else rec.get("seeds")
            rows.append({**base, "seeds": n, "quantity": m["metric"], "region": "target", "group": "luminance",
                         "pixels": None,
                         "fast": m["fast"], "monte_carlo": m["reference"], "monte_carlo_se": m["reference_se"],
                         "fast_se": m.get("fast_se", 0.0),
                         "deviation": m["deviation"], "deviation_se": m["deviation_se"],
                         "verdict": BEYOND_VISIBILITY if unseen and m["metric"] == "contrast_radiance" else
                         verdict(m["deviation"], m["deviation_se"], rec["tolerance"], n)})
    return rows


def _csv_bytes(rows: list[dict]) -> bytes:
    cols: list[str] = []
    for r in rows:
        for k in r:
            if k not in cols:
                cols.append(k)
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=cols, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in cols})
    return buf.getvalue().encode()


def assemble_tables(spec: StudySpec, out: Path) -> None:
    """Write results.csv, visibility.csv and timings.csv from the finished cases."""
    from rigsim.study.analysis import visibility_table

    rows, timings = read_results(spec, out)
    atomic_write_bytes(out / "results.csv", _csv_bytes(rows))
    checks = read_checks(spec, out)
    if checks or (out / "agreement.csv").is_file():
        atomic_write_bytes(out / "agreement.csv", _csv_bytes(agreement_rows(checks)))
    atomic_write_bytes(out / "timings.csv", _csv_bytes(timings))
    atomic_write_bytes(out / "visibility.csv", _csv_bytes(visibility_table(rows, spec.contrast_threshold)))
    try:  # Parquet when pyarrow is there
        import pandas as pd

        buf = io.BytesIO()
        pd.DataFrame(rows).to_parquet(buf)
        atomic_write_bytes(out / "results.parquet", buf.getvalue())
    except ImportError:  # optional output
        pass
