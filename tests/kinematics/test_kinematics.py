"""Kinematics: FK against the thesis' closed form, Jacobians against finite differences,
analytic IK round trips, numerical IK success rates, bad input, workspace and accuracy."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pinocchio as pin
import pytest
from matplotlib.figure import Figure

import armlab
from armlab import ArmlabError, InputError, UnreachableError
from armlab.kinematics import (
    accuracy_study,
    fk,
    fk_batch,
    has_analytic_ik,
    ik,
    ik_all,
    ik_all_batch,
    ik_nearest,
    ik_solve,
    jacobian,
    max_reach_m,
    workspace_cloud,
)
from armlab.kinematics.accuracy import LINK_TOLERANCES_M
from armlab.kinematics.analytic_ik import ik_all_batch_reasons
from armlab.kinematics.forward import analytic_jacobian
from armlab.plots import plot_accuracy, plot_accuracy_scatter, plot_workspace
from conftest import PANDA_FINGERS, PANDA_URDF


def _rot_err(R1: np.ndarray, R2: np.ndarray) -> np.ndarray:
    """Rotation angle between stacks of rotation matrices (..., 3, 3), in [rad]:
    ``||R1 - R2||_F = 2 sqrt(2) sin(angle / 2)`` (accurate for small angles)."""
    s = np.linalg.norm(R1 - R2, axis=(-2, -1)) / (2.0 * math.sqrt(2.0))
    return 2.0 * np.arcsin(np.clip(s, 0.0, 1.0))


# ------------------------------------------------------------------------------ forward
def test_fk_matches_thesis_wrist_centre_equations(teachbot6):
    """Thesis eq. 3-8: px = c1 (a1 + a2 c2 + a3 c23 - d4 s23), py = s1 (...),
    pz = -(a2 s2 + a3 s23 + d4 c23), with theta = q + offset, at the origin of DH frame 4."""
    rng = np.random.default_rng(11)
    dh = teachbot6.dh
    a1, a2, a3, d4 = dh.a_m[1], dh.a_m[2], dh.a_m[3], dh.d_m[3]
    assert (a1, a2, a3, d4) == pytest.approx((0.120, 0.220, 0.080, 0.202))
    for q in teachbot6.random_q(rng, 300):
        th = q + dh.offset_rad
        c1, s1 = math.cos(th[0]), math.sin(th[0])
        c2, s2 = math.cos(th[1]), math.sin(th[1])
        c23, s23 = math.cos(th[1] + th[2]), math.sin(th[1] + th[2])
        bracket = a1 + a2 * c2 + a3 * c23 - d4 * s23
        expected = [c1 * bracket, s1 * bracket, -(a2 * s2 + a3 * s23 + d4 * c23)]
        np.testing.assert_allclose(fk(teachbot6, q, frame="link4")[:3, 3], expected, atol=1e-12)


def test_fk_matches_closed_form_dh_table(teachbot6):
    rng = np.random.default_rng(12)
    q = teachbot6.random_q(rng, 200)
    np.testing.assert_allclose(fk_batch(teachbot6, q), teachbot6.dh.fk(q), atol=1e-12)


def _fd_twist(robot, q, h=1e-6):
    """Central finite differences of the tool pose: (6, n) [dp/dq; omega/dq] in the world."""
    n = robot.n_joints
    J = np.zeros((6, n))
    for j in range(n):
        dq = np.zeros(n)
        dq[j] = h
        Tp, Tm = fk(robot, q + dq), fk(robot, q - dq)
        J[:3, j] = (Tp[:3, 3] - Tm[:3, 3]) / (2 * h)
        J[3:, j] = pin.log3(Tp[:3, :3] @ Tm[:3, :3].T) / (2 * h)
    return J


@pytest.mark.parametrize("name", ["teachbot6", "ur5", "panda"])
def test_geometric_jacobian_matches_finite_differences(name, request):
    robot = request.getfixturevalue(name)
    rng = np.random.default_rng(13)
    for q in robot.random_q(rng, 10):
        q = np.clip(q, robot.limits.lower_rad + 1e-5, robot.limits.upper_rad - 1e-5)
        J = jacobian(robot, q)
        np.testing.assert_allclose(J, _fd_twist(robot, q), atol=1e-7)
        # the local variant is the same twist in tool axes
        R = fk(robot, q)[:3, :3]
        Jl = jacobian(robot, q, reference="local")
        np.testing.assert_allclose(np.vstack([R @ Jl[:3], R @ Jl[3:]]), J, atol=1e-12)


@pytest.mark.parametrize("name", ["teachbot6", "ur5", "panda"])
def test_analytic_jacobian_matches_finite_differences(name, request):
    robot = request.getfixturevalue(name)
    rng = np.random.default_rng(14)
    h = 1e-6
    checked = 0
    for q in robot.random_q(rng, 20):
        rpy = pin.rpy.matrixToRpy(fk(robot, q)[:3, :3])
        if abs(abs(rpy[1]) - math.pi / 2) < 0.2:  # representation singularity
            continue
        Ja = analytic_jacobian(robot, q)
        for j in range(robot.n_joints):
            dq = np.zeros(robot.n_joints)
            dq[j] = h
            Tp, Tm = fk(robot, q + dq), fk(robot, q - dq)
            drpy = pin.rpy.matrixToRpy(Tp[:3, :3]) - pin.rpy.matrixToRpy(Tm[:3, :3])
            drpy = (drpy + math.pi) % (2 * math.pi) - math.pi
            fd = np.concatenate([(Tp[:3, 3] - Tm[:3, 3]), drpy]) / (2 * h)
            np.testing.assert_allclose(Ja[:, j], fd, atol=1e-6)
        checked += 1
    assert checked >= 10


# ------------------------------------------------------------------------------ analytic IK
def test_ik_round_trip_10000_configurations(teachbot6):
    """The solution set contains the original (1e-9 rad) and every solution reproduces the
    pose (1e-9 m, 1e-9 rad). Samples where the arm is nearly singular (smallest singular value
    of the Jacobian < 1e-5), where q is inherently ill-conditioned, are counted and bounded,
    and still must contain the original to 1e-6 rad."""
    robot = teachbot6
    rng = np.random.default_rng(2024)
    q = robot.random_q(rng, 10_000)
    T = fk_batch(robot, q)
    sol, valid = ik_all_batch(robot, T)
    assert sol.shape == (10_000, 8, 6) and valid.shape == (10_000, 8)
    assert valid.any(axis=1).all()
    dist = np.where(valid, np.abs(sol - q[:, None, :]).max(axis=2), np.inf).min(axis=1)
    sigma_min = np.array([np.linalg.svd(jacobian(robot, qk), compute_uv=False)[-1] for qk in q])
    near_singular = sigma_min < 1e-5
    assert near_singular.sum() <= 10  # 0.1 %
    assert dist[~near_singular].max() < 1e-9
    assert dist.max() < 1e-6
    # every returned solution reproduces the pose (checked with Pinocchio, not the DH code)
    counts = valid.sum(axis=1)
    T_sol = fk_batch(robot, sol[valid])
    T_ref = np.repeat(T, counts, axis=0)
    assert np.abs(T_sol[:, :3, 3] - T_ref[:, :3, 3]).max() < 1e-9
    assert _rot_err(T_sol[:, :3, :3], T_ref[:, :3, :3]).max() < 1e-9
    assert robot.within_limits(sol[valid], tol=0.0).all()
    assert counts.max() <= 8 and counts.mean() > 2


def test_ik_all_matches_batch_and_branch_count(teachbot6):
    q = np.array([0.3, 0.4, 0.5, 0.6, 0.7, 0.8])
    T = fk(teachbot6, q)
    sols = ik_all(teachbot6, T)
    sol_b, valid_b = ik_all_batch(teachbot6, T)
    assert len(sols) == valid_b.sum()
    np.testing.assert_allclose(sols, sol_b[0][valid_b[0]])
    # with +-pi ranges and the wrist centre near the base axis (the arm reaches it from the
    # front and from behind) all 8 branches exist, are distinct and reproduce the pose
    wide = teachbot6.with_limits(lower_rad=np.full(6, -math.pi), upper_rad=np.full(6, math.pi))
    q8 = np.array([0.3, -0.2, 1.2, 0.6, 0.7, 0.8])
    assert np.hypot(*fk(wide, q8, frame="link4")[:2, 3]) < 0.437 - 0.12 - 0.05
    all8 = ik_all(wide, fk(wide, q8))
    assert len(all8) == 8
    assert min(np.abs(a - b).max() for i, a in enumerate(all8) for b in all8[:i]) > 1e-3
    for s in all8:
        np.testing.assert_allclose(fk(wide, s), fk(wide, q8), atol=1e-12)


def test_ik_all_adds_two_pi_variants_for_wide_ranges(teachbot6):
    wide = teachbot6.with_limits(
        lower_rad=np.r_[-math.pi, -math.pi, -math.pi, -2 * math.pi, -math.pi, -math.pi],
        upper_rad=np.r_[math.pi, math.pi, math.pi, 2 * math.pi, math.pi, math.pi],
    )
    T = fk(wide, np.array([0.3, -0.2, 1.2, 0.6, 0.7, 0.8]))
    sols = ik_all(wide, T)
    assert len(sols) == 16  # q4 and q4 - 2 pi (or + 2 pi) for each of the 8 branches
    q4 = np.sort(sols[:, 3])
    assert np.sum(np.abs(q4) > math.pi) == 8
    for s in sols:
        np.testing.assert_allclose(fk(wide, s), T, atol=1e-12)


def test_ik_honours_base_and_tool_transforms(teachbot6):
    base = np.eye(4)
    base[:3, :3] = pin.rpy.rpyToMatrix(0.1, -0.2, 0.3)
    base[:3, 3] = [0.5, -0.2, 0.8]
    robot = armlab.load_robot("teachbot6", transform_base_to_world=base)
    tool = np.eye(4)
    tool[:3, :3] = pin.rpy.rpyToMatrix(0.0, 0.5, 0.0)
    tool[:3, 3] = [0.02, 0.0, 0.05]
    robot.set_tool(tool)
    rng = np.random.default_rng(3)
    q = robot.random_q(rng, 200)
    T = fk_batch(robot, q)
    sol, valid = ik_all_batch(robot, T)
    dist = np.where(valid, np.abs(sol - q[:, None, :]).max(axis=2), np.inf).min(axis=1)
    assert dist.max() < 1e-8
    np.testing.assert_allclose(
        fk_batch(robot, sol[valid])[:, :3, 3],
        np.repeat(T, valid.sum(1), axis=0)[:, :3, 3],
        atol=1e-12,
    )


def test_ik_nearest_picks_the_reference_branch(teachbot6):
    rng = np.random.default_rng(4)
    q = teachbot6.random_q(rng, 500)
    T = fk_batch(teachbot6, q)
    np.testing.assert_allclose(ik_nearest(teachbot6, T, q), q, atol=1e-6)
    one = ik_nearest(teachbot6, T[0], q[0])
    assert one.shape == (6,)
    # weights: a zero weight on every joint but q1 still picks a solution with the closest q1
    sols = ik_all(teachbot6, T[1])
    w = np.array([1.0, 0, 0, 0, 0, 0])
    pick = ik_nearest(teachbot6, T[1], np.zeros(6), weights=w)
    assert abs(pick[0]) == pytest.approx(np.abs(sols[:, 0]).min())


def test_ik_nearest_sequential_keeps_branch_along_a_path(teachbot6):
    q0 = np.array([0.2, 0.3, 0.6, 0.4, -0.8, 0.1])
    q1 = np.array([0.6, 0.5, 0.3, 0.9, -0.5, 0.7])
    path = q0 + np.linspace(0, 1, 50)[:, None] * (q1 - q0)
    T = fk_batch(teachbot6, path)
    out = ik_nearest(teachbot6, T, q0, sequential=True)
    np.testing.assert_allclose(out, path, atol=1e-9)


def test_wrist_singularity_returns_defined_solution(teachbot6):
    q = np.array([0.3, 0.2, 0.4, 0.7, 0.0, -0.5])  # q5 = 0: axes 4 and 6 aligned
    T = fk(teachbot6, q)
    sols = ik_all(teachbot6, T)
    for s in sols:
        np.testing.assert_allclose(fk(teachbot6, s), T, atol=1e-12)
    wrist_flat = sols[np.abs(sols[:, 4]) < 1e-9]
    assert len(wrist_flat) >= 1
    assert np.all(wrist_flat[:, 3] == 0.0)  # q4 = reference (0), q6 takes up q4 + q6
    np.testing.assert_allclose(wrist_flat[0, 3] + wrist_flat[0, 5], q[3] + q[5], atol=1e-12)
    # with a reference the q4 of the reference is kept: the original comes back
    np.testing.assert_allclose(ik_nearest(teachbot6, T, q), q, atol=1e-12)


def test_unreachable_poses_raise_with_reason(teachbot6):
    T = fk(teachbot6, np.array([0.3, 0.2, 0.4, 0.7, 0.5, -0.5]))
    far = T.copy()
    far[:3, 3] *= 3.0
    with pytest.raises(UnreachableError, match="outside reach"):
        ik_all(teachbot6, far)
    axis = np.eye(4)
    axis[:3, 3] = [0.0, 0.0, 0.2 + 0.2]  # wrist centre on the joint-1 axis (tool points up)
    with pytest.raises(UnreachableError, match="shoulder singularity"):
        ik_all(teachbot6, axis)
    # a pose whose every solution breaks some range: joint 2 beyond its 135 deg bound
    wide = teachbot6.with_limits(lower_rad=np.full(6, -math.pi), upper_rad=np.full(6, math.pi))
    q_out = np.array([0.0, 2.6, -1.0, 0.0, 0.5, 0.0])
    T_out = fk(wide, q_out)
    sols_wide = ik_all(wide, T_out)
    assert not teachbot6.within_limits(sols_wide).any()
    with pytest.raises(
        UnreachableError,
        match=r"all 4 solutions lie outside the joint ranges "
        r"\(joint2 blocks 4\)",
    ):
        ik_all(teachbot6, T_out)
    with pytest.raises(UnreachableError, match=r"pose 1 \(of 2\)"):
        ik_nearest(teachbot6, np.stack([T, far]), np.zeros(6))
    sol, valid, reasons = ik_all_batch_reasons(teachbot6, np.stack([T, far, axis, T_out]))
    assert reasons.tolist() == [0, 3, 2, 4]
    assert valid.any(axis=1).tolist() == [True, False, False, False]


def test_bad_input_raises_our_errors(teachbot6, ur5):
    T = fk(teachbot6, np.zeros(6))
    nan = T.copy()
    nan[0, 3] = np.nan
    with pytest.raises(InputError, match="NaN"):
        ik_all(teachbot6, nan)
    with pytest.raises(InputError, match=r"poses\[1\] contains NaN"):
        ik_nearest(teachbot6, np.stack([T, nan]), np.zeros(6))
    _, valid, reasons = ik_all_batch_reasons(teachbot6, np.stack([T, nan]))
    assert reasons[1] == 1 and not valid[1].any()
    with pytest.raises(InputError, match="shape"):
        ik_all(teachbot6, np.eye(3))
    with pytest.raises(InputError, match="one \\(4, 4\\) pose"):
        ik_all(teachbot6, np.stack([T, T]))
    skew = T.copy()
    skew[:3, :3] *= 1.1
    with pytest.raises(InputError, match="orthonormal"):
        ik_all(teachbot6, skew)
    with pytest.raises(InputError, match="q_ref"):
        ik_nearest(teachbot6, T, np.zeros(5))
    with pytest.raises(InputError, match="weights"):
        ik_nearest(teachbot6, T, np.zeros(6), weights=[1, 1, 1])
    with pytest.raises(InputError, match="NaN"):
        ik(ur5, nan[None][0], np.zeros(6))
    with pytest.raises(InputError, match="q_seed"):
        ik(ur5, fk(ur5, np.zeros(6)), np.zeros(3))


def test_non_spherical_wrist_robots_are_refused(teachbot6, ur5):
    with pytest.raises(ArmlabError, match="no analytic IK for ur5.*no DH table"):
        ik_all(ur5, np.eye(4))
    assert not has_analytic_ik(ur5) and has_analytic_ik(teachbot6)
    bent = teachbot6.copy()
    a = teachbot6.dh.a_m.copy()
    a[4] = 0.03  # a_4 != 0: axes 4, 5, 6 no longer meet
    bent.dh = dataclasses.replace(teachbot6.dh, a_m=a)
    with pytest.raises(ArmlabError, match="no analytic IK for teachbot6.*do not intersect"):
        ik_all(bent, np.eye(4))
    twisted = teachbot6.copy()
    alpha = teachbot6.dh.alpha_rad.copy()
    alpha[2] = 0.3
    twisted.dh = dataclasses.replace(teachbot6.dh, alpha_rad=alpha)
    with pytest.raises(ArmlabError, match="alpha_2 is not 0"):
        ik_all_batch(twisted, np.eye(4)[None])


# ------------------------------------------------------------------------------ numerical IK
@pytest.mark.parametrize("name", ["teachbot6", "ur5", "panda"])
def test_numerical_ik_success_rate(name, request):
    """>= 99.5 % of random reachable poses (FK of random in-range q), from random seeds."""
    robot = request.getfixturevalue(name)
    rng = np.random.default_rng(99)
    n = 400
    q = robot.random_q(rng, n)
    seeds = robot.random_q(rng, n)
    results = [
        ik_solve(robot, fk(robot, q[k]), seeds[k], rng=np.random.default_rng(k)) for k in range(n)
    ]
    ok = np.array([r.success for r in results])
    assert ok.mean() >= 0.995, f"{name}: {ok.mean():.2%}"
    for r, qk in zip(results, q, strict=True):
        if r.success:
            assert r.position_error_m <= 1e-6 and r.rotation_error_rad <= 1e-6
            assert robot.within_limits(r.q, tol=0.0)
            T = fk(robot, r.q)
            T0 = fk(robot, qk)
            assert np.linalg.norm(T[:3, 3] - T0[:3, 3]) <= 1e-6


def test_numerical_ik_reports_failure_honestly(ur5):
    T = fk(ur5, np.zeros(6))
    T[:3, 3] = [3.0, 0.0, 0.5]  # far outside a 0.85 m arm
    res = ik_solve(ur5, T, np.zeros(6), restarts=2, max_iter=30)
    assert not res.success and res.restarts == 2
    assert res.position_error_m > 1.5
    assert json.loads(json.dumps(res.to_dict()))["success"] is False
    with pytest.raises(UnreachableError, match="numerical IK failed"):
        ik(ur5, T, np.zeros(6), restarts=1, max_iter=20)


def test_numerical_ik_other_frame_and_base(panda):
    base = np.eye(4)
    base[:3, 3] = [1.0, 2.0, 0.5]
    robot = armlab.load_robot(
        PANDA_URDF, lock_joints=PANDA_FINGERS, tool_frame="panda_hand", transform_base_to_world=base
    )
    q = np.array([0.1, -0.3, 0.2, -2.0, 0.1, 1.8, 0.5])
    T = fk(robot, q, frame="panda_link5")
    res = ik_solve(robot, T, np.zeros(7), frame="panda_link5")
    assert res.success
    np.testing.assert_allclose(fk(robot, res.q, frame="panda_link5"), T, atol=2e-6)


# ------------------------------------------------------------------------------ workspace
def test_workspace_reach_meets_thesis_requirement(teachbot6):
    """Independent estimate: the wrist centre reaches a1 + a2 + hypot(a3, d4) from the base
    axis (arm stretched horizontally) and the tool (0.2 m along z6) can point outward, so
    max reach = a1 + a2 + hypot(a3, d4) + 0.2 = 0.75726 m; max height a2 + hypot + 0.2."""
    dh = teachbot6.dh
    tool = np.linalg.norm(dh.transform_tool_to_last[:3, 3])
    expected = dh.a_m[1] + dh.a_m[2] + math.hypot(dh.a_m[3], dh.d_m[3]) + tool
    result = workspace_cloud(teachbot6, n_samples=4000, seed=1)
    assert result.max_reach_m >= 0.7  # thesis 2.2.2
    assert result.max_reach_m == pytest.approx(expected, abs=1e-6)
    assert result.max_height_m == pytest.approx(
        dh.a_m[2] + math.hypot(dh.a_m[3], dh.d_m[3]) + tool, abs=1e-6
    )
    assert result.cloud_max_radius_m <= result.max_reach_m + 1e-12
    assert result.radius_m.max() == pytest.approx(result.cloud_max_radius_m)
    np.testing.assert_allclose(
        np.hypot(*fk(teachbot6, result.q_max_reach)[:2, 3]), result.max_reach_m, atol=1e-12
    )
    assert max_reach_m(teachbot6) == pytest.approx(expected, abs=1e-6)
    d = json.loads(json.dumps(result.to_dict()))
    assert d["max_reach_m"] == pytest.approx(expected, abs=1e-6)
    fig = plot_workspace(result)
    assert isinstance(fig, Figure) and len(fig.axes) == 2


def test_workspace_is_in_the_base_frame_and_seeded(teachbot6):
    base = np.eye(4)
    base[:3, :3] = pin.rpy.rpyToMatrix(0.0, 0.0, 0.7)
    base[:3, 3] = [1.0, 0.0, 0.3]
    moved = armlab.load_robot("teachbot6", transform_base_to_world=base)
    a = workspace_cloud(teachbot6, n_samples=500, seed=5, refine=False)
    b = workspace_cloud(moved, n_samples=500, seed=5, refine=False)
    np.testing.assert_allclose(a.points_m, b.points_m, atol=1e-12)
    c = workspace_cloud(teachbot6, n_samples=500, seed=6, refine=False)
    assert not np.allclose(a.points_m, c.points_m)
    with pytest.raises(InputError):
        workspace_cloud(teachbot6, n_samples=0)


# ------------------------------------------------------------------------------ accuracy
def test_accuracy_study_is_reproducible(teachbot6):
    a = accuracy_study(teachbot6, n_samples=500, seed=3)
    b = accuracy_study(teachbot6, n_samples=500, seed=3)
    c = accuracy_study(teachbot6, n_samples=500, seed=4)
    np.testing.assert_array_equal(a.error_combined_m, b.error_combined_m)
    assert a.to_dict() == b.to_dict()
    assert not np.array_equal(a.error_combined_m, c.error_combined_m)
    d = json.loads(json.dumps(a.to_dict()))
    assert d["total_p95_m"] == a.total_p95_m
    assert set(d["errors"]) == {"angle", "length", "combined"}


def test_accuracy_statistics_follow_from_the_jacobian(teachbot6):
    """The Monte-Carlo statistics against a computation that shares nothing with it but the
    robot: with independent joint errors uniform in +-e (variance e^2 / 3), the first-order
    error ``J_v dtheta`` of each sample has per-axis variance ``sum_i J_ai^2 e^2 / 3`` and is
    bounded by ``sum_i |J_ai| e``. The sample variance over 3000 poses matches the mean of the
    analytic one within its sampling error, and no sample breaks its bound. (Which ``e``
    reproduces the thesis' 3.7.1 "about 1 mm" is a modelling choice, not tested here.)"""
    e = math.radians(5.0 / 60.0)
    res = accuracy_study(
        teachbot6, n_samples=3000, seed=0, angle_error_rad=e, length_tolerances_m={}
    )
    J = np.array([jacobian(teachbot6, q)[:3] for q in res.q])  # (n, 3, n_joints)
    var_model = (J**2).sum(axis=2) * e**2 / 3.0  # (n, 3)
    dp = res.error_angle_m
    var_mc = (dp**2).mean(axis=0)
    # sampling error of a mean of squares: ~ sqrt(var(dp^2) / n) relative ~ sqrt(2/n)-ish
    np.testing.assert_allclose(var_mc, var_model.mean(axis=0), rtol=0.08)
    bound = np.abs(J).sum(axis=2) * e
    assert np.all(np.abs(dp) <= bound * (1 + 1e-3) + 1e-9)
    # and the errors scale with e to first order: half the bound, half the error, up to the
    # second-order term ~ e^2 x reach (0.76 m)
    half = accuracy_study(
        teachbot6, n_samples=3000, seed=0, angle_error_rad=e / 2, length_tolerances_m={}
    )
    np.testing.assert_allclose(half.error_angle_m, dp / 2, rtol=0, atol=e**2 * 0.76)
    # lengths: each length error moves the point by exactly its size, so |dp| <= sum tol
    lengths = accuracy_study(teachbot6, n_samples=500, seed=1, point="wrist_centre")
    assert lengths.total_m("length").max() <= sum(LINK_TOLERANCES_M.values()) + 1e-12


def test_accuracy_angle_errors_match_jacobian(teachbot6):
    """First order: dp = J_v(q) dtheta; the Monte-Carlo error agrees to O(e^2)."""
    res = accuracy_study(teachbot6, n_samples=200, seed=8, length_tolerances_m={})
    assert not np.any(res.error_length_m)
    for k in range(200):
        lin = jacobian(teachbot6, res.q[k])[:3] @ res.dtheta_rad[k]
        np.testing.assert_allclose(res.error_angle_m[k], lin, atol=5e-6)
    tool = accuracy_study(teachbot6, n_samples=3000, seed=0)
    assert 0.5e-3 < tool.total_p95_m < 1.5e-3
    fig = plot_accuracy(tool)
    assert isinstance(fig, Figure) and len(fig.axes) == 12
    assert isinstance(plot_accuracy_scatter(tool), Figure)


def test_accuracy_bad_input(teachbot6, ur5):
    with pytest.raises(ArmlabError, match="DH table"):
        accuracy_study(ur5)
    with pytest.raises(InputError, match="unknown length parameter"):
        accuracy_study(teachbot6, length_tolerances_m={"b2": 1e-4})
    with pytest.raises(InputError, match="point"):
        accuracy_study(teachbot6, point="elbow")
    with pytest.raises(InputError, match="angle_error_rad"):
        accuracy_study(teachbot6, angle_error_rad=-1.0)
