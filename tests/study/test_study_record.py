"""One design, one answer: the study folder as one consistent record, the design's verdict, the
study's controller in every stage (issue: "one design, one answer").

Each test here reproduces a defect seen by a user and fails on the code before the fix:
export rebuilt the robot from robot_desc (drive overrides lost); sizing used its own 1 ms /
4095-pulse controller; a re-run left the earlier study's files beside the new ones; a failing
design reported every stage "ok", exported tables and exited 0.
"""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from armlab.cli import main as cli_main
from armlab.deploy import read_setpoints
from armlab.dynamics.checks import SizingOptions, checks_for_column, evaluate_checks
from armlab.errors import DesignFailure, InputError
from armlab.robot import load_profile
from armlab.robot.drivetrain import DriveTrain
from armlab.study import load_study, run_spec
from armlab.study.record import load_design, robot_from_design

STUDY = """
[study]
name = "record"
stages = ["kinematics", "plan", "sizing", "export"]
report = false
[robot]
name = "teachbot6"
[payload]
mass_kg = 0.5
[waypoints]
unit = "deg"
joint = [[0, 0, 0, 0, 0, 0], [40, 25, 20, 30, 30, 60]]
[plan]
planner = "ptp"
profile = "scurve"
"""


def write_study(folder: Path, extra: str = "", name: str = "study.toml") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(STUDY + extra)
    return path


def run(study: Path, out: Path, *flags: str) -> int:
    return cli_main(["run", str(study), "--out", str(out), *flags])


def summary_of(out: Path) -> dict:
    return json.loads((out / "summary.json").read_text())


# ---------------------------------------------------------------------------- 1: export == run
def test_export_reproduces_run_with_drive_overrides(tmp_path, capsys):
    study = write_study(tmp_path, "[drives.joint2]\nratio = 300\n")
    out = tmp_path / "run"
    assert run(study, out) == 0
    exported = tmp_path / "exported"
    assert cli_main(["export", str(out), "--format", "csv", "--out", str(exported)]) == 0
    # bit for bit: the same robot (ratio 300), limits and controller, rebuilt from design.json
    assert (exported / "setpoints.csv").read_bytes() == (out / "setpoints.csv").read_bytes()
    table = read_setpoints(out / "setpoints.csv")
    design = load_design(out)
    drive = design["drives"]["joint2"]
    assert drive["reducer"]["ratio"] == 300
    enc = drive["encoder"]
    counts_per_rad = enc["pulses_per_rev"] * enc["decoding"] * 300 / (2 * math.pi)
    q_end = math.radians(25)
    j = table.joint_names.index("joint2")
    assert table.counts[-1, j] == round(q_end * counts_per_rad)


def test_export_with_another_profile_says_what_differs(tmp_path, capsys):
    study = write_study(tmp_path)
    out = tmp_path / "run"
    assert run(study, out) == 0
    capsys.readouterr()
    code = cli_main(
        [
            "export",
            str(out),
            "--profile",
            "reference_dda_10ms",
            "--format",
            "csv",
            "--out",
            str(tmp_path / "x"),
        ]
    )
    assert code == 0
    err = capsys.readouterr().err
    assert "cycle_s 0.001 -> 0.01" in err
    assert read_setpoints(tmp_path / "x" / "setpoints.csv").cycle_s == pytest.approx(0.01)
    # never into the study folder: its setpoints.csv is the study's record
    assert cli_main(["export", str(out), "--profile", "reference_dda_10ms", "--out", str(out)]) == 2


# ---------------------------------------------------------------------------- 2: one controller
def test_sizing_encoder_checks_use_the_study_controller(tmp_path):
    spec = load_study(write_study(tmp_path, "[controller]\ncycle_s = 0.004\n"))
    res = run_spec(spec, None)
    sizing = res.context.sizing
    table = res.context.setpoints
    assert table.cycle_s == pytest.approx(0.004)
    peak_table = np.abs(table.dcounts).max(axis=0)
    for k, js in enumerate(sizing.joints):
        check = next(c for c in js.checks if c.name == "encoder_pulse_rate")
        assert check.limit == 4095
        # the sizing's peak counts per cycle is the table's (within a count of discretisation)
        assert check.value == pytest.approx(peak_table[k], rel=0.02, abs=1.5)
    # and the counts per joint revolution are the table's (one function for both)
    cpr = res.context.controller.counts_per_rad(res.context.robot) * 2 * math.pi
    assert [js.counts_per_joint_rev for js in sizing.joints] == pytest.approx(list(cpr))


