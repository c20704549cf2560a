"""Generated command lines for every command (valid ones, and mutations: unknown options, missing
and repeated arguments, values of the wrong type, extreme numbers, paths to binary files, folders
and nothing): click's usage error (exit 2), one ``error:`` line, or success with finite outputs —
never a traceback, a hang or a memory blow-up."""

from __future__ import annotations

import time

import pytest
from hypothesis import given, settings

from tests.fuzz.cases import (BUGS, HAZARDS, CliCase, _materialize, classify_cli, cli, cli_cases, command_skeletons,
                              run_cli_case)

CHEAP = tuple(n for n in command_skeletons() if n not in ("render mitsuba", "dataset", "demo", "ambient mc"))


@settings(settings.get_profile("rigsim-fuzz"), max_examples=120)
@given(case=cli_cases(CHEAP))
def test_command_lines(case, ws):
    res = run_cli_case(case, ws, timeout=60)
    assert res.outcome not in BUGS, f"{res.outcome}: {res.detail}"


@settings(settings.get_profile("rigsim-fuzz"), max_examples=12)
@given(case=cli_cases(("ambient mc", "demo")))
def test_command_lines_of_long_commands(case, ws):
    res = run_cli_case(case, ws, timeout=90)
    assert res.outcome not in BUGS, f"{res.outcome}: {res.detail}"


@pytest.mark.parametrize("argv", HAZARDS, ids=lambda a: " ".join(a)[:60])
def test_hazards_are_refused_in_seconds(argv, ws, tmp_path):
    """Command lines that once ended in a traceback, a memory blow-up or a hang."""
    t0 = time.perf_counter()
    code, out, err = cli(_materialize(argv, ws, tmp_path), cwd=tmp_path)
    outcome, detail = classify_cli(code, out, err)
    assert outcome in ("refused", "usage error"), (outcome, detail, err[-500:])
    assert time.perf_counter() - t0 < 30
    if "200000x200000" in argv or "16000x16000" in argv:
        assert "memory" in err and "TB" in err or "GB" in err, err  # says how much it would need


def test_skeletons_are_valid(ws):
    """Every unmutated command line works (else the fuzzing would only ever test refusals)."""
    for name in CHEAP:
        res = run_cli_case(CliCase(name, command_skeletons()[name], []), ws)
        assert res.outcome == "ok", (name, res.outcome, res.detail)
