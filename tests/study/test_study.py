"""Studies: validation before rendering, resume after a kill, dask equals serial, the report."""

import json
import logging
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from rigsim.errors import ConfigError
from rigsim.study import load_study, run_study

ROOT = Path(__file__).resolve().parents[2]

TINY = """
[study]
name = "tiny"
seed = 3

[sweep]
rigs = ["{root}/rigs/twin-strobes-close-to-port.toml"]
sensors = ["sony_ilce-7rm2"]
waters = ["coastal"]
distances_m = {distances}
targets = ["black-disk"]
target_fill = 0.4
extend_visibility = false

[render]
width = 24
height = 16
spp = 2

[capture]
exposure = "auto"
"""


def tiny(tmp_path, distances="[1.0, 2.0, 3.0]", extra=""):
    p = tmp_path / "tiny.toml"
    p.write_text(TINY.format(root=ROOT, distances=distances) + extra)
    return p


@pytest.mark.render
def test_dask_local_cluster_equals_serial(tmp_path):
    spec = load_study(tiny(tmp_path, "[1.0, 2.0]"))
    a = run_study(spec, tmp_path / "serial", serial=True, progress=False)
    b = run_study(spec, tmp_path / "dask", progress=False)
    ta, tb = (a / "results.csv").read_text(), (b / "results.csv").read_text()
    assert ta == tb and ta.count("\n") == 3  # header + 2 cases × 1 sensor
    assert (a / "visibility.csv").read_text() == (b / "visibility.csv").read_text()


@pytest.mark.render
def test_interrupted_study_resumes_to_the_same_table(tmp_path):
    path = tiny(tmp_path)
    ref = run_study(load_study(path), tmp_path / "ref", serial=True, progress=False)
    out = tmp_path / "killed"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "rigsim.cli", "study", str(path), "--out", str(out), "--serial",
                             "--no-report"], env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True)
    deadline = time.time() + 240
    while time.time() < deadline and len(list(out.glob("cases/*/result.json"))) < 1:
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    finished = len(list(out.glob("cases/*/result.json")))
    assert 1 <= finished <= 3
    # nothing half-written is left as a result
    assert not list(out.glob("cases/*/result.json.*"))
    done = []
    run_study(load_study(path), out, serial=True, progress=False, on_case_done=done.append)
    assert len(done) == 3 - finished  # finished cases were skipped
    assert (out / "results.csv").read_text() == (ref / "results.csv").read_text()


@pytest.mark.render
def test_a_study_resumed_by_other_code_computes_its_finished_cases_again(tmp_path, monkeypatch, caplog):
    import rigsim.code_version as code_version_module
    import rigsim.study.runner as runner
    from rigsim.code_version import code_version

    path = tiny(tmp_path, "[1.0, 2.0]")
    spec = load_study(path)
    out = run_study(spec, tmp_path / "s", serial=True, progress=False)
    first = (out / "results.csv").read_text()
    records = sorted(out.glob("cases/*/result.json"))
    assert len(records) == 2 and all(json.loads(f.read_text())["meta"]["code"] == code_version() for f in records)
    done = []
    run_study(spec, out, serial=True, progress=False, on_case_done=done.append)
    assert done == []  # the same code: nothing computed again
    # a record from before the code was recorded counts as other code
    rec = json.loads(records[0].read_text())
    del rec["meta"]["code"]
    records[0].write_text(json.dumps(rec))
    assert runner.pending_cases(spec, out) == [c for c in spec.cases() if records[0].parent.name == spec.case_id(c)]
    # an updated rigsim: every finished case is of other code; none of them reaches the tables meanwhile
    for module in (runner, code_version_module):
        monkeypatch.setattr(module, "code_version", lambda: "0123456789ab")
    assert runner.pending_cases(spec, out) == spec.cases()
    assert runner.read_results(spec, out)[0] == []
    with caplog.at_level(logging.WARNING, logger="rigsim.study.runner"):
        run_study(spec, out, serial=True, progress=False, on_case_done=done.append)
    assert len(done) == 2 and "2 finished case(s) or check(s)" in caplog.text and "0123456789ab" in caplog.text
    assert all(json.loads(f.read_text())["meta"]["code"] == "0123456789ab" for f in records)
    assert (out / "results.csv").read_text() == first  # (the same code in fact: the same numbers)


@pytest.mark.render
def test_a_case_computed_by_code_loaded_after_an_edit_is_named_and_left_out(tmp_path, monkeypatch, caplog):
    """A worker that imported rigsim after its files changed mid-run computes with other code: the run says so
    (one line per item) and keeps that case out of the tables, so a run never mixes two codes silently."""
    import rigsim.study.runner as runner

    run_one = runner._run_one

    def edited_meanwhile(*args, **kwargs):
        res = run_one(*args, **kwargs)
        res["meta"]["code"] = "feedbeef0000"
        return res

    monkeypatch.setattr(runner, "_run_one", edited_meanwhile)
    spec = load_study(tiny(tmp_path, "[1.0]"))
    with caplog.at_level(logging.WARNING, logger="rigsim.study.runner"):
        out = run_study(spec, tmp_path / "s", serial=True, progress=False)
    assert f"{spec.case_id(spec.cases()[0])} was computed by other rigsim code (feedbeef0000" in caplog.text
    assert "run the study again" in caplog.text
    assert runner.read_results(spec, out)[0] == [] and runner.pending_cases(spec, out) == spec.cases()


