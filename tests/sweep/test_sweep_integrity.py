"""Sweeps that cannot mix stale rows: provenance of every row, one sweep and one client per
folder, the exit status of ``armlab sweep``, and a client killed with SIGKILL."""

from __future__ import annotations

import json
import os
import random
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

import armlab
from armlab.cli import main
from armlab.deploy.provenance import file_sha256
from armlab.errors import InputError
from armlab.io.lock import SweepLock
from armlab.sweep import load_sweep, run_sweep_spec
from armlab.sweep.provenance import PROVENANCE_FIELDS
from armlab.sweep.spec import parameter_key, parameter_sets
from armlab.sweep.task import run_parameter_set
from cases import quick_study
from conftest import REPO, start_sweep


def write_sweep(
    folder: Path,
    values: list,
    *,
    key: str = "payload.mass_kg",
    robot: str = "teachbot6",
    samples: int = 0,
    stages: list[str] | None = None,
    name: str = "sweep.toml",
) -> Path:
    """A study file and a sweep file over one parameter in ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "study.toml").write_text(
        quick_study("integrity", robot=robot, accuracy_samples=samples)
    )
    extra = "" if stages is None else f'[set]\n"study.stages" = {json.dumps(stages)}\n'
    path = folder / name
    path.write_text(
        f"""
[sweep]
name = "integrity"
study = "study.toml"
figures = ["duration_s"]
{extra}
[[parameter]]
key = "{key}"
values = {json.dumps(values)}
"""
    )
    return path


def cli(args: list[str], client) -> int:
    """``armlab sweep ARGS`` in this process, on the module's cluster."""
    return main(["sweep", *args, "--scheduler", client.scheduler.address])


def parts_of(out: Path) -> dict[str, float]:
    """{key: finished_at} of the part files; each must be a complete one-row table."""
    rows = {}
    for part in (out / "results.parts").glob("*.parquet"):
        df = pd.read_parquet(part)
        assert len(df) == 1 and df["key"].iloc[0] == part.stem
        rows[part.stem] = float(df["finished_at"].iloc[0])
    return rows


# ---------------------------------------------------------------------------- provenance
def test_rows_and_sweep_json_record_their_inputs_and_a_changed_drives_file_reruns(
    tmp_path, client, capsys
):
    from armlab.robot.catalogue import default_catalogue_path
    from armlab.robot.controller import profiles_dir

    # two copies of teachbot6, one row each
    robots = [tmp_path / "robot_a", tmp_path / "robot_b"]
    for folder in robots:
        shutil.copytree(REPO / "robot_desc" / "teachbot6", folder)
    urdfs = [f"{r.name}/teachbot6.urdf" for r in robots]
    path = write_sweep(tmp_path, urdfs, key="robot.name", robot=urdfs[0])
    spec = load_sweep(path)
    out = tmp_path / "out"
    df = run_sweep_spec(spec, out, client=client, quiet=True)
    meta = json.loads((out / "sweep.json").read_text())
    assert meta["armlab_version"] == armlab.__version__
    assert meta["study_file_sha256"] == file_sha256(tmp_path / "study.toml")
    assert meta["sweep_file_sha256"] == file_sha256(path)
    inputs = {k: v["sha256"] for k, v in meta["inputs"].items()}
    assert inputs["urdf"] == file_sha256(robots[0] / "teachbot6.urdf")
    assert inputs["drives"] == file_sha256(robots[0] / "drives.toml")
    assert inputs["mdh"] == file_sha256(robots[0] / "mdh.toml")
    assert inputs["catalogue"] == file_sha256(default_catalogue_path())
    assert inputs["profile"] == file_sha256(profiles_dir() / "reference_dda.toml")
    assert meta["set_keys"] == [parameter_key(s) for s in parameter_sets(spec)]
    # every row carries its provenance, computed on the worker that ran it
    assert set(PROVENANCE_FIELDS) <= set(df.columns) and (df["status"] == "done").all()
    assert (df["armlab_version"] == armlab.__version__).all()
    for name in ("urdf", "drives", "mdh", "catalogue", "profile"):
        assert (df[f"{name}_sha256"] == inputs[name]).all(), name  # identical copies
    assert df["inputs_sha256"].is_unique  # the parameter set is part of it
    # every worker has loaded robot_b (a worker process keeps the robots it loaded)
    warm = client.run(
        run_parameter_set,
        spec.study_document,
        str(spec.study_dir),
        spec.study_source,
        {"robot.name": urdfs[1]},
        "warm-up",
    )
    assert [row["status"] for row in warm.values()] == ["done", "done"]
    # slower joint 1 in robot_b: the same command reruns its row only, with the new drives
    drives = robots[1] / "drives.toml"
    drives.write_text(
        drives.read_text().replace("acceleration_rad_s2 = 3.5", "acceleration_rad_s2 = 1.0", 1)
    )
    capsys.readouterr()
    df2 = run_sweep_spec(load_sweep(path), out, client=client, quiet=True)
    err = capsys.readouterr().err
    assert "1 row(s) were computed from other inputs (drives.toml (sha256" in err
    assert list(df2["finished_at"] == df["finished_at"]) == [True, False]
    assert list(df2["drives_sha256"]) == [inputs["drives"], file_sha256(drives)]
    # no worker plans with the robot it loaded before the edit
    assert df2["duration_s"][1] > df["duration_s"][1] + 0.1
    assert df2["duration_s"][0] == df["duration_s"][0]
    disk = pd.read_parquet(out / "results.parquet").set_index("key")
    assert disk.loc[df2["key"], "drives_sha256"].tolist() == df2["drives_sha256"].tolist()
    # nothing changed since: nothing runs
    df3 = run_sweep_spec(load_sweep(path), out, client=client, quiet=True)
    pd.testing.assert_series_equal(df3["finished_at"], df2["finished_at"])
    assert "other inputs" not in capsys.readouterr().err


