"""Ctrl-C stops ``rigsim study`` / ``rigsim dataset`` cleanly: one line saying how to resume,
exit 130, no traceback from the command or its dask workers; the resumed run's tables are those
of an uninterrupted run."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.interrupt.harness import ROOT, compare, study_job


def _as_in_a_terminal():
    """The child's SIGINT as in a terminal (default): a test runner started in the background of a
    non-interactive shell has SIGINT ignored, and an ignored signal stays ignored across exec."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _interrupt_after(cmd, out: Path, items: str, n: int, timeout=300):
    p = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                         start_new_session=True, preexec_fn=_as_in_a_terminal)
    t0 = time.time()
    while time.time() - t0 < timeout and len(list(out.glob(items))) < n and p.poll() is None:
        time.sleep(0.05)
    assert p.poll() is None, "the run ended before it could be interrupted"
    os.killpg(p.pid, signal.SIGINT)  # what Ctrl-C in a terminal does: the whole process group
    t1 = time.time()
    o, e = p.communicate(timeout=120)
    return p.returncode, o, e, time.time() - t1


@pytest.fixture(scope="module")
def ref(tmp_path_factory):
    """An uninterrupted run (serial: the same tables as with dask)."""
    out = tmp_path_factory.mktemp("sigint") / "ref"
    r = subprocess.run(study_job(serial=True).command(out), cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    return out


@pytest.mark.parametrize("serial", [False, True], ids=["dask", "serial"])
def test_ctrl_c_stops_a_study_with_one_line_and_it_resumes(tmp_path, serial, ref):
    job = study_job(serial=serial)
    out = tmp_path / "interrupted"
    code, o, e, took = _interrupt_after(job.command(out), out, job.items, 2)
    assert code == 130, e
    lines = [ln for ln in e.splitlines() if ln.strip()]
    assert len(lines) == 1, e
    assert lines[0].startswith("interrupted (") and "are finished and kept" in lines[0]
    assert "to resume, run the same command again: rigsim study" in lines[0] and str(out) in lines[0]
    assert "Traceback" not in e + o and "KeyboardInterrupt" not in e + o
    assert took < 60
    r = subprocess.run(job.command(out), cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert compare(job, ref, out) == []


def test_sigterm_stops_like_ctrl_c(tmp_path):
    job = study_job(serial=True)
    out = tmp_path / "t"
    p = subprocess.Popen(job.command(out), cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    t0 = time.time()
    while time.time() - t0 < 300 and len(list(out.glob(job.items))) < 1 and p.poll() is None:
        time.sleep(0.05)
    p.terminate()
    o, e = p.communicate(timeout=120)
    assert p.returncode == 130 and e.strip().startswith("interrupted") and e.strip().count("\n") == 0, e
