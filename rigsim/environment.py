"""What the machine must provide, checked before it is needed, with one line saying what to install.

* libLLVM for Mitsuba's vectorised variant (:func:`ensure_usable_llvm`);
* off-screen OpenGL (EGL or OSMesa) for the rig designer's 3-D view (:func:`check_offscreen_gl`).

libLLVM
-------

Dr.Jit 1.5 loads libLLVM when it is imported: the file named by ``DRJIT_LIBLLVM_PATH``, else
``libLLVM.so`` on the loader's path, else one of
``/usr/lib/{x86_64-linux-gnu,aarch64-linux-gnu,wsl/lib}/libLLVM*.so.*``.  On a Debian 12
machine where rigsim was installed the ordinary Python way (``pip install -e .``), that is the
system's libLLVM 15 (Mesa depends on it).  It loads, and ``dr.zeros(...)`` works, but the first
kernel that takes a floating-point minimum or maximum — every render — makes LLVM abort the
whole process with ``LLVM ERROR: Cannot select: ... fminimum ...  In function: drjit_<hash>``.

:func:`ensure_usable_llvm` therefore tries each libLLVM it finds (newest first; the places
Dr.Jit looks and ``/usr/lib/llvm-*/lib``, ``/usr/local/lib``, Homebrew's) in a child process
(:func:`probe`: ``dr.detail.llvm_version()`` and a kernel with ``dr.minimum``/``dr.maximum`` on
floats, the instructions that fail) and sets ``DRJIT_LIBLLVM_PATH`` to the first that works.
If the user set ``DRJIT_LIBLLVM_PATH`` to one that does not work, or none works, it stops with
one line saying what to install (:class:`~rigsim.errors.EnvironmentProblem`).  A probe's result
is cached in ``<cache>/llvm-probe.json`` per library file (path, size, time) and Dr.Jit version,
so the check costs a fraction of a second once per machine.

``RIGSIM_LLVM_CHECK=0`` skips the check (Dr.Jit then picks its library itself).
"""

from __future__ import annotations

import dataclasses
import glob
import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

from rigsim.errors import EnvironmentProblem

__all__ = ["LibLLVM", "Probe", "SEARCH_PATTERNS", "candidate_libraries", "library_version", "probe",
           "ensure_usable_llvm", "MIN_LLVM_MAJOR", "INSTALL_HINT", "check_offscreen_gl", "GL_INSTALL_HINT"]

#: Where libLLVM is looked for (Dr.Jit's own places first).
SEARCH_PATTERNS = (
    "/usr/lib/x86_64-linux-gnu/libLLVM*.so*", "/usr/lib/aarch64-linux-gnu/libLLVM*.so*", "/usr/lib/wsl/lib/libLLVM*.so*",
    "/usr/lib/llvm-*/lib/libLLVM*.so*", "/usr/lib64/libLLVM*.so*", "/usr/local/lib/libLLVM*.so*",
    "/usr/local/opt/llvm/lib/libLLVM*.dylib", "/opt/homebrew/opt/llvm/lib/libLLVM*.dylib",
)
#: The oldest LLVM known to compile Dr.Jit 1.5's kernels (15 aborts on fminimum; 14 is refused by Dr.Jit).
MIN_LLVM_MAJOR = 16
#: What to do about it.
INSTALL_HINT = ("install libLLVM 16 or newer (Debian/Ubuntu: `apt install libllvm19`; or `bash tools/setup.sh install`) "
                "or set DRJIT_LIBLLVM_PATH to one; RIGSIM_MITSUBA_VARIANT=scalar_spectral renders without LLVM, slowly")

_VERSION = re.compile(r"libLLVM(?:-(\d+)(?:\.\d+)*\.(?:so|dylib)|\.so\.(\d+)(?:\.\d+)*$|-(\d+)(?:\.\d+)*$)")

