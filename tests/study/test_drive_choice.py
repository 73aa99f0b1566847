"""Issue 25 items 2-3: a drive selection that passes every stage, and advice that was tried.

From a bare URDF and a short study with ``[sizing] select = true``, UR10 with 5 kg reaches a
verdict (before: the shoulder's AKM42E could not be tuned at the 50 us current period, exit 2);
``armlab drives`` then ``armlab run`` with its file give the same verdict (before: the
selection was judged on a plan made without its limits); a failing design lists remedies that
were measured, each reproduced by running its keys; a payload x speed sweep has no error rows;
xArm7, a Kinova arm and SO-101 reach a verdict; ``[drives.<joint>]`` works beside
``select = true``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from armlab.cli import main
from armlab.dynamics import size
from armlab.errors import InfeasibleError
from armlab.robot.catalogue import load_catalogue
from armlab.robot.drives_file import read_drives
from armlab.study.drive_stages import selection_duty
from armlab.study.remedies import Remedy
from armlab.study.report import summary_text
from armlab.study.runner import run_spec
from armlab.study.spec import load_study, parse_study
from armlab.sweep import parse_sweep
from armlab.sweep.spec import parameter_key, parameter_sets
from armlab.sweep.task import run_parameter_set

UR10 = "erd:ur_description/urdf/ur10_robot.urdf"

#: the short study of the issue: waypoints, payload, acceleration / jerk, select = true (2
#: inertia samples and no report keep it fast). allow_estimated: the catalogue has no UR10-class
#: motor read from a published sheet yet (its Kollmorgen AKM values are marked estimated,
#: docs/catalogue.md); read parts alone leave the shoulder without a pair, one line saying so
#: (test_read_parts_alone_name_what_allow_estimated_would_add)
UR10_STUDY = f"""
[study]
name = "UR10 5 kg"
report = false
[robot]
name = "{UR10}"
[payload]
mass_kg = 5.0
[limits]
acceleration_rad_s2 = 3.0
jerk_rad_s3 = 30.0
[waypoints]
unit = "deg"
joint = [[0, -90, 90, -90, -90, 0], [60, -60, 60, -90, -90, 30], [0, -90, 90, -90, -90, 0]]
[plan]
planner = "ptp"
[sizing]
select = true
allow_estimated = true
[control]
n_inertia_samples = 2
[tracking]
feedforward = ["computed_torque", "efficiency"]
"""


@pytest.fixture(scope="module")
def ur10(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("ur10") / "ur10.toml"
    path.write_text(UR10_STUDY)
    return path


@pytest.fixture(scope="module")
def ur10_run(ur10):
    return run_spec(load_study(ur10))


def _values(report) -> list[float]:
    return [c.value for j in report.joints for c in j.checks]


def test_ur10_with_5_kg_reaches_a_verdict_with_every_chosen_drive_tuned(ur10_run):
    res = ur10_run
    for stage in ("plan", "sizing", "tuning", "tracking", "export"):
        assert res.stages[stage].status == "ok", (stage, res.stages[stage].note)
    assert res.verdict in ("pass", "fail")
    sel = res.context.selection
    # select -> limits -> plan ran until the choice was stable: at least the first selection
    # (on the plan without drives) and one on the plan its drives produce
    assert 2 <= sel.rounds <= 6
    assert res.summary["sizing"]["selection"]["rounds"] == sel.rounds
    assert res.summary["sizing"]["verdict"] == "pass"
    # the sizing is on the plan the chosen drives produce: the plan was made with their limits
    vel = res.context.robot.limits.velocity_rad_s
    assert np.all(np.max(np.abs(res.trajectory.qd), axis=0) <= vel * (1 + 1e-9))
    # every candidate passed over names why; a tuning skip names the loop and its margin, and
    # the skipped pair is not the one installed
    for joint, lines in sel.skipped.items():
        drive = res.context.robot.drives[joint]
        for line in lines:
            pair, why = line.split(": ", 1)
            assert why.startswith(("tuning:", "tracking")), line
            if why.startswith("tuning:"):
                assert "loop" in why and "margin" in why
                assert pair != f"{drive.motor.model} + {drive.reducer.model}"
    # each chosen drive's loops meet the spec at the controller's periods
    pm = res.context.gains.spec["phase_margin_deg"]
    for gains in res.context.gains.joints.values():
        for loop in gains.loops().values():
            assert loop.phase_margin_deg >= pm - 1e-6
            assert loop.phase_margin_discrete_deg >= pm - 1e-6


def test_drives_then_run_gives_the_same_verdict(ur10, ur10_run, tmp_path):
    out = tmp_path / "drives.toml"
    assert main(["drives", UR10, str(ur10), "--out", str(out)]) == 0
    ctx = ur10_run.context
    assert read_drives(out, ctx.robot.joint_names) == ctx.robot.drives  # every number
    study = tmp_path / "with_drives.toml"
    study.write_text(
        UR10_STUDY.replace("select = true", "select = false").replace(
            f'name = "{UR10}"', f'name = "{UR10}"\ndrives = "{out}"'
        )
    )
    again = run_spec(load_study(study))
    assert again.verdict == ur10_run.verdict
    assert again.failed_checks == ur10_run.failed_checks
    # the same plan (both made with the chosen drives' limits), so the same sizing: the run's
    # on its plan passes, and on the selection's duty cycle (plan + holds) it gives the
    # selection's numbers
    assert math.isclose(again.trajectory.duration, ur10_run.trajectory.duration, rel_tol=1e-12)
    np.testing.assert_allclose(again.trajectory.q, ur10_run.trajectory.q, rtol=0, atol=1e-12)
    assert again.summary["sizing"]["verdict"] == "pass"
    duty = selection_duty(again.context)
    resized = size(
        again.robot, duty, dt=again.spec.plan.check_dt_s, controller=again.context.controller
    )
    np.testing.assert_allclose(_values(resized), _values(ur10_run.context.sizing), rtol=1e-9)
    assert math.isclose(
        again.context.tracking.tcp_max_error_m,
        ur10_run.context.tracking.tcp_max_error_m,
        rel_tol=1e-9,
    )


#: the built-in teachbot6 study, short and with velocity feed-forward only: it fails tracking
#: (0.77 mm > 0.5 mm)
FAILING_DEMO = {
    "study.report": False,
    "plan.planner": "ptp",
    "kinematics.workspace_samples": 0,
    "kinematics.accuracy_samples": 0,
    "control.n_inertia_samples": 20,
    "tracking.feedforward": ["velocity"],
}


@pytest.mark.slow  # 7-14 s (2 shared cores): the failing study, 2 remedy runs, 1 again
def test_a_failing_design_lists_remedies_that_were_measured():
    res = run_spec(load_study(None, FAILING_DEMO), remedies=2)
    assert res.verdict == "fail" and "tracking" in res.failed_checks[0]
    block = res.summary["remedies"]
    measured = block["measured"]
    assert block["limit"] == 2 and 1 <= len(measured) <= 2 < block["candidates"]
    ranks = [Remedy(r["keys"], r["why"], r["verdict"], r["tcp_error_m"]).rank() for r in measured]
    assert ranks == sorted(ranks)  # passing first, then by TCP error
    before = res.context.tracking.tcp_max_error_m
    for r in measured:
        assert r["tcp_error_before_m"] == pytest.approx(before, rel=1e-12)
        assert f"{before * 1e3:.3g} -> {r['tcp_error_m'] * 1e3:.3g} mm" in r["text"]
        assert r["text"].startswith("`[")
    # the outcome of the best is what its keys give in a study run of their own
    best = measured[0]
    again = run_spec(load_study(None, {**FAILING_DEMO, **best["keys"]}))
    assert again.verdict == best["verdict"]
    assert math.isclose(again.context.tracking.tcp_max_error_m, best["tcp_error_m"], rel_tol=1e-9)
    text = summary_text(res)
    assert "remedies:" in text and best["text"] in text
    # no advice that was not tried: the diagnosis names only what it measured
    assert "next:" not in " ".join(res.failed_checks)


@pytest.mark.slow  # 20-28 s (2 shared cores): four UR10 studies
def test_payload_by_speed_sweep_on_ur10_has_no_error_rows(ur10):
    sweep = parse_sweep(
        {
            "sweep": {"study": str(ur10)},
            "set": {"waypoints.joint": [[0, -90, 90, -90, -90, 0], [60, -60, 60, -90, -90, 30]]},
            "parameter": [
                {"key": "payload.mass_kg", "values": [2.0, 5.0]},
                {"key": "plan.speed_scale", "values": [0.5, 1.0]},
            ],
        }
    )
    rows = [
        run_parameter_set(
            sweep.study_document, str(sweep.study_dir), str(ur10), p, parameter_key(p)
        )
        for p in parameter_sets(sweep)
    ]
    assert len(rows) == 4
    for row in rows:
        assert row["status"] == "done", row["error"]


_ARMS = {
    # no tool frame and no controller profile: the study's decisions derive them (the URDF's
    # eef / end_effector frame; dda_n_axis for 7 and 5 axes); Kinova's continuous joints load
    "xarm7": (
        'name = "erd:xarm_description/urdf/xarm7.urdf"',
        1.0,
        "[[0, -30, 0, 30, 0, 60, 0], [40, -10, 20, 60, 20, 70, 30]]",
        ("link_eef", "dda_n_axis"),
    ),
    "kinova": (
        'name = "erd:kinova_description/robots/kinova.urdf"',
        0.5,
        "[[0, 180, 180, 0, 180, 0], [40, 150, 150, 30, 150, 30]]",
        ("j2s6s200_end_effector", "reference_dda"),
    ),
    "so101": (
        'name = "erd:so_arm_description/urdf/so101.urdf"\nlock_joints = ["gripper"]',
        0.1,
        "[[0, 0, 0, 0, 0], [40, 20, -20, 20, 30]]",
        (None, "dda_n_axis"),
    ),
}


@pytest.mark.parametrize("arm", sorted(_ARMS))
def test_other_arms_reach_a_verdict_from_a_short_study(arm, tmp_path):
    robot, payload, joints, (tool, profile) = _ARMS[arm]
    doc = f"""
