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
from tests.fuzz.cases import BAD_MESSAGE, REFUSED, TRACEBACK

CHEAP = tuple(n for n in command_skeletons() if n not in ("render mitsuba", "dataset", "demo", "ambient mc", "optimise"))


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


@settings(settings.get_profile("rigsim-fuzz"), max_examples=2)  # ~25 s each; tools/soak.py runs more
@given(case=cli_cases(("optimise",)))
def test_command_lines_of_the_optimiser(case, ws):
    res = run_cli_case(case, ws, timeout=120)
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


_CHAINED = """Traceback (most recent call last):
  File "rigsim/fileio.py", line 53, in ensure_folder
FileExistsError: [Errno 17] File exists: 'x.toml'

The above exception was the direct cause of the following exception:

Traceback (most recent call last):
  File "rigsim/fileio.py", line 55, in ensure_folder
rigsim.errors.OutputError: x.toml: cannot write: exists and is not a folder
error: x.toml: cannot write: exists and is not a folder
"""


def test_debug_traces_are_read_past_chained_exceptions():
    """``--log-level debug`` prints traces on purpose, chained ones too (the soak of seed 4242 called a
    chained trace before a correct one-line error a bad message); without debug a trace is a bug."""
    assert classify_cli(1, "", _CHAINED, debug=True)[0] == REFUSED
    assert classify_cli(1, "", _CHAINED)[0] == TRACEBACK
    assert classify_cli(1, "", _CHAINED + "error: a second line\n", debug=True)[0] == BAD_MESSAGE
