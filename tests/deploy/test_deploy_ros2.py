"""armlab.deploy.ros2: the controllers YAML and the FollowJointTrajectory goal, checked against
the parameter definitions and message files of the ros2_controllers / ros2_control /
control_msgs / common_interfaces releases stored in tests/data/ros2 (SOURCES.md: repo, tag,
path)."""

from __future__ import annotations

import json
import math
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
import yaml

from armlab.cli import main as cli_main
from armlab.control import ArmGains, CascadeGains, LoopGains
from armlab.control.gains import PlantSummary
from armlab.deploy import (
    jtc_constraints,
    render_follow_joint_trajectory,
    ros2_controllers_yaml,
    setpoint_table,
)
from armlab.deploy.ros2 import check_joint_trajectory
from armlab.dynamics.sizing import lever_arms_m
from armlab.errors import InputError
from armlab.io import write_json
from armlab.kinematics.forward import tool_positions
from armlab.study import export_study
from cases import cosine_motion
from conftest import make_study_folder

DATA = Path(__file__).resolve().parents[1] / "data" / "ros2"
BUDGET_M = 5e-4


# ---------------------------------------------------------------------- reference definitions
def jtc_definitions() -> dict:
    doc = yaml.safe_load((DATA / "joint_trajectory_controller_parameters.yaml").read_text())
    return doc["joint_trajectory_controller"]


def cm_definitions() -> dict:
    doc = yaml.safe_load((DATA / "controller_manager_parameters.yaml").read_text())
    return doc["controller_manager"]


def jtc_plugin_class() -> str:
    root = ET.parse(DATA / "joint_trajectory_plugin.xml").getroot()
    return root.find("class").get("name")


def msg_fields(name: str, part: int = 0) -> dict[str, str]:
    """Field name -> type of a .msg (or of part ``part`` of a .action), constants left out."""
    text = (DATA / name).read_text().split("\n---")[part]
    out = {}
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line or "=" in line:
            continue
        ftype, fname = line.split()[:2]
        out[fname] = ftype
    return out


def _leaves(d: dict, path=()):
    for k, v in d.items():
        if isinstance(v, dict):
            yield from _leaves(v, (*path, k))
        else:
            yield (*path, k), v


_TYPES = {
    "double": lambda v: isinstance(v, float),
    "int": lambda v: isinstance(v, int) and not isinstance(v, bool),
    "bool": lambda v: isinstance(v, bool),
    "string": lambda v: isinstance(v, str),
    "string_array": lambda v: isinstance(v, list) and all(isinstance(x, str) for x in v),
}


def check_against_definitions(params: dict, defs: dict, joints: list[str]) -> None:
    """Every leaf of ``params`` (a ros__parameters block) is a declared parameter of ``defs``
    (``__map_joints`` standing for a joint name) of the declared type, passing its validation."""
    for path, value in _leaves(params):
        node = defs
        for key in path:
            if key in node:
                node = node[key]
            elif key in joints and "__map_joints" in node:
                node = node["__map_joints"]
            else:
                raise AssertionError(f"{'.'.join(path)}: not a parameter of the definitions")
        assert "type" in node, path
        assert _TYPES[node["type"]](value), (path, node["type"], value)
        for rule, arg in (node.get("validation") or {}).items():
            if rule == "one_of<>":
                assert value in arg[0], (path, value)
            elif rule == "subset_of<>":
                assert set(value) <= set(arg[0]), (path, value)
            elif rule in ("gt_eq", "gt_eq<>"):
                assert value >= arg[0], (path, value)
            elif rule == "size_gt<>":
                assert len(value) > arg[0], path
            elif rule == "unique<>":
                assert len(set(value)) == len(value), path


# ---------------------------------------------------------------------- gains without tuning
def hand_gains(robot) -> ArmGains:
    """Cascades for every joint (hand-set numbers; the export only reads them)."""
    joints = {}
    for k, name in enumerate(robot.joint_names):
        d = robot.drives[name]
        w = d.motor.speed_limit_rad_s
        inertia = {"min": 1e-5, "nominal": 2e-5, "max": 3e-5}
        joints[name] = CascadeGains(
            joint=name,
            current=LoopGains("current", "PI", kp=5.0, ki=1e4, sample_time_s=5e-5),
            speed=LoopGains("speed", "PI", kp=0.1, ki=2.0, sample_time_s=1e-3),
            position=LoopGains(
                "position",
                "PI" if k == 0 else "P",
                kp=40.0 + k,
                ki=5.0 if k == 0 else 0.0,
                sample_time_s=1e-3,
                output_min=-w,
                output_max=w,
                settling_time_s=0.1 + 0.01 * k,
                settling_time_discrete_s=0.12 + 0.01 * k,
            ),
            plant=PlantSummary(
                ratio=float(d.reducer.ratio),
                inertia_motor_kg_m2=inertia,
                inertia_joint_kg_m2=inertia,
            ),
        )
    return ArmGains(joints=joints, robot=robot.name)


