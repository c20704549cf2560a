"""Tiles of rows on threads, and fresh memory: how the fast engine uses both cores.

The per-pixel passes of :func:`rigsim.preview.render_preview` work on tiles of image rows of about
:data:`TILE_SAMPLES` samples, so that every per-band array of a tile stays in the cache, and run the
tiles on a thread pool: numpy releases the GIL inside its loops, so the threads share the cores.
Every tile writes only its own rows, and each is computed the same way whichever thread runs it:
the image does not depend on the number of threads.

Writing to memory for the first time costs more than computing it on some machines (see
:func:`no_hugepage_advice`).
"""

from __future__ import annotations

import contextlib
import os
import threading
from concurrent.futures import ThreadPoolExecutor

__all__ = ["TILE_SAMPLES", "default_threads", "thread_map", "run", "row_tiles", "no_hugepage_advice"]

#: Samples (pixels × pixel_samples²) per tile of the per-pixel passes.
TILE_SAMPLES = 8192


def default_threads() -> int:
    """Threads of the per-pixel passes: the cores this process may run on, or fewer where
    ``OMP_NUM_THREADS`` says so — as a dask worker's nanny does (``OMP_NUM_THREADS=1``: the study's
    workers are one process per core, so a second thread in each only made them wait for each other;
    measured 2026-12-07 on 2 cores, two processes each making four of the demo's photographs in turn:
    25.2 s with two threads each, 23.2 s with one)."""
    try:
        cores = max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # not on Linux
        cores = max(1, os.cpu_count() or 1)
    try:
        omp = int(os.environ.get("OMP_NUM_THREADS", ""))
    except ValueError:  # unset, or not a number (OpenMP's lists such as "4,2": not ours to read)
        return cores
    return max(1, min(cores, omp))


@contextlib.contextmanager
def thread_map(threads: int):
    """A ``map`` over ``threads`` threads (the built-in ``map`` for one)."""
    if threads <= 1:
        yield map
        return
    with ThreadPoolExecutor(max_workers=threads, thread_name_prefix="rigsim-preview") as ex:
        yield ex.map


def run(pmap, fn, items) -> None:
    """``fn`` on every item through ``pmap``; exceptions raised in the threads are raised here."""
    for _ in pmap(fn, items):
        pass


def row_tiles(height: int, samples_per_row: int) -> list[tuple[int, int]]:
    """Row ranges ``(y0, y1)`` of about :data:`TILE_SAMPLES` samples each."""
    rows = max(1, TILE_SAMPLES // max(samples_per_row, 1))
    return [(y, min(y + rows, height)) for y in range(0, height, rows)]


_HUGEPAGE_LOCK = threading.Lock()
_HUGEPAGE_USERS = [0, None]  # renders in progress, numpy's setting before the first


def _thp_compacts_on_fault() -> bool:
    """Whether the kernel compacts memory synchronously when advised memory faults (THP ``defrag`` set to
    ``madvise`` or ``defer+madvise``)."""
    try:
        with open("/sys/kernel/mm/transparent_hugepage/defrag") as f:
            mode = f.read().split("[", 1)[1].split("]", 1)[0]
    except (OSError, IndexError):
        return False
    return mode in ("madvise", "defer+madvise")


@contextlib.contextmanager
def no_hugepage_advice():
    """numpy advises the kernel to back every array of 4 MB or more with transparent huge pages.  Where
    the kernel then compacts memory synchronously on the first write to such an array (see
    :func:`_thp_compacts_on_fault`; numpy issue #31590), fresh memory is several times slower to
    write — five times on the 2-core development VM, most of the cost of writing an image's layers.
    The advice is off while an image is made (the first render to start turns it off, the last to end
    restores numpy's setting); it changes only how fast pages arrive, never a value.
    """
    try:
        from numpy._core import multiarray as ma
    except ImportError:  # numpy < 2
        from numpy.core import multiarray as ma
    get, set_ = getattr(ma, "_get_madvise_hugepage", None), getattr(ma, "_set_madvise_hugepage", None)
    if get is None or set_ is None or not _thp_compacts_on_fault():
        yield
        return
    with _HUGEPAGE_LOCK:
        if _HUGEPAGE_USERS[0] == 0:
            _HUGEPAGE_USERS[1] = bool(get())
            set_(False)
        _HUGEPAGE_USERS[0] += 1
    try:
        yield
    finally:
        with _HUGEPAGE_LOCK:
            _HUGEPAGE_USERS[0] -= 1
            if _HUGEPAGE_USERS[0] == 0:
                set_(_HUGEPAGE_USERS[1])