#: The probe: loads the library, prints its version, compiles and runs a kernel with float min/max.
_PROBE = r"""
import sys
try:
    import drjit as dr
    from drjit.llvm import Float
    v = dr.detail.llvm_version()
    if v and v[0] >= 0:
        print("RIGSIM-LLVM-VERSION", ".".join(map(str, v)), flush=True)
    a = dr.arange(Float, 64) * %r
    b = dr.minimum(a, 20.5) + dr.maximum(a * 0.5, 3.25)
    dr.eval(b)
    assert abs(float(b[63]) - max(63 * %r * 0.5, 3.25) - min(63 * %r, 20.5)) < 1e-3
    print("RIGSIM-LLVM-OK", flush=True)
except (ImportError, RuntimeError) as e:
    text = " ".join(str(e).split())
    print("RIGSIM-LLVM-MISSING" if "could not be found" in text or "No module" in text else "RIGSIM-LLVM-ERROR",
          text, flush=True)
"""


@dataclasses.dataclass(frozen=True)
class LibLLVM:
    """A libLLVM file and the major version its name states (None if it does not)."""

    path: Path
    major: int | None


@dataclasses.dataclass(frozen=True)
class Probe:
    """What :func:`probe` found out about one library (``path`` None: Dr.Jit's own choice)."""

    path: str | None
    ok: bool
    version: str | None
    detail: str
    missing: bool = False

    @property
    def major(self) -> int | None:
        try:
            return int(self.version.split(".")[0]) if self.version else None
        except ValueError:
            return None

    def describe(self) -> str:
        v = f"libLLVM {self.version}" if self.version else "libLLVM"
        return f"{v} ({self.path or 'the one Dr.Jit found'})"


def library_version(path: str | Path) -> int | None:
    """The major version in a libLLVM file name: ``libLLVM-15.so.1`` → 15, ``libLLVM.so.19.1`` → 19."""
    m = _VERSION.search(Path(path).name)
    if not m:
        return None
    return int(next(g for g in m.groups() if g))


def candidate_libraries(patterns=SEARCH_PATTERNS) -> list[LibLLVM]:
    """The libLLVM files on this machine, one per real file, newest version first."""
    seen: dict[str, LibLLVM] = {}
    for pat in patterns:
        for f in sorted(glob.glob(pat)):
            p = Path(f)
            try:
                if not p.is_file():
                    continue
                real = os.path.realpath(p)
            except OSError:
                continue
            major = library_version(p) or library_version(real)
            if real not in seen or (seen[real].major is None and major is not None):
                seen[real] = LibLLVM(p, major)
    return sorted(seen.values(), key=lambda c: (-(c.major or 0), str(c.path)))


def _drjit_version() -> str:
    try:
        from importlib.metadata import version

        return version("drjit")
    except Exception:  # noqa: BLE001 - not installed: the probe will say so
        return "?"


def _cache_file() -> Path:
    from rigsim.fileio import cache_dir

    return cache_dir() / "llvm-probe.json"


def _cache_key(path: str | None) -> str | None:
    if path is None:
        return None
    try:
        st = os.stat(path)
    except OSError:
        return None
    return f"{os.path.realpath(path)}|{st.st_size}|{int(st.st_mtime)}|drjit {_drjit_version()}|{sys.executable}"


def _read_cache() -> dict:
    try:
        data = json.loads(_cache_file().read_text())
        return data if isinstance(data, dict) else {}
    except (OSError, ValueError):
        return {}


def _write_cache(key: str, result: Probe) -> None:
    from rigsim.fileio import atomic_write_text

    data = _read_cache()
    data[key] = dataclasses.asdict(result)
    try:
        atomic_write_text(_cache_file(), json.dumps(data, indent=1))
    except OSError:
        pass  # a read-only home: probe again next time


