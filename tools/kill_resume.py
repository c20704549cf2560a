"""Kill ``rigsim study`` and ``rigsim dataset`` with SIGKILL at random moments, resume, compare.

    python tools/kill_resume.py                      # 10 kills of each, dask (as a user runs them)
    python tools/kill_resume.py --kills 3 --serial   # quicker: in-process runs
    python tools/kill_resume.py --only study --seed 4

For each command (the tiny study ``tests/data/tiny-study.toml``: 8 cases of the fast engine; the
tiny dataset ``tests/data/tiny-dataset.toml``: 6 Mitsuba samples) it runs the command once
uninterrupted, then starts it again and again into another folder, each time killing the run's
process group with SIGKILL at a random moment and letting the next run resume; after the last
kill one run finishes.  The final tables and files are compared with the uninterrupted run's
(byte for byte; the per-item JSON records without their wall times) and checked for duplicated,
missing or unreadable rows and for temporary files left behind (``tests/interrupt/harness.py``).
Exit status 1 if anything differs.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--kills", type=int, default=10, help="SIGKILLs per command (default 10)")
    ap.add_argument("--only", choices=("study", "dataset"), default=None)
    ap.add_argument("--serial", action="store_true", help="run the commands with --serial (no dask)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the kill moments")
    ap.add_argument("--work", type=Path, default=None, help="folder for the runs (default: a temporary one)")
    ap.add_argument("--samples", type=int, default=6, help="dataset samples (default 6)")
    args = ap.parse_args()

    from tests.interrupt.harness import dataset_job, kill_and_resume, study_job

    jobs = []
    if args.only in (None, "study"):
        jobs.append(study_job(serial=args.serial))
    if args.only in (None, "dataset"):
        jobs.append(dataset_job(args.samples, serial=args.serial))
    tmp = None
    work = args.work
    if work is None:
        tmp = tempfile.TemporaryDirectory(prefix="rigsim-kill-")
        work = Path(tmp.name)
    reports = []
    for i, job in enumerate(jobs):
        reports.append(kill_and_resume(job, work, kills=args.kills, seed=args.seed + i,
                                       log=lambda m: print("  " + m, flush=True)))
    print()
    for r in reports:
        print(r.summary())
    total = sum(r.kills for r in reports)
    ok = all(r.identical for r in reports)
    print(f"\n{total} kills in all: {'every resumed run identical to the uninterrupted one' if ok else 'DIFFERENCES'}")
    if tmp is not None:
        tmp.cleanup()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