@pytest.fixture(scope="module")
def gains6(teachbot6):
    return hand_gains(teachbot6)


@pytest.fixture(scope="module")
def constraints(teachbot6, gains6):
    return jtc_constraints(
        teachbot6, gains6, accuracy_m=BUDGET_M, accuracy_source="test", controller="reference_dda"
    )


# ---------------------------------------------------------------------- controllers YAML
def test_controllers_yaml_matches_ros2_controllers_definitions(teachbot6, gains6, constraints):
    text = ros2_controllers_yaml(gains6, constraints=constraints)
    doc = yaml.safe_load(text)
    assert set(doc) == {"controller_manager", "joint_trajectory_controller"}
    cm = doc["controller_manager"]["ros__parameters"]
    assert cm["update_rate"] == 1000 and cm_definitions()["update_rate"]["type"] == "int"
    assert cm["joint_trajectory_controller"] == {"type": jtc_plugin_class()}
    params = doc["joint_trajectory_controller"]["ros__parameters"]
    joints = list(teachbot6.joint_names)
    check_against_definitions(params, jtc_definitions(), joints)
    assert params["joints"] == joints
    assert set(params["gains"]) == set(joints)
    for k, j in enumerate(joints):
        g = params["gains"][j]
        assert set(g) == {
            "p",
            "i",
            "d",
            "ff_velocity_scale",
            "u_clamp_max",
            "u_clamp_min",
            "i_clamp_max",
            "i_clamp_min",
            "antiwindup_strategy",
        }
        assert g["p"] == 40.0 + k
        w = teachbot6.drives[j].motor.speed_limit_rad_s / teachbot6.drives[j].reducer.ratio
        assert (
            g["u_clamp_max"] == pytest.approx(w, rel=1e-15)
            and g["u_clamp_min"] == -g["u_clamp_max"]
        )
        assert g["antiwindup_strategy"] == ("conditional_integration" if k == 0 else "none")
    c = params["constraints"]
    assert c["goal_time"] == pytest.approx(0.12 + 0.01 * 5)  # the slowest position loop
    for j in joints:
        assert c[j] == {
            "trajectory": constraints.trajectory_rad[j],
            "goal": constraints.goal_rad[j],
        }
    # the checker itself refuses what 6.9.0 no longer declares (the old symmetric i_clamp)
    with pytest.raises(AssertionError, match="i_clamp: not a parameter"):
        check_against_definitions(
            {"gains": {"joint1": {"i_clamp": 1.0}}}, jtc_definitions(), joints
        )
    with pytest.raises(AssertionError):
        check_against_definitions(
            {"gains": {"joint1": {"antiwindup_strategy": "legacy"}}}, jtc_definitions(), joints
        )


def test_yaml_numbers_are_doubles_and_unlimited_clamps_are_left_out(teachbot6, gains6):
    one = gains6[teachbot6.joint_names[0]]
    tiny = one.replace_loop(
        LoopGains("position", "P", kp=1e-5, sample_time_s=1e-3, settling_time_s=0.2)
    )
    text = ros2_controllers_yaml(tiny)
    assert "p: 1.0e-05" in text  # YAML 1.1 reads 1e-05 as a string
    g = yaml.safe_load(text)["joint_trajectory_controller"]["ros__parameters"]["gains"]["joint1"]
    assert g["p"] == 1e-5 and isinstance(g["p"], float)
    assert not any("clamp" in k for k in g)  # +-inf: the JTC defaults


