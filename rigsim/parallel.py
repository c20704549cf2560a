"""Map a pure function over work items: serial, an embedded dask LocalCluster, or a dask scheduler.

Used by studies and datasets.  Results are stored by the caller's ``store`` callback as
each item finishes (on the client side, so a remote cluster needs no shared disk);
items whose ``is_done`` is true are skipped, which makes runs resumable.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable, Sequence
from typing import Any

from rigsim.errors import ConfigError, Interrupted, RigsimError

log = logging.getLogger(__name__)

__all__ = ["run_tasks", "default_workers", "check_workers", "connect_scheduler"]

#: Seconds to wait for a dask scheduler given by address before giving up.
CONNECT_TIMEOUT_S = 10
#: Memory one worker process of the embedded cluster needs at least (bytes; rigsim + Mitsuba loaded).
WORKER_MEMORY_BYTES = 400 << 20
#: glibc's thresholds in a worker whose environment sets ``MALLOC_TRIM_THRESHOLD_`` (dask's nanny sets
#: 65 536 B, so that workers return freed memory at once): above this size a block is its own mapping
#: (M_MMAP_THRESHOLD, bytes; 32 MiB is glibc's largest dynamic value on 64-bit) and the heap is trimmed
#: beyond this much free memory (M_TRIM_THRESHOLD, bytes).  With dask's value every array of the
#: fast engine's photon tracer (a few MB, allocated and freed at each bounce) was mapped and unmapped
#: again: a demo case took 10 s in a worker instead of 4 s alone (14 s of the kernel's page faults
#: per 2 cases; measured 2026-12-02).
MMAP_THRESHOLD_BYTES = 32 << 20
TRIM_THRESHOLD_BYTES = 256 << 20


def default_workers() -> int:
    """Worker processes of the embedded cluster: two where there are two cores or more.

    Dr.Jit renders on every core, but each case first compiles its kernel with LLVM on one
    core (~1.7 s); with two workers one compiles while the other renders (a 4-case study on
    2 cores: 15.6 s instead of 20.4 s wall).
    """
    import os

    return 2 if (os.cpu_count() or 1) >= 2 else 1


def check_workers(workers: int | None) -> int | None:
    """``workers`` if it is a usable number of worker processes (1 … 4 × cores, and fits in memory)."""
    import os

    if workers is None:
        return None
    hi = max(8, 4 * (os.cpu_count() or 1))
    if isinstance(workers, bool) or not isinstance(workers, int) or not 1 <= workers <= hi:
        raise ConfigError(f"cannot start {workers} worker processes", field="--workers",
                          allowed=f"1 … {hi} (4 per core on this machine)")
    from rigsim.resources import check_memory

    check_memory(workers * WORKER_MEMORY_BYTES, f"{workers} worker processes", field="--workers")
    return workers


def connect_scheduler(address: str):
    """A dask ``Client`` of the scheduler at ``address``, or a one-line error saying why not."""
    from dask.distributed import Client

    text = str(address).strip()
    if not text:
        raise ConfigError("no scheduler address given", field="--scheduler", allowed="tcp://HOST:PORT")
    try:
        return Client(text, timeout=CONNECT_TIMEOUT_S)
    except Exception as exc:  # noqa: BLE001 - bad address, refused, unreachable, timed out: all one line
        why = " ".join(str(exc).split()) or type(exc).__name__
        raise ConfigError(f"cannot connect to the dask scheduler at {text!r}: {why}", field="--scheduler",
                          allowed="the address a running `dask scheduler` prints, e.g. tcp://10.0.0.5:8786") from None


def _progress(label: str, total: int, done: int, enabled: bool):
    from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn,
                               TimeRemainingColumn)

    prog = Progress(TextColumn(f"[bold]{label}[/bold]"), BarColumn(), MofNCompleteColumn(),
                    TextColumn("elapsed"), TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(),
                    disable=not enabled)
    task = prog.add_task(label, total=total, completed=done)
    return prog, task


def run_tasks(items: Sequence[Any], compute: Callable[[Any], Any], store: Callable[[Any, Any], None], *,
              is_done: Callable[[Any], bool] = lambda item: False, key: Callable[[Any], str] = str,
              scheduler: str | None = None, workers: int | None = None, serial: bool = False,
              progress: bool = True, label: str = "tasks",
              on_done: Callable[[Any], None] | None = None,
              more: Callable[[], Sequence[Any]] | None = None) -> int:
    """Run ``compute(item)`` for every item not yet done and ``store(item, result)`` each result.

    Parameters
    ----------
    items
        Work items (picklable).
    compute
        A module-level (picklable) function of one item.
    store
        Called in this process with each finished item and its result, in completion order.
    is_done
        Items for which it is true are skipped (resume).
    key
        A unique, stable name per item (dask task keys).
    scheduler
        Address of a running dask scheduler; None: an embedded ``LocalCluster``.
    workers
        Worker processes of the embedded cluster (default :func:`default_workers`).
    serial
        Compute in this process, without dask (same results).
    progress
        Show a progress bar with ETA.
    on_done
        Called after each item is stored.
    more
        Work decided by finished work: called at the start and after each item is stored; the
        items it returns that are neither done nor seen before are run too, on the same workers
        while the others still run (a study's steps beyond the sweep, each decided by the last).

    Returns
    -------
    The number of items computed in this call.

    Raises
    ------
    TaskFailures
        After every other item has been computed and stored, if some items raised: their
        keys and errors (the stored results are kept; running again retries only those).
    Interrupted
        On Ctrl-C (KeyboardInterrupt): every item finished before it is stored; running
        again computes only the others.
    ConfigError
        ``workers`` out of range or more than the memory allows; a scheduler that cannot be
        reached (within :data:`CONNECT_TIMEOUT_S`).
    """
    workers = check_workers(workers)
    todo = [it for it in items if not is_done(it)]
    done0 = len(items) - len(todo)
    if done0:
        log.info("resuming: %d of %d %s already finished", done0, len(items), label)
    prog, task = _progress(label, len(items), done0, progress)
    failures: list[tuple[str, BaseException]] = []
    stored = [0]
    seen = {key(it) for it in items}
    total = [len(items)]

    def extra() -> list:
        """The items ``more`` adds now (neither done nor seen before); the progress bar grows by them."""
        if more is None:
            return []
        new = []
        for it in more():
            if key(it) not in seen and not is_done(it):
                seen.add(key(it))
                new.append(it)
        if new:
            total[0] += len(new)
            prog.update(task, total=total[0])
        return new

    def finish(it, get_result):
        try:
            res = get_result()
        except Exception as exc:  # noqa: BLE001 - one failed item must not lose the others
            failures.append((key(it), exc))
            log.error("%s %s failed: %s", label, key(it), exc)
        else:
            store(it, res)
            stored[0] += 1
            if on_done:
                on_done(it)
        prog.advance(task)

    def interrupted() -> Interrupted:
        n_done = done0 + stored[0]
        return Interrupted(f"{n_done} of {total[0]} {label} items are finished and kept")

    try:
        with prog:
            todo += extra()
            if serial or not todo:
                queue = list(todo)
                while queue:
                    it = queue.pop(0)
                    finish(it, lambda it=it: compute(it))
                    new = extra()
                    todo += new
                    queue += new
            else:
                _run_dask(todo, compute, finish, key, scheduler, workers, label, extra)
    except KeyboardInterrupt:
        raise interrupted() from None
    _raise_failures(failures, label, len(todo))
    return len(todo)


def tune_allocator() -> bool:
    """In a process started with ``MALLOC_TRIM_THRESHOLD_`` set (a dask worker), raise glibc's mmap
    and trim thresholds (:data:`MMAP_THRESHOLD_BYTES`, :data:`TRIM_THRESHOLD_BYTES`) with ``mallopt``;
    returns whether it did (once per process; nothing elsewhere, or without glibc)."""
    import ctypes
    import os

    global _TUNED
    if _TUNED or "MALLOC_TRIM_THRESHOLD_" not in os.environ:
        return False
    _TUNED = True
    try:
        libc = ctypes.CDLL("libc.so.6")
    except OSError:
        return False
    m_trim, m_mmap = -1, -3  # <malloc.h>: M_TRIM_THRESHOLD, M_MMAP_THRESHOLD
    return bool(libc.mallopt(m_mmap, MMAP_THRESHOLD_BYTES)) and bool(libc.mallopt(m_trim, TRIM_THRESHOLD_BYTES))


_TUNED = False


class _InWorker:
    """``compute`` as a dask task: the allocator tuned first (:func:`tune_allocator`)."""

    def __init__(self, compute: Callable[[Any], Any]):
        self.compute = compute

    def __call__(self, item):
        tune_allocator()
        return self.compute(item)


def _run_dask(todo, compute, finish, key, scheduler, workers, label, extra) -> None:
    import dask
    from dask.distributed import Client, LocalCluster, as_completed

    logging.getLogger("distributed").setLevel(logging.ERROR)
    cluster = None
    if scheduler:
        client = connect_scheduler(scheduler)
    else:
        # the workers' own logs stay quiet (CRITICAL): a task's exception reaches us through its
        # future and is reported below; at shutdown a worker may still send a heartbeat to the
        # closed scheduler and log a traceback (seen once in ~10 demo runs) that means nothing
        # (and without dask's MALLOC_TRIM_THRESHOLD_: see MMAP_THRESHOLD_BYTES)
        with _sigint_ignored(), dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}):
            cluster = LocalCluster(n_workers=workers or default_workers(), threads_per_worker=1, processes=True,
                                   dashboard_address=":0", silence_logs=logging.CRITICAL)
        client = Client(cluster)
    try:
        task = _InWorker(compute)
        futures = {client.submit(task, it, pure=False, key=f"{label}-{key(it)}"): it for it in todo}
        running = as_completed(futures)
        for fut in running:
            finish(futures[fut], fut.result)
            for it in extra():  # work the finished work decided: now, ahead of what is still queued
                todo.append(it)  # (a chain of such steps then ends with the rest, not after it)
                new = client.submit(task, it, pure=False, key=f"{label}-{key(it)}", priority=1)
                futures[new] = it
                running.add(new)
    finally:
        _close_quietly(client, cluster)


@contextlib.contextmanager
def _sigint_ignored():
    """SIGINT ignored while child processes start (they keep ignoring it: a Ctrl-C in the terminal
    reaches the whole process group, and the workers would print their own KeyboardInterrupt)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)


def _close_quietly(client, cluster) -> None:
    """Close the client and the embedded cluster; a second Ctrl-C while closing is ignored."""
    import signal
    import threading

    old = None
    if threading.current_thread() is threading.main_thread():
        old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        try:
            client.close()
        finally:
            if cluster is not None:
                cluster.close()
    except Exception as exc:  # noqa: BLE001 - closing must not hide what happened before
        log.debug("closing the dask cluster: %s", exc)
    finally:
        if old is not None:
            signal.signal(signal.SIGINT, old)


class TaskFailures(RigsimError):
    """Some items of :func:`run_tasks` raised; ``failures`` holds (key, exception) pairs."""

    def __init__(self, message: str, failures: list[tuple[str, BaseException]]):
        super().__init__(message)
        self.failures = failures


def _raise_failures(failures, label: str, n: int) -> None:
    if not failures:
        return
    lines = "; ".join(f"{k}: {e}" for k, e in failures[:5]) + (" …" if len(failures) > 5 else "")
    raise TaskFailures(f"{len(failures)} of {n} {label} items failed ({lines}); the others are stored, "
                       "and running again retries only the failed ones", failures)
