"""A sweep through a real Dask cluster (scheduler and workers as separate processes) that loses
a worker mid-sweep, then resumes with nothing left to do."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from cases import quick_study
from conftest import start_sweep, sweep_env

DASK = [sys.executable, "-m", "dask"]
ARMLAB = [sys.executable, "-m", "armlab.cli"]

# Each study does real work (the Monte-Carlo accuracy study of thesis 3.7 and a short plan) so
# that the 24 studies take a few seconds on two workers: long enough to kill one mid-sweep.
STUDY = quick_study("dask quick", ("kinematics", "plan"), accuracy_samples=20000)

SWEEP = """
[sweep]
name = "dask kill test"
study = "study.toml"
figures = ["max_reach_m"]
[[parameter]]
key = "payload.mass_kg"
values = [0.0, 0.25, 0.5, 0.75]
[[parameter]]
key = "drives.joint2.ratio"
values = [300, 350, 410]
[[parameter]]
key = "plan.speed_scale"
values = [0.5, 1.0]
"""


def _start(cmd, log: Path) -> subprocess.Popen:
    return subprocess.Popen(
        cmd, stdout=log.open("w"), stderr=subprocess.STDOUT, start_new_session=True
    )


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()


@pytest.fixture
def cluster(tmp_path):
    """(address, [worker processes]): a scheduler and two single-thread workers on 127.0.0.1."""
    from distributed import Client

    sched_file = tmp_path / "scheduler.json"
    procs = [
        _start(
            [
                *DASK,
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--no-dashboard",
                "--scheduler-file",
                str(sched_file),
                "--idle-timeout",
                "300",
            ],
            tmp_path / "scheduler.log",
        )
    ]
    try:
        deadline = time.monotonic() + 60
        while not sched_file.is_file() and time.monotonic() < deadline:
            time.sleep(0.1)
        address = json.loads(sched_file.read_text())["address"]
        workers = [
            _start(
                [
                    *DASK,
                    "worker",
                    address,
                    "--host",
                    "127.0.0.1",
                    "--nthreads",
                    "1",
                    "--no-nanny",
                    "--no-dashboard",
                    "--name",
                    f"w{i}",
                    "--death-timeout",
                    "60",
                ],
                tmp_path / f"worker{i}.log",
            )
            for i in range(2)
        ]
        procs += workers
        with Client(address, timeout="30s") as c:
            c.wait_for_workers(2, timeout=60)
        yield address, workers
    finally:
        for p in reversed(procs):
            _stop(p)


def test_sweep_survives_a_dead_worker_and_resumes(tmp_path, cluster):
    address, workers = cluster
    (tmp_path / "study.toml").write_text(STUDY)
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(SWEEP)
    out = tmp_path / "out"
    proc = start_sweep([str(sweep), "--scheduler", address], out, rows=3)
    victim = workers[0]
    victim.send_signal(signal.SIGKILL)  # the worker dies with its task in hand
    killed_at = time.time()
    n_done = len(list((out / "results.parts").glob("*.parquet")))  # rows before the kill
    stdout, stderr = proc.communicate(timeout=180)
    assert proc.returncode == 0, stderr
    assert n_done < 24  # the kill came mid-sweep
    df = pd.read_parquet(out / "results.parquet")
    assert len(df) == 24 and df["key"].is_unique
    assert (df["status"] == "done").all(), df[df["status"] != "done"]["error"].tolist()
    assert "24 done, 0 error; 24 run now" in stdout
    # the studies ran in the two worker processes we started (host:pid), and after the kill
    # only the surviving one finished studies
    pids = {int(w.rsplit(":", 1)[1]) for w in df["worker"]}
    assert pids <= {w.pid for w in workers} and workers[1].pid in pids
    late = df[df["finished_at"] > killed_at + 0.5]
    assert len(late) > 0
    assert not late["worker"].str.endswith(f":{victim.pid}").any()
    # the same command again runs nothing new
    again = subprocess.run(proc.args, capture_output=True, text=True, env=sweep_env(), timeout=120)
    assert again.returncode == 0, again.stderr
    assert "0 run now" in again.stdout and "24 already in" in again.stdout
    df2 = pd.read_parquet(out / "results.parquet")
    pd.testing.assert_frame_equal(
        df2.sort_values("key").reset_index(drop=True), df.sort_values("key").reset_index(drop=True)
    )
