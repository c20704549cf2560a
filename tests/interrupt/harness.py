"""Kill a ``rigsim study`` / ``rigsim dataset`` run with SIGKILL at random moments, resume it, and
compare what it finally wrote with an uninterrupted run of the same command.

Used by ``tests/interrupt/test_kill_resume.py`` (a few kills, CI) and ``tools/kill_resume.py``
(10 kills of each command).  A kill is ``SIGKILL`` to the run's process group (the command and
its dask worker processes: what the kernel's OOM killer or ``kill -9 -PGID`` does); after each kill
the folder is checked (every finished item's record parses; no other run holds the lock), then the
next run resumes it.  After the last kill one run goes to the end, and its tables and files must
equal the uninterrupted run's: byte for byte, except the wall times inside the per-item records
and ``timings.csv``, which are compared without their timing fields / not at all.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TINY_STUDY = ROOT / "tests" / "data" / "tiny-study.toml"
TINY_DATASET = ROOT / "tests" / "data" / "tiny-dataset.toml"

#: Files that differ between identical runs by design (wall times) or are not results.
NOT_COMPARED = {"timings.csv", ".rigsim.lock", "report.html"}


@dataclasses.dataclass
class Job:
    """One command to kill and resume."""

    name: str                 # "study" or "dataset"
    argv: list[str]           # after "rigsim", without --out
    items: str                # glob of the per-item completion records below the folder

    def command(self, out: Path) -> list[str]:
        return [sys.executable, "-m", "rigsim.cli", *self.argv, "--out", str(out)]


def study_job(serial: bool = False) -> Job:
    return Job("study", ["study", str(TINY_STUDY), "--no-report", *(["--serial"] if serial else [])],
               "cases/*/result.json")


def dataset_job(n: int = 6, serial: bool = False) -> Job:
    return Job("dataset", ["dataset", str(TINY_DATASET), "--n", str(n), *(["--serial"] if serial else [])],
               "samples/*/record.json")


def _env() -> dict:
    return {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}


def run_to_end(job: Job, out: Path, timeout: float = 1800) -> tuple[float, subprocess.CompletedProcess]:
    t0 = time.perf_counter()
    r = subprocess.run(job.command(out), capture_output=True, text=True, timeout=timeout, cwd=ROOT, env=_env())
    return time.perf_counter() - t0, r


def timed_run(job: Job, out: Path, timeout: float = 1800) -> tuple[float, float, subprocess.CompletedProcess]:
    """Run to the end, watching the folder: (seconds to the first finished item, seconds in all, result)."""
    t0 = time.perf_counter()
    with open(out.parent / f"{out.name}.stderr", "w+") as fh:
        p = subprocess.Popen(job.command(out), stdout=subprocess.DEVNULL, stderr=fh, cwd=ROOT, env=_env())
        first = None
        while p.poll() is None:
            if first is None and any(out.glob(job.items)):
                first = time.perf_counter() - t0
            if time.perf_counter() - t0 > timeout:
                p.kill()
            time.sleep(0.05)
        total = time.perf_counter() - t0
        fh.seek(0)
        err = fh.read()
    return (first if first is not None else total), total, subprocess.CompletedProcess(p.args, p.returncode, "", err)


def _strip_times(node):
    if isinstance(node, dict):
        return {k: _strip_times(v) for k, v in node.items() if "wall_time" not in k and k != "seconds"}
    if isinstance(node, list):
        return [_strip_times(v) for v in node]
    return node


def _files(root: Path) -> dict[str, Path]:
    return {str(p.relative_to(root)): p for p in sorted(root.rglob("*")) if p.is_file()}


def integrity_problems(job: Job, out: Path) -> list[str]:
    """What is wrong with a (possibly killed) folder: unreadable records, a lock still held."""
    problems = []
    for f in sorted(out.glob(job.items)):
        try:
            json.loads(f.read_text())
        except (OSError, ValueError) as exc:
            problems.append(f"{f.relative_to(out)}: unreadable ({exc})")
    lock = out / ".rigsim.lock"
    if lock.is_file():
        import fcntl

        fd = os.open(lock, os.O_RDWR)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            problems.append("the folder lock is still held after the kill")
        finally:
            os.close(fd)
    return problems


def _rows(path: Path) -> list[tuple]:
    return [tuple(r) for r in csv.reader(io.StringIO(path.read_text()))][1:]


def compare(job: Job, ref: Path, out: Path) -> list[str]:
    """Differences between the resumed folder ``out`` and the uninterrupted ``ref`` (empty: identical)."""
    diffs = []
    a, b = _files(ref), _files(out)
    a = {k: v for k, v in a.items() if Path(k).name not in NOT_COMPARED}
    b = {k: v for k, v in b.items() if Path(k).name not in NOT_COMPARED}
    for k in sorted(set(a) - set(b)):
        diffs.append(f"missing: {k}")
    for k in sorted(set(b) - set(a)):
        diffs.append(f"extra: {k}")
    for k in sorted(set(a) & set(b)):
        if Path(k).name in ("result.json", "record.json"):
            ja, jb = json.loads(a[k].read_text()), json.loads(b[k].read_text())
            if _strip_times(ja) != _strip_times(jb):
                diffs.append(f"differs (besides wall times): {k}")
        elif a[k].read_bytes() != b[k].read_bytes():
            diffs.append(f"differs: {k}")
    table = "results.csv" if job.name == "study" else "manifest.csv"
    if (out / table).is_file() and (ref / table).is_file():
        ra, rb = _rows(ref / table), _rows(out / table)
        if len(set(rb)) != len(rb):
            diffs.append(f"{table}: {len(rb) - len(set(rb))} duplicated rows")
        if set(ra) - set(rb):
            diffs.append(f"{table}: {len(set(ra) - set(rb))} rows missing")
        if set(rb) - set(ra):
            diffs.append(f"{table}: {len(set(rb) - set(ra))} rows that the uninterrupted run does not have")
    return diffs


@dataclasses.dataclass
class KillReport:
    job: str
    kills: int
    runs_that_finished: int            # runs that ended before their kill moment (a folder completed)
    finished_at_kills: list[int]       # items finished in the folder at each kill
    rounds: int                        # folders killed and resumed to the end
    integrity: list[str]
    final_rc: list[int]
    leftovers: list[str]
    diffs: list[str]
    total_items: int
    ref_seconds: float
    seconds: float
    final_stderr: str = ""

    @property
    def identical(self) -> bool:
        return not self.diffs and not self.integrity and not any(self.final_rc) and not self.leftovers

    def summary(self) -> str:
        verdict = "IDENTICAL to the uninterrupted run" if self.identical else "DIFFERENT"
        lines = [f"{self.job}: {self.kills} SIGKILLs in {self.rounds} folder(s) resumed to the end; items finished "
                 f"at each kill: {self.finished_at_kills} of {self.total_items}; {self.runs_that_finished} runs ended "
                 f"before their kill moment; {verdict} (uninterrupted run {self.ref_seconds:.0f} s, "
                 f"harness {self.seconds:.0f} s)"]
        for p in self.integrity + self.diffs + [f"left behind: {x}" for x in self.leftovers]:
            lines.append(f"  - {p}")
        if any(self.final_rc):
            lines.append(f"  final run exit {self.final_rc}: {self.final_stderr[-500:]}")
        return "\n".join(lines)


def kill_and_resume(job: Job, work: Path, *, kills: int, seed: int = 0, ref: Path | None = None,
                    ref_seconds: float | None = None, log=print) -> KillReport:
    """Run ``job`` uninterrupted (unless ``ref`` is given); then start it and SIGKILL it ``kills`` times at
    random moments, each run resuming the folder the last one left.

    A kill moment is uniform in ``[0.05, 1] ×`` the expected length of the run: the uninterrupted
    run's start-up (time to its first finished item) plus its time per item × the items still to
    do.  When a run ends before its moment the folder is complete: it is compared with the
    uninterrupted run and a new folder is started, so that every kill hits a run with work left.
    The last folder is finished by a run that is not killed and compared too.
    """
    rng = random.Random(seed)
    t_start = time.perf_counter()
    work.mkdir(parents=True, exist_ok=True)
    startup = None
    if ref is None:
        ref = work / f"{job.name}-uninterrupted"
        shutil.rmtree(ref, ignore_errors=True)
        startup, ref_seconds, r = timed_run(job, ref)
        if r.returncode != 0:
            raise RuntimeError(f"the uninterrupted {job.name} run failed: {r.stderr[-1000:]}")
        log(f"{job.name}: uninterrupted run {ref_seconds:.1f} s (first item after {startup:.1f} s)")
    ref_seconds = ref_seconds or 10.0
    startup = ref_seconds * 0.3 if startup is None else startup
    total = len(list(ref.glob(job.items)))
    per_item = max(ref_seconds - startup, 0.1) / max(total, 1)
    finished, integrity, diffs, leftovers, rcs = [], [], [], [], []
    early, rounds, stderr = 0, 0, ""

    def close_round(out: Path, rc: int, err: str):
        nonlocal rounds, stderr
        rounds += 1
        rcs.append(rc)
        if rc:
            stderr = err
        leftovers.extend(f"{out.name}/{k}" for k in _files(out)
                         if Path(k).name.startswith(".") and Path(k).name != ".rigsim.lock")
        diffs.extend(f"{out.name}: {d}" for d in compare(job, ref, out))

    out = work / f"{job.name}-killed-1"
    shutil.rmtree(out, ignore_errors=True)
    k = 0
    while k < kills:
        left = total - len(list(out.glob(job.items)))
        # a moment in the expected length of this run: start-up (imports, cluster, kernel compilation)
        # plus the items still to do
        delay = rng.uniform(0.05, 1.0) * (startup + per_item * left)
        err_file = work / f"{job.name}-stderr.txt"
        with open(err_file, "w") as fh:
            p = subprocess.Popen(job.command(out), stdout=subprocess.DEVNULL, stderr=fh, cwd=ROOT, env=_env(),
                                 start_new_session=True)
        try:
            p.wait(timeout=delay)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()
            k += 1
            time.sleep(0.2)
            try:  # dask workers of the killed run that had not gone yet
                os.killpg(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            n = len(list(out.glob(job.items)))
            finished.append(n)
            integrity.extend(f"{out.name} after kill {k}: {x}" for x in integrity_problems(job, out))
            log(f"{job.name}: kill {k}/{kills} at {delay:.1f} s: {n}/{total} items finished")
            continue
        early += 1
        err = err_file.read_text(errors="replace")
        log(f"{job.name}: the run ended before its kill moment ({delay:.1f} s): {out.name} complete")
        close_round(out, p.returncode, err)
        out = work / f"{job.name}-killed-{rounds + 1}"
        shutil.rmtree(out, ignore_errors=True)
    _, r = run_to_end(job, out)
    close_round(out, r.returncode, r.stderr)
    return KillReport(job.name, kills, early, finished, rounds, integrity, rcs, leftovers, diffs, total,
                      ref_seconds, time.perf_counter() - t_start, stderr)
