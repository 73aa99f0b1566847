"""Plans that keep clear (issue 27): optimal() with a clearance constraint
(armlab.planning.optimal_clearance), checked against coal called directly
(tests/oracles/coal_env_clearance.py) on a fine grid."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from armlab.collision import CollisionScene, Shape
from armlab.errors import InfeasibleError, InputError
from armlab.planning import optimal
from armlab.planning.optimal_clearance import ClearanceRows
from armlab.planning.optimiser import build_optimal
from armlab.study.build import build_robot
from armlab.study.spec import load_study
from oracles.clearance_grid import grid_distances
from oracles.coal_env_clearance import env_clearance

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "teachbot6_obstacles_study.toml"


def _coal(shape: Shape):
    return (shape.name, shape.coal_geometry(), shape.transform())


@pytest.fixture(scope="module")
def demo():
    """The example study: the demo cycle, a table under it and a box between waypoints 1, 2."""
    spec = load_study(EXAMPLE, {"study.stages": ["kinematics", "plan"]})
    robot = build_robot(spec)
    W = np.radians(np.asarray(spec.waypoints.joint, float))
    scene = CollisionScene.from_study(spec, robot)
    return spec, robot, W, scene


@pytest.fixture(scope="module")
def plain(demo):
    _, robot, W, _ = demo
    return optimal(robot, W)


@pytest.fixture(scope="module")
def clear(demo):
    _, robot, W, scene = demo
    return optimal(robot, W, clearance=scene)


def test_the_plain_demo_plan_goes_through_the_box(demo, plain):
    """Without the constraint the example is a real test: coal finds the tool in the box."""
    spec, robot, _, _ = demo
    d, _, obstacle, t = env_clearance(robot, plain, [_coal(s) for s in spec.obstacles])
    assert d < -0.02 and obstacle == "box"
    assert 1.0 < t < 3.0  # between the pick (waypoint 1) and the place (waypoint 2)


def test_optimal_plans_around_the_box(demo, plain, clear):
    spec, robot, W, scene = demo
    c = spec.plan.clearance_m
    # independent: coal's distances on a 2 ms grid keep the clearance (certificate tolerance
    # of the package's check: 0.1 mm)
    d, link, obstacle, t = env_clearance(robot, clear, [_coal(s) for s in spec.obstacles])
    assert d >= c - 1e-4, (d, link, obstacle, t)
    assert clear.stats["min_clearance_m"] >= c - 1e-4
    # every pair the scene checks (self pairs too), coal on the scene's shapes, 5 ms grid
    _, D = grid_distances(scene, clear, 0.005)
    assert D.min() >= c - 1e-4
    assert clear.meta["clearance"]["ok"]
    # still a plan of the request: every limit holds on the fine grid, the waypoints are
    # passed, and keeping clear costs time (within 10 % here)
    assert clear.report.ok(1e-6)
    q_wp = clear.at(np.asarray(clear.meta["waypoint_times_s"]))[0]
    np.testing.assert_allclose(q_wp, W, atol=1e-6)
    assert plain.duration < clear.duration < 1.1 * plain.duration


def test_a_plan_already_clear_is_the_plain_plan(demo, plain):
    _, robot, W, _ = demo
    far = Shape("crate", "box", (0.2, 0.2, 0.2), (-0.8, -0.8, 0.0))
    scene = CollisionScene.from_robot(robot, [far], clearance_m=0.01)
    traj = optimal(robot, W, clearance=scene)
    assert traj.duration == pytest.approx(plain.duration, rel=1e-12)
    assert traj.stats["clearance_rounds"] == 0
    assert traj.stats["min_clearance_m"] > 0.01


def test_a_waypoint_in_collision_is_bad_input(demo):
    _, robot, W, _ = demo
    # a sphere around the tool point of waypoint 2 (x, y, z from the forward kinematics)
    tcp = robot.model.createData()
    import pinocchio as pin

    pin.framesForwardKinematics(robot.model, tcp, W[2])
    p = tcp.oMf[robot.tool_frame_id].translation
    scene = CollisionScene.from_robot(
        robot, [Shape("bin", "sphere", (0.03,), tuple(float(x) for x in p))], clearance_m=0.01
    )
    with pytest.raises(InputError, match=r"waypoint 2: .*bin penetrate"):
        optimal(robot, W, clearance=scene)


def test_a_wall_between_the_waypoints_is_refused_naming_the_pair(teachbot6):
    """joint1 0 -> 90 deg with a wall along 45 deg from 0.12 m off the axis to 3 m, 3 m high:
    the arm cannot fold into 0.12 m, so no motion gets past; the refusal names the pair."""
    r0 = 0.12
    c = (r0 + 1.5) / math.sqrt(2)
    wall = Shape("wall", "box", (3.0, 0.02, 3.0), (c, c, 0.0), (0.0, 0.0, 45.0))
    scene = CollisionScene.from_robot(teachbot6, [wall], clearance_m=0.01)
    W = np.radians([[0, 0, 0, 0, 0, 0], [90, 0, 0, 0, 0, 0]])
    with pytest.raises(InfeasibleError, match=r"clearance: .* and wall .* at t = "):
        optimal(teachbot6, W, clearance=scene, tau_max=False, n_intervals=12)


def test_rows_enter_the_problem_as_written(teachbot6):
    """The extended problem's last rows are sum_i C[i, k] q_k[i] (hand computed)."""
    prob = build_optimal(
        teachbot6, np.radians([[0, 0, 0, 0, 0, 0], [30, 10, 0, 0, 0, 0]]), tau_max=False
    )
    prob.x0 = prob.make_warm_start()
    rows = ClearanceRows(prob.n, prob.N)
    rng = np.random.default_rng(1)
    grads = {(k, (0, 0)): (rng.normal(size=prob.n), 0.1) for k in (0, 5, 17)}
    grads[(5, (0, 1))] = (rng.normal(size=prob.n), -0.2)
    rows.rows.update(grads)
    st = prob._structure(prob.limits)
    lbx, ubx, lbg, ubg = prob._bounds(st, prob.limits)
    p = prob._params(prob.limits)
    ext, p2, lbg2, ubg2 = rows.extend(st, p, lbg, ubg)
    x = prob.x0 / prob._scale_vector()
    g = np.asarray(ext.g_fun(x, p2)).ravel()
    q = prob.x0[st.slices["q"]].reshape(prob.N + 1, prob.n)
    M = 2  # two rows at knot 5
    assert g.size == lbg.size + (prob.N + 1) * M
    np.testing.assert_allclose(g[: lbg.size], np.asarray(st.g_fun(x, p)).ravel(), atol=1e-12)
    extra, lo = g[lbg.size :], lbg2[lbg.size :]
    for (k, _), (c, bound) in grads.items():
        j = [i for i in range(k * M, k * M + M) if lo[i] == bound]
        assert len(j) == 1
        assert extra[j[0]] == pytest.approx(float(c @ q[k]), abs=1e-12)
    assert np.sum(np.isfinite(lo)) == len(grads) and np.all(np.isinf(ubg2[lbg.size :]))