def test_constraints_keep_the_tool_point_within_the_budget(teachbot6, constraints):
    """goal tolerances on all joints at once, or one joint at its path tolerance, move the tool
    point by at most the budget (forward kinematics, random poses); the rules are not slack."""
    names = list(teachbot6.joint_names)
    goal = np.array([constraints.goal_rad[j] for j in names])
    path = np.array([constraints.trajectory_rad[j] for j in names])
    lever = lever_arms_m(teachbot6)
    np.testing.assert_allclose(path, BUDGET_M / lever, rtol=1e-12)
    np.testing.assert_allclose(goal * len(names), path, rtol=1e-12)
    rng = np.random.default_rng(3)
    lo, hi = teachbot6.limits.lower_rad, teachbot6.limits.upper_rad
    q = rng.uniform(lo, hi, size=(400, 6))
    x0 = tool_positions(teachbot6, q)
    signs = rng.choice([-1.0, 1.0], size=q.shape)
    moved = np.linalg.norm(tool_positions(teachbot6, q + signs * goal) - x0, axis=1)
    assert moved.max() <= BUDGET_M * (1 + 1e-9)
    assert moved.max() > 0.3 * BUDGET_M  # and not far below it
    for j in range(6):
        dq = np.zeros(6)
        dq[j] = path[j]
        one = np.linalg.norm(tool_positions(teachbot6, q + dq) - x0, axis=1)
        assert one.max() <= BUDGET_M * (1 + 1e-9)
    # joint 1 at its path tolerance, stretched arm: close to the whole budget
    assert constraints.trajectory_rad["joint1"] * lever[0] == pytest.approx(BUDGET_M)


def test_stopped_velocity_and_encoder_floor(teachbot6, gains6, constraints):
    cpr = np.array([teachbot6.drives[j].counts_per_rad() for j in teachbot6.joint_names])
    assert constraints.stopped_velocity_tolerance_rad_s == pytest.approx(
        max(1.0 / (cpr * 1e-3)), rel=1e-12
    )
    assert constraints.goal_time_s == pytest.approx(0.17)
    for j, c in zip(teachbot6.joint_names, cpr, strict=True):
        assert constraints.goal_rad[j] * c >= 1.0  # at least one count
    with pytest.raises(InputError, match=r"goal tolerance of .* below one encoder count"):
        jtc_constraints(teachbot6, gains6, accuracy_m=1e-6, controller="reference_dda")
    with pytest.raises(InputError, match="accuracy budget must be > 0"):
        jtc_constraints(teachbot6, gains6, accuracy_m=0.0, controller="reference_dda")
    with pytest.raises(InputError, match="no gains for joint"):
        ros2_controllers_yaml(gains6, joints=["joint1", "elbow"])


# ---------------------------------------------------------------------- trajectory goal
def test_follow_joint_trajectory_goal_matches_messages(teachbot6, constraints):
    table = setpoint_table(
        teachbot6, cosine_motion(teachbot6, duration_s=2.0, n=201), controller="reference_dda"
    )
    text = render_follow_joint_trajectory(table, constraints)
    doc = json.loads(text)
    assert yaml.safe_load(text) == doc  # also YAML 1.1 (ros2 action send_goal)
    assert doc["action_type"] == "control_msgs/action/FollowJointTrajectory"
    goal = doc["goal"]
    assert set(goal) <= set(msg_fields("FollowJointTrajectory.action", 0))
    traj = goal["trajectory"]
    assert set(traj) == set(msg_fields("JointTrajectory.msg"))
    assert set(traj["header"]) == set(msg_fields("Header.msg"))
    assert set(traj["header"]["stamp"]) == set(msg_fields("Time.msg"))
    point_fields = msg_fields("JointTrajectoryPoint.msg")
    duration_fields = set(msg_fields("Duration.msg"))
    tol_fields = set(msg_fields("JointTolerance.msg"))
    pts = traj["points"]
    assert len(pts) == table.n_cycles == 2001
    for p in pts[:3] + pts[-3:]:
        assert set(p) <= set(point_fields) and "effort" not in p
        assert set(p["time_from_start"]) == duration_fields
    # values: the table's rows; times exact in nanoseconds
    q = np.array([p["positions"] for p in pts])
    qd = np.array([p["velocities"] for p in pts])
    qdd = np.array([p["accelerations"] for p in pts])
    assert np.array_equal(q, table.q_rad) and np.array_equal(qd, table.qd_rad_s)
    assert np.array_equal(qdd, table.qdd_rad_s2) and np.abs(qdd).max() > 0.01
    ns = [p["time_from_start"]["sec"] * 10**9 + p["time_from_start"]["nanosec"] for p in pts]
    assert ns == [k * 1_000_000 for k in range(2001)]
    assert pts[-1]["time_from_start"] == {"sec": 2, "nanosec": 0}
    assert traj["joint_names"] == list(table.joint_names)
    for key, tol, vel in (
        ("path_tolerance", constraints.trajectory_rad, 0.0),
        ("goal_tolerance", constraints.goal_rad, constraints.stopped_velocity_tolerance_rad_s),
    ):
        for row in goal[key]:
            assert set(row) == tol_fields
            assert row["position"] == pytest.approx(tol[row["name"]], abs=1e-9)
            assert row["velocity"] == pytest.approx(vel, abs=1e-9)
    assert goal["goal_time_tolerance"] == {"sec": 0, "nanosec": 170_000_000}
    check_joint_trajectory(traj)