def test_decoding_of_the_profile_reaches_sizing(tmp_path):
    base = run_spec(load_study(write_study(tmp_path)), None).context.sizing
    profile = tmp_path / "x2.toml"
    profile.write_text(
        'name = "x2"\ncycle_s = 0.001\nmax_pulses_per_cycle = 4095\ndecoding = 2\n'
        "servo_period_s = 0.001\n"
    )
    spec = load_study(write_study(tmp_path, '[controller]\nprofile = "x2.toml"\n', "s2.toml"))
    half = run_spec(spec, None).context.sizing
    for a, b in zip(base.joints, half.joints, strict=True):
        assert b.counts_per_joint_rev == pytest.approx(a.counts_per_joint_rev / 2)


def test_controller_servo_period_reaches_the_tuning(teachbot6):
    from armlab.control import tune_arm
    from armlab.robot import load_profile

    prof = load_profile().replace(servo_period_s=0.002)
    gains = tune_arm(teachbot6, controller=prof, n_inertia_samples=20)
    for g in gains.joints.values():
        assert g.speed.sample_time_s == 0.002 and g.position.sample_time_s == 0.002
    from armlab.errors import SpecError

    with pytest.raises(SpecError, match="controller profile"):
        tune_arm(teachbot6, controller=prof, speed_sample_time_s=0.001, n_inertia_samples=20)


# ---------------------------------------------------------------------------- 4: stale outputs
def test_run_into_another_studys_folder_is_refused(tmp_path, capsys):
    a = write_study(tmp_path, name="a.toml")
    b = tmp_path / "b.toml"
    b.write_text(STUDY.replace("[40, 25, 20, 30, 30, 60]", "[10, 5, 5, 0, 0, 0]"))
    out = tmp_path / "out"
    assert run(a, out) == 0
    first = (out / "setpoints.csv").read_bytes()
    capsys.readouterr()
    assert run(b, out) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert (out / "setpoints.csv").read_bytes() == first  # refused: nothing touched
    assert run(b, out, "--overwrite") == 0
    n_b = summary_of(out)["export"]["n_cycles"]
    exported = tmp_path / "e"
    assert cli_main(["export", str(out), "--out", str(exported)]) == 0
    assert read_setpoints(exported / "setpoints.csv").n_cycles == n_b
    # the same study again into its own folder is fine
    assert run(b, out) == 0


