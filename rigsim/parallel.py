"""Map a pure function over work items: serial, an embedded dask LocalCluster, or a dask scheduler.

Used by studies and datasets.  Results are stored by the caller's ``store`` callback as
each item finishes (on the client side, so a remote cluster needs no shared disk);
items whose ``is_done`` is true are skipped, which makes runs resumable.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from typing import Any

log = logging.getLogger(__name__)

__all__ = ["run_tasks"]


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
              on_done: Callable[[Any], None] | None = None) -> int:
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
        Worker processes of the embedded cluster (default 1: Dr.Jit already uses every core).
    serial
        Compute in this process, without dask (same results).
    progress
        Show a progress bar with ETA.
    on_done
        Called after each item is stored.

    Returns
    -------
    The number of items computed in this call.
    """
    todo = [it for it in items if not is_done(it)]
    done0 = len(items) - len(todo)
    if done0:
        log.info("resuming: %d of %d %s already finished", done0, len(items), label)
    prog, task = _progress(label, len(items), done0, progress)
    with prog:
        if serial or not todo:
            for it in todo:
                store(it, compute(it))
                prog.advance(task)
                if on_done:
                    on_done(it)
            return len(todo)
        from dask.distributed import Client, LocalCluster, as_completed

        logging.getLogger("distributed").setLevel(logging.ERROR)
        cluster = None
        if scheduler:
            client = Client(scheduler)
        else:
            cluster = LocalCluster(n_workers=workers or 1, threads_per_worker=1, processes=True,
                                   dashboard_address=":0", silence_logs=logging.ERROR)
            client = Client(cluster)
        try:
            futures = {client.submit(compute, it, pure=False, key=f"{label}-{key(it)}"): it for it in todo}
            for fut in as_completed(futures):
                it = futures[fut]
                store(it, fut.result())
                prog.advance(task)
                if on_done:
                    on_done(it)
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    return len(todo)
