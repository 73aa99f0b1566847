"""``armlab export`` re-checks, never trusts (issue 24, item 3): an edited study record (with
its checksums put right) ends in a refusal or in a table that is right for the edited design.

The attacks of the issue: design.json's joint 2 ratio 410 -> 820 / 8200 / 24600 with the new
sha256 in summary.json (export commanded 2025 / 20145 / 60405 motor rpm against a 1500 rpm
motor), and a failing study whose summary.json says ``design.verdict = "pass"``.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from armlab.cli import main
from armlab.deploy.provenance import file_sha256
from armlab.deploy.table import read_setpoints
from armlab.robot.drives import Drive, Encoder
from armlab.robot.drives_file import motor_from_dict, reducer_from_dict
from cases import one_line, quick_study

#: relative tolerance of the motor-speed comparison (the pre-flight's speed tolerance is 1e-6)
SPEED_RTOL = 1e-6


def _run(tmp_path, name: str, stages, extra: str = "") -> object:
    study = tmp_path / f"{name}.toml"
    study.write_text(quick_study(name, stages) + extra)
    out = tmp_path / name
    code = main(["run", str(study), "--out", str(out)])
    return out, code


def _rewrite(folder, name: str, edit) -> None:
    """Edit ``folder/name`` (JSON) and put its new sha256 into summary.json, as an attacker
    who knows the format would."""
    path = folder / name
    data = json.loads(path.read_text())
    edit(data)
    path.write_text(json.dumps(data, indent=2))
    if name != "summary.json":
        summary = json.loads((folder / "summary.json").read_text())
        summary["files"][name] = file_sha256(path)
        (folder / "summary.json").write_text(json.dumps(summary, indent=2))


def _drive(d: dict) -> Drive:
    """The drive of a design.json entry, built independently of the export."""
    nn = {k: v for k, v in d["motor"].items() if v is not None}
    rn = {k: v for k, v in d["reducer"].items() if v is not None}
    return Drive(
        joint=d["joint"],
        motor=motor_from_dict(nn),
        reducer=reducer_from_dict(rn),
        encoder=Encoder(**d["encoder"]),
    )


@pytest.mark.parametrize("ratio", [820, 8200, 24600])
def test_an_edited_ratio_is_refused_or_exported_within_the_motor_speed(tmp_path, capsys, ratio):
    out, code = _run(tmp_path, "a", ("kinematics", "plan", "export"))
    assert code == 0
    assert json.loads((out / "design.json").read_text())["drives"]["joint2"]["reducer"][
        "ratio"
    ] == pytest.approx(410)

    def edit(record):
        record["drives"]["joint2"]["reducer"]["ratio"] = ratio

    _rewrite(out, "design.json", edit)
    capsys.readouterr()
    exp = tmp_path / "exp"
    code = main(["export", str(out), "--out", str(exp)])
    if code != 0:
        assert code in (1, 2)
        line = one_line(capsys)
        assert "joint2" in line and "speed" in line
        assert not exp.exists() or not any(exp.iterdir())
        return
    # a table was written: it must be right for the edited design (ratio, motor speed limit)
    drive = _drive(json.loads((out / "design.json").read_text())["drives"]["joint2"])
    table = read_setpoints(exp / "setpoints.csv")
    j = table.joint_names.index("joint2")
    cpr = drive.encoder.pulses_per_rev * drive.encoder.decoding * ratio / (2 * math.pi)
    assert table.counts_per_rad[j] == pytest.approx(cpr, rel=1e-12)
    motor_speed = np.max(np.abs(table.dcounts[:, j])) / table.cycle_s / cpr * ratio
    assert motor_speed <= drive.motor_speed_limit_rad_s * (1 + SPEED_RTOL)


#: a payload teachbot6's reducers cannot carry (joint5 reducer peak and average torque): the
#: sizing stage fails, the plan (inside the joint torque limits) does not
HEAVY = "[payload]\nmass_kg = 2.0\n"


def _failing_study(tmp_path):
    out, code = _run(tmp_path, "heavy", ("kinematics", "plan", "sizing", "export"), HEAVY)
    summary = json.loads((out / "summary.json").read_text())
    assert code == 1 and summary["design"]["verdict"] == "fail"
    assert summary["sizing"]["verdict"] == "fail" and not (out / "setpoints.csv").exists()
    return out


def test_a_failing_study_edited_to_pass_is_refused(tmp_path, capsys):
    out = _failing_study(tmp_path)

    def edit(summary):
        summary["design"].update(verdict="pass", failed_checks=[])

    _rewrite(out, "summary.json", edit)
    capsys.readouterr()
    code = main(["export", str(out), "--out", str(tmp_path / "exp")])
    assert code in (1, 2)
    line = one_line(capsys)
    assert "sizing" in line
    assert not (tmp_path / "exp" / "setpoints.csv").exists()


def test_a_failing_study_whose_stage_results_are_edited_to_pass_is_judged_again(tmp_path, capsys):
    """Every verdict in summary.json set to pass: the sizing is re-run with design.json's
    drive train on the recorded plan, and fails again."""
    out = _failing_study(tmp_path)

    def edit(summary):
        summary["design"].update(verdict="pass", failed_checks=[])
        summary["sizing"].update(verdict="pass", failed_checks=[])
        summary["study"]["stages"]["sizing"]["verdict"] = "pass"

    _rewrite(out, "summary.json", edit)
    capsys.readouterr()
    code = main(["export", str(out), "--out", str(tmp_path / "exp")])
    assert code == 1
    line = one_line(capsys)
    assert "export refused" in line and "sizing: " in line
    assert not (tmp_path / "exp" / "setpoints.csv").exists()


def test_an_edited_sizing_grid_is_refused_before_it_is_allocated(tmp_path, capsys):
    """A sizing grid of 1 ns in design.json's study document (checksum put right) would be
    ~1e9 samples when export re-runs the sizing: refused by its estimate
    (armlab.study.budget), one line naming it. (An edited controller cycle is refused by the
    profile's own range check.)"""
    out, code = _run(tmp_path, "g", ("kinematics", "plan", "sizing", "export"))
    assert code == 0

    def edit(record):
        record["study"]["document"]["plan"]["check_dt_s"] = 1e-9

    _rewrite(out, "design.json", edit)
    capsys.readouterr()
    assert main(["export", str(out), "--out", str(tmp_path / "exp")]) == 2
    line = one_line(capsys)
    assert "plan.check_dt_s = 1e-09" in line and "time samples" in line


def test_a_study_without_sizing_is_held_to_the_drives_peak_torque(tmp_path, capsys):
    """A study that did not size its drives: export still re-checks the hardware limits of
    design.json's drive train along the plan (peak motor torque, motor and reducer speed,
    pulse rate). joint2's derating edited to 0.01 (checksum put right): its motor can give 1 %
    of its peak torque, far below what the plan needs -- refused, the check named."""
    out, code = _run(tmp_path, "t", ("kinematics", "plan", "export"))
    assert code == 0

    def edit(record):
        record["drives"]["joint2"]["derating"] = 0.01

    _rewrite(out, "design.json", edit)
    capsys.readouterr()
    assert main(["export", str(out), "--out", str(tmp_path / "exp")]) == 1
    line = one_line(capsys)
    assert "export refused" in line and "sizing: joint2 motor_peak_torque" in line
    assert not (tmp_path / "exp" / "setpoints.csv").exists()


def test_an_edited_scene_is_checked_again_at_export(tmp_path, capsys):
    """The collision check runs again at export, on the recorded study's scene: a floor put
    0.3 m above the base in design.json's study document (checksum put right) -- links of the
    arm pass below it -- is refused in one line naming the floor; the unedited folder exports."""
    out, code = _run(tmp_path, "floor", ["kinematics", "plan", "export"])
    assert code == 0
    assert main(["export", str(out), "--format", "csv", "--out", str(tmp_path / "ok")]) == 0
    capsys.readouterr()

    def edit(record):
        record["study"]["document"].setdefault("robot", {})["floor_z_m"] = 0.3

    _rewrite(out, "design.json", edit)
    assert main(["export", str(out), "--format", "csv", "--out", str(tmp_path / "x")]) == 1
    line = one_line(capsys)
    assert "plan: the recorded plan collides" in line and "floor" in line
    assert not (tmp_path / "x" / "setpoints.csv").exists()