def test_an_armlab_upgrade_reruns_every_row(tmp_path, monkeypatch):
    """In-process workers (threads) so that the 'upgrade' reaches them too."""
    from distributed import Client, LocalCluster

    path = write_sweep(tmp_path, [0.0, 0.5])
    out = tmp_path / "out"
    with (
        LocalCluster(
            n_workers=1, threads_per_worker=1, processes=False, dashboard_address=":0"
        ) as cluster,
        Client(cluster) as c,
    ):
        df = run_sweep_spec(load_sweep(path), out, client=c, quiet=True)
        monkeypatch.setattr(armlab, "__version__", "99.0")
        df2 = run_sweep_spec(load_sweep(path), out, client=c, quiet=True)
    assert (df["armlab_version"] != "99.0").all() and (df2["armlab_version"] == "99.0").all()
    assert (df2["finished_at"].to_numpy() > df["finished_at"].to_numpy()).all()
    assert json.loads((out / "sweep.json").read_text())["armlab_version"] == "99.0"


def test_a_worker_with_other_inputs_gives_error_rows(tmp_path, client, monkeypatch):
    """The client 'upgraded', its worker processes not: their rows are errors saying so."""
    path = write_sweep(tmp_path, [0.0])
    monkeypatch.setattr(armlab, "__version__", "99.0")
    df = run_sweep_spec(load_sweep(path), tmp_path / "out", client=client, quiet=True)
    assert list(df["status"]) == ["error"]
    msg = df["error"].iloc[0]
    assert msg.startswith("InputError: this worker reads other inputs than the client")
    assert "armlab version 99.0 -> " in msg


# ---------------------------------------------------------------------------- one sweep
def test_another_sweep_in_the_folder_is_refused_unless_overwrite(tmp_path, client, capsys):
    a = write_sweep(tmp_path, [300, 410], key="drives.joint2.ratio", name="a.toml")
    b = write_sweep(tmp_path, [350, 450, 500], key="drives.joint2.ratio", name="b.toml")
    out = tmp_path / "out"
    assert cli([str(a), "--out", str(out)], client) == 0
    keys_a = set(pd.read_parquet(out / "results.parquet")["key"])
    capsys.readouterr()
    assert cli([str(b), "--out", str(out)], client) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holds another sweep over the same keys" in err
    assert "2 parameter sets, 0 of them in this sweep's 3" in err and "--overwrite" in err
    assert set(pd.read_parquet(out / "results.parquet")["key"]) == keys_a  # untouched
    assert cli([str(b), "--out", str(out), "--overwrite"], client) == 0
    keys_b = {parameter_key(s) for s in parameter_sets(load_sweep(b))}
    assert set(pd.read_parquet(out / "results.parquet")["key"]) == keys_b
    assert set(parts_of(out)) == keys_b
    assert json.loads((out / "sweep.json").read_text())["n_sets"] == 3
    # the same definition under another name is the same sweep: resumed, not refused
    c = b.with_name("c.toml")
    c.write_text(b.read_text().replace('name = "integrity"', 'name = "renamed"'))
    capsys.readouterr()
    assert cli([str(c), "--out", str(out)], client) == 0
    assert "0 run now" in capsys.readouterr().out