def probe(path: str | Path | None, *, timeout: float = 120.0, use_cache: bool = True) -> Probe:
    """Load libLLVM ``path`` in a child process and compile a kernel that uses float min/max.

    ``path`` None probes the library Dr.Jit picks itself.  A library that aborts the child
    (LLVM 15: "Cannot select ... fminimum") gives ``ok=False`` with LLVM's first error line.
    """
    path = None if path is None else str(path)
    key = _cache_key(path)
    if use_cache and key:
        hit = _read_cache().get(key)
        if isinstance(hit, dict):
            try:
                return Probe(**hit)
            except TypeError:
                pass
    env = {k: v for k, v in os.environ.items() if k != "DRJIT_LIBLLVM_PATH"}
    if path is not None:
        env["DRJIT_LIBLLVM_PATH"] = path
    import random

    x = 1.0 + random.random()  # a fresh literal: the kernel is compiled, not taken from a cache
    with tempfile.TemporaryDirectory(prefix="rigsim-llvm-probe-") as home:
        env["HOME"] = home  # and Dr.Jit's kernel cache (~/.drjit) is an empty one
        try:
            r = subprocess.run([sys.executable, "-c", _PROBE % (x, x, x)], capture_output=True, text=True,
                               timeout=timeout, env=env)
        except subprocess.TimeoutExpired:
            return Probe(path, False, None, f"the probe took longer than {timeout:g} s")
        except OSError as exc:
            return Probe(path, False, None, f"cannot run the probe: {exc}")
    out = r.stdout
    m = re.search(r"RIGSIM-LLVM-VERSION (\S+)", out)
    version = m.group(1) if m else None
    if "RIGSIM-LLVM-MISSING" in out:
        detail = out.split("RIGSIM-LLVM-MISSING", 1)[1].strip()
        result = Probe(path, False, version, detail[:300], missing=True)
    elif "RIGSIM-LLVM-ERROR" in out:
        result = Probe(path, False, version, out.split("RIGSIM-LLVM-ERROR", 1)[1].strip()[:300])
    elif "RIGSIM-LLVM-OK" in out and r.returncode == 0:
        result = Probe(path, True, version, "compiles float min/max")
    else:
        err = [ln.strip() for ln in r.stderr.splitlines() if ln.strip()]
        llvm = next((ln for ln in err if ln.startswith("LLVM ERROR")), None)
        if llvm and "fminimum" in r.stderr and "fminimum" not in llvm:
            llvm += " ... fminimum"
        what = llvm or (err[-1] if err else f"the probe ended with status {r.returncode}")
        if llvm:
            what = _clean(what)
        result = Probe(path, False, version, what[:300])
    if key:
        _write_cache(key, result)
    return result


def _clean(text: str) -> str:
    """LLVM's message without its node addresses: ``Cannot select: f32 = fminimum``."""
    return re.sub(r"\s+", " ", re.sub(r"0x[0-9a-f]+:?,?", "", text)).strip(" ,")


def _problem(p: Probe, alternatives: list[Probe]) -> EnvironmentProblem:
    alt = next((a for a in alternatives if a.ok), None)
    hint = (f"unset DRJIT_LIBLLVM_PATH or set it to {alt.path} (libLLVM {alt.version}, found on this machine)"
            if alt else INSTALL_HINT)
    return EnvironmentProblem(f"{p.describe()} cannot compile Dr.Jit {_drjit_version()}'s kernels "
                              f"({_clean(p.detail)}); {hint}")


