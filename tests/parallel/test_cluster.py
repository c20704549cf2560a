"""A real dask cluster on 127.0.0.1, started with the commands a user runs (``dask scheduler``, two
``dask worker``), running a dataset and a study through ``--scheduler``; one worker is killed mid-run
and the results are those of the local run."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(sys.executable).parent
DASK = BIN / "dask"
RIGSIM = BIN / "rigsim"

pytestmark = pytest.mark.skipif(not DASK.is_file(), reason="the dask command is not installed")

DATASET = f"""
[dataset]
width = 96
height = 64
engine = "fast"
wavelengths = "400:700:25"

[water]
presets = ["coastal", "jerlov-II"]
constituent_probability = 0.3

[rig]
files = ["{ROOT}/rigs/twin-strobes-45-wide.toml"]

[sensor]
names = ["sony_ilce-7rm2"]

[scene]
distance_m = [1.0, 2.0]
objects = [1, 1]
kinds = ["colorchecker", "mesh"]

[seabed]
probability = 0.5
extent_m = 8.0
cells = 256
"""

STUDY = f"""
[study]
name = "cluster"
seed = 3

[sweep]
rigs = ["{ROOT}/rigs/twin-strobes-45-wide.toml"]
sensors = ["sony_ilce-7rm2"]
waters = ["clear", "coastal"]
distances_m = [1.0, 2.0, 3.0]
targets = ["black-disk"]

[render]
engine = "fast"
width = 48
height = 32
wavelengths = "420:680:40"
"""


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start(args: list[str], log: Path) -> subprocess.Popen:
    return subprocess.Popen(args, stdout=log.open("w"), stderr=subprocess.STDOUT, cwd=ROOT, start_new_session=True)


def _stop(p: subprocess.Popen) -> None:
    if p.poll() is None:
        os.killpg(p.pid, signal.SIGTERM)
        try:
            p.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()


@pytest.fixture
def cluster(tmp_path):
    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    procs = [_start([str(DASK), "scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                    tmp_path / "scheduler.log")]
    deadline = time.time() + 60
    while time.time() < deadline:
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                break
        time.sleep(0.3)
    else:
        raise AssertionError("the scheduler did not start: " + (tmp_path / "scheduler.log").read_text())
    workers = [_start([str(DASK), "worker", addr, "--nworkers", "1", "--nthreads", "1", "--no-dashboard",
                       "--name", f"w{k}"], tmp_path / f"worker{k}.log") for k in range(2)]
    procs += workers
    from dask.distributed import Client

    with Client(addr, timeout=30) as c:
        c.wait_for_workers(2, timeout=90)
    try:
        yield addr, workers
    finally:
        for p in reversed(procs):
            _stop(p)


def _run(args: list[str], log: Path) -> subprocess.Popen:
    return subprocess.Popen([str(RIGSIM), *args], stdout=log.open("w"), stderr=subprocess.STDOUT, cwd=ROOT)


def _records(out: Path) -> dict:
    recs = {}
    for f in sorted(out.glob("samples/*/record.json")):
        r = json.loads(f.read_text())
        r.pop("wall_time_s", None)
        r["render"].pop("wall_time_s", None)
        recs[f.parent.name] = r
    return recs


SAME_BYTES = ("image.png", "clean.png", "instances.png", "mask.png", "depth_z_mm.png", "depth_range_mm.png",
              "labels.txt", "annotations.json", "camera.json")


def test_dataset_and_study_on_a_cluster_survive_a_killed_worker(cluster, tmp_path):
    addr, workers = cluster
    (tmp_path / "ds.toml").write_text(DATASET)
    (tmp_path / "study.toml").write_text(STUDY)
    n = 6
    run = _run(["dataset", str(tmp_path / "ds.toml"), "--n", str(n), "--out", str(tmp_path / "remote"),
                "--seed", "4", "--scheduler", addr], tmp_path / "dataset.log")
    # kill one worker (its nanny and process, SIGKILL) once the first sample is stored
    deadline = time.time() + 600
    while not list((tmp_path / "remote").glob("samples/*/record.json")):
        assert run.poll() is None, (tmp_path / "dataset.log").read_text()
        assert time.time() < deadline, "no sample within 10 minutes"
        time.sleep(0.2)
    os.killpg(workers[0].pid, signal.SIGKILL)
    done_before_kill = len(list((tmp_path / "remote").glob("samples/*/record.json")))
    assert run.wait(timeout=900) == 0, (tmp_path / "dataset.log").read_text()
    assert done_before_kill < n, "the kill came after the run: it tested nothing"
    # the same samples computed here, in this process, one after another
    from rigsim.dataset import load_dataset_spec, run_dataset

    local = run_dataset(load_dataset_spec(tmp_path / "ds.toml"), n, tmp_path / "local", seed=4, serial=True,
                        progress=False)
    remote = tmp_path / "remote"
    assert _records(remote) == _records(local) and len(_records(local)) == n
    for i in range(n):
        for f in SAME_BYTES:
            a, b = remote / "samples" / f"{i:06d}" / f, local / "samples" / f"{i:06d}" / f
            assert a.read_bytes() == b.read_bytes(), (i, f)
    assert (remote / "coco.json").read_bytes() == (local / "coco.json").read_bytes()
    # a study through the same cluster (one worker left) gives the local study's table
    run = _run(["study", str(tmp_path / "study.toml"), "--out", str(tmp_path / "study-remote"), "--scheduler", addr],
               tmp_path / "study.log")
    assert run.wait(timeout=900) == 0, (tmp_path / "study.log").read_text()
    from rigsim.study import load_study, run_study

    run_study(load_study(tmp_path / "study.toml"), tmp_path / "study-local", serial=True, progress=False)
    a = (tmp_path / "study-remote" / "results.csv").read_text().splitlines()
    b = (tmp_path / "study-local" / "results.csv").read_text().splitlines()
    assert len(a) == len(b) >= 7

    def rows(lines):  # (the wall times differ)
        import csv

        out = []
        for r in csv.DictReader(lines):
            out.append({k: v for k, v in r.items() if "time" not in k})
        return sorted(out, key=lambda r: json.dumps(r, sort_keys=True))

    assert rows(a) == rows(b)
