"""One writer per study folder (issue 24, item 2): ``armlab run`` and ``armlab export`` lock the
folder they write (``DIR/.armlab.lock``, the sweep's lock implementation, :mod:`armlab.io.lock`);
a second client is refused with exit 2 and one line naming the holder."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time

import pytest

from armlab.cli import main
from armlab.io.lock import STUDY_LOCK_NAME, FolderLock
from cases import quick_study
from conftest import sweep_env

#: a study whose folder export accepts: plan + set-point table (teachbot6 has drives)
STAGES = ("kinematics", "plan", "export")


def _study(tmp_path, name: str, scale: float = 1.0, report: bool = False) -> str:
    text = quick_study(name, STAGES, report=report)
    if scale != 1.0:
        text = text.replace('planner = "ptp"', f'planner = "ptp"\nspeed_scale = {scale}')
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return str(path)


def _hashes(folder) -> tuple[str, str]:
    """(design.json's study sha256, summary.json's study hash) of a study folder."""
    design = json.loads((folder / "design.json").read_text())
    summary = json.loads((folder / "summary.json").read_text())
    return design["study"]["sha256"], summary["study"]["hash"]


def test_a_run_or_export_into_a_locked_folder_is_refused_naming_the_holder(tmp_path, capsys):
    study = _study(tmp_path, "a")
    out = tmp_path / "out"
    assert main(["run", study, "--out", str(out)]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    capsys.readouterr()
    with FolderLock(out, "armlab run") as lock:
        info = json.loads(lock.path.read_text())
        assert info["pid"] == os.getpid() and info["command"] == "armlab run"
        assert main(["run", study, "--out", str(out)]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"another armlab run writes here (pid {os.getpid()}" in err[0]
        # export reads the folder: refused while a run holds it, nothing written
        assert main(["export", str(out), "--out", str(tmp_path / "exp")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "another armlab run writes here" in err[0]
        assert not (tmp_path / "exp").exists()
    # the refused clients left the folder as the run wrote it; the lock is gone with its holder
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    # an export's own out folder is locked as well
    exp = tmp_path / "exp"
    exp.mkdir()
    with FolderLock(exp, "armlab export"):
        assert main(["export", str(out), "--out", str(exp)]) == 2
        assert "another armlab export writes here" in capsys.readouterr().err
    assert main(["export", str(out), "--out", str(exp)]) == 0
    assert (exp / "setpoints.csv").is_file() and not (exp / STUDY_LOCK_NAME).exists()


def test_a_dead_runs_lock_is_taken_over(tmp_path):
    study = _study(tmp_path, "a")
    out = tmp_path / "out"
    out.mkdir()
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    holder = {"command": "armlab run", "pid": dead.pid, "host": socket.gethostname()}
    (out / STUDY_LOCK_NAME).write_text(json.dumps({**holder, "started_at": time.time()}))
    assert main(["run", study, "--out", str(out)]) == 0
    assert not (out / STUDY_LOCK_NAME).exists()
    design_hash, summary_hash = _hashes(out)
    assert design_hash == summary_hash


def _armlab(*args: str) -> subprocess.Popen:
    cmd = [sys.executable, "-m", "armlab.cli", *args]
    return subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=sweep_env()
    )


@pytest.mark.slow
def test_two_runs_racing_into_one_folder_leave_a_refusal_or_a_consistent_folder(tmp_path):
    """Issue 24 item 2: ``armlab run A --out C`` and ``armlab run B --out C --overwrite`` started
    together, 10 times. Every run ends 0 (A and B pass) or is refused with exit 2 and one line;
    no traceback; the folder holds one run's files (design.json's study hash is summary.json's)
    and ``armlab export`` accepts it. (Before the lock: 2 of 10 trials left B's design.json
    beside A's summary.json.)"""
    # with the report's plots: a longer run, and the .tmp files a second run used to remove
    a = _study(tmp_path, "a", report=True)
    b = _study(tmp_path, "b", scale=0.5, report=True)
    refusals = ("another armlab run writes here", "holds the outputs of another study")
    for trial in range(10):
        out = tmp_path / f"c{trial}"
        first = _armlab("run", a, "--out", str(out))
        if trial % 2:  # the second one a little later on odd trials
            time.sleep(0.3)
        second = _armlab("run", b, "--out", str(out), "--overwrite")
        results = [(p.wait(timeout=600), *p.communicate()) for p in (first, second)]
        for code, _, err in results:
            assert "Traceback" not in err, err
            if code == 2:
                lines = err.strip().splitlines()
                assert len(lines) == 1 and any(r in lines[0] for r in refusals), err
            else:
                assert code == 0, err
        assert any(code == 0 for code, _, _ in results)
        design_hash, summary_hash = _hashes(out)
        assert design_hash == summary_hash
        exp = _armlab("export", str(out), "--out", str(tmp_path / f"e{trial}"))
        code, _, err = exp.wait(timeout=600), *exp.communicate()
        assert code == 0, err
        assert not (out / STUDY_LOCK_NAME).exists()


def test_export_refuses_a_summary_and_a_design_of_two_studies(tmp_path, capsys):
    """What two runs racing into one folder used to leave (A's summary.json beside B's
    design.json, every checksum matching): export refuses it in one line."""
    from armlab.deploy.provenance import file_sha256

    a, b = tmp_path / "a", tmp_path / "b"
    assert main(["run", _study(tmp_path, "a"), "--out", str(a)]) == 0
    assert main(["run", _study(tmp_path, "b", scale=0.5), "--out", str(b)]) == 0
    for name in ("design.json", "trajectory.npz"):  # B's files into A's folder
        (a / name).write_bytes((b / name).read_bytes())
    summary = json.loads((a / "summary.json").read_text())
    summary["files"].update({n: file_sha256(a / n) for n in ("design.json", "trajectory.npz")})
    (a / "summary.json").write_text(json.dumps(summary))
    capsys.readouterr()
    assert main(["export", str(a), "--out", str(tmp_path / "exp")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "two runs wrote into this folder" in err[0]
    assert not (tmp_path / "exp").exists()
