"""Runners for :mod:`tests.fuzz.test_worker`: cases that defeat the in-process time limit or kill
the process, as a real bug could (a ``ConfigCase``'s ``kind`` says which)."""

from __future__ import annotations

import os
import signal
import time

from tests.fuzz import cases as fz


def run_config_case(case, ws, *, timeout=60.0):
    if case.kind == "swallowed-alarm":
        # what an alarm raised inside a garbage-collector callback amounts to: it never arrives
        with fz.time_limit(timeout):
            signal.signal(signal.SIGALRM, signal.SIG_IGN)
            time.sleep(3600)
    if case.kind == "abort":
        os.abort()
    return fz.guarded(f"file:{case.kind}", lambda: (fz.OK, "fine"), timeout=timeout)


def run_cli_case(case, ws, *, timeout=60.0):
    raise AssertionError("not used")


run_folder_case = run_cli_case
