"""Replanning from any state: ``ptp_sync`` from a moving start to a goal speed (issue 15).

The 1-D moves are checked against a brute-force scan of the durations each can take; the
synchronised plans with the property checker of ``test_planner_properties`` (limits from the
first sample, exact ends, continuity, honest derivatives) -- except rest at the ends, which a
replanned move does not have: its boundary speeds are checked instead.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_planner_properties import (
    NAMED,
    Case,
    _decades,
    _limits,
    _move,
    _robot_name,
    check_trajectory,
    get_robot,
)

from armlab.errors import InfeasibleError, InputError
from armlab.planning import ptp_sync
from armlab.robot import resolve_limits
from armlab.trajectory.profiles import (
    trapezoid_blocked_from_state,
    trapezoid_from_state,
    trapezoid_min_time,
    trapezoid_min_time_from_state,
)
from armlab.trajectory.profiles.from_state import _ramps_distance


def _reachable(D, v0, v1, v, a, T) -> bool:
    """Brute force: the distances the family reaches in ``T`` span ``[D(lo), D(hi)]``."""
    if T < abs(v1 - v0) / a:
        return False
    lo, hi = max((v0 + v1 - a * T) / 2, -v), min((v0 + v1 + a * T) / 2, v)
    tol = 1e-9 * (abs(D) + 1e-9)
    return (
        _ramps_distance(lo, v0, v1, T, a) <= D + tol
        and D <= _ramps_distance(hi, v0, v1, T, a) + tol
    )


def test_one_joint_minimum_time_and_gaps_match_a_scan():
    """Over 300 random moves (speeds both ways, a third ending at rest): the minimum time is
    reachable and nothing shorter is; the gap, where there is one, is exactly what the scan
    finds unreachable; rest to rest is the classic trapezoid."""
    rng = np.random.default_rng(2)
    gaps = 0
    for it in range(300):
        v, a = rng.uniform(0.1, 3.0), rng.uniform(0.1, 10.0)
        D, v0, v1 = rng.uniform(-3, 3), rng.uniform(-v, v), rng.uniform(-v, v)
        if it % 3 == 0:
            v1 = 0.0
        elif it % 3 == 1:  # both speeds one way, a short move that way: a gap is likely
            v1 = abs(v1) * np.sign(v0)
            D = np.sign(v0) * rng.uniform(0, (v0 * v0 + v1 * v1) / (2 * a))
        T = trapezoid_min_time_from_state(D, v0, v1, v, a)
        gap = trapezoid_blocked_from_state(D, v0, v1, v, a)
        end = max(3 * T + 1, 1.5 * gap[1] if gap else 0.0)
        Ts = np.linspace(abs(v1 - v0) / a, end, 800)
        ok = np.array([_reachable(D, v0, v1, v, a, x) for x in Ts])
        assert _reachable(D, v0, v1, v, a, T) and not ok[Ts < T * (1 - 1e-6)].any()
        later = Ts >= T * (1 + 1e-9)
        if gap:
            gaps += 1
            inside = (Ts > gap[0] * (1 + 1e-6)) & (Ts < gap[1] * (1 - 1e-6))
            assert not ok[inside].any()
            later &= ~((Ts > gap[0] * (1 - 1e-6)) & (Ts < gap[1] * (1 + 1e-6)))
        assert ok[later].all()
    assert gaps > 30
    assert trapezoid_min_time_from_state(1.3, 0, 0, 2.0, 3.0) == pytest.approx(
        trapezoid_min_time(1.3, 2.0, 3.0), rel=1e-14
    )


def test_one_joint_move_keeps_its_limits_and_ends_exactly():
    rng = np.random.default_rng(4)
    for _ in range(300):
        v, a = rng.uniform(0.1, 3.0), rng.uniform(0.1, 10.0)
        D, v0, v1 = rng.uniform(-3, 3), rng.uniform(-v, v), rng.uniform(-v, v)
        T = trapezoid_min_time_from_state(D, v0, v1, v, a)
        gap = trapezoid_blocked_from_state(D, v0, v1, v, a)
        for k in (1.0, 1.3, 5.0):
            if gap and gap[0] < k * T < gap[1]:
                with pytest.raises(InfeasibleError, match="cannot take"):
                    trapezoid_from_state(D, v0, v1, v, a, k * T)
                continue
            p = trapezoid_from_state(D, v0, v1, v, a, k * T)
            s, sd, sdd, _ = p.evaluate(np.linspace(0.0, k * T, 400))
            assert sd[0] == pytest.approx(v0, abs=1e-14)
            assert s[-1] == pytest.approx(D, abs=1e-9) and sd[-1] == pytest.approx(v1, abs=1e-9)
            assert np.all(np.abs(sd) <= v * (1 + 1e-12)) and np.all(np.abs(sdd) <= a * (1 + 1e-12))
    with pytest.raises(InfeasibleError, match="at least"):
        trapezoid_from_state(1.0, 0.0, 0.0, 1.0, 1.0, 0.5)
    with pytest.raises(InputError, match="within v_max"):
        trapezoid_min_time_from_state(1.0, 2.0, 0.0, 1.0, 1.0)


def replan_case(seed: int, profile: str = "trapezoid"):
    """A random ``ptp_sync`` from a moving state: robot, limits (a decade spread, half the
    robot's own on teachbot6), start and goal, start speeds up to the limit (``"scurve"``:
    and start accelerations the jerk limit can hold), goal speeds (zero in a third of the
    cases), a third of the joints moving fast towards a close goal, torque on or off.
    Returns ``(case, qd_start, qdd_start, qd_goal)``."""
    scurve = profile == "scurve"
    rng = np.random.default_rng([1515 if scurve else 915, seed])
    robot = get_robot(_robot_name(rng))
    kinds = ("v_max", "a_max", "j_max") if scurve else ("v_max", "a_max")
    kw = _limits(rng, robot, kinds, own=robot.name == "teachbot6")
    lim = resolve_limits(robot, **kw)
    w = _move(rng, robot, 2)
    n, lo, hi = robot.n_joints, robot.limits.lower_rad, robot.limits.upper_rad
    w[0] = lo + (hi - lo) * rng.uniform(0.3, 0.7, n)  # room to brake a start speed
    w[1] = np.clip(w[0] + (w[1] - w[0]) * 0.4, lo, hi)
    v, a, j = lim.velocity_rad_s, lim.acceleration_rad_s2, lim.jerk_rad_s3
    v0 = (
        v
        * rng.uniform(-1, 1, n)
        * rng.choice([0.05, 0.2, 0.5] if scurve else [0.05, 0.2, 0.5, 1.0])
    )
    a0 = np.zeros(n)
    if scurve:  # within what the jerk limit can stop before the speed limit
        a0 = a * rng.uniform(-1, 1, n) * rng.choice([0.0, 0.3, 1.0])
        a0 = np.sign(a0) * np.minimum(np.abs(a0), np.sqrt(2 * j * (v - np.sign(a0) * v0)) * 0.99)
    v1 = np.zeros(n) if seed % 3 == 0 else v * rng.uniform(-0.5, 0.5, n)
    short = rng.random(n) < 0.3  # a short move the way the joint already goes: gaps
    v1[short] = np.abs(v1[short]) * np.sign(v0[short])
    reach = (v0**2 + v1**2) / (2 * a)
    w[1, short] = np.clip(
        w[0, short] + np.sign(v0[short]) * rng.uniform(0, 1, n)[short] * reach[short],
        lo[short],
        hi[short],
    )
    dt = float(_decades(rng, -3, -1.5, 1)[0])
    torque = bool(rng.random() < 0.5)
    state = {"qd_start": v0, "qd_goal": v1, **({"qdd_start": a0} if scurve else {})}

    def fn():
        return ptp_sync(
            robot, w[0], w[1], profile, dt=dt, tau_max=None if torque else False, **state, **kw
        )

    case = Case(f"ptp_{profile}", seed, robot, fn, lim, torque, w, ptp=True, info={"dt": dt})
    return case, v0, a0, v1


def moving_failures(case: Case, traj) -> list[str]:
    """:func:`check_trajectory`'s failures that apply to a move from a moving state: it need
    not rest at its ends, and a joint with no distance to go but a start speed brakes and
    comes back."""
    failures, _ = check_trajectory(case, traj)
    return [
        f
        for f in failures
        if not f.startswith("does not rest at its ends") and f != "a joint without a move moves"
    ]


@pytest.mark.parametrize("seed", range(40))
def test_replanned_ptp_holds_every_property(seed):
    """The limits hold from the first sample (torque too where on), both ends are exact,
    the start and goal speeds are the asked ones; or a named one-line refusal (a start speed
    that cannot be braked inside the joint range)."""
    case, v0, _, v1 = replan_case(seed)
    try:
        traj = case.run()
    except NAMED as exc:
        assert "\n" not in str(exc)
        return
    assert moving_failures(case, traj) == [], str(case)
    np.testing.assert_array_equal(traj.qd[0], v0)
    np.testing.assert_array_equal(traj.qd[-1], v1)
    np.testing.assert_allclose(traj.at([0.0])[1][0], v0, atol=1e-12)
    assert traj.meta["qd_start"] == v0.tolist()


def test_from_rest_the_replan_is_the_classic_plan(teachbot6):
    """Zero start and goal speeds: the rest-to-rest plan, bit for bit."""
    q0 = np.array([0.0, -0.3, 0.4, 0.0, 0.5, 0.0])
    q1 = np.array([0.8, 0.2, -0.2, 0.9, -0.4, 1.2])
    a = ptp_sync(teachbot6, q0, q1, "trapezoid", dt=1e-3)
    b = ptp_sync(teachbot6, q0, q1, "trapezoid", dt=1e-3, qd_start=np.zeros(6), qd_goal=None)
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.t, b.t)


def test_replanning_mid_motion_continues_the_motion(teachbot6):
    """Cut a plan halfway and replan from its state to the same goal: the new plan starts
    with that speed, ends at rest on the goal, and is no longer than the rest of the old one
    (the old plan is one of the candidates the minimum-time replan beats)."""
    q0 = np.array([0.0, -0.3, 0.4, 0.0, 0.5, 0.0])
    q1 = np.array([0.8, 0.2, -0.2, 0.9, -0.4, 1.2])
    first = ptp_sync(teachbot6, q0, q1, "trapezoid", dt=1e-3, tau_max=False)
    tc = 0.4 * first.duration
    q, qd, qdd, _ = first.at([tc])
    again = ptp_sync(
        teachbot6, q[0], q1, "trapezoid", dt=1e-3, tau_max=False, qd_start=qd[0], qdd_start=qdd[0]
    )
    assert again.duration <= first.duration - tc + 1e-9
    np.testing.assert_allclose(again.qd[0], qd[0], atol=1e-12)
    np.testing.assert_array_equal(again.q[-1], q1)


def test_common_duration_skips_a_joints_gap(teachbot6):
    """Joint 2 runs forward at 1 rad/s towards a goal 0.25 rad ahead, to arrive at 0.5 rad/s
    (a = 2 rad/s^2): it can arrive within 0.396 s, or after reversing from 1.104 s on --
    ``v_c = -+sqrt((1 + 0.25) / 2 - 2 x 0.25)``, ``T = (1.5 -+ 2 v_c) / 2`` -- but not in
    between. Joint 1 alone would take 1.0 s (rest to rest over 0.5 rad): the plan takes
    1.104 s."""
    centre = 0.5 * (teachbot6.limits.lower_rad + teachbot6.limits.upper_rad)
    q1 = centre.copy()
    q1[0] += 0.5
    q1[1] += 0.25
    v0, v1 = np.zeros(6), np.zeros(6)
    v0[1], v1[1] = 1.0, 0.5
    traj = ptp_sync(
        teachbot6,
        centre,
        q1,
        "trapezoid",
        v_max=2.0,
        a_max=2.0,
        dt=1e-3,
        tau_max=False,
        qd_start=v0,
        qd_goal=v1,
    )
    vc = np.sqrt((1 + 0.25) / 2 - 2 * 0.25)
    assert trapezoid_blocked_from_state(0.25, 1.0, 0.5, 2.0, 2.0) == pytest.approx(
        ((1.5 - 2 * vc) / 2, (1.5 + 2 * vc) / 2), rel=1e-14
    )
    assert traj.duration == pytest.approx((1.5 + 2 * vc) / 2, rel=1e-12)
    assert traj.meta["binding"]["gap"] is True
    assert traj.qd[:, 1].min() < 0  # it reverses
    np.testing.assert_array_equal(traj.q[-1], q1)


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"qd_start": np.full(6, 1e3)}, "qd_start: joint1 .* velocity limit"),
        ({"qd_goal": np.full(6, -1e3)}, "qd_goal: joint1"),
        ({"qdd_start": np.full(6, 1e6)}, "qdd_start: joint1 .* acceleration limit"),
        ({"qd_start": np.ones(5)}, "shape"),
        ({"qd_start": np.full(6, np.nan)}, "finite"),
        ({"qd_start": np.full(6, 0.1), "profile": "velocity"}, "profile='trapezoid' or 'scurve'"),
        ({"qd_start": np.full(6, 0.1), "sync": "phase"}, "sync='time'"),
    ],
)
def test_bad_start_states_are_named(teachbot6, kw, match):
    q0 = np.zeros(6)
    q1 = np.full(6, 0.3)
    with pytest.raises(InputError, match=match):
        ptp_sync(teachbot6, q0, q1, **{"profile": "trapezoid", **kw})