def test_folder_with_foreign_files_is_never_cleared(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    assert run(write_study(tmp_path), out, "--overwrite") == 2
    assert (out / "notes.txt").read_text() == "mine"


def test_export_refuses_a_folder_whose_files_changed(tmp_path):
    out = tmp_path / "run"
    assert run(write_study(tmp_path), out) == 0
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    (out / "trajectory.npz").write_bytes((tmp_path / "other.npz").read_bytes())
    with pytest.raises(InputError, match="trajectory.npz does not match the checksum"):
        from armlab.study import export_study

        export_study(out, "csv", out_dir=tmp_path / "e")
    (out / "summary.json").unlink()
    with pytest.raises(InputError, match="no summary.json"):
        export_study(out, "csv", out_dir=tmp_path / "e")


# ---------------------------------------------------------------------------- 5: verdict
FAILING = STUDY.replace('profile = "scurve"\n', 'profile = "scurve"\ntorque_limits = false\n') + (
    "[drives.joint2]\nratio = 15\n"
)


def failing_study(tmp_path: Path) -> Path:
    """joint 2 on a 15:1 reducer, planned without torque limits: its drive cannot hold the arm."""
    path = tmp_path / "failing.toml"
    path.write_text(FAILING)
    return path


def test_a_failing_design_is_not_ok(tmp_path, capsys):
    out = tmp_path / "out"
    assert run(failing_study(tmp_path), out) == 1
    err = capsys.readouterr().err
    assert "the design fails" in err and "joint2" in err
    s = summary_of(out)
    assert s["design"]["verdict"] == "fail"
    assert any("joint2" in f for f in s["design"]["failed_checks"])
    assert s["sizing"]["status"] == "ok" and s["sizing"]["verdict"] == "fail"
    assert s["study"]["stages"]["sizing"]["verdict"] == "fail"
    # no controller table for a failing design; export refused with the checks named
    assert not (out / "setpoints.csv").exists()
    with pytest.raises(DesignFailure, match="joint2"):
        from armlab.study import export_study

        export_study(out, "csv", out_dir=tmp_path / "e")
    assert cli_main(["export", str(out), "--out", str(tmp_path / "e")]) == 1
    assert not (tmp_path / "e" / "setpoints.csv").exists()
    # --force exports, and the file records what it was forced past
    assert cli_main(["export", str(out), "--force", "--out", str(tmp_path / "f")]) == 0
    text = (tmp_path / "f" / "setpoints.csv").read_text()
    assert "forced_despite" in text and "joint2" in text
    # the C export too: the header names the study file and states every failed check, the
    # data file holds the table (issue 23: an empty ARMLAB_SP_SOURCE_FILE and no checks)
    assert (
        cli_main(["export", str(out), "--format", "c", "--force", "--out", str(tmp_path / "c")])
        == 0
    )
    header = (tmp_path / "c" / "setpoints.h").read_text()
    failed = s["design"]["failed_checks"]
    assert f'#define ARMLAB_SP_SOURCE_FILE "{s["study"]["source"]}"' in header
    assert f'#define ARMLAB_SP_SOURCE_SHA256 "{s["study"]["hash"]}"' in header
    assert "#define ARMLAB_SP_FORCED 1" in header
    assert f"#define ARMLAB_SP_N_FAILED_CHECKS {len(failed)}" in header
    for check in failed:
        assert f" *   {check}" in header
    table = read_setpoints(tmp_path / "f" / "setpoints.csv")
    data = (tmp_path / "c" / "setpoints.c").read_text()
    rows = data.split("ARMLAB_SP_COUNTS[ARMLAB_SP_N_CYCLES][ARMLAB_SP_N_AXES] = {")[1]
    assert rows.split("};")[0].count("{") == table.n_cycles > 0


def test_run_force_writes_the_table_and_records_it(tmp_path):
    out = tmp_path / "out"
    assert run(failing_study(tmp_path), out, "--force") == 1
    text = (out / "setpoints.csv").read_text()
    assert "forced_despite" in text
    assert summary_of(out)["export"]["forced"] is True


def test_a_passing_design_passes(tmp_path):
    out = tmp_path / "out"
    assert run(write_study(tmp_path), out) == 0
    s = summary_of(out)
    assert s["design"]["verdict"] == "pass" and s["design"]["failed_checks"] == []
    assert s["export"]["written"] is True
    assert set(s["files"]) >= {"design.json", "trajectory.npz", "setpoints.csv"}


def test_check_against_a_zero_limit_says_so_in_words():
    from armlab.robot.drives import Drive, Encoder, Motor, Reducer

    m = Motor("m", 0.1, 3000.0, 1.0, 0.05, 0.05, 1.0, 1e-3, 1e-6, supply_voltage_V=24.0)
    r = Reducer("r", 100.0, 0.8, 50.0, 100.0, 5000.0)
    arr = DriveTrain.from_drives([Drive("j", m, r, Encoder(1000, 4), 1.0, 10.0)])
    # no-load speed 24 / 0.05 = 480 rad/s at the motor: 5 rad/s at the joint is 500 rad/s
    tau, qd = np.array([[1.0]]), np.array([[5.0]])
    res = evaluate_checks(
        tau, qd, np.zeros_like(tau), np.ones(1), arr, np.array([0.5]), SizingOptions(load_profile())
    )
    env = next(c for c in checks_for_column(res, 0) if c.name == "motor_envelope")
    assert not env.ok and env.limit == 0.0
    assert "no-load speed" in env.note and env.to_dict()["margin"] is None
    assert "no-load speed" in env.describe()


# ---------------------------------------------------------------------------- the record
def test_design_record_rebuilds_the_study_robot(tmp_path):
    path = write_study(tmp_path)
    doc = tomllib.loads(path.read_text())
    doc["robot"]["base_rpy_deg"] = [90.0, 0.0, 0.0]
    doc["payload"]["mass_kg"] = 1.25
    doc["drives"] = {"joint3": {"ratio": 80}, "joint2": {"amplifier": "maxon ESCON Module 50/5"}}
    # a wall-mounted teachbot6 cannot hold its arm on joint 1 (27 N m of gravity, 9.6 N m
    # available): the record is written before any stage, so the kinematics stage suffices
    doc["study"]["stages"] = ["kinematics"]
    from armlab.study import parse_study

    spec = parse_study(doc, base_dir=tmp_path, source="x")
    res = run_spec(spec, tmp_path / "out")
    robot = robot_from_design(load_design(tmp_path / "out"))
    ref = res.context.robot
    assert robot.payload.mass_kg == pytest.approx(1.25)
    assert robot.drives["joint3"].reducer.ratio == 80
    amp = ref.drives["joint2"].amplifier
    assert amp is not None and robot.drives["joint2"].amplifier == amp  # issue 28
    np.testing.assert_allclose(robot.transform_base_to_world, ref.transform_base_to_world)
    np.testing.assert_allclose(robot.model.gravity.linear, ref.model.gravity.linear)
    assert abs(robot.model.gravity.linear[2]) < 1e-9  # 90 deg about x: gravity along base y
    q = np.radians([10, 20, 30, 40, 50, 60])
    from armlab.robot.rigid_body import gravity_torques

    np.testing.assert_allclose(gravity_torques(robot, q), gravity_torques(ref, q), atol=1e-12)


def test_a_rerun_removes_the_earlier_runs_exports(tmp_path):
    from armlab.study import export_study

    study = write_study(tmp_path)
    out = tmp_path / "out"
    assert run(study, out) == 0
    written = export_study(out, "json").files  # default folder: out/export
    assert [p.parent.name for p in written] == ["export"]
    (out / "export" / "mine.txt").write_text("kept")
    assert run(study, out) == 0
    assert sorted(p.name for p in (out / "export").iterdir()) == ["mine.txt"]


def test_a_folder_left_with_partial_files_only_is_cleared(tmp_path):
    """A run killed after it cleared its folder and before it wrote its design record leaves
    at most partial files (``.*.tmp``) and no record: the next run clears them instead of
    taking them for another study's outputs; a real file of another study is still refused."""
    study = write_study(tmp_path)
    out = tmp_path / "out"
    out.mkdir()
    (out / ".setpoints.csv.dead.tmp").write_text("partial")
    assert run(study, out) == 0
    assert not list(out.glob(".*.tmp")) and (out / "summary.json").is_file()
    other = write_study(tmp_path, "[controller]\ncycle_s = 0.002\n", name="other.toml")
    assert run(other, out) == 2  # refused on one line ("holds the outputs of another study")
    assert (out / "summary.json").is_file()


def test_kill_9_at_random_moments_never_leaves_a_mixed_folder(tmp_path):
    """A study run killed at any moment leaves either no summary.json (export refuses the folder)
    or a folder whose files all match it; a re-run of the same study then completes."""
    import os
    import signal
    import subprocess
    import sys
    import time

    from armlab.study import export_study

    study = write_study(tmp_path)
    out = tmp_path / "out"
    rng = np.random.default_rng(3)
    env = {**os.environ, "MPLBACKEND": "Agg"}
    cmd = [sys.executable, "-m", "armlab.cli", "run", str(study), "--out", str(out)]
    assert subprocess.run(cmd, env=env, capture_output=True).returncode == 0
    for delay in rng.uniform(0.05, 4.0, 4):
        proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(delay)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        if (out / "summary.json").is_file():
            export_study(out, "csv", out_dir=tmp_path / "e")  # consistent: checksums match
        else:
            with pytest.raises(InputError, match="no summary.json"):
                export_study(out, "csv", out_dir=tmp_path / "e")
        # the same study re-runs into its own folder (stale .tmp files cleared)
        (out / ".setpoints.csv.dead.tmp").write_text("partial")
        assert subprocess.run(cmd, env=env, capture_output=True).returncode == 0
        assert not list(out.glob(".*.tmp"))
        export_study(out, "csv", out_dir=tmp_path / "e")
