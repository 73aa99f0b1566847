"""Study files and the study runner (armlab.study)."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import tomllib

import numpy as np
import pytest

import armlab
import armlab.kinematics
import armlab.trajectory
from armlab.errors import InputError, SpecError
from armlab.study import (
    apply_overrides,
    demo_study_path,
    load_study,
    parse_study,
    run_spec,
    run_study,
)
from armlab.study.build import build_robot
from armlab.study.figures import KEY_FIGURES
from armlab.study.spec import STAGES, check_key

DESIGN_KEYS = ("robot", "static_load", "trajectory", "sizing", "control", "tracking", "export")

QUICK = """
[study]
name = "quick"
stages = ["kinematics"]
report = true
[robot]
name = "teachbot6"
[payload]
mass_kg = 0.5
[waypoints]
unit = "deg"
joint = [[0, 0, 0, 0, 0, 0], [30, 10, 20, 0, 30, 0], [60, 20, 10, 45, -20, 90]]
[plan]
planner = "ptp"
"""


def quick_doc(**sections) -> dict:
    doc = tomllib.loads(QUICK)
    for k, v in sections.items():
        doc[k] = v
    return doc


# ---------------------------------------------------------------------------- parsing
def test_demo_study_parses_and_names_every_stage():
    spec = load_study(None)
    assert spec.robot.name == "teachbot6"
    assert spec.study.stages == STAGES
    assert spec.source == "<built-in demo>"
    assert demo_study_path().is_file()
    # reproducible: the same file gives the same hash
    assert load_study(None).hash == spec.hash


@pytest.mark.parametrize(
    "mutate, key",
    [
        (lambda d: d["plan"].update(speed_scal=0.5), "plan.speed_scal"),
        (lambda d: d.update(planner={"x": 1}), "planner"),
        (lambda d: d["payload"].update(mass_kg="heavy"), "payload.mass_kg"),
        (lambda d: d["payload"].update(mass_kg=-1.0), "payload.mass_kg"),
        (lambda d: d["plan"].update(speed_scale=0.0), "plan.speed_scale"),
        (lambda d: d["plan"].update(speed_scale=1.5), "plan.speed_scale"),
        (lambda d: d["plan"].update(planner="teleport"), "plan.planner"),
        (lambda d: d["waypoints"].update(unit="grad"), "waypoints.unit"),
        (lambda d: d["waypoints"].update(joint=[[0, 0], [1]]), "waypoints.joint"),
        (
            lambda d: d["waypoints"].update(cartesian=[[0.5, 0, 0.3, 0, 0, 0]] * 2),
            "waypoints.joint",
        ),
        (lambda d: d["study"].update(stages=["plan", "kinematics"]), "study.stages"),
        (lambda d: d["study"].update(stages=["kinematics", "fly"]), "study.stages[1]"),
        (lambda d: d["study"].update(seed=1.5), "study.seed"),
        (lambda d: d.update(drives={"joint2": {"ratio": 0}}), "drives.joint2.ratio"),
        (lambda d: d.update(drives={"joint2": {"gear": 100}}), "drives.joint2.gear"),
        (lambda d: d.update(controller={"cycle_s": 5.0}), "controller.cycle_s"),
        (lambda d: d.update(limits={"velocity_rad_s": [1.0, -1.0]}), "limits.velocity_rad_s[1]"),
        (lambda d: d.pop("robot"), "robot.name"),
        (lambda d: d["plan"].update(planner="line"), "plan.planner"),
    ],
)
def test_bad_study_names_the_key(mutate, key):
    doc = quick_doc()
    mutate(doc)
    with pytest.raises(SpecError) as err:
        parse_study(doc)
    assert str(err.value).startswith(key), str(err.value)
    assert "\n" not in str(err.value)


def test_check_key_and_overrides():
    for good in (
        "payload.mass_kg",
        "drives.joint2.ratio",
        "drives.joint3.motor",
        "controller.cycle_s",
        "control.position_bandwidth_rad_s",
        "plan.speed_scale",
    ):
        check_key(good)
    for bad in ("payload", "payload.mass", "drives.joint2", "drives.joint2.gear", "robots.name"):
        with pytest.raises(SpecError, match=bad.replace(".", r"\.")):
            check_key(bad)
    doc = quick_doc()
    new = apply_overrides(doc, {"payload.mass_kg": np.float64(1.25), "drives.joint2.ratio": 300})
    assert new["payload"]["mass_kg"] == 1.25 and type(new["payload"]["mass_kg"]) is float
    assert new["drives"]["joint2"]["ratio"] == 300
    assert "drives" not in doc  # the original is untouched
    assert parse_study(new).hash != parse_study(doc).hash


def test_study_file_errors(tmp_path):
    with pytest.raises(SpecError, match="not found"):
        load_study(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[robot\nname=")
    with pytest.raises(SpecError, match="not valid TOML"):
        load_study(bad)


# ---------------------------------------------------------------------------- robot
def test_drive_override_updates_the_derived_effort_limit(teachbot6):
    spec = parse_study(quick_doc(drives={"joint2": {"ratio": 300}, "joint5": {"motor": "55LYX04"}}))
    robot = build_robot(spec)
    d2 = robot.drives["joint2"]
    assert d2.reducer.ratio == 300
    # thesis table 4.3 rule, computed here independently: stall x ratio x efficiency x derating
    assert robot.limits.effort_Nm[1] == pytest.approx(0.28 * 300 * 0.6 * 0.8)
    assert robot.drives["joint5"].motor.model == "55LYX04"
    # the motor brings its maker derating (0.8, thesis table 4.3) along
    assert robot.drives["joint5"].derating == 0.8
    assert robot.limits.effort_Nm[4] == pytest.approx(0.28 * 298 * 0.6 * 0.8)
    # the description robot is untouched
    assert teachbot6.drives["joint2"].reducer.ratio == 410
    assert teachbot6.limits.effort_Nm[1] == pytest.approx(0.28 * 410 * 0.6 * 0.8)
    assert robot.limits.effort_Nm[0] == teachbot6.limits.effort_Nm[0]


def test_a_catalogue_motor_can_replace_a_joint_motor():
    from armlab.dynamics import load_catalogue

    path = load_catalogue().path  # read the file independently
    entry = next(
        m
        for m in tomllib.loads(open(path).read())["motor"]
        if m["model"] == "maxon RE 30 60 W 24 V"
    )
    spec = parse_study(quick_doc(drives={"joint3": {"motor": "maxon RE 30 60 W 24 V"}}))
    robot = build_robot(spec)
    assert robot.drives["joint3"].motor.torque_constant_Nm_A == entry["torque_constant_Nm_A"]
    assert robot.limits.effort_Nm[2] == pytest.approx(
        entry["stall_torque_Nm"] * 385 * 0.6 * entry.get("derating", 1.0)
    )


@pytest.mark.parametrize(
    "drives, limits, key",
    [
        ({"joint9": {"ratio": 100}}, {}, "drives.joint9"),
        ({"joint3": {"motor": "warp-drive"}}, {}, "drives.joint3.motor"),
        ({}, {"velocity_rad_s": [1.0, 1.0]}, "limits.velocity_rad_s"),
    ],
)
def test_bad_robot_changes_name_the_key(drives, limits, key):
    spec = parse_study(quick_doc(drives=drives, limits=limits))
    with pytest.raises(SpecError) as err:
        build_robot(spec)
    assert str(err.value).startswith(key)


def test_payload_and_limit_overrides():
    spec = parse_study(quick_doc(payload={"mass_kg": 1.5}, limits={"velocity_rad_s": 0.1}))
    robot = build_robot(spec)
    assert robot.payload.mass_kg == 1.5
    assert np.all(robot.limits.velocity_rad_s == 0.1)


# ---------------------------------------------------------------------------- running
def test_quick_study_writes_the_design_outputs(tmp_path, capsys):
    spec = parse_study(quick_doc())
    summary = run_study_doc(spec, tmp_path)
    on_disk = json.loads((tmp_path / "summary.json").read_text())
    for key in DESIGN_KEYS:
        assert key in on_disk and "status" in on_disk[key], key
    assert on_disk["robot"]["name"] == "teachbot6" and on_disk["robot"]["n_joints"] == 6
    assert on_disk["kinematics"]["status"] == "ok"
    assert on_disk["trajectory"]["status"] == "skipped"  # not in study.stages
    assert summary["study"]["stages"]["kinematics"]["status"] == "ok"
    report = (tmp_path / "report.md").read_text()
    assert "## Kinematics" in report and "3 waypoints" in report
    # the progress bar is silent without a terminal (pytest's stderr is not a TTY)
    assert capsys.readouterr().err == ""


def run_study_doc(spec, out):
    return run_spec(spec, out, progress=None).summary


def test_tcp_positions_are_the_forward_kinematics():
    spec = parse_study(quick_doc())
    res = run_spec(spec)
    q = np.radians(np.array(spec.waypoints.joint))
    tcp = np.array(res.summary["kinematics"]["tcp_positions_m"])
    expect = np.array([armlab.kinematics.fk(res.robot, row)[:3, 3] for row in q])
    np.testing.assert_allclose(tcp, expect, atol=1e-12)


def test_cartesian_waypoints_go_through_ik(teachbot6):
    q = np.radians([[0, 10, 20, 0, 30, 0], [40, 20, 30, 10, -40, 20]])
    rows = []
    for T in (armlab.kinematics.fk(teachbot6, r) for r in q):
        R = T[:3, :3]  # URDF roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll)
        pitch = -math.asin(R[2, 0])
        roll, yaw = math.atan2(R[2, 1], R[2, 2]), math.atan2(R[1, 0], R[0, 0])
        rows.append([*T[:3, 3], roll, pitch, yaw])
    doc = quick_doc(waypoints={"unit": "rad", "cartesian": rows})
    res = run_spec(parse_study(doc))
    kin = res.summary["kinematics"]
    assert kin["waypoints_from"] == "cartesian (IK)"
    q_ik = np.array(kin["waypoints_rad"])
    for row, qi in zip(q, q_ik, strict=True):  # same pose (maybe another branch)
        np.testing.assert_allclose(
            armlab.kinematics.fk(teachbot6, qi), armlab.kinematics.fk(teachbot6, row), atol=1e-9
        )


def test_waypoint_out_of_range_is_an_error_recorded_in_the_summary(tmp_path):
    doc = quick_doc()
    doc["waypoints"]["joint"][1][2] = 170.0  # joint3 range is -90 .. 160 deg
    with pytest.raises(InputError) as err:
        run_spec(parse_study(doc), tmp_path)
    msg = str(err.value)
    assert msg.startswith("kinematics: waypoints.joint[1]: joint3 = 170 deg")
    on_disk = json.loads((tmp_path / "summary.json").read_text())
    assert on_disk["kinematics"]["status"] == "error"
    assert "joint3" in on_disk["kinematics"]["error"]


def test_run_study_prints_a_one_screen_summary(tmp_path, capsys):
    path = tmp_path / "quick.toml"
    path.write_text(QUICK)
    summary = run_study(path, tmp_path / "out")
    out = capsys.readouterr().out
    decided, rest = out.split("armlab study 'quick'", 1)
    assert decided.startswith("decided before the first stage:")  # armlab.study.decisions
    assert "robot.tool_frame = tool0 (default: the frame named tool0)" in decided
    lines = ("armlab study 'quick'" + rest).strip().splitlines()
    assert len(lines) <= 24
    assert lines[0].startswith("armlab study 'quick': robot teachbot6")
    for stage in STAGES:
        assert any(line.strip().startswith(stage) for line in lines), stage
    assert "summary.json" in lines[-1]
    assert summary["study"]["source"] == str(path)


def test_cli_reports_a_bad_study_on_one_line(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(QUICK.replace('planner = "ptp"', 'planner = "ptp"\nspeed = 3'))
    proc = subprocess.run(
        [sys.executable, "-m", "armlab.cli", "run", str(bad), "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().count("\n") == 0
    assert "plan.speed: unknown key" in proc.stderr


# ---------------------------------------------------------------------------- key figures
def test_key_figures_of_a_study_that_plans_only():
    """The key figures come from the stages' typed results: the plan's duration and its peak
    ratio to each limit (the LimitReport's, recomputed here from the trajectory), NaN or None
    for every stage that did not run, and each stage's status."""
    spec = parse_study(quick_doc(study={"name": "kf", "stages": ["kinematics", "plan"]}))
    res = run_spec(spec)
    kf = res.key_figures()
    assert set(KEY_FIGURES) | {"sizing_binding", "verdict"} <= set(kf)  # what a sweep may plot
    traj, robot = res.trajectory, res.robot
    assert traj is not None
    assert kf["duration_s"] == pytest.approx(traj.duration, rel=1e-12)
    report = traj.check_limits(robot, dt=spec.plan.check_dt_s)
    assert kf["peak_velocity_ratio"] == pytest.approx(report.ratios["velocity"].max(), rel=1e-6)
    assert 0.0 < kf["peak_velocity_ratio"] <= 1.0 + 1e-6
    reach = max(np.linalg.norm(armlab.kinematics.fk(robot, q)[:2, 3]) for q in traj.q[::10])
    assert kf["max_reach_m"] >= reach - 1e-9  # no planned tool point is beyond the reach
    for name in ("max_static_torque_Nm", "sizing_min_margin", "min_phase_margin_deg"):
        assert math.isnan(kf[name]), name
    assert math.isnan(kf["tcp_max_error_m"]) and math.isnan(kf["n_cycles"])
    assert kf["sizing_ok"] is None and kf["sizing_binding"] == ""
    assert kf["stage_plan"] == "ok" and kf["stage_sizing"] == "skipped"
    assert kf["verdict"] == res.verdict == "pass" and kf["n_failed_checks"] == 0  # plan asked
    assert res.summary["key_figures"] == kf  # summary.json shows the same row


# ---------------------------------------------------------------------------- the whole chain
FULL = """
[study]
name = "full chain"
[robot]
name = "teachbot6"
[payload]
mass_kg = 0.5
[waypoints]
unit = "deg"
joint = [[0, 0, 0, 0, 0, 0], [20, 10, 15, 10, 20, 30], [0, 0, 0, 0, 0, 0]]
[plan]
planner = "ptp"
profile = "scurve"
[control]
n_inertia_samples = 30
[tracking]
feedforward = ["velocity", "acceleration", "gravity"]
"""


LOOPS = ("current", "speed", "position")


def gains_joints(summary: dict) -> list[str]:
    return [j for j in summary["robot"]["joint_names"] if j in summary["control"]]


def _key_figure_rows(report: str) -> dict[str, str]:
    """``figure -> value`` of the table under report.md's "## Key figures" heading."""
    section = report.split("## Key figures", 1)[1].split("\n## ", 1)[0]
    rows = [line.strip("|").split("|") for line in section.splitlines() if line.startswith("| ")]
    return {name.strip(): value.strip() for name, value in rows[1:]}  # the header row left out


def test_full_chain_outputs_are_what_independent_computations_give(tmp_path, capsys):
    """`armlab run` through every stage, then every output file checked against a computation
    that does not read the object that wrote it: sha256 of the bytes, the set-point table
    against the saved trajectory and encoder counts from drives.toml's own numbers, the
    summary's margins against python-control's on the saved gains, the tracking verdict by
    re-simulating from the folder's files alone; and `armlab export` takes the folder."""
    import hashlib
    import re
    from pathlib import Path

    import control as ct

    from armlab.cli import main
    from armlab.control import joint_plant, simulate_tracking
    from armlab.control.loops import CascadeModel
    from armlab.control.margins import freq_grid
    from armlab.control.plant import INERTIA_CASES, inertia_range
    from armlab.deploy import load_gains, load_trajectory, read_setpoints

    path = tmp_path / "full.toml"
    path.write_text(FULL)
    out = tmp_path / "out"
    assert main(["run", str(path), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert {s: i["status"] for s, i in summary["study"]["stages"].items()} == dict.fromkeys(
        ("robot", *STAGES), "ok"
    )
    assert printed.splitlines()[-1].startswith(f"files in {out}/")
    # report.md and every plot it shows
    report = (out / "report.md").read_text()
    shown = re.findall(r"^!\[.*\]\(([^)]+)\)$", report, flags=re.M)
    assert {"plan_profiles.png", "tracking_error.png", "tracking_drive_model.png"} <= set(shown)
    for png in shown:
        assert (out / png).is_file(), png
    # the report's key figures are the summary's (they were read before they were filled)
    figures = _key_figure_rows(report)
    kf = summary["key_figures"]
    assert set(figures) == {k for k in kf if not k.startswith("stage_")}
    for name in ("duration_s", "max_static_torque_Nm", "min_phase_margin_deg", "tcp_max_error_m"):
        assert float(figures[name]) == pytest.approx(kf[name], rel=5e-4), name  # 4 digits shown
    assert float(figures["n_cycles"]) == kf["n_cycles"] > 0
    assert figures["verdict"] == summary["design"]["verdict"] == "pass"
    # the key figures against the stage blocks (a separate rendering of the same results)
    margins = [
        (c["margin"], f"{j}:{c['name']}")
        for j in summary["robot"]["joint_names"]
        for c in summary["sizing"][j]["checks"]
        if c["margin"] is not None
    ]
    low = min(m for m, _ in margins)
    assert kf["sizing_min_margin"] == low
    assert (low, kf["sizing_binding"]) in margins  # a check with that margin (ties: the first)
    assert kf["sizing_ok"] is True
    loops = [summary["control"][j][loop] for j in gains_joints(summary) for loop in LOOPS]
    pm = [x for f in loops for x in (f["phase_margin_deg"], f["phase_margin_discrete_deg"])]
    assert kf["min_phase_margin_deg"] == pytest.approx(min(x for x in pm if x is not None))
    assert kf["max_static_torque_Nm"] == pytest.approx(
        max(summary["static_load"][j]["torque_Nm"] for j in summary["robot"]["joint_names"])
    )
    # each file's sha256 in the summary is the file's (computed here independently)
    files = summary["export"]["files"]
    assert set(files) == {"setpoints.csv", "gains.json", "trajectory.npz"}
    for name, info in files.items():
        assert hashlib.sha256((out / name).read_bytes()).hexdigest() == info["sha256"]
    # the set-point table is the saved trajectory sampled every cycle, in encoder counts
    # computed here from drives.toml's numbers (pulses x decoding x ratio / 2 pi)
    saved = load_trajectory(out / "trajectory.npz")
    table = read_setpoints(out / "setpoints.csv")
    q_saved = saved.at(table.t_s)[0]
    np.testing.assert_allclose(table.q_rad, q_saved, atol=1e-9)
    drives = tomllib.loads(
        (Path(armlab.__file__).parents[2] / "robot_desc/teachbot6/drives.toml").read_text()
    )["joint"]
    cpr = np.array(
        [
            d["encoder"]["pulses_per_rev"] * d["encoder"]["decoding"] * d["reducer"]["ratio"]
            for d in drives
        ]
    ) / (2 * math.pi)
    assert np.abs(table.counts - q_saved * cpr).max() <= 0.5 + 1e-6
    np.testing.assert_array_equal(np.diff(table.counts, axis=0), table.dcounts[1:])
    wp = np.radians(tomllib.loads(FULL)["waypoints"]["joint"])
    np.testing.assert_allclose(q_saved[0], wp[0], atol=1e-9)
    np.testing.assert_allclose(q_saved[-1], wp[-1], atol=1e-6)
    # the plan keeps every limit: velocity and acceleration of the saved trajectory on a fine
    # grid against the robot's limits, computed here
    robot = armlab.load_robot("teachbot6", payload_kg=0.5)
    tt = np.linspace(0.0, saved.duration, 4001)
    _, qd, qdd, _ = saved.at(tt)
    assert np.all(np.abs(qd) <= robot.limits.velocity_rad_s * (1 + 1e-6))
    # the summary's worst-case margin of joint 2's speed loop is python-control's
    # (ct.stability_margins, an independent implementation) over the inertia cases, on the
    # gains read back from gains.json
    gains = load_gains(out / "gains.json")
    inertias = inertia_range(robot, n_samples=30, seed=0)
    plant = joint_plant(robot, "joint2", inertias=inertias)
    pm = []
    for case in INERTIA_CASES:
        L = CascadeModel(plant.at(case), gains["joint2"]).open_loop("speed", discrete=True)
        _, p, _, _, _, _ = ct.stability_margins(ct.frd(L, freq_grid(L.dt, n=4000)))
        pm.append(p)
    assert summary["control"]["joint2"]["speed"]["phase_margin_discrete_deg"] == pytest.approx(
        min(pm), abs=0.5
    )
    assert min(pm) >= 45.0  # the study's (default) spec
    # the tracking verdict comes back from the folder's files alone
    res = simulate_tracking(
        robot,
        saved,
        gains,
        feedforward=("velocity", "acceleration", "gravity"),
        controller="reference_dda",
    )
    assert res.tcp_max_error_m == pytest.approx(summary["tracking"]["tcp"]["max_error_m"], rel=1e-9)
    assert summary["tracking"]["tcp"]["within_accuracy"] == (res.tcp_max_error_m <= 0.5e-3)
    for joint in summary["robot"]["joint_names"]:
        block = summary["sizing"][joint]
        for key in ("peak_torque_Nm", "rms_torque_Nm", "peak_speed_rad_s", "motor_peak_speed_rpm"):
            assert math.isfinite(block[key])
        assert {"name", "value", "limit", "margin", "ok"} <= set(block["checks"][0])
    # thesis tables 4.2/4.3: the drives are also sized against each joint's worst case
    req = summary["sizing"]["requirement_moves"]
    assert req["ok"] == (req["failures"] == [])
    assert "worst case (the thesis' requirements)" in report
    # the folder is what `armlab export` reads
    assert main(["export", str(out), "--format", "json", "--out", str(tmp_path / "x")]) == 0
    assert (tmp_path / "x").is_dir() and any((tmp_path / "x").iterdir())


def test_cartesian_line_study_starts_and_ends_at_the_waypoints():
    rows = [[0.42, 0.0, -0.10, 180, 0, 0], [0.42, 0.15, -0.10, 180, 0, 0]]
    doc = quick_doc(
        waypoints={"unit": "deg", "cartesian": rows},
        plan={"planner": "line", "speed_m_s": 0.05, "check_dt_s": 0.01},
    )
    doc["study"]["stages"] = ["kinematics", "plan"]
    res = run_spec(parse_study(doc))
    assert res.summary["trajectory"]["method"] == "line"
    tcp = armlab.kinematics.forward.tool_positions(res.robot, res.trajectory.q[[0, -1]])
    np.testing.assert_allclose(tcp, np.array(rows)[:, :3], atol=1e-9)
    # the straight line at 0.05 m/s takes at least its length / speed
    assert res.trajectory.duration >= 0.15 / 0.05


def test_a_plain_urdf_study_skips_the_drive_stages():
    from conftest import UR5_URDF

    doc = quick_doc(
        robot={"name": str(UR5_URDF)},
        waypoints={"unit": "deg", "joint": [[0, -90, 90, 0, 90, 0], [30, -70, 70, 20, 70, 10]]},
        limits={"acceleration_rad_s2": 5.0, "jerk_rad_s3": 50.0},
        payload={"mass_kg": 1.0},
    )
    doc["study"]["stages"] = ["kinematics", "plan", "sizing", "tuning", "export"]
    doc["plan"]["check_dt_s"] = 0.01
    res = run_spec(parse_study(doc))
    s = res.summary
    assert s["robot"]["name"] == "ur5_robot" and s["trajectory"]["status"] == "ok"
    for key in ("sizing", "control", "export"):
        assert s[key]["status"] == "skipped" and "no drives.toml" in s[key]["reason"]
    # the study's acceleration limit is the one the plan honoured
    assert s["trajectory"]["peak_ratio"]["acceleration"] <= 1 + 1e-6
    assert np.all(res.robot.limits.acceleration_rad_s2 == 5.0)


def test_design_verdict_from_the_stage_records():
    """A failed check fails the design; otherwise a judging stage that did not run leaves it
    incomplete (with the reason); advisories are listed but decide nothing."""
    from armlab.study.verdict import StageRecord, design_verdict

    asked = ("kinematics", "plan", "sizing")
    ok = {
        "kinematics": StageRecord("kinematics", "ok"),
        "plan": StageRecord("plan", "ok", "pass", advisories=("plan: note",)),
        "sizing": StageRecord("sizing", "ok", "pass"),
    }
    d = design_verdict(ok, asked)
    assert d.verdict == "pass" and d.advisories == ["plan: note"] and d.not_judged == []
    skipped = {**ok, "sizing": StageRecord("sizing", "skipped", reason="no drive train")}
    d = design_verdict(skipped, asked)
    assert d.verdict == "incomplete" and d.not_judged == ["sizing (no drive train)"]
    assert "NOT JUDGED: sizing (no drive train)" in d.lines()[0]
    failing = {**skipped, "plan": StageRecord("plan", "ok", "fail", failed_checks=("plan: x",))}
    d = design_verdict(failing, asked)
    assert d.verdict == "fail" and d.failed_checks == ["plan: x"]
    assert d.lines()[:2] == ["design: the design FAILS 1 check(s)", "  FAILED  plan: x"]
    d = design_verdict({"kinematics": ok["kinematics"]}, asked)  # stopped after kinematics
    assert d.not_judged == ["plan (not run)", "sizing (not run)"]
