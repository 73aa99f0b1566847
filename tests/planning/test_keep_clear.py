"""The planners that do not plan around obstacles (Cartesian lines, TOPP) report the clearance
of their plan and refuse one that comes too close (armlab.planning.keep_clear, issue 27);
coal called directly (tests/oracles/coal_env_clearance.py) confirms each verdict."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from armlab.collision import CollisionError, CollisionScene
from armlab.planning import line, time_optimal_path
from armlab.study.build import build_robot
from armlab.study.spec import load_study
from oracles.coal_env_clearance import env_clearance

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "teachbot6_obstacles_study.toml"


@pytest.fixture(scope="module")
def setup():
    spec = load_study(EXAMPLE, {"study.stages": ["kinematics", "plan"]})
    robot = build_robot(spec)
    W = np.radians(np.asarray(spec.waypoints.joint, float))
    obstacles = [(s.name, s.coal_geometry(), s.transform()) for s in spec.obstacles]
    return robot, W, CollisionScene.from_study(spec, robot), obstacles


def _tool_pose(robot, q):
    data = robot.model.createData()
    pin.framesForwardKinematics(robot.model, data, q)
    return data.oMf[robot.tool_frame_id].homogeneous.copy()


def test_a_line_through_the_box_is_refused_and_really_collides(setup):
    robot, W, scene, obstacles = setup
    A = _tool_pose(robot, W[1])
    B = A.copy()
    B[:3, 3] += [-0.05, 0.2, 0.0]  # sideways at the pick's height, across the box
    with pytest.raises(CollisionError, match=r"the line plan collides: .*box penetrate .* at t ="):
        line(robot, A, B, 0.2, q_start=W[1], clearance=scene)
    plain = line(robot, A, B, 0.2, q_start=W[1])
    d, _, obstacle, _ = env_clearance(robot, plain, obstacles)
    assert d < 0 and obstacle == "box"


def test_a_clear_line_carries_its_clearance(setup):
    robot, W, scene, obstacles = setup
    A = _tool_pose(robot, W[1])
    B = A.copy()
    B[:3, 3] += [0.05, -0.05, 0.05]  # up and away from the box
    traj = line(robot, A, B, 0.2, q_start=W[1], clearance=scene)
    c = scene.clearance_m
    assert traj.stats["min_clearance_m"] >= c and traj.meta["clearance"]["ok"]
    assert env_clearance(robot, traj, obstacles)[0] >= c - 1e-4


def test_topp_through_the_box_is_refused_and_really_collides(setup):
    robot, W, scene, obstacles = setup
    with pytest.raises(CollisionError, match=r"time_optimal_path plan collides: .*and box"):
        time_optimal_path(robot, W[1:3], j_max=False, clearance=scene)
    d, _, obstacle, _ = env_clearance(
        robot, time_optimal_path(robot, W[1:3], j_max=False), obstacles
    )
    assert d < 0 and obstacle == "box"
