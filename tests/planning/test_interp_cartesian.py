"""Cartesian interpolators: line (Jiang 1987, eq. 6-9; HEU thesis, 6.3.3), arc through three
points (Jiang 1987, eq. 10-24; HEU thesis, 6.3.4-6.3.5), tangent-arc corner blending (SHU
controller paper, §2.2 (2))."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from armlab.errors import InputError, LimitViolation, UnreachableError
from armlab.kinematics import fk, fk_batch
from armlab.planning.path_ik import path_derivatives, track_path
from armlab.planning.paths import circle_through
from armlab.trajectory import ArcPath, BlendPath, LinePath, arc3, blend, line

# a comfortable configuration of teachbot6 (wrist bent, arm not stretched)
Q_START = np.array([0.3, 0.3, 0.9, 0.5, 0.7, 0.2])


@pytest.fixture(scope="module")
def start(teachbot6):
    return fk(teachbot6, Q_START)


def _goal(T0, dp, rotvec=(0.0, 0.0, 0.0)):
    T1 = T0.copy()
    T1[:3, 3] += dp
    T1[:3, :3] = T0[:3, :3] @ pin.exp3(np.asarray(rotvec, float))
    return T1


def _distance_to_segment(P, a, b):
    u = (b - a) / np.linalg.norm(b - a)
    d = P - a
    along = d @ u
    assert np.all(along >= -1e-12) and np.all(along <= np.linalg.norm(b - a) + 1e-12)
    return np.linalg.norm(d - np.outer(along, u), axis=1)


# ---------------------------------------------------------------------- geometry
@settings(max_examples=200, deadline=None)
@given(pts=st.lists(st.floats(-1.0, 1.0), min_size=9, max_size=9))
def test_circle_through_three_points(pts):
    p1, p2, p3 = np.reshape(pts, (3, 3))
    a, b = p3 - p1, p2 - p1
    if np.linalg.norm(np.cross(a, b)) < 1e-3:  # near-collinear: tested below
        return
    c = circle_through(p1, p2, p3)
    for p in (p1, p2, p3):
        assert np.linalg.norm(p - c.centre) == pytest.approx(c.radius, abs=1e-9 * max(1, c.radius))
        assert abs((p - c.centre) @ c.normal) < 1e-9 * max(1, c.radius)
    # travel p1 -> p2 -> p3 is positive about the normal
    assert 0 < c.angle_of(p2) < c.angle_of(p3) < 2 * math.pi
    path = ArcPath(p1, p2, p3, rotation=np.eye(3))
    np.testing.assert_allclose(
        path.evaluate(path.s_points).position, [p1, p2, p3], atol=1e-9 * max(1, c.radius)
    )


def test_circle_degenerate_points():
    p = np.array([0.3, 0.1, 0.2])
    with pytest.raises(InputError, match="collinear"):
        circle_through(p, p + [0.01, 0, 0], p + [0.02, 0, 0])
    with pytest.raises(InputError, match="coincide"):
        circle_through(p, p, p)


def test_blend_geometry_shu_controller_paper():
    # square corner, radius R: tangent points at R tan(45 deg) = R from the corner, centre at
    # R / sin(45 deg) from it on the bisector
    P = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0]], float)
    R = 0.2
    path = BlendPath(P, R, rotation=np.eye(3))
    assert path.tangent_lengths[0] == pytest.approx(R)
    arc = path.pieces[1]
    np.testing.assert_allclose(arc.circle.centre, [1 - R, R, 0], atol=1e-15)
    assert np.linalg.norm(arc.circle.centre - P[1]) == pytest.approx(R / math.sin(math.pi / 4))
    assert path.length == pytest.approx(2 * (1 - R) + R * math.pi / 2)
    s = np.linspace(0, path.length, 4001)
    smp = path.evaluate(s)
    np.testing.assert_allclose(np.linalg.norm(smp.dp_ds, axis=1), 1.0, atol=1e-12)
    assert np.abs(np.diff(smp.dp_ds, axis=0)).max() < 2 * (s[1] - s[0]) / R  # G1, no kink
    # closest approach to the corner: R / sin(45) - R
    d = np.linalg.norm(smp.position - P[1], axis=1).min()
    assert d == pytest.approx(R / math.sin(math.pi / 4) - R, abs=1e-6)


def test_blend_degenerate_input():
    P = np.array([[0, 0, 0], [1, 0, 0], [1, 0.1, 0]], float)
    with pytest.raises(InputError, match="too large for segment 1"):
        BlendPath(P, 0.2, rotation=np.eye(3))
    with pytest.raises(InputError, match="turns back"):
        BlendPath(np.array([[0, 0, 0], [1, 0, 0], [0.5, 0, 0]], float), 0.1, rotation=np.eye(3))
    with pytest.raises(InputError, match="coincide"):
        BlendPath(np.array([[0, 0, 0], [0, 0, 0], [1, 0, 0]], float), 0.1, rotation=np.eye(3))
    # straight-through corner needs no arc
    path = BlendPath(np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0]], float), 0.1, rotation=np.eye(3))
    assert path.length == pytest.approx(2.0)


# ---------------------------------------------------------------------- IK map derivatives
def test_path_derivatives_match_finite_differences(teachbot6, start):
    path = LinePath(start, _goal(start, [0.05, -0.1, 0.08], [0.3, 0.2, -0.5]), "slerp")
    s = np.linspace(0.01, path.length - 0.01, 7)
    h = 1e-5
    q = track_path(teachbot6, path, s, Q_START)
    qp = track_path(teachbot6, path, s + h, Q_START)
    qm = track_path(teachbot6, path, s - h, Q_START)
    g, hh = path_derivatives(teachbot6, q, path.evaluate(s))
    np.testing.assert_allclose(g, (qp - qm) / (2 * h), atol=1e-7 * np.abs(g).max())
    np.testing.assert_allclose(hh, (qp - 2 * q + qm) / h**2, atol=1e-4 * np.abs(hh).max())


# ---------------------------------------------------------------------- line
@pytest.mark.parametrize("profile", ["trapezoid", "scurve"])
@pytest.mark.parametrize("orientation", ["hold", "slerp"])
def test_line_keeps_tcp_on_segment(teachbot6, start, profile, orientation):
    goal = _goal(start, [0.05, -0.1, 0.08], [0.3, 0.2, -0.5])
    traj = line(
        teachbot6, start, goal, 0.3, q_start=Q_START, profile=profile, orientation=orientation
    )
    T = fk_batch(teachbot6, traj.q)
    assert _distance_to_segment(T[:, :3, 3], start[:3, 3], goal[:3, 3]).max() <= 1e-9
    np.testing.assert_allclose(T[0], start, atol=1e-9)
    np.testing.assert_allclose(T[-1, :3, 3], goal[:3, 3], atol=1e-9)
    if orientation == "hold":
        assert np.abs(T[:, :3, :3] - start[:3, :3]).max() < 1e-9
    else:
        np.testing.assert_allclose(T[-1, :3, :3], goal[:3, :3], atol=1e-9)
    report = traj.check_limits(teachbot6)
    assert report.ok(1e-9), report.violations()
    assert traj.meta["slowdown"]["kind"] in ("velocity", "acceleration")  # 0.3 m/s is too fast
    assert traj.meta["speed"] < 0.3
    assert (traj.qddd is not None) == (profile == "scurve")
    # the speed along the path follows the profile: |dp/dt| = sdot
    v_tcp = np.linalg.norm(np.gradient(T[:, :3, 3], traj.t, axis=0), axis=1)
    assert v_tcp.max() <= traj.meta["speed"] * (1 + 1e-2)


def test_line_orientation_strategies(teachbot6, start):
    goal = _goal(start, [0.04, -0.05, 0.03], [0.3, 0.2, -0.5])
    first = line(teachbot6, start, goal, 0.05, q_start=Q_START, orientation="first")
    last = line(teachbot6, start, goal, 0.05, q_start=Q_START, orientation="last")
    for traj in (first, last):
        T = fk_batch(teachbot6, traj.q)
        np.testing.assert_allclose(T[-1], goal, atol=1e-9)
        assert traj.check_limits(teachbot6).ok(1e-9)
        # a stop between the two motions
        assert np.any(np.all(np.abs(traj.qd[1:-1]) < 1e-12, axis=1))
    T = fk_batch(teachbot6, first.q)
    # orientation first: the position stays at the start until the rotation is done
    k_rot_done = np.argmax(np.abs(T[:, :3, :3] - goal[:3, :3]).max(axis=(1, 2)) < 1e-9)
    assert np.abs(T[: k_rot_done + 1, :3, 3] - start[:3, 3]).max() < 1e-9


def test_line_degenerate_and_unreachable(teachbot6, start):
    traj = line(teachbot6, start, start, 0.1, q_start=Q_START)
    assert traj.n_samples == 1 and traj.meta["zero_length"]
    far = _goal(start, [0.6, 0.0, 0.0])
    with pytest.raises(UnreachableError, match=r"s = [0-9.]+ m, p = \["):
        line(teachbot6, start, far, 0.1, q_start=Q_START)
    with pytest.raises(LimitViolation, match="joint"):
        line(
            teachbot6,
            start,
            _goal(start, [0.05, -0.1, 0.08]),
            0.3,
            q_start=Q_START,
            on_limit="raise",
        )
    with pytest.raises(InputError, match="q_start puts the tool"):
        line(teachbot6, start, far, 0.1, q_start=Q_START + 0.1)
    with pytest.raises(InputError, match="orientation"):
        line(teachbot6, start[:3, 3], far, 0.1)


def test_line_through_wrist_singularity_is_reported(teachbot6):
    qa = Q_START.copy()
    qa[4] = 0.2
    qb = qa.copy()
    qb[4] = -0.2  # the straight line between them crosses sin(theta5) = 0
    with pytest.raises(UnreachableError, match="singularity"):
        line(teachbot6, fk(teachbot6, qa), fk(teachbot6, qb), 0.05, q_start=qa)


def test_line_numerical_ik_arm(ur5):
    q0 = np.array([0.2, -1.2, 1.5, -1.8, -1.5, 0.3])
    T0 = fk(ur5, q0)
    T1 = _goal(T0, [0.1, 0.1, -0.05], [0.0, 0.2, 0.1])
    traj = line(ur5, T0, T1, 0.2, q_start=q0, a_max=3.0)
    P = fk_batch(ur5, traj.q)[:, :3, 3]
    assert _distance_to_segment(P, T0[:3, 3], T1[:3, 3]).max() <= 1e-9
    from armlab.robot import resolve_limits

    assert traj.check_limits(ur5, limits=resolve_limits(ur5, a_max=3.0)).ok(1e-9)


# ---------------------------------------------------------------------- arc
@pytest.mark.parametrize("full_circle", [False, True])
def test_arc_through_three_points_keeps_radius(teachbot6, start, full_circle):
    p1 = start[:3, 3]
    p2, p3 = p1 + [0.02, 0.02, 0.0], p1 + [0.04, 0.0, 0.01]
    traj = arc3(teachbot6, p1, p2, p3, 0.05, q_start=Q_START, full_circle=full_circle)
    centre, radius = np.array(traj.meta["centre_m"]), traj.meta["radius_m"]
    P = fk_batch(teachbot6, traj.q)[:, :3, 3]
    assert np.abs(np.linalg.norm(P - centre, axis=1) - radius).max() <= 1e-9
    assert np.abs((P - centre) @ np.array(traj.meta["normal"])).max() <= 1e-9
    # passes through the three points: IK at their arc lengths, then FK
    path = ArcPath(p1, p2, p3, rotation=start[:3, :3], full_circle=full_circle)
    q = track_path(teachbot6, path, path.s_points, Q_START)
    Pp = fk_batch(teachbot6, q)[:, :3, 3]
    expected = [p1, p2, p3] + ([p1] if full_circle else [])
    np.testing.assert_allclose(Pp, expected, atol=1e-9)
    np.testing.assert_allclose(P[-1], p1 if full_circle else p3, atol=1e-9)
    assert traj.check_limits(teachbot6).ok(1e-9)
    # orientation held
    R = fk_batch(teachbot6, traj.q)[:, :3, :3]
    assert np.abs(R - start[:3, :3]).max() < 1e-9


def test_arc_rotate_orientation_and_errors(teachbot6, start):
    # an arc in the plane normal to the tool axis: turning with it mostly turns joint 6
    p1 = start[:3, 3]
    e1, e2 = start[:3, 0], start[:3, 1]
    p2, p3 = p1 + 0.02 * e1 + 0.01 * e2, p1 + 0.04 * e1
    traj = arc3(teachbot6, p1, p2, p3, 0.05, q_start=Q_START, orientation="rotate")
    assert traj.check_limits(teachbot6).ok(1e-9)
    T = fk_batch(teachbot6, traj.q)
    n = np.array(traj.meta["normal"])
    # the tool turns with the arc: its rotation relative to the start is about the normal by
    # the swept polar angle
    swept = traj.meta["s"][-1] / traj.meta["radius_m"]
    rel = pin.log3(T[-1, :3, :3] @ start[:3, :3].T)
    np.testing.assert_allclose(rel, n * swept, atol=1e-9)
    with pytest.raises(InputError, match="collinear"):
        arc3(teachbot6, p1, p1 + [0.01, 0, 0], p1 + [0.02, 0, 0], 0.05, q_start=Q_START)
    with pytest.raises(InputError, match="orientation"):
        arc3(teachbot6, p1, p2, p3, 0.05)


# ---------------------------------------------------------------------- blend
def test_blend_flyby_chain(teachbot6, start):
    p1 = start[:3, 3]
    pts = np.array([p1, p1 + [0.06, 0, 0], p1 + [0.06, 0.06, 0], p1 + [0.0, 0.06, 0.04]])
    R = 0.02
    traj = blend(teachbot6, pts, R, 0.1, q_start=Q_START)
    assert traj.check_limits(teachbot6).ok(1e-9)
    P = fk_batch(teachbot6, traj.q)[:, :3, 3]
    np.testing.assert_allclose(P[[0, -1]], pts[[0, -1]], atol=1e-9)
    # FlyBy: never stops in between, passes the first corner at R / sin(45 deg) - R
    speed = np.linalg.norm(np.gradient(P, traj.t, axis=0), axis=1)
    assert speed[1:-1].min() > 0
    d = np.linalg.norm(P - pts[1], axis=1).min()
    assert d == pytest.approx(R / math.sin(math.pi / 4) - R, abs=2e-3)
    # exact corners (radius 0): the tool stops at every taught point
    stops = blend(teachbot6, pts, 0.0, 0.1, q_start=Q_START)
    Ps = fk_batch(teachbot6, stops.q)[:, :3, 3]
    for p in pts:
        k = np.argmin(np.linalg.norm(Ps - p, axis=1))
        assert np.linalg.norm(Ps[k] - p) < 1e-9
        assert np.abs(stops.qd[k]).max() < 1e-12
    assert stops.check_limits(teachbot6).ok(1e-9)
    with pytest.raises(InputError, match="too large"):
        blend(teachbot6, pts, 0.07, 0.1, q_start=Q_START)


@settings(
    max_examples=20, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    dp=st.lists(st.floats(-0.05, 0.05), min_size=3, max_size=3),
    rot=st.lists(st.floats(-0.3, 0.3), min_size=3, max_size=3),
    speed=st.floats(0.01, 0.5),
    profile=st.sampled_from(["trapezoid", "scurve"]),
)
def test_line_random_moves(teachbot6, start, dp, rot, speed, profile):
    if np.linalg.norm(dp) < 1e-3:
        return
    T1 = _goal(start, dp, rot)
    try:
        traj = line(teachbot6, start, T1, speed, q_start=Q_START, profile=profile)
    except UnreachableError:  # a defined outcome: the message names the point
        return
    P = fk_batch(teachbot6, traj.q)[:, :3, 3]
    assert _distance_to_segment(P, start[:3, 3], T1[:3, 3]).max() <= 1e-9
    assert traj.check_limits(teachbot6).ok(1e-9)
    assert traj.meta["speed"] <= speed * (1 + 1e-12)
