"""Writing results safely: never half-written, never two runs at once, and one clear line when
the disk says no.

* :func:`atomic_write_bytes` — a temporary file in the same folder, flushed, then renamed over
  the target; on any failure the temporary file is removed and an
  :class:`~rigsim.errors.OutputError` (an ``OSError``) names the file and the reason
  (permission denied, no space left on device, read-only file system).
* :func:`staged_output` — the files of one command (a render, a capture) written into a hidden
  staging folder and moved into place together, or not at all.
* :func:`folder_lock` — one rigsim run per output folder (``flock`` on ``.rigsim.lock``: a run
  killed with SIGKILL releases it); a second run is refused with :class:`~rigsim.errors.FolderInUse`.
* :func:`remove_stale_temp_files` — the temporary files a killed run left behind.
"""

from __future__ import annotations

import contextlib
import datetime
import io
import os
import re
import shutil
import socket
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from rigsim.errors import FolderInUse, OutputError

__all__ = ["cache_dir", "png_bytes", "atomic_write_bytes", "atomic_write_text", "atomic_write_npz", "ensure_folder",
           "check_writable", "staged_output", "output_folder", "folder_lock", "remove_stale_temp_files",
           "drop_unreadable_records", "LOCK_NAME"]

#: Name of the lock file in an output folder.
LOCK_NAME = ".rigsim.lock"
#: Temporary files: ``.<name>.<random>.tmp`` (atomic writes), ``.<name>.tmp`` and ``.partial-*`` folders.
_STALE = re.compile(r"^\..+\.tmp$|^.+\.tmp\.exr$")
_STAGING_PREFIX = ".partial-"


def cache_dir() -> Path:
    """rigsim's cache folder: ``$RIGSIM_CACHE`` or ``~/.cache/rigsim`` (downloads, crash logs, probes)."""
    return Path(os.environ.get("RIGSIM_CACHE") or Path.home() / ".cache" / "rigsim")


def ensure_folder(path: str | Path) -> Path:
    """Create ``path`` (and its parents) or raise :class:`OutputError` saying why not."""
    p = Path(path)
    try:
        p.mkdir(parents=True, exist_ok=True)
    except FileExistsError as exc:
        raise OutputError(p, "exists and is not a folder") from exc
    except OSError as exc:
        raise OutputError(getattr(exc, "filename", None) or p, exc) from exc
    if not p.is_dir():
        raise OutputError(p, "exists and is not a folder")
    return p


def check_writable(folder: str | Path) -> Path:
    """Create ``folder`` and write and remove a small file in it: an :class:`OutputError` now
    (permissions, read-only or full disk) rather than after minutes of work."""
    folder = ensure_folder(folder)
    try:
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=".rigsim-write-check.", suffix=".tmp")
        try:
            os.write(fd, b"rigsim" * 170)
            os.fsync(fd)
        finally:
            os.close(fd)
            Path(tmp).unlink(missing_ok=True)
    except OSError as exc:
        raise OutputError(folder, exc) from exc
    return folder


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write a file atomically (temporary file in the same folder, then rename).

    Raises
    ------
    OutputError
        The folder cannot be created or written, or the disk is full; nothing is left behind.
    """
    path = Path(path)
    ensure_folder(path.parent)
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name[:200]}.", suffix=".tmp")
    except OSError as exc:
        raise OutputError(path, exc) from exc
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the usual permissions
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(exc, OutputError):
            raise
        raise OutputError(path, exc) from exc
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def png_bytes(rgb8: np.ndarray) -> bytes:
    """PNG bytes of an 8-bit RGB image (zlib level 3: a photograph-sized image in ~0.1 s)."""
    import cv2

    ok, buf = cv2.imencode(".png", np.ascontiguousarray(rgb8[..., ::-1]), [cv2.IMWRITE_PNG_COMPRESSION, 3])
    if not ok:
        raise RuntimeError("PNG encoding failed")
    return buf.tobytes()


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write a text file atomically (UTF-8)."""
    atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_npz(path: str | Path, arrays: dict[str, np.ndarray]) -> None:
    """Write a compressed ``.npz`` atomically."""
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    atomic_write_bytes(path, buf.getvalue())


@contextlib.contextmanager
def staged_output(out: str | Path) -> Iterator[Path]:
    """A staging folder inside ``out`` whose files are moved into ``out`` when the block ends.

    If the block raises (an error, a full disk, Ctrl-C) the staging folder is removed and
    ``out`` keeps what it held before: no half set of outputs.  Sub-folders are not supported.
    """
    out = ensure_folder(out)
    try:
        stage = Path(tempfile.mkdtemp(prefix=_STAGING_PREFIX, dir=out))
    except OSError as exc:
        raise OutputError(out, exc) from exc
    try:
        try:
            yield stage
        except OutputError as exc:  # name the file where it was going, not the staging folder
            if exc.path.startswith(str(stage) + os.sep):
                raise OutputError(out / Path(exc.path).relative_to(stage), exc) from exc
            raise
        names = sorted(p.name for p in stage.iterdir() if p.is_file() and not _STALE.match(p.name))
        for name in names:
            try:
                os.replace(stage / name, out / name)
            except OSError as exc:
                raise OutputError(out / name, exc) from exc
    finally:
        shutil.rmtree(stage, ignore_errors=True)


