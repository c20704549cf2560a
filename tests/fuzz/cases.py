"""Generated input for everything a user writes or hands rigsim — rig, water, sensor, study and
dataset TOML files, command lines for every command, render folders — and the invariants it
must meet.

Used by ``tests/fuzz/test_*.py`` (a fixed seed, a few dozen cases each: CI) and by
``tools/soak.py`` (≥ 10 000 cases, counts by outcome).  Each case ends in one outcome:

``ok``
    accepted; the result was checked (images and tables finite, radiance ≥ 0).
``refused``
    a :class:`~rigsim.errors.RigsimError` (or ``error: ...`` from the command line) of one
    line that names the file (for files) — what a user should see for bad input.
``usage error``
    the command line's usage message (``Usage: ...`` / ``Error: ...``), exit status 2.

and the bugs the soak counts (a case never passes with one of them):

``traceback``
    an exception that is not a RigsimError, a Python traceback printed or logged, or the
    command line's "internal error" line;
``bad message``
    a refusal of more than one line, or one that does not name the file it is about;
``nan``
    an accepted input whose image or table holds NaN/inf or negative radiance;
``hang``
    the case took longer than its time limit;
``memory``
    a MemoryError, or the process grew by more than :data:`MEMORY_LIMIT_BYTES`;
``wrong exit``
    a command-line exit status that fits none of the above.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime
import functools
import io
import json
import logging
import math
import os
import re
import shutil
import signal
import sys
import tempfile
import threading
import time
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import strategies as st

ROOT = Path(__file__).resolve().parents[2]

OK, REFUSED, USAGE = "ok", "refused", "usage error"
TRACEBACK, BAD_MESSAGE, NAN, HANG, MEMORY, WRONG_EXIT = ("traceback", "bad message", "nan", "hang", "memory",
                                                         "wrong exit")
#: The process running the case died (a segfault, an abort, the kernel's OOM killer): only the
#: soak sees it, since it runs cases in a worker process (``tools/soak.py``).
CRASH = "crash"
GOOD = (OK, REFUSED, USAGE)
BUGS = (TRACEBACK, BAD_MESSAGE, NAN, HANG, MEMORY, WRONG_EXIT, CRASH)
#: Growth of the resident memory during one case that counts as a blow-up.
MEMORY_LIMIT_BYTES = 3 << 30
#: Wavelengths of the tiny renders that check accepted input (nm).
TINY_BANDS = (450.0, 550.0, 650.0)


@dataclasses.dataclass
class Result:
    """What one case did."""

    kind: str
    outcome: str
    detail: str = ""
    seconds: float = 0.0

    @property
    def is_bug(self) -> bool:
        return self.outcome in BUGS


# ============================================================================ a small TOML writer

_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(k: str) -> str:
    return k if _BARE.match(k) else _string(k)


def _string(s: str) -> str:
    out = ['"']
    for ch in s:
        o = ord(ch)
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif o < 0x20 or o == 0x7F:
            out.append(f"\\u{o:04X}")
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, (datetime.datetime, datetime.date, datetime.time)):
        return v.isoformat()
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_key(str(k))} = {_value(x)}" for k, x in v.items()) + "}"
    return _string(str(v))


def toml_dumps(doc: dict) -> str:
    """TOML text of ``doc`` (tables as ``[a.b]``, lists of tables as ``[[a]]``, NaN as ``nan``)."""
    lines: list[str] = []

    def table(d: dict, prefix: list[str]):
        subs = []
        for k, v in d.items():
            if isinstance(v, dict) and v:
                subs.append((k, v, False))
            elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
                subs.append((k, v, True))
            else:
                lines.append(f"{_key(str(k))} = {_value(v)}")
        for k, v, many in subs:
            name = ".".join(_key(str(p)) for p in [*prefix, k])
            if many:
                for item in v:
                    lines.append(f"\n[[{name}]]")
                    for ik, iv in item.items():
                        lines.append(f"{_key(str(ik))} = {_value(iv)}")
            else:
                lines.append(f"\n[{name}]")
                table(v, [*prefix, k])

    table(doc, [])
    return "\n".join(lines) + "\n"


# ============================================================================ base documents

KINDS = ("rig", "water", "sensor", "study", "dataset")


def _absolutize(node: Any, base: Path) -> Any:
    """String values naming an existing file relative to ``base`` (or the repository) made absolute."""
    if isinstance(node, dict):
        return {k: _absolutize(v, base) for k, v in node.items()}
    if isinstance(node, list):
        return [_absolutize(v, base) for v in node]
    if isinstance(node, str) and ("/" in node or node.endswith((".toml", ".csv", ".obj", ".ply"))):
        for root in (base, ROOT, ROOT / "data"):
            p = (root / node)
            if p.is_file():
                return str(p.resolve())
    return node


def _doc(path: Path) -> dict:
    return _absolutize(tomllib.loads(path.read_text()), path.parent)


@functools.cache
def base_documents() -> dict[str, tuple[tuple[str, dict], ...]]:
    """Valid documents of each kind: the shipped files and a few written here."""
    rigs = tuple((p.name, _doc(p)) for p in sorted((ROOT / "rigs").glob("*.toml")))
    sensors = tuple((p.name, _doc(p)) for p in sorted((ROOT / "sensors").glob("*.toml")))
    waters = (
        ("constituents", {"water": {"name": "bay", "chl_mg_per_m3": 1.0, "cdom_a440_per_m": 0.1,
                                    "small_particles_ppm": 0.1, "large_particles_ppm": 0.3}}),
        ("preset-override", {"water": {"preset": "coastal", "chl_mg_per_m3": 2.0, "detritus_exponent": 0.724,
                                       "phytoplankton": True, "pure_water": "pope-fry-1997"}}),
        ("iops", {"water": {"a_per_m": 0.2, "b_per_m": 0.8, "phase": "hg:0.9"}}),
        ("iops-posed", {"water": {"a_per_m": 0.1, "b_per_m": 0.3, "phase": "ff:0.0183", "wavelength_nm": 532}}),
        ("original-names", {"water": {"chlorophyllConc": 0.5, "domConc": 0.05, "smallPartConc": 0.0,
                                      "largePartConc": 0.1}}),
        ("marine-snow", {"water": {"preset": "coastal", "particles": {"level": "coastal", "albedo": 0.1}}}),
        ("marine-snow-numbers", {"water": {"a_per_m": 0.1, "b_per_m": 0.3, "particles": {
            "number_per_m3": 5000.0, "d_min_mm": 0.3, "d_max_mm": 4.0, "size_slope": 3.5, "albedo": 0.05}}}),
    )
    studies = (("tiny-study.toml", _doc(ROOT / "tests" / "data" / "tiny-study.toml")),
               ("demo.toml", _doc(ROOT / "studies" / "demo.toml")))
    datasets = (("tiny-dataset.toml", _doc(ROOT / "tests" / "data" / "tiny-dataset.toml")),
                ("underwater-training.toml", _doc(ROOT / "datasets" / "underwater-training.toml")),
                ("seabed.toml", _doc(ROOT / "datasets" / "seabed.toml")))
    return {"rig": rigs, "water": waters, "sensor": sensors, "study": studies, "dataset": datasets}


# ============================================================================ strategies: values and mutations

SPECIAL_NUMBERS = [0, -0.0, -1, 1, 2, -1e-9, 1e-320, 1e308, -1e308, 2**63 - 1, -(2**63), 10**6, 10**9, 0.5, 90, 180,
                   360, 1000, 1e15, float("nan"), float("inf"), float("-inf")]
SPECIAL_STRINGS = ["", " ", "x", "nan", "inf", "1e999", "true", "0", "-1", "../../etc/passwd", "/etc/passwd", "/dev/zero",
                   "/", ".", "C:\\x", "💧水", "\u202eRTL", "é", "\t", "coastal", "clear", "colorchecker", "dome",
                   "flat", "strobe", "video", "hg:2", "hg:nan", "ff:-1", "blackbody:-5", "blackbody:1e9",
                   "400:700:0", "400:300:10", "400:700:1e-9", "RGGB", "XXXX", "sony_ilce-7rm2", "a" * 5000]


def numbers() -> st.SearchStrategy:
    return st.one_of(st.sampled_from(SPECIAL_NUMBERS), st.floats(allow_nan=True, allow_infinity=True),
                     st.integers(-(2**63), 2**63 - 1), st.integers(-5, 5))


def weird_values() -> st.SearchStrategy:
    """Values a field should refuse (or, sometimes, accept)."""
    scalars = st.one_of(numbers(), st.sampled_from(SPECIAL_STRINGS), st.text(max_size=12), st.booleans(),
                        st.just(datetime.datetime(1979, 5, 27, 7, 32)), st.just(datetime.date(2024, 1, 1)))
    return st.one_of(
        scalars, scalars, scalars,
        st.lists(numbers(), max_size=5),
        st.lists(scalars, max_size=4),
        st.just([]), st.just({}), st.just({"x": 1}),
        st.just(list(range(20000))),
        st.just("a" * 200_000),
        st.recursive(st.just(0), lambda c: st.lists(c, min_size=1, max_size=1), max_leaves=60),
    )


def _paths(node: Any, prefix: tuple = ()) -> list[tuple]:
    out = []
    if isinstance(node, dict):
        for k, v in node.items():
            out.append(prefix + (k,))
            out.extend(_paths(v, prefix + (k,)))
    elif isinstance(node, list) and len(node) <= 50:
        for i, v in enumerate(node):
            out.append(prefix + (i,))
            out.extend(_paths(v, prefix + (i,)))
    return out


def _get(node, path):
    for p in path:
        node = node[p]
    return node


def _misspell(key: str, how: int, pos: int) -> str:
    if not key:
        return "x"
    i = pos % len(key)
    ops = [key[:i] + key[i + 1:], key[:i] + key[i] + key[i:], key[:i] + key[i + 1:i + 2] + key[i:i + 1] + key[i + 2:],
           key.upper(), key + "s", key.replace("_", "-"), key.replace("_", ""), key[:i] + "x" + key[i + 1:],
           " " + key, key + " "]
    new = ops[how % len(ops)]
    return new if new != key else key + "x"


@st.composite
def mutated_document(draw, kind: str) -> tuple[dict, list[str]]:
    """A base document of ``kind`` with 0–3 mutations (the list says which)."""
    import copy

    name, base = draw(st.sampled_from(base_documents()[kind]))
    doc = copy.deepcopy(base)
    ops = [f"base {name}"]
    for _ in range(draw(st.integers(0, 3))):
        paths = _paths(doc)
        op = draw(st.sampled_from(["set", "set", "set", "scale", "scale", "delete", "rename", "add", "retype"]))
        if not paths:
            op = "add"
        if op == "add":
            tables = [()] + [p for p in paths if isinstance(_get(doc, p), dict)]
            where = draw(st.sampled_from(tables))
            key = draw(st.one_of(st.sampled_from(["colour", "nmae", "extra", "spp ", "Width", "ключ", "a.b", "seed"]),
                                 st.text(min_size=1, max_size=8)))
            _get(doc, where)[key] = draw(weird_values())
            ops.append(f"add {'.'.join(map(str, where + (key,)))}")
            continue
        path = draw(st.sampled_from(paths))
        parent, last = _get(doc, path[:-1]), path[-1]
        if op == "scale" and isinstance(parent[last], (int, float)) and not isinstance(parent[last], bool):
            # a plausible value far from the usual one: more documents get through to the renderer
            f = draw(st.sampled_from([0, 1e-9, 1e-3, 0.1, 0.5, 2, 10, 1e3, 1e6, 1e12, -1, -0.5]))
            parent[last] = type(parent[last])(parent[last] * f) if isinstance(parent[last], float) else \
                int(parent[last] * f) if abs(parent[last] * f) < 2**62 else parent[last] * f
        elif op in ("set", "scale"):
            parent[last] = draw(weird_values())
        elif op == "retype":
            parent[last] = draw(st.sampled_from([{}, [], "", 0, [{}], {"a": {"b": 1}}, True]))
        elif op == "delete":
            del parent[last]
        elif op == "rename" and isinstance(parent, dict):
            new = _misspell(str(last), draw(st.integers(0, 20)), draw(st.integers(0, 50)))
            parent[new] = parent.pop(last)
        ops.append(f"{op} {'.'.join(map(str, path))}")
    return doc, ops


@st.composite
def document_bytes(draw, kind: str) -> tuple[bytes, list[str]]:
    """The bytes of a file of ``kind``: a (mutated) document, sometimes damaged as text or bytes."""
    doc, ops = draw(mutated_document(kind))
    text = toml_dumps(doc)
    data = text.encode("utf-8")
    damage = draw(st.sampled_from(["none"] * 8 + ["truncate", "insert", "binary", "empty", "comments", "bom",
                                                  "latin1", "utf16", "crlf", "duplicate", "deep", "huge", "nul",
                                                  "garbage-text"]))
    if damage == "truncate" and data:
        data = data[:draw(st.integers(0, len(data) - 1))]
    elif damage == "insert":
        pos = draw(st.integers(0, len(data)))
        data = data[:pos] + draw(st.binary(min_size=1, max_size=8)) + data[pos:]
    elif damage == "binary":
        data = draw(st.binary(max_size=300))
    elif damage == "empty":
        data = b""
    elif damage == "comments":
        data = b"# nothing but a comment\n\n   \n"
    elif damage == "bom":
        data = b"\xef\xbb\xbf" + data
    elif damage == "latin1":
        data = (text + '\n# caf\u00e9 \u00e9t\u00e9\n').encode("latin-1", "replace")
    elif damage == "utf16":
        data = text.encode("utf-16")
    elif damage == "crlf":
        data = text.replace("\n", "\r\n").encode()
    elif damage == "duplicate":
        lines = text.splitlines()
        heads = [ln for ln in lines if ln.startswith("[")]
        data = (text + "\n" + (heads[0] if heads else "[x]") + "\n[x]\n").encode()
    elif damage == "deep":
        n = draw(st.sampled_from([100, 1000, 5000]))
        data = (text + "\ndeep = " + "[" * n + "]" * n + "\n").encode()
    elif damage == "huge":
        data = data + b"# " + b"x" * 100 + b"\n" * draw(st.sampled_from([1000, 200_000]))
    elif damage == "nul":
        data = data + b"\x00"
    elif damage == "garbage-text":
        data = draw(st.text(max_size=200)).encode("utf-8", "replace")
    if damage != "none":
        ops.append(f"damage {damage}")
    return data, ops


@dataclasses.dataclass
class ConfigCase:
    kind: str
    data: bytes
    ops: list[str]

    def __repr__(self) -> str:  # hypothesis prints this for a failing example
        return f"ConfigCase({self.kind!r}, ops={self.ops}, {len(self.data)} bytes: {self.data[:300]!r})"


@st.composite
def config_cases(draw, kinds: tuple[str, ...] = KINDS) -> ConfigCase:
    kind = draw(st.sampled_from(kinds))
    data, ops = draw(document_bytes(kind))
    return ConfigCase(kind, data, ops)


# ============================================================================ the workspace

class Workspace:
    """A temporary folder with what cases need: a tiny render folder, a raw file, a study folder."""

    def __init__(self, root: str | Path | None = None):
        self._tmp = None
        if root is None:
            self._tmp = tempfile.TemporaryDirectory(prefix="rigsim-fuzz-")
            root = self._tmp.name
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        self._n = 0
        self.binary = self.root / "binary.toml"
        self.binary.write_bytes(bytes(range(256)) * 4)
        self.folder = self.root / "a-folder.toml"
        self.folder.mkdir(exist_ok=True)
        self.empty = self.root / "empty.toml"
        self.empty.write_bytes(b"")

    def close(self):
        if self._tmp is not None:
            self._tmp.cleanup()

    def case_dir(self) -> Path:
        self._n += 1
        d = self.root / "cases" / f"{self._n:06d}"
        d.mkdir(parents=True, exist_ok=True)
        return d

    @functools.cached_property
    def render_dir(self) -> Path:
        """A render folder of the fast engine (6×4 pixels, three bands)."""
        d = self.root / "render"
        code, out, err = cli(["render", str(ROOT / "rigs" / "twin-strobes-45-wide.toml"), "--water", "coastal",
                              "--distance", "1.5", "--size", "12x8", "--engine", "preview", "--wavelengths",
                              "450:650:100", "--out", str(d)])
        assert code == 0, err
        return d

    @functools.cached_property
    def raw_file(self) -> Path:
        """A DNG written by ``rigsim capture`` of :attr:`render_dir` (64×96 pixels)."""
        d = self.root / "capture"
        code, out, err = cli(["capture", str(self.render_dir), "--sensor", "sony_ilce-7rm2", "--auto-exposure",
                              "--shape", "64,96", "--out", str(d)])  # LibRaw refuses a very small mosaic
        assert code == 0, err
        return d / "raw.dng"

    @functools.cached_property
    def study_dir(self) -> Path:
        """A finished tiny study (two cases of the fast engine)."""
        d = self.root / "study"
        spec = self.root / "two-case-study.toml"
        doc = _doc(ROOT / "tests" / "data" / "tiny-study.toml")
        doc["sweep"]["rigs"] = doc["sweep"]["rigs"][:1]
        doc["sweep"]["waters"] = doc["sweep"]["waters"][:1]
        spec.write_text(toml_dumps(doc))
        code, out, err = cli(["study", str(spec), "--out", str(d), "--serial"])
        assert code == 0, err
        self.study_file = spec
        return d

    @functools.cached_property
    def spectral_image(self):
        from rigsim.spectral_image import SpectralImage

        return SpectralImage.load(self.render_dir)


# ============================================================================ running a case

class CaseTimeout(BaseException):
    """Raised in the main thread when a case runs past its time limit."""


@contextlib.contextmanager
def time_limit(seconds: float | None):
    if not seconds or threading.current_thread() is not threading.main_thread():
        yield
        return

    def fire(signum, frame):
        raise CaseTimeout(f"took longer than {seconds:g} s")

    old = signal.signal(signal.SIGALRM, fire)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def _rss() -> int:
    try:
        return int(Path("/proc/self/statm").read_text().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


class _LogCatcher(logging.Handler):
    """Records log records that carry a traceback (``log.exception``): a user would see it."""

    def __init__(self):
        super().__init__(level=logging.DEBUG)
        self.tracebacks: list[str] = []

    def emit(self, record):
        if record.exc_info and record.exc_info[0] is not None and not issubclass(record.exc_info[0], CaseTimeout):
            self.tracebacks.append(f"{record.name}: {record.getMessage()} ({record.exc_info[0].__name__})")


def guarded(kind: str, fn, *, timeout: float | None = 60.0) -> Result:
    """Run ``fn() -> (outcome, detail)`` under a time limit, catching what escapes as bugs."""
    from rigsim.errors import RigsimError

    catcher = _LogCatcher()
    logging.getLogger().addHandler(catcher)
    rss0 = _rss()
    t0 = time.perf_counter()
    try:
        with time_limit(timeout), np.errstate(all="ignore"):
            outcome, detail = fn()
    except CaseTimeout as exc:
        outcome, detail = HANG, str(exc)
    except MemoryError as exc:
        outcome, detail = MEMORY, f"MemoryError: {exc}"
    except RigsimError as exc:  # reached here only if a check below let it through
        outcome, detail = _refusal(str(exc), None)
    except Exception as exc:  # noqa: BLE001
        import traceback

        tb = traceback.extract_tb(exc.__traceback__)
        where = f"{Path(tb[-1].filename).name}:{tb[-1].lineno}" if tb else "?"
        outcome, detail = TRACEBACK, f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]} at {where}"
    finally:
        logging.getLogger().removeHandler(catcher)
    grew = _rss() - rss0
    if outcome in GOOD and grew > MEMORY_LIMIT_BYTES:
        outcome, detail = MEMORY, f"resident memory grew by {grew / 2**30:.1f} GiB"
    if outcome in GOOD and catcher.tracebacks:
        outcome, detail = TRACEBACK, "logged a traceback: " + "; ".join(catcher.tracebacks[:3])
    return Result(kind, outcome, detail, time.perf_counter() - t0)


def _refusal(message: str, file: Path | None) -> tuple[str, str]:
    text = str(message)
    if "\n" in text.strip():
        return BAD_MESSAGE, f"more than one line: {text[:300]!r}"
    if file is not None and str(file) not in text and file.name not in text:
        return BAD_MESSAGE, f"does not name {file.name}: {text[:300]!r}"
    return REFUSED, text[:300]


# ---------------------------------------------------------------------------- checks of accepted input

def check_image(si, what: str = "image") -> tuple[str, str]:
    """``ok`` if every spectral array of the SpectralImage is finite and ≥ 0, else ``nan``."""
    arrays = {"radiance": si.radiance, **{k: v for k, v in si.layers.items() if k not in ("range_m", "object_id")}}
    for name, a in arrays.items():
        a = np.asarray(a)
        if not np.all(np.isfinite(a)):
            return NAN, f"{what}: {name} has {int(np.sum(~np.isfinite(a)))} non-finite values"
        if np.any(a < 0):
            return NAN, f"{what}: {name} has negative values (min {a.min():g})"
    return OK, f"{what} {si.radiance.shape} finite"


def _tiny_preview(scene):
    from rigsim.preview import render_preview

    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return render_preview(scene, width=6, height=4, wavelengths_nm=list(TINY_BANDS), layers=("range_m", "clear"))


def _after_rig(rig, ws):
    from rigsim.scene.build import build_scene

    return check_image(_tiny_preview(build_scene(rig, "coastal", "colorchecker", 1.5)), "preview of the rig")


def _after_water(w, ws):
    from rigsim.config.rig import load_rig
    from rigsim.scene.build import build_scene

    wl = np.asarray(getattr(w, "posed_wavelength_nm", None) or TINY_BANDS, float)
    w.check_range(wl)
    table = w.iop_table(wl)
    for k, v in table.items():
        v = np.asarray(v, float)
        if not np.all(np.isfinite(v)):
            return NAN, f"iop_table {k} not finite: {v}"
        if k in ("a_per_m", "b_per_m", "c_per_m", "bb_per_m") and np.any(v < 0):
            return NAN, f"iop_table {k} negative: {v}"
    if getattr(w, "posed_wavelength_nm", None) is not None:
        return OK, "posed water: IOP table finite"
    rig = load_rig(ROOT / "rigs" / "twin-strobes-45-wide.toml")
    return check_image(_tiny_preview(build_scene(rig, w, "colorchecker", 1.5)), "preview in the water")


def _after_sensor(sensor, ws):
    from rigsim.sensor import auto_exposure, capture
    from rigsim.sensor.optics import lens_for

    si = ws.spectral_image
    lens = lens_for(si)
    exposure = auto_exposure(si, sensor, lens=lens)
    cap = capture(si, sensor, exposure, seed=1)
    for name in ("electrons", "raw", "linear_rgb", "srgb"):
        a = getattr(cap, name, None)
        if a is not None and not np.all(np.isfinite(np.asarray(a, float))):
            return NAN, f"capture {name} not finite"
    return OK, f"capture {np.asarray(cap.raw).shape}"


def _after_study(spec, ws, d: Path):
    cases = spec.cases()
    r = spec.render
    if not (r.engine == "preview" and len(cases) <= 8 and r.width * r.height <= 32 * 24
            and len(r.wavelengths_nm) <= 8 and len(spec.sensors) <= 2):
        return OK, f"{len(cases)} cases (not run)"
    from rigsim.study import run_study

    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = run_study(spec, d / "study-out", serial=True, progress=False)
    text = (out / "results.csv").read_text()
    if re.search(r"(^|,)(nan|inf|-inf)(,|$)", text, re.M | re.I):
        return NAN, "results.csv holds nan/inf"
    return OK, f"ran {len(cases)} cases"


def _after_dataset(spec, ws):
    from rigsim.dataset.sample import build_sample_scene, draw_sample

    for i in range(2):
        rec = draw_sample(spec, i, 0)
        scene, _ = build_sample_scene(spec, rec)
        res = check_image(_tiny_preview(scene), f"preview of sample {i}")
        if res[0] != OK:
            return res
    return OK, "two samples drawn and previewed"


def loader(kind: str):
    if kind == "rig":
        from rigsim.config.rig import load_rig

        return load_rig
    if kind == "water":
        from rigsim.config.water import load_water

        return lambda p: load_water(str(p))
    if kind == "sensor":
        from rigsim.sensor.model import load_sensor_file

        return load_sensor_file
    if kind == "study":
        from rigsim.study import load_study

        return load_study
    from rigsim.dataset import load_dataset_spec

    return load_dataset_spec


def run_config_case(case: ConfigCase, ws: Workspace, *, timeout: float | None = 60.0) -> Result:
    """Write the file, read it with the loader of its kind, check what comes out."""
    from rigsim.errors import RigsimError

    d = ws.case_dir()
    path = d / f"fuzz-{case.kind}.toml"
    path.write_bytes(case.data)

    def go():
        try:
            obj = loader(case.kind)(path)
        except RigsimError as exc:
            return _refusal(str(exc), path)
        try:
            if case.kind == "rig":
                return _after_rig(obj, ws)
            if case.kind == "water":
                return _after_water(obj, ws)
            if case.kind == "sensor":
                return _after_sensor(obj, ws)
            if case.kind == "study":
                return _after_study(obj, ws, d)
            return _after_dataset(obj, ws)
        except RigsimError as exc:  # accepted by the loader, refused when used: one line still
            return _refusal(str(exc), None)

    try:
        return guarded(f"file:{case.kind}", go, timeout=timeout)
    finally:
        shutil.rmtree(d, ignore_errors=True)


# ============================================================================ command lines

def cli(argv: list[str], *, cwd: Path | None = None) -> tuple[int, str, str]:
    """Run ``rigsim argv`` in this process: (exit status, stdout, stderr)."""
    from rigsim.cli import run_command

    out, err = io.StringIO(), io.StringIO()
    old = os.getcwd()
    try:
        if cwd is not None:
            os.chdir(cwd)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = run_command([str(a) for a in argv])
            except SystemExit as exc:  # code that calls sys.exit itself
                code = exc.code if isinstance(exc.code, int) else 1
    finally:
        os.chdir(old)
    return code, out.getvalue(), err.getvalue()


def junk_values(ws_paths: dict[str, str]) -> st.SearchStrategy:
    fixed = ["", "-1", "0", "1", "nan", "inf", "-inf", "1e309", "-0", "abc", "1/0", "0/0", "1,2,3", ",", "💧",
             "x" * 5000, "--help", "-", "/", "/dev/null", "/dev/zero", "200000x200000", "16384x16384", "1x1", "0x0",
             "3x", "x3", "99999999999999999999", "400:700:0", "400:7e9:1e-9", "700:400:10", "300:2500:1", "hg:2",
             "../../../etc/passwd", "tcp://127.0.0.1:1", "0.0.0.0", "::1", "99999", "65536", "0.000001", "1e-300",
             "true", "none", "all", "shot,read", "bogus,shot", "cie:99", "cie:3", "black", "kd", "monte-carlo",
             "grayworld", "chart", "manual", "1,1", "1,1,1", "-1,1,1", "0,0,0,0", "5,1,1,5", "sensor", "4,4",
             "100000,100000", "client", "server", "coastal", "jerlov-II", "clear", "sony_ilce-7rm2", "colorchecker",
             "bottom", "white-disk", "sines", "pierson-moskowitz", "volpath", "1/125", "1/0.0", "\x1b[31m", "a\nb"]
    return st.one_of(st.sampled_from(fixed), st.sampled_from(sorted(ws_paths.values())), st.text(max_size=10),
                     st.integers(-10**12, 10**12).map(str), st.floats().map(repr), extreme_numbers())


def extreme_numbers() -> st.SearchStrategy:
    """Numbers as text that parse but ask for too much (or nothing): where limits are missed."""
    return st.sampled_from(["0", "-1", "-5", "1", "2", "3", "7", "64", "1000", "65535", "65536", "100000", "2147483648",
                            "4294967296", "1000000000000", "9223372036854775808", "1e6", "1e9", "1e12", "1e30",
                            "1e-300", "0.0001", "-0.0", "nan", "inf", "-inf"])


def _is_number(t: str) -> bool:
    try:
        float(t)
    except ValueError:
        return False
    return True


def command_skeletons(ws: Workspace | None = None) -> dict[str, list[str]]:
    """A valid, cheap command line per command (the cases mutate them; ``@…`` are filled in per case)."""
    rig = str(ROOT / "rigs" / "twin-strobes-45-wide.toml")
    return {
        "water show": ["water", "show", "coastal", "--wavelengths", "400:700:50", "--json"],
        "water show file": ["water", "show", "@WATERFILE", "--wavelengths", "450,550"],
        "water plot": ["water", "plot", "coastal", "clear", "--out", "@OUT/w.png"],
        "water list": ["water", "list"],
        "render": ["render", rig, "--water", "coastal", "--distance", "1.5", "--size", "6x4", "--engine", "preview",
                   "--wavelengths", "450:650:100", "--out", "@OUT/r"],
        "render mitsuba": ["render", rig, "--water", "coastal", "--distance", "1.5", "--size", "4x3", "--spp", "1",
                           "--wavelengths", "550", "--out", "@OUT/r"],
        "capture": ["capture", "@RENDER", "--sensor", "sony_ilce-7rm2", "--auto-exposure", "--out", "@OUT/c"],
        "capture manual": ["capture", "@RENDER", "--sensor", "action_cam_1-2.3in", "--shutter", "1/125", "--iso",
                           "200", "--wb", "manual", "--wb-gains", "2,1,1.5", "--noise", "shot,read", "--out",
                           "@OUT/c"],
        "develop": ["develop", "@RAW", "--out", "@OUT/d", "--wb", "grayworld"],
        "sample-raw": ["sample-raw", "sony-ilce-7rm3"],
        "ambient kd": ["ambient", "--water", "coastal", "--sun-zenith", "30", "--depths", "1,5", "--model", "kd",
                       "--json"],
        "ambient mc": ["ambient", "--water", "clear", "--sun-zenith", "30", "--depths", "1", "--photons", "2000",
                       "--wavelengths", "450,550", "--json"],
        "study": ["study", "@STUDYFILE", "--out", "@OUT/s", "--serial", "--no-report"],
        "report": ["report", "@STUDY"],
        "dataset": ["dataset", str(ROOT / "tests" / "data" / "tiny-dataset.toml"), "--n", "1", "--out", "@OUT/ds",
                    "--serial"],
        "app": ["app", "--port", "8765", "--host", "127.0.0.1", "--workdir", "@OUT"],
        "demo": ["demo", "--quick", "--serial", "--out", "@OUT/demo"],
        "optimise": ["optimise", rig, "--water", "coastal", "--distance", "1.5", "--quick", "--no-check", "--out",
                     "@OUT/o"],
        "root": ["--version"],
    }


#: How often each command is drawn (the expensive ones less often).
COMMAND_WEIGHTS = {"render mitsuba": 0, "dataset": 3, "study": 5, "demo": 2, "ambient mc": 5, "optimise": 2}


@dataclasses.dataclass
class CliCase:
    name: str
    argv: list[str]
    ops: list[str]

    def __repr__(self) -> str:
        return f"CliCase({self.name!r}, {self.argv!r}, ops={self.ops})"


@st.composite
def cli_cases(draw, names: tuple[str, ...] | None = None, weights: dict[str, int] | None = None) -> CliCase:
    ws_paths = {"@BINARY": "@BINARY", "@FOLDER": "@FOLDER", "@EMPTY": "@EMPTY", "@RENDER": "@RENDER",
                "@RAW": "@RAW", "@NOPE": "@NOPE", "@STUDY": "@STUDY"}
    skel = command_skeletons()
    weights = {**COMMAND_WEIGHTS, **(weights or {})}
    pool = [n for n in (names or tuple(skel)) for _ in range(weights.get(n, 5))]
    name = draw(st.sampled_from(pool))
    argv = list(skel[name])
    ops: list[str] = []
    if draw(st.integers(0, 30)) == 0:
        argv = draw(st.lists(st.one_of(junk_values(ws_paths), st.sampled_from([t for v in skel.values() for t in v])),
                             max_size=6))
        return CliCase(name, argv, ["random argv"])
    for _ in range(draw(st.integers(0, 3))):
        op = draw(st.sampled_from(["value", "value", "value", "number", "number", "number", "drop", "unknown",
                                   "insert", "dup", "help", "root", "eq", "parallel"]))
        opts = [i for i, t in enumerate(argv) if t.startswith("--") and i + 1 < len(argv)
                and not argv[i + 1].startswith("--")]
        nums = [i + 1 for i in opts if _is_number(argv[i + 1]) or "," in argv[i + 1] or ":" in argv[i + 1]
                or "x" in argv[i + 1]]
        if op == "number" and nums:
            i = draw(st.sampled_from(nums))
            v = argv[i]
            if "," in v or ":" in v or ("x" in v and not _is_number(v)):  # lists, ranges, sizes: one part
                sep = "," if "," in v else ":" if ":" in v else "x"
                parts = v.split(sep)
                parts[draw(st.integers(0, len(parts) - 1))] = draw(extreme_numbers())
                argv[i] = sep.join(parts)
            else:
                argv[i] = draw(extreme_numbers())
            ops.append(f"number {argv[i - 1]} {argv[i]}")
        elif op == "parallel" and "--serial" in argv:
            argv.remove("--serial")
            extra = draw(st.sampled_from([[], ["--workers", "1"], ["--workers", "0"], ["--workers", "-1"],
                                          ["--workers", "100000"], ["--scheduler", "bogus"],
                                          ["--scheduler", "tcp://127.0.0.1:9"], ["--scheduler", ""]]))
            argv += extra
            ops.append(f"parallel {extra}")
        elif op == "value" and argv:
            cands = [i + 1 for i in opts] + [i for i, t in enumerate(argv) if not t.startswith("-")]
            i = draw(st.sampled_from(cands)) if cands else 0
            argv[i] = draw(junk_values(ws_paths))
            ops.append(f"value {i}")
        elif op == "drop" and argv:
            i = draw(st.integers(0, len(argv) - 1))
            ops.append(f"drop {argv[i]!r}")
            del argv[i]
        elif op == "unknown":
            argv.insert(draw(st.integers(0, len(argv))), draw(st.sampled_from(["--bogus", "-x", "--size=", "--", "-",
                                                                                "--out=", "--spp=-1", "--json=1"])))
            ops.append("unknown option")
        elif op == "insert":
            argv.insert(draw(st.integers(0, len(argv))), draw(junk_values(ws_paths)))
            ops.append("insert token")
        elif op == "dup" and opts:
            i = draw(st.sampled_from(opts))
            argv += [argv[i], draw(junk_values(ws_paths))]
            ops.append(f"duplicate {argv[i]}")
        elif op == "help":
            argv.append("--help")
            ops.append("--help")
        elif op == "root":
            argv = [draw(st.sampled_from(["--log-level", "--log-level=debug", "--version", "--bogus"])),
                    *([draw(st.sampled_from(["debug", "info", "bogus", "", "ERROR"]))]
                      if draw(st.booleans()) else []), *argv]
            ops.append("root option")
        elif op == "eq" and opts:
            i = draw(st.sampled_from(opts))
            argv[i:i + 2] = [f"{argv[i]}={draw(junk_values(ws_paths))}"]
            ops.append("--opt=value")
    return CliCase(name, argv, ops)


def _materialize(argv: list[str], ws: Workspace, d: Path) -> list[str]:
    def sub(t: str) -> str:
        if "@OUT" in t:
            t = t.replace("@OUT", str(d))
        if "@WATERFILE" in t:
            w = d / "water.toml"
            w.write_text('[water]\nchl_mg_per_m3 = 1.0\ncdom_a440_per_m = 0.1\n')
            t = t.replace("@WATERFILE", str(w))
        if "@STUDYFILE" in t:
            _ = ws.study_dir
            t = t.replace("@STUDYFILE", str(ws.study_file))
        for key, val in (("@BINARY", lambda: ws.binary), ("@FOLDER", lambda: ws.folder), ("@EMPTY", lambda: ws.empty),
                         ("@RENDER", lambda: ws.render_dir), ("@RAW", lambda: ws.raw_file),
                         ("@NOPE", lambda: ws.root / "does-not-exist.toml"), ("@STUDY", lambda: ws.study_dir)):
            if key in t:
                t = t.replace(key, str(val()))
        return t

    return [sub(t) for t in argv]


#: Samples a fuzzed ``rigsim dataset`` makes at most (see :func:`offline_stubs`).
DATASET_CAP = 4


@contextlib.contextmanager
def offline_stubs():
    """Commands that would serve forever, download, or run for minutes do their checks only.

    ``rigsim app``: the server is not started (its options are checked as before serving);
    ``rigsim sample-raw``: nothing is downloaded; ``rigsim demo``: the study is not run;
    ``rigsim dataset --n N`` with a valid N above :data:`DATASET_CAP` makes the first
    :data:`DATASET_CAP` samples (65 535 samples take as long as asked for, with progress: long
    work by request, not a hang; the range check of N runs as before).
    """
    import rigsim.dataset as dataset
    import rigsim.sensor.samples as samples
    import rigsim.study as study
    import rigsim.ui.app as ui_app
    from rigsim.dataset.writer import MAX_SAMPLES
    from rigsim.errors import ConfigError

    saved = (ui_app.main, samples.fetch_sample_raw, study.run_study, dataset.run_dataset)
    real_run_dataset = dataset.run_dataset

    def capped_run_dataset(spec, n, out, **kw):
        if isinstance(n, int) and not isinstance(n, bool) and DATASET_CAP < n <= MAX_SAMPLES:
            n = DATASET_CAP
        return real_run_dataset(spec, n, out, **kw)

    def fake_main(**kw):
        check = getattr(ui_app, "check_options", None)
        if check is not None:
            check(**{k: kw[k] for k in ("host", "port", "workdir", "rig") if k in kw})

    def fake_fetch(name):
        if name not in samples.SAMPLE_RAWS:
            raise ConfigError(f"unknown sample {name!r}", field="name", allowed=", ".join(samples.SAMPLE_RAWS))
        return samples.cache_dir() / "samples" / samples.SAMPLE_RAWS[name].filename

    real_run_study = study.run_study

    def fake_run_study(spec, out, **kw):
        if spec.name == "demo":
            raise _Stop()
        return real_run_study(spec, out, **kw)

    ui_app.main, samples.fetch_sample_raw, study.run_study, dataset.run_dataset = (
        fake_main, fake_fetch, fake_run_study, capped_run_dataset)
    try:
        yield
    finally:
        ui_app.main, samples.fetch_sample_raw, study.run_study, dataset.run_dataset = saved


class _Stop(Exception):
    """The demo stub stops here (its options were accepted)."""


def _stderr_lines(err: str) -> list[str]:
    return [ln for ln in err.splitlines() if ln.strip() and not ln.startswith("warning:")
            and not re.match(r"^\s*(study|dataset|render)\b.*(━|ETA)", ln)]


def _strip_debug_traces(err: str) -> str:
    """``--log-level debug`` prints traces on purpose: keep what follows them."""
    out, skipping = [], False
    for ln in err.splitlines():
        if ln.startswith(("Traceback (most recent call last)", "During handling", "The above exception")):
            skipping = True  # a trace, or the line that chains the next one to it
            continue
        if skipping and (ln.startswith(("  ", "During handling", "The above exception")) or not ln.strip()):
            continue
        if skipping:  # the exception line ends the trace
            skipping = False
            if re.match(r"^[\w.]+(Error|Exception|Interrupt|Exit|Abort|Failures|Problem|InUse|Interrupted)\b", ln):
                continue
        out.append(ln)
    return "\n".join(out) + ("\n" if out else "")


def classify_cli(code: int, out: str, err: str, *, debug: bool = False) -> tuple[str, str]:
    """The outcome of one command line from its exit status and output."""
    if debug:
        err = _strip_debug_traces(err)
    both = out + err
    if "_Stop" in err:  # the demo stub: options accepted
        return OK, "demo options accepted (study not run)"
    if "Traceback (most recent call last)" in both or "internal error in" in err:
        line = next((ln for ln in err.splitlines() if "internal error" in ln or "Error" in ln), err[-300:])
        return TRACEBACK, line[:400]
    lines = _stderr_lines(err)
    if code == 0:
        return OK, (out.strip().splitlines() or [""])[-1][:200]
    if code == 2 and any(ln.startswith("Error:") for ln in lines) and not any(ln.startswith("error:") for ln in lines):
        return USAGE, next(ln for ln in lines if ln.startswith("Error:"))[:200]
    if code == 2 and "Usage:" in both and not any(ln.startswith("error:") for ln in lines):
        return USAGE, "help shown"
    if code in (1, 2, 3) and lines and lines[-1].startswith("error:"):
        errors = [ln for ln in lines if ln.startswith("error:")]
        if len(errors) != 1 or len(lines) != 1:
            return BAD_MESSAGE, f"{len(lines)} lines on stderr: {err[-400:]!r}"
        if "out of memory" in lines[-1]:
            return MEMORY, lines[-1][:300]
        return REFUSED, lines[-1][:300]
    return WRONG_EXIT, f"exit {code}: {err[-300:]!r}"


def _check_cli_outputs(case: CliCase, argv: list[str], d: Path) -> tuple[str, str] | None:
    """After exit 0: the outputs a command wrote are finite."""
    if case.name.startswith("render") and (d / "r" / "spectral.npz").is_file():
        with np.load(d / "r" / "spectral.npz") as z:
            for k in z.files:
                if k in ("layer_range_m", "layer_object_id"):
                    continue
                a = z[k]
                if np.issubdtype(a.dtype, np.number) and (not np.all(np.isfinite(a)) or np.any(a < 0)):
                    return NAN, f"render wrote non-finite or negative {k}"
    if case.name.startswith("capture") and (d / "c" / "linear.tiff").is_file():
        import tifffile

        a = tifffile.imread(d / "c" / "linear.tiff")
        if not np.all(np.isfinite(a)):
            return NAN, "capture wrote non-finite linear.tiff"
    return None


def run_cli_case(case: CliCase, ws: Workspace, *, timeout: float | None = 60.0) -> Result:
    d = ws.case_dir()

    def go():
        argv = _materialize(case.argv, ws, d)
        with offline_stubs():
            code, out, err = cli(argv, cwd=d)
        debug = any(a in ("--log-level=debug", "--log-level=DEBUG") for a in argv) or any(
            a == "--log-level" and b.lower() == "debug" for a, b in zip(argv, argv[1:]))
        outcome, detail = classify_cli(code, out, err, debug=debug)
        if outcome == OK:
            bad = _check_cli_outputs(case, argv, d)
            if bad:
                return bad
            if "--json" in argv and out.strip().startswith("{"):
                if re.search(r"\b(NaN|Infinity)\b", out):
                    return NAN, "JSON output holds NaN/Infinity"
        return outcome, detail

    try:
        return guarded(f"cli:{case.name}", go, timeout=timeout)
    finally:
        shutil.rmtree(d, ignore_errors=True)


# ============================================================================ render and study folders

@dataclasses.dataclass
class FolderCase:
    kind: str              # "render" (then `rigsim capture`) or "study" (then `rigsim report` / resume)
    target: str            # which file
    damage: str
    arg: int = 0
    payload: bytes = b""

    def __repr__(self) -> str:
        return f"FolderCase({self.kind!r}, {self.target!r}, {self.damage!r}, arg={self.arg}, {self.payload[:60]!r})"


@st.composite
def folder_cases(draw) -> FolderCase:
    kind = draw(st.sampled_from(["render", "render", "study"]))
    if kind == "render":
        target = draw(st.sampled_from(["spectral.npz", "spectral.npz", "meta.json", "scene.json"]))
        damages = ["delete", "truncate", "flip", "junk", "empty"]
        if target == "spectral.npz":
            damages += ["nan", "negative", "shape", "missing-array", "unknown-layer", "strings", "inf-wavelength",
                        "object"]
        else:
            damages += ["json-junk"]
    else:
        target = draw(st.sampled_from(["study.json", "results.csv", "result.json", "case-png"]))
        damages = ["delete", "truncate", "flip", "junk", "empty", "json-junk"]
    return FolderCase(kind, target, draw(st.sampled_from(damages)), draw(st.integers(0, 10**6)),
                      draw(st.binary(max_size=64)))


def _damage_file(p: Path, case: FolderCase) -> None:
    if case.damage == "delete":
        p.unlink(missing_ok=True)
        return
    data = p.read_bytes() if p.is_file() else b""
    if case.damage == "truncate":
        p.write_bytes(data[: case.arg % max(len(data), 1)])
    elif case.damage == "flip" and data:
        b = bytearray(data)
        for k in range(1 + case.arg % 8):
            i = (case.arg * (k + 7919)) % len(b)
            b[i] ^= 0xFF
        p.write_bytes(bytes(b))
    elif case.damage == "junk":
        p.write_bytes(case.payload)
    elif case.damage == "empty":
        p.write_bytes(b"")
    elif case.damage == "json-junk":
        p.write_text(["[]", "{}", "null", '{"scene": 5, "render": "x"}', '{"scene": {"camera": []}}', "1e999",
                      '{"render": {"engine": "nope"}}', '"text"', '{"a": NaN}'][case.arg % 9])


def _damage_npz(p: Path, case: FolderCase) -> None:
    with np.load(p) as z:
        arrays = {k: z[k] for k in z.files}
    r = arrays["radiance"].astype(np.float32)
    if case.damage == "nan":
        r.flat[case.arg % r.size] = np.nan
        arrays["radiance"] = r
    elif case.damage == "negative":
        r.flat[case.arg % r.size] = -1.0
        arrays["radiance"] = r
    elif case.damage == "shape":
        arrays["radiance"] = r[..., :1] if case.arg % 2 else r[0]
    elif case.damage == "missing-array":
        arrays.pop(["radiance", "wavelength_nm", "bandwidth_nm"][case.arg % 3])
    elif case.damage == "unknown-layer":
        arrays["layer_bogus"] = r
    elif case.damage == "strings":
        arrays["wavelength_nm"] = np.array(["a"] * arrays["wavelength_nm"].size)
    elif case.damage == "inf-wavelength":
        wl = arrays["wavelength_nm"].astype(float)
        wl[0] = np.inf
        arrays["wavelength_nm"] = wl
    elif case.damage == "object":
        arrays["layer_flash"] = np.array([{"x": 1}], dtype=object)
    np.savez(p, **arrays)


def run_folder_case(case: FolderCase, ws: Workspace, *, timeout: float | None = 60.0) -> Result:
    d = ws.case_dir()

    def go():
        if case.kind == "render":
            src = d / "render"
            shutil.copytree(ws.render_dir, src)
            p = src / case.target
            if case.damage in ("delete", "truncate", "flip", "junk", "empty", "json-junk"):
                _damage_file(p, case)
            else:
                _damage_npz(p, case)
            code, out, err = cli(["capture", str(src), "--sensor", "sony_ilce-7rm2", "--auto-exposure", "--out",
                                  str(d / "c")], cwd=d)
            outcome, detail = classify_cli(code, out, err)
            if outcome == OK:
                import tifffile

                if not np.all(np.isfinite(tifffile.imread(d / "c" / "linear.tiff"))):
                    return NAN, "capture of a damaged folder wrote non-finite values"
            return outcome, f"{case.target} {case.damage}: {detail}"
        src = d / "study"
        shutil.copytree(ws.study_dir, src)
        if case.target == "result.json":
            p = sorted(src.glob("cases/*/result.json"))[case.arg % 2]
        elif case.target == "case-png":
            p = sorted(src.glob("cases/*/*.png"))[case.arg % 2]
        else:
            p = src / case.target
        _damage_file(p, case)
        code, out, err = cli(["report", str(src)], cwd=d)
        first = classify_cli(code, out, err)
        if first[0] in BUGS:
            return first[0], f"report after {case.target} {case.damage}: {first[1]}"
        code, out, err = cli(["study", str(ws.study_file), "--out", str(src), "--serial", "--no-report"], cwd=d)
        second = classify_cli(code, out, err)
        return second[0], f"resume after {case.target} {case.damage}: {second[1]}"

    try:
        return guarded(f"folder:{case.kind}", go, timeout=timeout)
    finally:
        shutil.rmtree(d, ignore_errors=True)


# ============================================================================ known hazards (regressions)

#: Command lines that once ended in a traceback, a memory blow-up or a hang: each must now be
#: refused in seconds with one line (found by this fuzzing; ``@…`` as in :func:`command_skeletons`).
HAZARDS = [
    ["render", str(ROOT / "rigs" / "twin-strobes-45-wide.toml"), "--water", "coastal", "--distance", "2",
     "--size", "200000x200000", "--engine", "preview", "--out", "@OUT/r"],
    ["render", str(ROOT / "rigs" / "twin-strobes-45-wide.toml"), "--water", "coastal", "--distance", "2",
     "--size", "16000x16000", "--engine", "preview", "--out", "@OUT/r"],
    ["render", str(ROOT / "rigs" / "twin-strobes-45-wide.toml"), "--water", "coastal", "--distance", "2",
     "--wavelengths", "400:7e9:1e-9", "--engine", "preview", "--out", "@OUT/r"],
    ["water", "show", "coastal", "--wavelengths", "400:inf:10"],
    ["water", "plot", "coastal", "--out", "@OUT/w.3e16"],
    ["ambient", "--water", "clear", "--sun-zenith", "30", "--depths", "1,2,3,4,5,6,7,8,9,10,11", "--photons",
     "100000000", "--wavelengths", "450", "--json"],
    ["dataset", str(ROOT / "tests" / "data" / "tiny-dataset.toml"), "--n", "1000000000000", "--out", "@OUT/ds",
     "--serial"],
    ["dataset", str(ROOT / "tests" / "data" / "tiny-dataset.toml"), "--n", "1", "--seed", "-5", "--out", "@OUT/ds",
     "--serial"],
    ["study", "@STUDYFILE", "--out", "@OUT/s", "--workers", "100000", "--no-report"],
    ["study", "@STUDYFILE", "--out", "@OUT/s", "--scheduler", "bogus", "--no-report"],
    ["capture", "@RENDER", "--sensor", "action_cam_1-2.3in", "--shutter", "1/125", "--iso", "2301685871418556",
     "--out", "@OUT/c"],
    ["render", "rigs/x.toml", "--bogus"],
    ["render"],
    ["water", "show"],
    ["--log-level", "bogus", "water", "list"],
]
