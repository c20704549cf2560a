"""The rig designer without a usable EGL/OpenGL says what to install in one line (VTK would
crash the server with a segmentation fault the first time it draws the 3-D view)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def test_app_without_egl_is_one_line(tmp_path):
    from tests.ui.wsclient import free_port

    # libglvnd's EGL finds no vendor library: what a machine without libegl-mesa0 looks like to VTK
    env = {**os.environ, "__EGL_VENDOR_LIBRARY_FILENAMES": str(tmp_path / "none.json"), "RIGSIM_GL_CHECK": "1"}
    r = subprocess.run([sys.executable, "-m", "rigsim.cli", "app", "--port", str(free_port())], capture_output=True,
                       text=True, timeout=300, cwd=ROOT, env=env)
    assert r.returncode == 3, (r.returncode, r.stderr[-2000:])
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith(("error:", "Traceback"))]
    assert len(lines) == 1 and lines[0].startswith("error: the rig designer's 3-D view needs off-screen OpenGL")
    assert "apt install libegl1 libegl-mesa0 libgl1-mesa-dri" in lines[0] and "--view client" in lines[0]


def test_the_check_passes_where_opengl_works():
    from rigsim.environment import check_offscreen_gl

    check_offscreen_gl()
