"""Continuous joints and the default tool frame (issue 25 item 5): a continuous joint with
``<limit lower upper>`` is a revolute joint over that range, one without is unbounded; the tool
frame the URDF implies is chosen by a stated rule, never silently a finger tip."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from armlab.cli import main
from armlab.deploy.table import read_setpoints
from armlab.robot import load_robot
from armlab.robot.model import robot_desc_dir

KINOVA = "erd:kinova_description/robots/kinova.urdf"
URDF = robot_desc_dir() / "teachbot6" / "teachbot6.urdf"
JOINT1_LIMIT = '<limit lower="-2.96705972839036" upper="2.96705972839036"'


@pytest.fixture(scope="module")
def unbounded_arm(tmp_path_factory) -> Path:
    """teachbot6 with joint 1 continuous and no range (its drives file beside it)."""
    folder = tmp_path_factory.mktemp("contarm")
    text = URDF.read_text()
    assert JOINT1_LIMIT in text and 'name="joint1" type="revolute"' in text
    text = text.replace('name="joint1" type="revolute"', 'name="joint1" type="continuous"')
    text = text.replace(JOINT1_LIMIT, "<limit", 1)
    (folder / "contarm.urdf").write_text(text)
    (folder / "drives.toml").write_text((URDF.parent / "drives.toml").read_text())
    return folder / "contarm.urdf"


def test_continuous_joints_with_limits_load_as_revolute_over_their_range():
    robot = load_robot(KINOVA)  # refused before issue 25 ("give continuous joints limits")
    assert robot.continuous_joints == {
        "j2s6s200_joint_1": True,
        "j2s6s200_joint_4": True,
        "j2s6s200_joint_6": True,
    }
    assert robot.model.nq == robot.model.nv == 6  # one angle each, not (cos, sin)
    for j in robot.continuous_joints:
        i = robot.joint_names.index(j)
        # the URDF's <limit lower="-6.28318530718" upper="6.28318530718">
        assert robot.limits.lower_rad[i] == pytest.approx(-6.28318530718, abs=1e-12)
        assert robot.limits.upper_rad[i] == pytest.approx(6.28318530718, abs=1e-12)
    assert not robot.limits.unbounded.any()


def test_a_continuous_joint_without_range_is_unbounded(unbounded_arm):
    robot = load_robot(unbounded_arm)
    assert robot.continuous_joints == {"joint1": False}
    assert robot.limits.unbounded.tolist() == [True] + [False] * 5
    assert math.isinf(robot.limits.upper_rad[0]) and robot.limits.upper_rad[0] > 0
    # poses and seeds are drawn from one turn
    q = robot.random_q(np.random.default_rng(1), 500)
    assert np.all(np.abs(q[:, 0]) <= math.pi) and np.ptp(q[:, 0]) > math.pi
    assert robot.limits.centre_rad[0] == 0.0
    assert robot.within_limits(np.array([10.0, 0, 0, 0, 0, 0]))  # 10 rad: no limit
    assert not robot.within_limits(np.array([0, 10.0, 0, 0, 0, 0]))


def test_an_unbounded_joint_plans_and_exports_past_any_turn(unbounded_arm, tmp_path, capsys):
    study = tmp_path / "study.toml"
    study.write_text(
        f"""[study]
name = "unbounded"
stages = ["kinematics", "plan", "export"]
[robot]
name = "{unbounded_arm}"
[waypoints]
unit = "deg"
joint = [[0, 0, 0, 0, 0, 0], [200, 20, 30, 0, 40, 0]]
[plan]
planner = "ptp"
[kinematics]
workspace_samples = 50
accuracy_samples = 50
"""
    )
    out = tmp_path / "out"
    assert main(["run", str(study), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "joint joint1 = unbounded" in printed
    assert main(["export", str(out), "--format", "cia402", "--out", str(tmp_path / "c")]) == 0
    rows = (tmp_path / "c" / "cia402_objects.csv").read_text().splitlines()
    limits = [r.split(",") for r in rows if ",joint1,0x607D," in r]
    # no software position limit: the whole INTEGER32 range
    assert [int(r[6]) for r in limits] == [-(2**31), 2**31 - 1]
    table = read_setpoints(out / "setpoints.csv")
    # joint 1 ends 200 deg from its start: more than its old range of +-170 deg allowed
    turned = (table.counts[-1, 0] - table.counts[0, 0]) / table.counts_per_joint_rev[0] * 360.0
    assert turned == pytest.approx(200.0, abs=360.0 / table.counts_per_joint_rev[0])


def test_armlab_info_says_which_joints_are_continuous(unbounded_arm, capsys):
    assert main(["info", str(unbounded_arm)]) == 0
    rows: dict[str, str] = {}
    for line in capsys.readouterr().out.splitlines():  # the limits table comes first
        if line.strip():
            rows.setdefault(line.split()[0], line)
    assert rows["joint1"].split()[1] == "C" and "unbounded" in rows["joint1"]
    assert rows["joint2"].split()[1] == "R"


@pytest.mark.parametrize(
    ("urdf", "frame", "rule"),
    [
        ("erd:ur_description/urdf/ur10_robot.urdf", "tool0", "tool0"),
        (KINOVA, "j2s6s200_end_effector", "end_effector"),  # not the last frame: a finger tip
        ("erd:xarm_description/urdf/xarm7.urdf", "link_eef", "eef"),
        ("teachbot6", "tool0", "tool0"),
    ],
)
def test_the_default_tool_frame_follows_a_stated_rule(urdf, frame, rule):
    robot = load_robot(urdf)
    assert robot.tool_frame == frame
    assert rule in robot.tool_frame_from
    last = robot.model.frames[len(robot.model.frames) - 1].name
    if urdf == KINOVA:
        assert "finger" in last and robot.tool_frame != last
