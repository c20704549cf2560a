"""The soak's worker process (``tests/fuzz/worker.py``): a case that its own alarm cannot stop is
killed from outside and counted as a hang, a dying worker as a crash, and the cases after them
still run."""

from __future__ import annotations

from tests.fuzz import cases as fz
from tests.fuzz.worker import CaseWorker


def test_a_stalled_or_dying_case_is_counted_and_the_soak_goes_on(tmp_path):
    w = CaseWorker(tmp_path, timeout=1.0, grace=4.0, module="tests.fuzz.stall_runs")
    try:
        results = [w.run("files", fz.ConfigCase(kind, b"", [])) for kind in
                   ("fine", "swallowed-alarm", "fine", "abort", "fine")]
    finally:
        w.close()
    assert [r.outcome for r in results] == [fz.OK, fz.HANG, fz.OK, fz.CRASH, fz.OK], results
    assert results[1].kind == "file:swallowed-alarm" and "killed" in results[1].detail
    assert 4.0 <= results[1].seconds < 30
    assert "died" in results[3].detail and results[3].kind == "file:abort"
    assert w.restarts == 2