def _zombie() -> subprocess.Popen:
    """A child process that has ended and is not reaped yet."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        stat = Path(f"/proc/{proc.pid}/stat").read_text()
        if stat[stat.rfind(")") + 2] == "Z":
            break
        time.sleep(0.01)
    return proc


def test_the_lock_refuses_a_live_client_and_takes_over_from_a_dead_one(tmp_path):
    path = write_sweep(tmp_path, [0.0])
    out = tmp_path / "out"
    out.mkdir()
    with SweepLock(out) as lock:
        info = json.loads(lock.path.read_text())
        assert info["pid"] == os.getpid() and info["host"] == socket.gethostname()
        with pytest.raises(
            InputError, match=f"another armlab sweep writes here \\(pid {os.getpid()}"
        ):
            run_sweep_spec(load_sweep(path), out, quiet=True)
    assert not (out / ".sweep.lock").exists()
    # a lock of a process that is gone: taken over
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (out / ".sweep.lock").write_text(
        json.dumps({"pid": dead.pid, "host": socket.gethostname(), "started_at": time.time()})
    )
    with SweepLock(out) as lock:
        assert json.loads(lock.path.read_text())["pid"] == os.getpid()
    # a recycled pid (this process, but another start time) and a zombie (a killed client its
    # parent has not reaped yet) are gone too
    zombie = _zombie()
    for pid, start in [(os.getpid(), info["proc_start"] - 1), (zombie.pid, None)]:
        holder = {"pid": pid, "host": socket.gethostname(), "started_at": 0, "proc_start": start}
        (out / ".sweep.lock").write_text(json.dumps(holder))
        with SweepLock(out) as lock:
            assert json.loads(lock.path.read_text())["pid"] == os.getpid()
    zombie.wait()
    # another host's lock cannot be checked: refused, naming the file to delete
    (out / ".sweep.lock").write_text(
        json.dumps({"pid": 1, "host": "elsewhere.invalid", "started_at": time.time()})
    )
    with pytest.raises(InputError, match="on elsewhere.invalid .*delete it if that sweep is gone"):
        SweepLock(out).acquire()


# A client that tries to take the lock once, all of them at the same moment, and keeps it.
RACER = """
import sys, time
from pathlib import Path
from armlab.errors import InputError
from armlab.io.lock import SweepLock
folder, go = Path(sys.argv[1]), Path(sys.argv[2])
print("ready", flush=True)
while not go.exists():
    time.sleep(0.001)
try:
    SweepLock(folder).acquire()
    print("taken")
except InputError:
    print("refused")