def test_goal_checks_like_the_controller(teachbot6):
    table = setpoint_table(
        teachbot6, cosine_motion(teachbot6, duration_s=0.2, n=21), controller="reference_dda"
    )
    traj = json.loads(render_follow_joint_trajectory(table))["goal"]["trajectory"]
    check_joint_trajectory(traj)
    moving = json.loads(json.dumps(traj))
    moving["points"][-1]["velocities"][2] = 0.01
    with pytest.raises(InputError, match="joint3 ends at 0.01 rad/s"):
        check_joint_trajectory(moving)
    late = json.loads(json.dumps(traj))
    late["points"][5]["time_from_start"] = dict(late["points"][4]["time_from_start"])
    with pytest.raises(InputError, match="point 5 is not increasing"):
        check_joint_trajectory(late)
    short = json.loads(json.dumps(traj))
    short["points"][3]["accelerations"] = [0.0]
    with pytest.raises(InputError, match="not 6 values per point"):
        check_joint_trajectory(short)
    with pytest.raises(InputError, match="no points"):
        check_joint_trajectory({"joint_names": ["a"], "points": []})


# ---------------------------------------------------------------------- armlab export
def test_export_ros2_and_trajectory_use_the_studys_budget(teachbot6, gains6, tmp_path, capsys):
    tr = cosine_motion(teachbot6, duration_s=1.0, n=101)
    study = make_study_folder(tmp_path / "study", teachbot6, tr, gains6)
    summary = json.loads((study / "summary.json").read_text())
    summary["tracking"] = {
        "tcp": {"accuracy_m": 1e-3, "within_accuracy": True},
        "feedforward": ["gravity"],
    }
    write_json(study / "summary.json", summary)
    out = tmp_path / "out"
    assert cli_main(["export", str(study), "--format", "ros2", "--out", str(out)]) == 0
    assert cli_main(["export", str(study), "--format", "trajectory", "--out", str(out)]) == 0
    printed = capsys.readouterr().out.split()
    assert [Path(p).name for p in printed] == ["ros2_controllers.yaml", "joint_trajectory.json"]
    params = yaml.safe_load((out / "ros2_controllers.yaml").read_text())[
        "joint_trajectory_controller"
    ]["ros__parameters"]
    check_against_definitions(params, jtc_definitions(), list(teachbot6.joint_names))
    lever = lever_arms_m(teachbot6)
    for j, name in enumerate(teachbot6.joint_names):
        assert params["constraints"][name]["trajectory"] == pytest.approx(1e-3 / lever[j])
        assert params["gains"][name]["ff_velocity_scale"] == 0.0  # no velocity feed-forward
    assert "summary.json tracking.tcp.accuracy_m" in (out / "ros2_controllers.yaml").read_text()
    goal = json.loads((out / "joint_trajectory.json").read_text())
    assert goal["meta"]["constraints"]["accuracy_m"] == 1e-3
    assert goal["meta"]["trajectory_sha256"] in (out / "joint_trajectory.json").read_text()
    tol = {r["name"]: r["position"] for r in goal["goal"]["goal_tolerance"]}
    for name in teachbot6.joint_names:
        assert tol[name] == pytest.approx(params["constraints"][name]["goal"], abs=1e-9)
    assert len(goal["goal"]["trajectory"]["points"]) == 1001
    # without a tracking block: armlab's 0.5 mm servo budget, velocity feed-forward on
    bare = make_study_folder(tmp_path / "bare", teachbot6, tr, gains6)
    res = export_study(bare, "ros2", None, tmp_path / "o2")
    text = res.files[0].read_text()
    params = yaml.safe_load(text)["joint_trajectory_controller"]["ros__parameters"]
    assert params["constraints"]["joint1"]["trajectory"] == pytest.approx(5e-4 / lever[0])
    assert params["gains"]["joint1"]["ff_velocity_scale"] == 1.0
    assert re.search(r"half of the thesis' 1 mm", text)
    assert not math.isnan(params["constraints"]["goal_time"])