def ensure_usable_llvm(*, patterns=SEARCH_PATTERNS, probe_fn=probe, loaded_ok: bool = False) -> Probe | None:
    """Make Dr.Jit use a libLLVM that works (sets ``DRJIT_LIBLLVM_PATH``), before it is imported.

    Returns the probe of the library chosen, or None when there is nothing to check (the check
    is off, Dr.Jit is imported already and not ``loaded_ok``) or no libLLVM exists at all (rigsim
    then falls back to Mitsuba's scalar variant, as before).  ``patterns`` and ``probe_fn`` are
    where to look and how to try a library (tests give their own).

    Raises
    ------
    EnvironmentProblem
        ``DRJIT_LIBLLVM_PATH`` names a library that does not work, or every libLLVM found is
        one that does not work: one line saying what to install.
    """
    if os.environ.get("RIGSIM_LLVM_CHECK", "1").strip().lower() in ("0", "no", "false", "off"):
        return None
    if "drjit" in sys.modules and not loaded_ok:  # too late to choose; variant.py checks the version it got
        return None
    user = os.environ.get("DRJIT_LIBLLVM_PATH")
    if user:
        if not os.path.isfile(user):
            found = [c for c in candidate_libraries(patterns) if (c.major or 0) >= MIN_LLVM_MAJOR]
            hint = (f"unset it (libLLVM {found[0].major} was found at {found[0].path})" if found else INSTALL_HINT)
            raise EnvironmentProblem(f"DRJIT_LIBLLVM_PATH={user}: no such file; {hint}")
        p = probe_fn(user)
        if p.ok:
            return p
        others = [probe_fn(c.path) for c in candidate_libraries(patterns)
                  if os.path.realpath(c.path) != os.path.realpath(user) and (c.major or 99) >= MIN_LLVM_MAJOR][:2]
        raise _problem(p, others)
    tried = []
    for c in candidate_libraries(patterns):
        if c.major is not None and c.major < 15:
            continue  # Dr.Jit refuses these itself
        p = probe_fn(c.path)
        tried.append(p)
        if p.ok:
            os.environ["DRJIT_LIBLLVM_PATH"] = str(c.path)
            return p
    p = probe_fn(None)  # wherever Dr.Jit finds one (LD_LIBRARY_PATH, ...)
    if p.ok:
        return p
    broken = [t for t in tried + [p] if not t.missing]
    if broken:
        raise _problem(broken[0], [])
    return None


# ============================================================================ off-screen OpenGL (EGL / OSMesa)

#: What the rig designer's server-drawn 3-D view needs.
GL_INSTALL_HINT = ("install EGL and Mesa (Debian/Ubuntu: `apt install libegl1 libegl-mesa0 libgl1-mesa-dri`; or "
                   "`bash tools/setup.sh install`), or start with --view client (the browser draws the 3-D view)")

_GL_PROBE = r"""
import pyvista as pv
pv.OFF_SCREEN = True
p = pv.Plotter(off_screen=True, window_size=(32, 24))
p.add_mesh(pv.Sphere())
img = p.screenshot(return_img=True)
p.close()
print("RIGSIM-GL-OK", img.shape, flush=True)
"""


def check_offscreen_gl(*, timeout: float = 120.0) -> None:
    """Draw a sphere off screen with PyVista in a child process; one line saying what to install if
    that fails (VTK crashes the process with a segmentation fault when EGL has no usable device).

    ``RIGSIM_GL_CHECK=0`` skips the check.

    Raises
    ------
    EnvironmentProblem
        Off-screen OpenGL does not work on this machine.
    """
    if os.environ.get("RIGSIM_GL_CHECK", "1").strip().lower() in ("0", "no", "false", "off"):
        return
    try:
        r = subprocess.run([sys.executable, "-c", _GL_PROBE], capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise EnvironmentProblem(f"off-screen OpenGL did not answer within {timeout:g} s; {GL_INSTALL_HINT}") from None
    if r.returncode == 0 and "RIGSIM-GL-OK" in r.stdout:
        return
    text = r.stderr + r.stdout
    reasons = []
    for needle, what in (("Failed to initialize OpenGL", "OpenGL could not be initialised"),
                         ("Could not initialize a device", "EGL found no device"),
                         ("libEGL", "libEGL is missing"), ("libOSMesa not found", "no OSMesa either"),
                         ("No module named", "PyVista/VTK is not installed")):
        if needle in text and what not in reasons:
            reasons.append(what)
    if r.returncode < 0:
        import signal as _signal

        try:
            name = _signal.Signals(-r.returncode).name
        except ValueError:
            name = f"signal {-r.returncode}"
        reasons.append(f"VTK crashed ({name})")
    elif not reasons:
        last = [ln for ln in text.splitlines() if ln.strip()]
        reasons.append(" ".join(last[-1].split())[:200] if last else f"exit status {r.returncode}")
    raise EnvironmentProblem("the rig designer's 3-D view needs off-screen OpenGL, which does not work here ("
                             + "; ".join(reasons) + f"); {GL_INSTALL_HINT}")