[study]
name = "{arm}"
report = false
[robot]
{robot}
[payload]
mass_kg = {payload}
[limits]
acceleration_rad_s2 = 3.0
jerk_rad_s3 = 30.0
[waypoints]
unit = "deg"
joint = {joints}
[plan]
planner = "ptp"
[sizing]
select = true
[control]
n_inertia_samples = 2
"""
    study = tmp_path / "study.toml"
    study.write_text(doc)
    res = run_spec(load_study(study))
    for stage in ("plan", "sizing", "tuning", "tracking", "export"):
        assert res.stages[stage].status == "ok", (stage, res.stages[stage].note)
    assert res.verdict in ("pass", "fail")
    assert res.summary["sizing"]["verdict"] == "pass"
    assert res.context.controller.name == profile
    if tool is not None:
        assert res.robot.tool_frame == tool
    sel = res.context.selection
    error = res.context.tracking.tcp_max_error_m
    for joint, lines in sel.skipped.items():  # a tracking miss moved a joint up: the rule
        drive = res.context.robot.drives[joint]
        for line in lines:
            if "tracking" in line:
                # the choice kept tracks no worse than one passed over for its tracking
                missed_mm = float(line.split(": tracking ", 1)[1].split(" mm", 1)[0])
                assert error * 1e3 <= missed_mm * (1 + 1e-2), line
                torque, inertia = (
                    float(part.split(" ", 1)[0]) for part in line.split("more than ")[1:]
                )
                assert drive.available_torque_Nm > torque * (
                    1 - 1e-3
                ) or drive.reflected_inertia_kg_m2 > inertia * (1 - 1e-3), line


def test_a_joint_override_works_beside_select(tmp_path):
    """``[drives.<joint>]`` beside ``select = true`` (before: refused, every joint needed a
    table): the joint is selected from the reducer it names, with its encoder; the others are
    selected freely."""
    doc = UR10_STUDY.replace(
        "[control]",
        '[drives.elbow_joint]\nreducer = "Harmonic Drive CSG-40-100-2A"\npulses_per_rev = 2048\n'
        "[control]",
    )
    spec = parse_study(
        {**_toml(doc), "study": {"stages": ["kinematics", "plan", "static_load", "sizing"]}},
        base_dir=tmp_path,
    )
    res = run_spec(spec)
    drives = res.context.robot.drives
    assert drives["elbow_joint"].reducer.model == "Harmonic Drive CSG-40-100-2A"
    assert drives["elbow_joint"].encoder.pulses_per_rev == 2048
    assert drives["shoulder_pan_joint"].encoder.pulses_per_rev == 1000  # the assumed encoder
    chosen = res.context.selection.joint("elbow_joint").chosen
    assert chosen is not None and chosen.reducer.model == "Harmonic Drive CSG-40-100-2A"
    assert res.summary["sizing"]["verdict"] == "pass"
    # an unknown name is one line naming the key
    bad = {**_toml(doc), "drives": {"elbow_joint": {"reducer": "no such reducer"}}}
    with pytest.raises(Exception, match=r"drives\.elbow_joint\.reducer"):
        run_spec(parse_study(bad, base_dir=tmp_path))


def test_a_choice_that_cycles_stops_with_one_line(tmp_path, monkeypatch):
    """A selection whose plans keep choosing the other drive stops with one line naming the
    rounds and the joints that change (a stand-in selection alternates the wrist-3 reducer)."""
    import armlab.dynamics as dynamics
    from armlab.study.stages import selection_for_study

    real = dynamics.select_drives
    calls = []

    def alternating(robot, duty, **kw):
        calls.append(1)
        rules = dict(kw.pop("candidates") or {})
        ratio = 100.0 if len(calls) % 2 else 160.0
        rules["wrist_3_joint"] = lambda d: d if math.isclose(d.reducer.ratio, ratio) else None
        return real(robot, duty, candidates=rules, **kw)

    monkeypatch.setattr(dynamics, "select_drives", alternating)
    spec = parse_study(
        {**_toml(UR10_STUDY), "study": {"stages": ["kinematics", "plan", "static_load"]}},
        base_dir=tmp_path,
    )
    line = r"^drive selection cycles: round \d chooses the drives of round \d again \(wrist_3"
    with pytest.raises(InfeasibleError, match=line):
        selection_for_study(spec)


def _toml(text: str) -> dict:
    import tomllib

    return tomllib.loads(text)


def test_read_parts_alone_name_what_allow_estimated_would_add(tmp_path):
    """With read parts only, the UR10 shoulder has no pair: one line naming the joint, the
    closest pair and how many estimated pairs the study left out."""
    study = tmp_path / "ur10.toml"
    study.write_text(UR10_STUDY.replace("allow_estimated = true", "allow_estimated = false"))
    with pytest.raises(InfeasibleError) as exc:
        run_spec(load_study(study))
    msg = str(exc.value)
    assert "\n" not in msg and "shoulder_lift_joint" in msg
    cat = load_catalogue()
    left_out = len(cat.combinations(True)) - len(cat.combinations(False))
    assert f"{left_out} catalogue pairs with estimated values were left out" in msg
