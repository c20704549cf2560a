"""Running fuzz cases in a worker process, watched from outside (``tools/soak.py``).

A case's own time limit is an alarm (``tests/fuzz/cases.py:time_limit``) raised in whatever Python
code runs when it fires; where Python cannot pass an exception on (a garbage-collector callback, a
destructor) it is printed and swallowed, and the case runs on.  Run in the soak's own process, one
such case stalled a 10 000-case soak for good.  :class:`CaseWorker` runs the cases in a spawned
process and kills and replaces it when it has not answered ``grace`` seconds past the time limit,
or records a crash when it dies.
"""

from __future__ import annotations

import importlib
import os
import resource
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


#: The family's prefix of a case's kind (as ``tests/fuzz/cases.py`` names it).
PREFIX = {"files": "file", "cli": "cli", "folders": "folder"}


def _kind(fam: str, case) -> str:
    return f"{PREFIX[fam]}:{getattr(case, 'name', None) or getattr(case, 'kind', '?')}"


def _serve(conn, root: str, timeout: float, memory_gb: float, module: str) -> None:
    """The worker process: run the cases it is sent, one at a time, and send back the results."""
    os.setsid()  # its own process group: a kill takes the local dask cluster a case started with it
    os.chdir(ROOT)
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))  # a crash is counted, not dumped into the checkout
    if memory_gb:
        lim = int(memory_gb * 2**30)
        resource.setrlimit(resource.RLIMIT_DATA, (lim, lim))
    from tests.fuzz import cases as fz

    runs = importlib.import_module(module)
    ws = fz.Workspace(root)
    runners = {"files": runs.run_config_case, "cli": runs.run_cli_case, "folders": runs.run_folder_case}
    conn.send("ready")
    while True:
        try:
            msg = conn.recv()
        except (EOFError, KeyboardInterrupt):
            return
        if msg is None:
            return
        fam, case = msg
        conn.send(runners[fam](case, ws, timeout=timeout))


class CaseWorker:
    """A worker process that runs cases; killed and replaced when it stops answering or dies."""

    def __init__(self, root: Path, *, timeout: float, grace: float, memory_gb: float = 0.0,
                 module: str = "tests.fuzz.cases"):
        import multiprocessing

        self.ctx = multiprocessing.get_context("spawn")  # no threads or Dr.Jit state inherited
        self.root, self.timeout, self.grace, self.memory_gb = Path(root), timeout, grace, memory_gb
        #: the module with ``run_config_case``, ``run_cli_case`` and ``run_folder_case``
        self.module = module
        self.proc = self.conn = None
        self.started = self.restarts = 0

    def _start(self) -> None:
        parent, child = self.ctx.Pipe()
        self.started += 1
        root = self.root / f"worker-{self.started:03d}"
        # not a daemon: a case may start a local dask cluster, whose nanny processes a daemon cannot have
        self.proc = self.ctx.Process(target=_serve, args=(child, str(root), self.timeout, self.memory_gb, self.module))
        self.proc.start()
        child.close()
        self.conn = parent
        if not self.conn.poll(600) or self.conn.recv() != "ready":
            raise SystemExit(f"soak: the worker process did not start (exit code {self.proc.exitcode})")

    def _stop(self, kill: bool) -> None:
        if self.proc is None:
            return
        if kill and self.proc.is_alive():
            self._kill_group()
        self.proc.join(30)
        if self.proc.is_alive():
            self._kill_group()
            self.proc.join()
        self.conn.close()
        self.proc = self.conn = None

    def run(self, fam: str, case):
        from tests.fuzz import cases as fz

        if self.proc is None or not self.proc.is_alive():
            if self.proc is not None:
                self._stop(kill=True)
                self.restarts += 1
            self._start()
        t0 = time.perf_counter()
        try:
            self.conn.send((fam, case))
            if self.conn.poll(self.timeout + self.grace):
                return self.conn.recv()
        except (EOFError, BrokenPipeError, ConnectionResetError):
            self.proc.join(10)
            code = self.proc.exitcode
            self._stop(kill=True)
            self.restarts += 1
            return fz.Result(_kind(fam, case), fz.CRASH, f"the worker process died (exit code {code})",
                             time.perf_counter() - t0)
        self._stop(kill=True)
        self.restarts += 1
        return fz.Result(_kind(fam, case), fz.HANG,
                         f"no answer {self.timeout + self.grace:g} s after the start (the case's own time limit "
                         f"did not stop it; the worker was killed)", time.perf_counter() - t0)

    def _kill_group(self) -> None:
        import signal

        try:
            os.killpg(self.proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            self.proc.kill()

    def close(self) -> None:
        if self.proc is not None and self.proc.is_alive():
            try:
                self.conn.send(None)
            except (BrokenPipeError, OSError):
                pass
        self._stop(kill=False)

