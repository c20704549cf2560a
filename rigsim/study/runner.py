"""Running a study: cases on dask.distributed, atomic per-case results, resume, progress.

Layout of a study folder::

    study.json                 the validated study (inputs)
    cases/<case_id>/result.json  rows of one scene (one per sensor); written last, atomically:
                                 its presence means the case is finished
    cases/<case_id>/*.png        images of that scene (per-sensor sRGB, radiance preview)
    results.csv                one row per case × sensor with every input and metric
    visibility.csv             visibility range per rig × sensor × water × target
    timings.csv                wall time per case (kept out of results.csv, which is reproducible)

Re-running the same study into the same folder skips finished cases (a case's id hashes
all of its inputs, so changing the study re-runs what changed).
"""

from __future__ import annotations

import csv
import io
import json
import logging
import time
from collections.abc import Callable
from pathlib import Path

from rigsim.fileio import (atomic_write_bytes, atomic_write_text, drop_unreadable_records, folder_lock,
                           remove_stale_temp_files)
from rigsim.study.spec import Case, StudySpec

log = logging.getLogger(__name__)

__all__ = ["run_study", "pending_cases", "assemble_tables", "read_results"]


def _case_dir(out: Path, spec: StudySpec, case: Case) -> Path:
    return out / "cases" / spec.case_id(case)


def pending_cases(spec: StudySpec, out: Path) -> list[Case]:
    """Cases of ``spec`` without a finished ``result.json`` in ``out``."""
    return [c for c in spec.cases() if not (_case_dir(out, spec, c) / "result.json").is_file()]


def _store(out: Path, spec: StudySpec, case: Case, result: dict) -> None:
    d = _case_dir(out, spec, case)
    d.mkdir(parents=True, exist_ok=True)
    for name, data in result.get("files", {}).items():
        atomic_write_bytes(d / name, data)
    record = {"case_id": spec.case_id(case), "case": case.key(), "rows": result["rows"],
              "meta": result.get("meta", {})}
    atomic_write_text(d / "result.json", json.dumps(record, indent=1, default=float))  # completion marker


def _run_one(args: tuple[StudySpec, Case]) -> dict:
    """Worker side: compute one case (imports inside so workers load only what they need)."""
    from rigsim.study.case import compute_case

    spec, case = args
    t0 = time.perf_counter()
    res = compute_case(spec, case)
    res.setdefault("meta", {})["wall_time_s"] = time.perf_counter() - t0
    return res


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
        atomic_write_text(out / "study.json", json.dumps(spec.describe(), indent=1, default=str))
        try:
            run_tasks([(spec, c) for c in spec.cases()], _run_one, lambda it, res: _store(out, spec, it[1], res),
                      is_done=lambda it: (_case_dir(out, spec, it[1]) / "result.json").is_file(),
                      key=lambda it: spec.case_id(it[1]), scheduler=scheduler, workers=workers, serial=serial,
                      progress=progress, label="study",
                      on_done=(lambda it: on_case_done(it[1])) if on_case_done else None)
        finally:
            assemble_tables(spec, out)  # the finished cases' tables, also when some cases failed
    return out


def read_results(spec: StudySpec, out: Path) -> tuple[list[dict], list[dict]]:
    """Rows of all finished cases in study order, and their timings."""
    rows, timings = [], []
    for case in spec.cases():
        f = _case_dir(out, spec, case) / "result.json"
        if not f.is_file():
            continue
        rec = json.loads(f.read_text())
        rows.extend(rec["rows"])
        timings.append({"case_id": rec["case_id"], "wall_time_s": rec["meta"].get("wall_time_s")})
    return rows, timings


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
    atomic_write_bytes(out / "timings.csv", _csv_bytes(timings))
    atomic_write_bytes(out / "visibility.csv", _csv_bytes(visibility_table(rows, spec.contrast_threshold)))
    try:  # Parquet when pyarrow is there
        import pandas as pd

        buf = io.BytesIO()
        pd.DataFrame(rows).to_parquet(buf)
        atomic_write_bytes(out / "results.parquet", buf.getvalue())
    except ImportError:  # optional output
        pass
