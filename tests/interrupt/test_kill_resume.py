"""SIGKILL at random moments, resume, compare with an uninterrupted run (a small version of
``tools/kill_resume.py``, which kills each command 10 times)."""

from __future__ import annotations

import json

import pytest

from tests.interrupt.harness import compare, dataset_job, integrity_problems, kill_and_resume, study_job


def test_study_killed_three_times_resumes_to_identical_tables(tmp_path):
    rep = kill_and_resume(study_job(serial=True), tmp_path, kills=3, seed=11, log=lambda m: None)
    assert rep.kills == 3 and len(rep.finished_at_kills) == 3
    assert rep.identical, rep.summary()


@pytest.mark.render
def test_dataset_killed_once_resumes_to_identical_samples(tmp_path):
    rep = kill_and_resume(dataset_job(3, serial=True), tmp_path, kills=1, seed=5, log=lambda m: None)
    assert rep.identical, rep.summary()


def test_the_comparison_sees_a_changed_missing_or_duplicated_row(tmp_path):
    """The harness itself: it must notice what it is there to notice."""
    import shutil

    from tests.interrupt.harness import run_to_end

    job = study_job(serial=True)
    ref = tmp_path / "ref"
    _, r = run_to_end(job, ref)
    assert r.returncode == 0, r.stderr
    assert compare(job, ref, ref) == [] and integrity_problems(job, ref) == []
    other = tmp_path / "other"
    shutil.copytree(ref, other)
    lines = (other / "results.csv").read_text().splitlines()
    (other / "results.csv").write_text("\n".join(lines + [lines[1]]) + "\n")
    res = sorted(other.glob("cases/*/result.json"))[0]
    rec = json.loads(res.read_text())
    rec["rows"][0]["contrast_radiance"] = 0.123
    res.write_text(json.dumps(rec))
    png = sorted(other.glob("cases/*/*.png"))[1]
    png.unlink()
    diffs = compare(job, ref, other)
    assert any("duplicated" in d for d in diffs) and any("differs (besides wall times)" in d for d in diffs)
    assert any(d.startswith("missing:") for d in diffs)
    res.write_text("{trunc")
    assert integrity_problems(job, other)