"""


def test_clients_racing_for_a_stale_lock_take_it_once(tmp_path):
    out, go = tmp_path / "out", tmp_path / "go"
    out.mkdir()
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (out / ".sweep.lock").write_text(
        json.dumps({"pid": dead.pid, "host": socket.gethostname(), "started_at": 0})
    )
    racers = [
        subprocess.Popen(
            [sys.executable, "-c", RACER, str(out), str(go)], stdout=subprocess.PIPE, text=True
        )
        for _ in range(3)
    ]
    for r in racers:
        assert r.stdout is not None and r.stdout.readline().strip() == "ready"
    go.touch()
    outcome = sorted(r.communicate(timeout=120)[0].strip() for r in racers)
    assert outcome == ["refused", "refused", "taken"]
    assert [p.name for p in out.iterdir()] == [".sweep.lock"]


# ---------------------------------------------------------------------------- exit status
def test_exit_status_counts_error_rows_and_failing_designs(tmp_path, client, capsys):
    # mostly errors: no motor holds 25 or 30 kg (the plan refuses those sets)
    errors = write_sweep(tmp_path / "e", [0.0, 25.0, 30.0])
    assert cli([str(errors), "--out", str(tmp_path / "e" / "out")], client) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("armlab: sweep: 2 of 3 rows are errors, 0 designs fail")
    # every row done, one design fails its sizing (1 kg is too much for the drives)
    stages = ["kinematics", "plan", "static_load", "sizing"]
    failing = write_sweep(tmp_path / "f", [0.0, 1.0], stages=stages)
    assert cli([str(failing), "--out", str(tmp_path / "f" / "out")], client) == 1
    err = capsys.readouterr().err
    assert "0 of 2 rows are errors, 1 designs fail, 0 not judged" in err
    # the Python API still returns the rows
    df = run_sweep_spec(load_sweep(failing), tmp_path / "f" / "out", client=client, quiet=True)
    assert list(df["verdict"]) == ["pass", "fail"] and (df["status"] == "done").all()
    # every design passes: 0; bad input: 2
    passing = write_sweep(tmp_path / "p", [0.0, 0.5])
    assert cli([str(passing), "--out", str(tmp_path / "p" / "out")], client) == 0
    assert cli([str(tmp_path / "nowhere.toml"), "--out", str(tmp_path / "x")], client) == 2


# ---------------------------------------------------------------------------- kill -9
def _kill_tree(proc: subprocess.Popen) -> int:
    """SIGKILL the sweep client (no cleanup runs), then the cluster processes it started;
    returns the client's exit status (-9 unless it had ended by itself)."""
    import psutil

    try:
        children = psutil.Process(proc.pid).children(recursive=True)
    except psutil.Error:
        children = []
    proc.kill()
    proc.communicate()
    for child in children:
        try:
            child.kill()
        except psutil.Error:
            pass
    psutil.wait_procs(children, timeout=30)
    return proc.returncode


def test_kill_9_at_a_random_moment_loses_and_doubles_nothing(tmp_path, client, capsys):
    """A client killed with SIGKILL (no handler, no cleanup) after a random number of rows and
    a random delay; the same command then finishes the sweep. The seed is in every message."""
    seed = random.randrange(1 << 30)
    rng = random.Random(seed)
    path = write_sweep(tmp_path, [0.0, 0.25, 0.5, 0.75], samples=20000)  # ~1 s a study
    path.write_text(
        path.read_text() + '[[parameter]]\nkey = "drives.joint2.ratio"\nvalues = [300, 410, 450]\n'
    )
    out = tmp_path / "out"
    keys = {parameter_key(s) for s in parameter_sets(load_sweep(path))}
    assert len(keys) == 12
    proc = start_sweep([str(path), "--workers", "2"], out, rows=1)
    try:
        # a second client on the folder while the first runs: refused, one line naming it
        capsys.readouterr()
        assert cli([str(path), "--out", str(out)], client) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"(pid {proc.pid} on" in err, (seed, err)
        # the moment: after a random number of rows, plus a random delay
        rows = rng.randint(1, 11)
        deadline = time.monotonic() + 120
        while len(list((out / "results.parts").glob("*.parquet"))) < rows:
            assert proc.poll() is None and time.monotonic() < deadline, seed
            time.sleep(0.005)
        time.sleep(rng.uniform(0.0, 0.3))
    finally:
        killed = _kill_tree(proc) == -signal.SIGKILL
    # only complete files under their final names: the part files are the record
    before = parts_of(out)
    assert set(before) <= keys, seed
    if (out / "results.parquet").is_file():
        table = pd.read_parquet(out / "results.parquet")
        assert table["key"].is_unique and set(table["key"]) <= set(before), seed
    json.loads((out / "sweep.json").read_text())
    if killed and len(before) < 12:  # killed mid-sweep: its lock is left behind
        assert (out / ".sweep.lock").is_file(), seed
    # the same command again: the dead client's lock is taken over, only the rest runs
    capsys.readouterr()
    assert cli([str(path), "--out", str(out)], client) == 0, seed
    text = capsys.readouterr().out
    assert f"{len(before)} already in" in text and f"{12 - len(before)} run now" in text, seed
    df = pd.read_parquet(out / "results.parquet")
    assert len(df) == 12 and set(df["key"]) == keys and df["key"].is_unique, seed
    assert (df["status"] == "done").all(), seed
    after = parts_of(out)
    assert set(after) == keys, seed
    assert {k: after[k] for k in before} == before, seed  # rows done were not run again
    assert not (out / ".sweep.lock").exists(), seed
    assert not list(out.rglob(".*.tmp")), seed  # temporaries of the killed writes removed
