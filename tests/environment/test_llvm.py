"""The Mitsuba variant choice and libLLVM: a libLLVM that Dr.Jit 1.5 cannot use (Debian 12's 15
aborts the process on 'fminimum') is detected before any render; another installed one is used,
or one line says what to install."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from rigsim.environment import Probe, candidate_libraries, ensure_usable_llvm, library_version, probe
from rigsim.errors import EnvironmentProblem

ROOT = Path(__file__).resolve().parents[2]
LLVM15 = next((p for p in ("/usr/lib/x86_64-linux-gnu/libLLVM-15.so.1", "/usr/lib/aarch64-linux-gnu/libLLVM-15.so.1",
                           "/usr/lib/llvm-15/lib/libLLVM-15.so.1") if os.path.isfile(p)), None)
GOOD = next((str(c.path) for c in candidate_libraries() if (c.major or 0) >= 16), None)


@pytest.mark.parametrize("name, major", [("libLLVM-15.so.1", 15), ("libLLVM.so.19.1", 19), ("libLLVM-19.so", 19),
                                         ("libLLVM-14.0.6.so.1", 14), ("libLLVM.so", None), ("libLLVM.dylib", None),
                                         ("libLLVM-17.dylib", 17)])
def test_version_from_the_file_name(name, major):
    assert library_version(name) == major


def _fake_libs(tmp_path, names):
    for n in names:
        (tmp_path / n).write_bytes(b"\x7fELF")
    return (str(tmp_path / "libLLVM*.so*"),)


def _fake_probe(works: dict):
    def p(path):
        if path is None:
            return Probe(None, False, None, "could not be found", missing=True)
        name = Path(path).name
        major = library_version(name)
        ok = works.get(major, False)
        return Probe(str(path), ok, f"{major}.0.0", "compiles float min/max" if ok else
                     "LLVM ERROR: Cannot select: f32 = fminimum")
    return p


def test_a_newer_libllvm_is_chosen_over_the_one_that_aborts(tmp_path, monkeypatch):
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH", raising=False)
    monkeypatch.delenv("RIGSIM_LLVM_CHECK", raising=False)
    pats = _fake_libs(tmp_path, ["libLLVM-15.so.1", "libLLVM.so.19.1", "libLLVM-14.so.1"])
    p = ensure_usable_llvm(patterns=pats, probe_fn=_fake_probe({19: True}), loaded_ok=True)
    assert p.ok and os.environ["DRJIT_LIBLLVM_PATH"] == str(tmp_path / "libLLVM.so.19.1")


def test_only_the_aborting_libllvm_stops_with_what_to_install(tmp_path, monkeypatch):
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH", raising=False)
    monkeypatch.delenv("RIGSIM_LLVM_CHECK", raising=False)
    pats = _fake_libs(tmp_path, ["libLLVM-15.so.1"])
    fake = _fake_probe({})

    def probe_fn(path):  # Dr.Jit's own search would find the same library
        return fake(path if path is not None else str(tmp_path / "libLLVM-15.so.1"))

    with pytest.raises(EnvironmentProblem) as e:
        ensure_usable_llvm(patterns=pats, probe_fn=probe_fn, loaded_ok=True)
    msg = str(e.value)
    assert "\n" not in msg and "libLLVM 15" in msg and "fminimum" in msg and "apt install libllvm19" in msg
    assert "DRJIT_LIBLLVM_PATH" not in os.environ


def test_no_libllvm_at_all_falls_back_as_before(tmp_path, monkeypatch):
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH", raising=False)
    assert ensure_usable_llvm(patterns=(str(tmp_path / "none*"),), probe_fn=_fake_probe({}), loaded_ok=True) is None


def test_a_user_choice_that_aborts_names_the_one_that_works(tmp_path, monkeypatch):
    pats = _fake_libs(tmp_path, ["libLLVM-15.so.1", "libLLVM-18.so.1"])
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", str(tmp_path / "libLLVM-15.so.1"))
    with pytest.raises(EnvironmentProblem, match=r"set it to .*libLLVM-18.so.1 \(libLLVM 18"):
        ensure_usable_llvm(patterns=pats, probe_fn=_fake_probe({18: True}), loaded_ok=True)
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", str(tmp_path / "missing.so"))
    with pytest.raises(EnvironmentProblem, match="no such file"):
        ensure_usable_llvm(patterns=pats, probe_fn=_fake_probe({18: True}), loaded_ok=True)


@pytest.mark.skipif(LLVM15 is None or GOOD is None, reason="needs libLLVM 15 and a libLLVM >= 16 installed")
def test_the_real_libllvm_15_is_found_out_by_the_probe():
    bad = probe(LLVM15, use_cache=False)
    assert not bad.ok and bad.version.startswith("15.") and ("fminimum" in bad.detail or "fmaximum" in bad.detail)
    good = probe(GOOD, use_cache=False)
    assert good.ok and good.major >= 16


@pytest.mark.skipif(LLVM15 is None or GOOD is None, reason="needs libLLVM 15 and a libLLVM >= 16 installed")
def test_render_with_libllvm_15_is_one_line_not_an_abort(tmp_path):
    """Without the check this process dies with SIGABRT printing LLVM's 'In function: drjit_<hash>'."""
    env = {**os.environ, "DRJIT_LIBLLVM_PATH": LLVM15, "RIGSIM_CACHE": str(tmp_path / "cache")}
    env.pop("RIGSIM_MITSUBA_VARIANT", None)
    r = subprocess.run([sys.executable, "-m", "rigsim.cli", "render", str(ROOT / "rigs" / "twin-strobes-45-wide.toml"),
                        "--water", "coastal", "--distance", "2", "--size", "4x3", "--spp", "1", "--wavelengths", "550",
                        "--out", str(tmp_path / "r")], capture_output=True, text=True, timeout=300, cwd=ROOT, env=env)
    assert r.returncode == 3, (r.returncode, r.stderr[-2000:])
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "In function" not in r.stderr, r.stderr[-2000:]
    assert "libLLVM 15" in lines[0] and GOOD in lines[0]
