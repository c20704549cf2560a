"""An output folder that cannot be written — read-only, disk full (a tiny tmpfs, or a writer that
fails) — gives one line naming the file and leaves no partial files."""

from __future__ import annotations

import errno
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
RENDER = ["render", str(ROOT / "rigs" / "twin-strobes-45-wide.toml"), "--water", "coastal", "--distance", "1.5",
          "--size", "12x8", "--engine", "preview", "--wavelengths", "450:650:100"]


def rigsim(*args):
    return subprocess.run([sys.executable, "-m", "rigsim.cli", *args], capture_output=True, text=True, timeout=600,
                          cwd=ROOT)


@pytest.fixture
def tmpfs(tmp_path):
    """A tmpfs of 20 kB (needs root: mount); yields its path."""
    m = tmp_path / "tiny"
    m.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=20k", "tmpfs", str(m)], capture_output=True)
    if r.returncode != 0:
        pytest.skip("cannot mount a tmpfs here (not root)")
    try:
        yield m
    finally:
        subprocess.run(["umount", "-l", str(m)], capture_output=True)


def _leftovers(root: Path) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in root.rglob("*"))


def test_disk_full_render_is_one_line_and_leaves_nothing(tmpfs):
    r = rigsim(*RENDER, "--out", str(tmpfs / "r"))
    assert r.returncode == 1, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip() and not ln.startswith("warning:")]
    assert len(lines) == 1 and "No space left on device" in lines[0] and str(tmpfs / "r") in lines[0], r.stderr
    assert ".partial" not in lines[0]
    assert _leftovers(tmpfs) == []  # not even the folder it made


def test_disk_full_in_an_existing_folder_keeps_what_was_there(tmpfs):
    (tmpfs / "r").mkdir()
    (tmpfs / "r" / "notes.txt").write_text("mine")
    r = rigsim(*RENDER, "--out", str(tmpfs / "r"))
    assert r.returncode == 1 and "No space left" in r.stderr
    assert _leftovers(tmpfs / "r") in (["notes.txt"], [".rigsim.lock", "notes.txt"])


def test_disk_full_study_is_one_line(tmpfs):
    r = rigsim("study", "tests/data/tiny-study.toml", "--serial", "--no-report", "--out", str(tmpfs / "s"))
    assert r.returncode == 1 and r.stderr.count("\n") == 1 and "No space left" in r.stderr, r.stderr
    assert not [p for p in (tmpfs / "s").rglob("*") if p.name.endswith(".tmp")]


def test_read_only_folder_is_one_line_before_any_work(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=64k", "tmpfs", str(ro)], capture_output=True)
    if r.returncode != 0:
        if os.geteuid() == 0:
            pytest.skip("cannot mount a read-only tmpfs")
        ro.chmod(0o555)
    try:
        for argv in (RENDER, ["study", "tests/data/tiny-study.toml", "--serial", "--no-report"],
                     ["dataset", "tests/data/tiny-dataset.toml", "--n", "1", "--serial"]):
            r2 = rigsim(*argv, "--out", str(ro / "x"))
            assert r2.returncode == 1 and r2.stderr.count("\n") == 1, r2.stderr
            assert ("Read-only file system" in r2.stderr or "Permission denied" in r2.stderr) and str(ro) in r2.stderr
    finally:
        subprocess.run(["umount", "-l", str(ro)], capture_output=True)


def test_a_failing_writer_leaves_no_partial_files(tmp_path, monkeypatch, run):
    """A writer that fails on the third file (in process): one line, and the folder stays empty."""
    import rigsim.fileio as fileio

    calls = {"n": 0}
    real = os.fsync

    def failing_fsync(fd):
        calls["n"] += 1
        if calls["n"] >= 4:  # after the folder check and two files
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(fd)

    monkeypatch.setattr(fileio.os, "fsync", failing_fsync)
    out = tmp_path / "r"
    code, o, e = run(*RENDER, "--out", out)
    assert code == 1 and "No space left on device" in e and e.count("\n") == 1, e
    assert not out.exists()
    assert not list(tmp_path.rglob("*.tmp"))
