"""Two runs on one output folder: the second refuses with a clear message, nothing is corrupted;
the lock goes with its process however that ends (SIGKILL included)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rigsim.errors import FolderInUse
from rigsim.fileio import folder_lock, remove_stale_temp_files

ROOT = Path(__file__).resolve().parents[2]
HOLD = ("import sys, time; sys.argv = ['rigsim', 'study', 'other.toml']\n"
        "from rigsim.fileio import folder_lock\n"
        "with folder_lock({out!r}):\n"
        "    print('held', flush=True); time.sleep(600)\n")


def _holder(out: Path) -> subprocess.Popen:
    p = subprocess.Popen([sys.executable, "-c", HOLD.format(out=str(out))], stdout=subprocess.PIPE, text=True,
                         cwd=ROOT, start_new_session=True)
    assert p.stdout.readline().strip() == "held"
    return p


def rigsim(*args):
    return subprocess.run([sys.executable, "-m", "rigsim.cli", *args], capture_output=True, text=True, timeout=600,
                          cwd=ROOT)


def test_a_second_study_or_dataset_on_the_same_folder_refuses(tmp_path):
    out = tmp_path / "out"
    p = _holder(out)
    try:
        for argv in (["study", "tests/data/tiny-study.toml", "--serial", "--no-report"],
                     ["dataset", "tests/data/tiny-dataset.toml", "--n", "1", "--serial"],
                     ["render", "rigs/twin-strobes-45-wide.toml", "--water", "coastal", "--distance", "1",
                      "--engine", "preview", "--size", "6x4"]):
            r = rigsim(*argv, "--out", str(out))
            assert r.returncode == 3, r.stderr
            lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
            assert len(lines) == 1 and "in use by another rigsim run" in lines[0], r.stderr
            assert f"pid {p.pid}" in lines[0] and "rigsim study other.toml" in lines[0]
        assert sorted(x.name for x in out.iterdir()) == [".rigsim.lock"]  # the second runs wrote nothing
    finally:
        os.killpg(p.pid, signal.SIGKILL)
        p.wait()
    # SIGKILL released it: the next run goes ahead
    with folder_lock(out):
        with pytest.raises(FolderInUse, match="in use"):
            with folder_lock(out):
                pass


def test_two_concurrent_studies_one_runs_one_refuses_and_the_result_is_whole(tmp_path):
    out = tmp_path / "s"
    cmd = [sys.executable, "-m", "rigsim.cli", "study", "tests/data/tiny-study.toml", "--serial", "--no-report",
           "--out", str(out)]
    a = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(0.05)
    b = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    ra, rb = a.communicate(timeout=600), b.communicate(timeout=600)
    codes = sorted([a.returncode, b.returncode])
    if codes == [0, 0]:
        pytest.skip("the first run finished before the second started (a very fast machine)")
    assert codes == [0, 3], (ra, rb)
    loser = ra if a.returncode == 3 else rb
    assert "in use by another rigsim run" in loser[1] and loser[1].count("\n") == 1
    rows = (out / "results.csv").read_text().splitlines()
    assert len(rows) == 9 and len(set(rows)) == 9  # header + 8 cases, none twice


def test_stale_temporary_files_are_removed_on_resume(tmp_path):
    d = tmp_path / "cases" / "x"
    d.mkdir(parents=True)
    for name in (".result.json.abc123.tmp", ".raw.dng.tmp", "spectral.tmp.exr"):
        (d / name).write_text("half")
    (tmp_path / ".partial-xyz").mkdir()
    (d / "result.json").write_text("{}")
    assert remove_stale_temp_files(tmp_path) == 4
    assert [p.name for p in d.iterdir()] == ["result.json"] and not (tmp_path / ".partial-xyz").exists()