def test_the_code_version_covers_the_computing_code_and_its_tables_not_the_presenting_code():
    from rigsim.code_version import _files

    names = {n for n, _ in _files()}
    assert {"rigsim/water/model.py", "rigsim/preview/model.py", "rigsim/study/case.py", "rigsim/sensor/__init__.py",
            "data/water/jerlov_iop_solonenko_mobley_2015.csv", "rigsim/dataset/sample.py"} <= names
    assert not [n for n in names if n.startswith(("rigsim/ui/", "rigsim/report/", "rigsim/cli/", "data/fast_engine/"))]
    assert not [n for n in names if "__pycache__" in n]


def test_typo_fails_before_rendering(tmp_path, monkeypatch):
    import rigsim.study.runner as runner

    monkeypatch.setattr(runner, "_run_one", lambda *a: pytest.fail("rendered despite a bad study file"))
    cases = [
        ('waters = ["coastal"]', 'waters = ["coastl"]', r"sweep.waters\[0\].*did you mean 'coastal'"),
        ('sensors = ["sony_ilce-7rm2"]', 'sensors = ["sony_ilce-7rm3"]', r"sweep.sensors\[0\]"),
        ('targets = ["black-disk"]', 'targets = ["black-disc"]', r"sweep.targets\[0\].*did you mean 'black-disk'"),
        ("spp = 2", "spp = -2", r"render.spp: out of range"),
        ("spp = 2", "sp = 2", r"render.sp: unknown key 'sp'"),
        ('rigs = ["', 'rigs = ["nope/', r"sweep.rigs\[0\].*file not found"),
        ("spp = 2", "spp = 2\nnoise_target = -0.1", r"render.noise_target: out of range"),
        ("spp = 2", "spp = 2\nnoise_target = 0.1\nmax_spp = 1", r"render.max_spp: max_spp 1 is below spp 2"),
    ]
    for old, new, pattern in cases:
        p = tiny(tmp_path)
        p.write_text(p.read_text().replace(old, new))
        with pytest.raises(ConfigError, match=pattern) as ei:
            run_study(load_study(p), tmp_path / "x", serial=True, progress=False)
        assert "\n" not in str(ei.value)
    p = tiny(tmp_path, "[2.0, 1.0]")
    with pytest.raises(ConfigError, match=r"sweep.distances_m: must be positive, increasing"):
        load_study(p)


def test_demo_study_is_valid_and_big_enough():
    spec = load_study(ROOT / "studies" / "demo.toml")
    assert len(spec.rigs) == 2 and len(spec.sensors) == 2
    assert len(spec.waters) >= 4 and len(spec.distances_m) >= 6
    quick = load_study(ROOT / "studies" / "demo.toml", quick=True)
    assert len(quick.cases()) < len(spec.cases())
    # photograph-sized by the fast engine, at least 8 cases checked by Monte Carlo, every water among them
    assert spec.render.engine == "preview" and spec.render.width >= 640 and spec.render.height >= 427
    checks = spec.check_cases()
    assert len(checks) >= 8 and {c.water for c in checks} == set(spec.waters)
    assert {c.distance_m for c in checks} == {min(spec.distances_m), max(spec.distances_m)}
    assert 0 < len(quick.check_cases()) < len(checks)


def test_report_names_the_scenes_that_missed_the_noise_target():
    from rigsim.report.html import noise_sentences

    def row(water, dist, noise, sensor):
        return {"rig": "edge", "water": water, "target": "colorchecker", "distance_m": dist,
                "mc_noise_p99": noise, "sensor": sensor}

    rows = [row("coastal", 3.0, 0.12, s) for s in ("a", "b")] + [
        row("jerlov-II", 3.0, 0.41, "a"), row("jerlov-II", 3.0, 0.41, "b"), row("jerlov-II", 1.0, 0.3, "a")]
    (s,) = noise_sentences(rows, 0.15, 1024)
    assert s.startswith("2 of 3 scenes stopped at 1024 paths per pixel")
    assert "edge in jerlov-II (colorchecker) at 1, 3 m (noise up to 0.41)" in s and "coastal" not in s
    (s,) = noise_sentences(rows[:2], 0.15, 1024)
    assert s.startswith("Every scene reached")
    assert noise_sentences(rows, None, None) == []


@pytest.mark.render
def test_report_is_self_contained(tmp_path):
    from rigsim.report.html import write_report

    out = run_study(load_study(tiny(tmp_path, "[1.0, 2.0]")), tmp_path / "r", serial=True, progress=False)
    html = write_report(out).read_text()
    assert "<img" in html and "data:image/png;base64," in html
    assert "src='http" not in html and 'src="http' not in html  # opens offline
    assert "twin-strobes-close-to-port" in html and "Visibility range" in html
