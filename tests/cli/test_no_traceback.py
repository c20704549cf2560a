"""The command line never shows a user a traceback: usage errors are click's message (exit 2),
rigsim's own errors one line, anything unexpected one line naming the log with the full trace
(exit 1), and ``--log-level debug`` shows the trace."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
RIG = str(ROOT / "rigs" / "twin-strobes-45-wide.toml")


def rigsim(*args, env=None, **kw):
    import os

    return subprocess.run([sys.executable, "-m", "rigsim.cli", *args], capture_output=True, text=True, timeout=300,
                          cwd=ROOT, env={**os.environ, **(env or {})}, **kw)


@pytest.mark.parametrize("argv, error", [
    (["render", "rigs/x.toml", "--bogus"], "No such option: --bogus"),
    (["render"], "Missing argument"),
    (["water", "show"], "Missing argument"),
    (["render", RIG, "--water", "coastal", "--distance", "abc", "--out", "x"], "Invalid value for '--distance'"),
    (["render", RIG, "--water", "coastal", "--distance", "1", "--spp", "1.5", "--out", "x"], "Invalid value for '--spp'"),
    (["--log-level", "bogus", "water", "list"], "Invalid value for '--log-level'"),
    (["water", "nosuchcommand"], "No such command"),
    (["dataset", "datasets/underwater-training.toml"], "Missing option '--n'"),
    (["optimise", RIG, "--distance", "1", "--out", "x"], "Missing option '--water'"),
    (["optimise", RIG, "--water", "coastal", "--distance", "1", "--seed", "-1", "--out", "x"], "Invalid value for '--seed'"),
])
def test_usage_errors_are_clicks_message_and_exit_2(argv, error):
    r = rigsim(*argv)
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr + r.stdout and "╭" not in r.stderr and "NoSuchOption" not in r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert any(ln.startswith("Error: ") and error in ln for ln in lines), r.stderr
    assert len(lines) <= 4 and lines[0].startswith("Usage: rigsim"), r.stderr


def test_no_arguments_shows_the_help():
    r = rigsim()
    assert r.returncode == 2 and "Usage:" in r.stdout + r.stderr and "Traceback" not in r.stdout + r.stderr


def _boom(run_command_argv, tmp_path, *, debug=False):
    """Run a command whose loader raises an unexpected ZeroDivisionError, in a child process."""
    code = ("import sys, rigsim.cli as c; c.load_commands(); import rigsim.cli.water as w\n"
            "def boom(*a, **k): raise ZeroDivisionError('division by zero')\n"
            "w.load_water = boom\n"
            "sys.exit(c.run_command(sys.argv[1:]))\n")
    return subprocess.run([sys.executable, "-c", code, *(["--log-level", "debug"] if debug else []),
                           *run_command_argv], capture_output=True, text=True, timeout=120, cwd=ROOT,
                          env={**__import__("os").environ, "RIGSIM_CACHE": str(tmp_path / "cache")})


def test_an_unexpected_error_is_one_line_naming_the_log(tmp_path):
    r = _boom(["water", "show", "coastal"], tmp_path)
    assert r.returncode == 1
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    line = lines[0]
    assert "internal error in `rigsim water show coastal`: ZeroDivisionError: division by zero" in line
    logs = list((tmp_path / "cache" / "logs").glob("rigsim-*.log"))
    assert len(logs) == 1 and str(logs[0]) in line
    text = logs[0].read_text()
    assert "Traceback (most recent call last)" in text and "def boom" not in line and "boom" in text
    assert "command: rigsim water show coastal" in text


def test_debug_log_level_prints_the_trace(tmp_path):
    r = _boom(["water", "show", "coastal"], tmp_path, debug=True)
    assert r.returncode == 1 and "Traceback (most recent call last)" in r.stderr and "ZeroDivisionError" in r.stderr
    r = rigsim("--log-level", "debug", "render", "rigs/nope.toml", "--water", "coastal", "--distance", "1", "--out",
               str(tmp_path / "x"))
    assert r.returncode == 2 and "Traceback" in r.stderr and r.stderr.strip().splitlines()[-1].startswith("error:")


def test_rigsim_errors_stay_one_line_and_warnings_too(tmp_path):
    r = rigsim("render", RIG, "--water", "coastal", "--distance", "1.5", "--size", "8x8", "--engine", "preview",
               "--wavelengths", "450:650:100", "--out", str(tmp_path / "r"))
    assert r.returncode == 0, r.stderr
    assert r.stderr.strip().startswith("warning: image aspect 8x8") and len(r.stderr.strip().splitlines()) == 1
    r = rigsim("render", RIG, "--water", "coastl", "--distance", "1.5", "--out", str(tmp_path / "r"))
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "did you mean 'coastal'" in r.stderr


def test_a_closed_pipe_is_no_traceback():
    p = subprocess.Popen([sys.executable, "-m", "rigsim.cli", "water", "list"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, cwd=ROOT)
    p.stdout.readline()
    p.stdout.close()
    err = p.stderr.read().decode()
    p.wait(timeout=60)
    assert "Traceback" not in err and "BrokenPipeError" not in err, err


@pytest.mark.parametrize("size", ["200000x200000", "16384x16384"])
def test_a_huge_image_is_refused_before_allocation_with_the_memory_it_needs(size, tmp_path):
    import resource
    import time

    t0 = time.perf_counter()
    r = rigsim("render", RIG, "--water", "coastal", "--distance", "2", "--size", size, "--engine", "preview",
               "--out", str(tmp_path / "r"))
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "memory" in r.stderr and ("TB" in r.stderr or "GB" in r.stderr), r.stderr
    assert time.perf_counter() - t0 < 60
    child = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024  # MB, the largest child so far
    assert child < 2000, f"a child grew to {child:.0f} MB"
    assert not (tmp_path / "r").exists()
