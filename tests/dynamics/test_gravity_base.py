"""Gravity of a rotated base: every torque consumer uses ``g_base = R_base_in_world^T g_world``.

The reference is ``pinocchio.rnea`` on a copy of the upright model whose gravity is set here,
independently of armlab, to ``R^T (0, 0, -9.81)`` for a base turned 90 deg about x (a wall
mount: gravity along -y of the base, joint 1 carries it).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import armlab
from armlab.control import simulate_tracking, tune_arm
from armlab.dynamics import inverse_dynamics, static_load
from armlab.dynamics.inverse import joint_torques
from armlab.dynamics.static_load import build_static_load
from armlab.errors import InputError
from armlab.planning.topp import path_dynamics
from armlab.robot import rigid_body
from armlab.robot.symbolic import inverse_dynamics_function
from armlab.trajectory import Trajectory, optimal

G_WORLD = np.array([0.0, 0.0, -9.81])
R_X90 = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
TOL_NM = 1e-9


def _base(R: np.ndarray) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = [0.1, -0.2, 1.5]  # a translation changes nothing in the dynamics
    return T


@pytest.fixture(scope="module")
def upright():
    return armlab.load_robot("teachbot6")


@pytest.fixture(scope="module", params=["load_robot", "setter"])
def tilted(request):
    if request.param == "load_robot":
        return armlab.load_robot("teachbot6", transform_base_to_world=_base(R_X90))
    robot = armlab.load_robot("teachbot6")
    robot.transform_base_to_world = _base(R_X90)
    return robot


@pytest.fixture(scope="module")
def reference(upright):
    """(model, data): the upright model with gravity rotated into the base by hand."""
    model = upright.model.copy()
    model.gravity = pin.Motion(R_X90.T @ G_WORLD, np.zeros(3))
    return model, model.createData()


def _rnea(ref, q, qd, qdd) -> np.ndarray:
    model, data = ref
    return np.array([pin.rnea(model, data, q[k], qd[k], qdd[k]) for k in range(len(q))])


def _states(robot, n: int, seed: int = 1):
    rng = np.random.default_rng(seed)
    q = robot.random_q(rng, n)
    return q, rng.uniform(-2, 2, q.shape), rng.uniform(-8, 8, q.shape)


# ---------------------------------------------------------------------------- the Robot
def test_model_gravity_is_the_world_gravity_in_the_base(upright, tilted):
    np.testing.assert_array_equal(upright.gravity_in_world, G_WORLD)
    np.testing.assert_array_equal(tilted.gravity_in_world, G_WORLD)
    np.testing.assert_allclose(upright.model.gravity.linear, G_WORLD, atol=0)
    np.testing.assert_allclose(tilted.model.gravity.linear, [0.0, -9.81, 0.0], atol=1e-15)
    np.testing.assert_allclose(tilted.model.gravity.angular, 0.0, atol=0)
    # copies (and payload changes, which copy) keep it
    for other in (tilted.copy(), tilted.with_payload(1.0)):
        np.testing.assert_array_equal(other.model.gravity.linear, tilted.model.gravity.linear)
        np.testing.assert_array_equal(other.transform_base_to_world, tilted.transform_base_to_world)
    # the transform is read-only: an in-place edit cannot leave the gravity behind
    with pytest.raises(ValueError):
        tilted.transform_base_to_world[0, 3] = 1.0


def test_setter_validates_and_round_trips(upright):
    robot = upright.copy()
    robot.transform_base_to_world = _base(R_X90)
    np.testing.assert_allclose(robot.model.gravity.linear, R_X90.T @ G_WORLD, atol=1e-15)
    robot.transform_base_to_world = None
    np.testing.assert_array_equal(robot.model.gravity.linear, G_WORLD)
    np.testing.assert_array_equal(upright.model.gravity.linear, G_WORLD)  # copy was independent
    robot.gravity_in_world = [0.0, 0.0, -9.80665]
    assert robot.model.gravity.linear[2] == -9.80665
    for bad in (np.eye(3), np.full((4, 4), np.nan), 2.0 * np.eye(4), _base(-R_X90)):
        with pytest.raises(InputError, match="transform_base_to_world"):
            robot.transform_base_to_world = bad
    with pytest.raises(InputError, match="gravity_in_world"):
        robot.gravity_in_world = [0.0, -9.81]
    with pytest.raises(InputError, match="transform_base_to_world"):
        armlab.load_robot("teachbot6", transform_base_to_world=np.eye(3))


def test_the_tilt_changes_the_torques(upright, tilted):
    """The comparison below can fail: the upright torques are tens of N m away."""
    q, qd, qdd = _states(upright, 64)
    diff = np.abs(
        rigid_body.inverse_dynamics(tilted, q, qd, qdd)
        - _rnea((upright.model, upright.model.createData()), q, qd, qdd)
    )
    assert diff.max(axis=0)[:3].min() > 5.0  # joints 1-3 carry the change
    q0 = np.zeros((1, 6))
    g_up, g_tilt = (
        rigid_body.gravity_torques(upright, q0)[0],
        rigid_body.gravity_torques(tilted, q0)[0],
    )
    assert abs(g_up[0]) < 1e-12 and abs(g_tilt[0]) > 1.0  # joint 1 now carries gravity


# ---------------------------------------------------------------------------- consumers
def test_rigid_body_entry_matches_rnea(tilted, reference):
    q, qd, qdd = _states(tilted, 50)
    model, data = reference
    tau = _rnea(reference, q, qd, qdd)
    assert np.abs(rigid_body.inverse_dynamics(tilted, q, qd, qdd) - tau).max() < TOL_NM
    assert np.abs(rigid_body.inverse_dynamics(tilted, q[3], qd[3], qdd[3]) - tau[3]).max() < TOL_NM
    g = np.array([pin.computeGeneralizedGravity(model, data, x) for x in q])
    assert np.abs(rigid_body.gravity_torques(tilted, q) - g).max() < TOL_NM
    nle = np.array([pin.nonLinearEffects(model, data, q[k], qd[k]) for k in range(len(q))])
    assert np.abs(rigid_body.nonlinear_effects(tilted, q, qd) - nle).max() < TOL_NM
    M = np.array([pin.crba(model, data, x) for x in q])
    assert np.abs(rigid_body.mass_matrix(tilted, q) - M).max() < 1e-12
    assert np.abs(rigid_body.mass_matrix(tilted, q[0]) - M[0]).max() < 1e-12
    with pytest.raises(InputError, match="qd has shape"):
        rigid_body.inverse_dynamics(tilted, q, qd[:, :5], qdd)


def test_trajectory_and_inverse_dynamics_match_rnea(tilted, reference):
    q, qd, qdd = _states(tilted, 40, seed=2)
    traj = Trajectory(np.arange(40) * 0.01, q, qd, qdd, joint_names=tilted.joint_names)
    tau = _rnea(reference, q, qd, qdd)
    assert np.abs(traj.torques(tilted) - tau).max() < TOL_NM
    assert np.abs(inverse_dynamics(tilted, traj).torque_Nm - tau).max() < TOL_NM
    assert np.abs(joint_torques(tilted, q, qd, qdd, threads=2) - tau).max() < TOL_NM


def test_casadi_twin_matches_rnea(tilted, reference):
    q, qd, qdd = _states(tilted, 10, seed=3)
    tau = _rnea(reference, q, qd, qdd)
    fn = inverse_dynamics_function(tilted)
    sym = np.array([np.asarray(fn(q[k], qd[k], qdd[k])).ravel() for k in range(10)])
    assert np.abs(sym - tau).max() < TOL_NM


def test_topp_coefficients_match_rnea(tilted, reference):
    q, dq, ddq = _states(tilted, 20, seed=4)
    m, c, g = path_dynamics(tilted, q, dq, ddq)
    z = np.zeros_like(q)
    g_ref = _rnea(reference, q, z, z)
    assert np.abs(g - g_ref).max() < TOL_NM
    assert np.abs(m - (_rnea(reference, q, z, dq) - g_ref)).max() < TOL_NM
    assert np.abs(c - (_rnea(reference, q, dq, ddq) - g_ref)).max() < TOL_NM


def test_static_load_gravity_term_matches_rnea(tilted, reference):
    model, data = reference
    problem = build_static_load(tilted, 2, mode="gravity", n_samples=16, n_starts=1)
    q = _states(tilted, 5, seed=5)[0]
    for x in q:
        g = pin.computeGeneralizedGravity(model, data, x)
        assert abs(problem.objective(x) - g[1]) < TOL_NM
        assert abs(problem.gravity_and_inertia(x)[0] - g[1]) < TOL_NM
    report = static_load(tilted, n_samples=32, n_starts=1)
    for j, x in enumerate(report.joints):
        g = pin.computeGeneralizedGravity(model, data, x.pose_rad)
        assert abs(x.gravity_Nm - abs(g[j])) < TOL_NM


@pytest.fixture(scope="module")
def gains(upright):
    return tune_arm(upright, n_inertia_samples=5, controller="reference_dda")


@pytest.mark.parametrize("feedforward", ["gravity", "computed_torque"])
def test_simulation_feedforward_holds_the_tilted_arm(tilted, reference, gains, feedforward):
    """At rest the feed-forward current is the gravity torque: the arm does not move at all."""
    model, data = reference
    q = np.array([0.3, -0.6, 0.9, 0.2, 0.7, 0.0])
    rest = Trajectory(np.array([0.0, 0.05]), np.vstack([q, q]), np.zeros((2, 6)), np.zeros((2, 6)))
    res = simulate_tracking(
        tilted,
        rest,
        gains,
        feedforward=feedforward,
        quantise=False,
        t_after_s=0.0,
        tcp=False,
        controller="reference_dda",
    )
    drives = [tilted.drives[n] for n in tilted.joint_names]
    NKt = np.array([d.reducer.ratio * d.motor.torque_constant_Nm_A for d in drives])
    g = pin.computeGeneralizedGravity(model, data, q)
    assert np.abs(res.current_A * NKt - g).max() < TOL_NM
    assert np.abs(res.q - q).max() < 1e-12


# ---------------------------------------------------------------------------- planner
def test_optimal_keeps_the_true_torques_within_the_limits(tilted, reference):
    w = np.array([[0.0, -0.3, 0.8, 0.0, 0.6, 0.0], [1.0, 0.4, -0.2, 1.2, -0.4, 0.9]])
    q = np.linspace(w[0], w[1], 50)
    z = np.zeros_like(q)
    tau_max = np.maximum(1.5 * np.abs(_rnea(reference, q, z, z)).max(axis=0), 2.0)
    traj = optimal(tilted, w, tau_max=tau_max, v_max=10.0, a_max=40.0, j_max=False, n_intervals=8)
    assert any(b[0] == "torque" for b in traj.stats["binding"])
    s = traj.sample(1e-3)
    ratio = np.abs(_rnea(reference, s.q, s.qd, s.qdd)).max(axis=0) / tau_max
    assert ratio.max() <= 1 + 1e-6, ratio
    assert ratio.max() > 0.99  # the limit binds


def test_entry_shapes_of_a_one_joint_arm(tmp_path):
    urdf = tmp_path / "one.urdf"
    urdf.write_text(
        '<?xml version="1.0"?><robot name="one"><link name="base"/><link name="arm">'
        '<inertial><origin xyz="0.2 0 0"/><mass value="1.0"/>'
        '<inertia ixx="0.001" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial></link>'
        '<joint name="j1" type="revolute"><parent link="base"/><child link="arm"/>'
        '<axis xyz="0 1 0"/><limit lower="-3" upper="3" velocity="1" effort="10"/></joint>'
        "</robot>"
    )
    robot = armlab.load_robot(urdf)
    q = np.array([[0.0], [0.5], [1.0]])
    g = rigid_body.gravity_torques(robot, q)
    assert g.shape == (3, 1) and rigid_body.gravity_torques(robot, q[1]).shape == (1,)
    np.testing.assert_allclose(g[:, 0], -9.81 * 0.2 * np.cos(q[:, 0]), atol=1e-12)  # holds +x arm
    assert rigid_body.mass_matrix(robot, q).shape == (3, 1, 1)
