"""The embedded dask cluster's worker processes (:mod:`rigsim.parallel`)."""

from __future__ import annotations

import os


def _probe(_item) -> tuple[str | None, bool]:
    """(the worker's MALLOC_TRIM_THRESHOLD_, whether a tuning was still to do) — run in a worker."""
    from rigsim.parallel import _TUNED

    return os.environ.get("MALLOC_TRIM_THRESHOLD_"), _TUNED


def test_workers_keep_glibcs_own_memory_thresholds():
    """dask's nanny starts workers with MALLOC_TRIM_THRESHOLD_=65536, under which every large numpy
    temporary is mapped and unmapped again (a demo case: 10 s instead of 4 s, most of it page faults).
    The embedded cluster's workers start without it."""
    from rigsim.parallel import run_tasks

    got = {}
    run_tasks([0, 1], _probe, lambda it, res: got.__setitem__(it, res), workers=1, progress=False)
    assert got[0][0] is None and got[1][0] is None, got


def test_a_worker_started_with_it_raises_the_thresholds(monkeypatch):
    """A worker of someone else's cluster (``dask worker``) has it: the task raises the thresholds."""
    import rigsim.parallel as P

    monkeypatch.setattr(P, "_TUNED", False)
    monkeypatch.setenv("MALLOC_TRIM_THRESHOLD_", "65536")
    assert P.tune_allocator() is True
    assert P.tune_allocator() is False  # once per process
    monkeypatch.setattr(P, "_TUNED", False)
    monkeypatch.delenv("MALLOC_TRIM_THRESHOLD_")
    assert P.tune_allocator() is False  # nothing to undo elsewhere


def _pid_of(item) -> int:
    return os.getpid()


def test_work_that_finished_work_decides_runs_on_the_workers_too():
    """``run_tasks(more=...)``: items that finished items decide (a study's steps beyond the sweep)
    are run as they are decided — on the cluster's workers like the rest, not afterwards in this
    process — and in serial runs here; each once, and counted in the return value."""
    from rigsim.parallel import run_tasks

    for kw in (dict(workers=2), dict(serial=True)):
        got: dict[int, int] = {}
        asked = []

        def more():  # a chain: each item decides the next, 0 → 1 → … → 5
            asked.append(len(got))
            return [k + 1 for k in got if k < 5]

        n = run_tasks([0], _pid_of, got.__setitem__, more=more, progress=False, **kw)
        assert sorted(got) == list(range(6)) and n == 6, (kw, got, n)
        here = set(got.values()) == {os.getpid()}
        assert here == ("serial" in kw), (kw, got)
        assert len(asked) == 7  # once at the start, once after each item
