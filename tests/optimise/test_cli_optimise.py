"""``rigsim optimise`` as a user runs it: files, the rig it writes, the sweep and its resumption, and
one-line errors."""

from __future__ import annotations

import json
import logging
import os
from pathlib import Path

import pytest

from rigsim.cli import run_command
from rigsim.config.rig import load_rig

RIG = str(Path(__file__).parents[2] / "rigs" / "twin-strobes-45-wide.toml")


def test_optimise_writes_a_rig_pictures_and_numbers(tmp_path, capsys):
    out = tmp_path / "o"
    rc = run_command(["optimise", RIG, "--water", "coastal", "--distance", "1.2", "--quick", "--no-check",
                      "--limits", "beam_angles_deg=80/110", "--out", str(out)])
    text = capsys.readouterr().out
    assert rc == 0, text
    names = {p.name for p in out.iterdir()}
    assert {"twin-strobes-45-wide-optimised.toml", "diagram.png", "before.png", "after.png", "metrics.csv",
            "sensitivities.csv", "result.json", "report.html"} <= names
    rig = load_rig(out / "twin-strobes-45-wide-optimised.toml")
    rec = json.loads((out / "result.json").read_text())
    best = rec["best_placement"]
    right = next(lt for lt in rig.lights if lt.name == "right")
    r, u, f = rig.camera.frame()
    p = [float((right.position_m[i] - rig.camera.position_m[i])) for i in range(3)]
    arm = (sum(x * y for x, y in zip(p, r)) ** 2 + sum(x * y for x, y in zip(p, u)) ** 2) ** 0.5
    assert arm == pytest.approx(best["arm length"], abs=2e-3)
    assert rig.lights[0].beam.beam_angle_deg == best["beam angle"]
    assert "For coastal water, subject at 1.2 m" in text and "report.html" in text
    assert rec["best"]["score"] < 0.9 * rec["start"]["score"]  # the 45-wide rig in coastal water gains


@pytest.mark.parametrize("args, words", [
    (["--water", "coastal", "--distance", "abc"], "--distance"),
    (["--water", "coastal", "--distance", "1", "--limits", "arm_length_m=2:1"], "arm_length_m"),
    (["--water", "coastal", "--distance", "1", "--weights", "glare=2"], "--weights"),
    (["--water", "nowhere", "--distance", "1"], "nowhere"),
    (["--water", "coastal", "--distance", "-1"], "distance"),
])
def test_bad_input_is_one_line(tmp_path, capsys, args, words):
    rc = run_command(["optimise", RIG, *args, "--quick", "--no-check", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and words in err and len(err.splitlines()) == 1 and "Traceback" not in err


def test_usage_mistake_prints_usage(capsys):
    rc = run_command(["optimise", RIG, "--distance", "1"])
    err = capsys.readouterr().err
    assert rc == 2 and "Usage:" in err and "--water" in err


def test_sweep_resumes_and_prints_a_sentence_per_water(tmp_path, capsys, caplog):
    out = tmp_path / "s"
    argv = ["optimise", RIG, "--water", "coastal", "--distance", "1,2", "--quick", "--out", str(out)]
    assert run_command(argv) == 0
    text = capsys.readouterr().out
    assert "For 1–2 m in coastal water the arms should be" in text
    cells = sorted(out.glob("cell-*.json"))
    assert [c.name for c in cells] == ["cell-coastal-1m.json", "cell-coastal-2m.json"]
    assert {"sweep.html", "sweep.csv", "sweep.png"} <= {p.name for p in out.iterdir()}
    # an interrupted sweep: one cell lost; the rerun computes only that one
    stamp = cells[0].stat().st_mtime_ns
    cells[1].unlink()
    os.utime(cells[0], ns=(stamp, stamp))
    assert run_command(argv) == 0
    assert cells[0].stat().st_mtime_ns == stamp and cells[1].exists()
    # a cell found by other rigsim code (an update between the runs) is searched again, with a warning
    from rigsim.code_version import code_version

    rec = json.loads(cells[0].read_text())
    assert rec["code"] == code_version()
    rec["code"] = "0" * 12
    cells[0].write_text(json.dumps(rec))
    os.utime(cells[0], ns=(stamp, stamp))
    stamp1 = cells[1].stat().st_mtime_ns
    with caplog.at_level(logging.WARNING, logger="rigsim.optimise.sweep"):
        assert run_command(argv) == 0
    assert "1 finished cell(s)" in caplog.text and "other rigsim code" in caplog.text and cells[0].name in caplog.text
    assert json.loads(cells[0].read_text())["code"] == code_version()
    assert cells[0].stat().st_mtime_ns != stamp and cells[1].stat().st_mtime_ns == stamp1