@contextlib.contextmanager
def output_folder(out: str | Path) -> Iterator[Path]:
    """The output folder of a one-shot command (render, capture, develop), held for the block.

    Checked writable before the work starts (:func:`check_writable`), locked
    (:func:`folder_lock`), and removed again if the block fails and the folder did not exist before.
    """
    out = Path(out)
    existed = out.exists()
    try:
        with folder_lock(check_writable(out)):
            yield out
    except BaseException:
        if not existed:
            shutil.rmtree(out, ignore_errors=True)
        raise


def remove_stale_temp_files(root: str | Path) -> int:
    """Remove the temporary files and staging folders of killed runs below ``root``; how many.

    Call only while holding :func:`folder_lock` of ``root`` (no live run is writing there).
    """
    n = 0
    root = Path(root)
    if not root.is_dir():
        return 0
    for dirpath, dirnames, filenames in os.walk(root):
        for d in list(dirnames):
            if d.startswith(_STAGING_PREFIX):
                shutil.rmtree(Path(dirpath) / d, ignore_errors=True)
                dirnames.remove(d)
                n += 1
        for f in filenames:
            if _STALE.match(f) and f != LOCK_NAME:
                try:
                    (Path(dirpath) / f).unlink()
                    n += 1
                except OSError:
                    pass
    return n


def drop_unreadable_records(root: str | Path, pattern: str, required: tuple[str, ...] = ()) -> list[Path]:
    """Remove the per-item completion records below ``root`` (``cases/*/result.json``) that are not a
    JSON object with the ``required`` keys, so that a resumed run computes those items again.

    Atomic writes never leave such a file; a damaged disk or a hand edit can.  Call only while
    holding :func:`folder_lock` of ``root``.  Returns the files removed.
    """
    import json

    dropped = []
    for f in sorted(Path(root).glob(pattern)):
        try:
            rec = json.loads(f.read_text(encoding="utf-8"))
            ok = isinstance(rec, dict) and all(k in rec for k in required)
        except (OSError, ValueError):
            ok = False
        if not ok:
            try:
                f.unlink()
                dropped.append(f)
            except OSError:
                pass
    return dropped


def _holder(lock_file: Path) -> str:
    try:
        text = lock_file.read_text(encoding="utf-8", errors="replace").strip()
    except OSError:
        return ""
    return " ".join(text.split())[:300]


@contextlib.contextmanager
def folder_lock(folder: str | Path, *, what: str | None = None) -> Iterator[Path]:
    """Hold the lock of an output folder while the block runs (one rigsim run per folder).

    The lock is an ``flock`` on ``folder/.rigsim.lock``; the operating system releases it
    when the process ends, however it ends (SIGKILL included), so there are no stale locks.
    The file holds the pid, host, start time and command of the holder, for the message
    another run gets.

    Raises
    ------
    FolderInUse
        Another process holds the lock.
    OutputError
        The folder cannot be created or written.
    """
    import fcntl

    folder = ensure_folder(folder)
    lock_file = folder / LOCK_NAME
    try:
        fd = os.open(lock_file, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:
        raise OutputError(lock_file, exc) from exc
    acquired = False
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            acquired = True
        except BlockingIOError:
            holder = _holder(lock_file)
            raise FolderInUse(f"{folder}: in use by another rigsim run ({holder or 'unknown process'}); wait for it "
                              "to finish or stop it, or give another output folder") from None
        except OSError as exc:  # e.g. a file system without locks: go on unlocked rather than fail
            if exc.errno not in (getattr(os, "ENOLCK", -1), getattr(os, "EOPNOTSUPP", -1),
                                 getattr(os, "ENOTSUP", -1)):
                raise OutputError(lock_file, exc) from exc
        cmd = " ".join(["rigsim", *sys.argv[1:]]) if sys.argv and "rigsim" in sys.argv[0] else what or "python"
        info = (f"pid {os.getpid()} on {socket.gethostname()}, since "
                f"{datetime.datetime.now().isoformat(timespec='seconds')}: {what or cmd}\n")
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, info.encode("utf-8", "replace"), 0)
        except OSError:
            pass  # the lock holds without the note (e.g. a full disk: the run will say so when it writes)
        yield lock_file
    finally:
        if acquired:
            try:
                os.ftruncate(fd, 0)
            except OSError:
                pass
        os.close(fd)  # releases the flock
