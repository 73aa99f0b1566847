"""Decide early, say it (issue 25 item 5): the controller's axis count, the tool frame, the
locked and continuous joints and the derived defaults are resolved and validated before the
first stage, printed first by ``armlab run`` and kept in summary.json."""

from __future__ import annotations

import json

import pytest

from armlab.cli import main
from armlab.errors import SpecError
from armlab.study import load_study, run_spec
from cases import one_line

XARM7 = "erd:xarm_description/urdf/xarm7.urdf"


def xarm_study(tmp_path, controller: str = "", stages=("kinematics", "plan")) -> str:
    path = tmp_path / "xarm.toml"
    path.write_text(
        f"""[study]
name = "xarm7"
stages = {json.dumps(list(stages))}
[robot]
name = "{XARM7}"
[limits]
acceleration_rad_s2 = 3.0
jerk_rad_s3 = 30.0
[waypoints]
unit = "deg"
joint = [[0, 0, 0, 30, 0, 30, 0], [40, 20, 10, 60, 10, 40, 20]]
[plan]
planner = "ptp"
[kinematics]
workspace_samples = 20
accuracy_samples = 20
{controller}"""
    )
    return str(path)


def decisions(summary: dict) -> dict[str, dict]:
    return {d["key"]: d for d in summary["robot"]["decisions"]}


def test_a_seven_axis_arm_gets_a_controller_for_seven_axes_and_says_so(tmp_path):
    result = run_spec(load_study(xarm_study(tmp_path)))
    assert result.context is not None
    assert result.context.controller.name == "dda_n_axis"
    index, _ = result.context.controller.axes(result.robot)
    assert len(index) == 7
    made = decisions(result.summary)
    assert made["controller.profile"]["value"] == "dda_n_axis"
    assert made["controller.profile"]["how"].startswith("derived: xarm7 has 7 joints")
    assert made["robot.tool_frame"]["value"] == "link_eef"
    assert made["robot.tool_frame"]["how"].startswith("default:")
    assert made["limits.acceleration"]["value"].startswith("study [limits]")


def test_a_profile_that_cannot_drive_the_arm_is_refused_before_any_stage(tmp_path):
    path = xarm_study(
        tmp_path,
        '[controller]\nprofile = "reference_dda"\n',
        stages=("kinematics", "plan", "static_load", "export"),
    )
    out = tmp_path / "out"
    with pytest.raises(SpecError, match=r"^robot: controller\.profile: .*dda_n_axis"):
        run_spec(load_study(path), out)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["study"]["stages"]["robot"]["status"] == "error"
    assert "kinematics" not in summary["study"]["stages"]  # no stage ran
    assert not (out / "trajectory.npz").exists()


def test_the_cli_prints_the_decisions_before_the_stages(tmp_path, capsys):
    assert main(["run", xarm_study(tmp_path), "--out", str(tmp_path / "o")]) in (0, 1)
    printed = capsys.readouterr().out
    first, table = printed.index("decided before the first stage:"), printed.index("  stage ")
    assert first < table
    assert "controller.profile = dda_n_axis (derived:" in printed
    assert "robot.tool_frame = link_eef (default:" in printed


def test_a_refused_profile_is_one_line_on_the_cli(tmp_path, capsys):
    path = xarm_study(tmp_path, '[controller]\nprofile = "reference_dda"\n')
    assert main(["run", path, "--out", str(tmp_path / "o")]) == 2
    line = one_line(capsys)
    assert "controller.profile" in line and "7" in line


def test_the_demo_states_its_choices(tmp_path):
    from armlab.study.spec import demo_study_path

    result = run_spec(load_study(demo_study_path(), {"study.stages": ["kinematics"]}))
    made = decisions(result.summary)
    assert made["controller.profile"] == {
        "key": "controller.profile",
        "value": "reference_dda",
        "how": "study",
    }
    assert made["robot.tool_frame"]["value"] == "tool0"
    assert made["drives"]["value"] == "the description's drives.toml"
