"""Jerk-limited replanning from any state (issue 15): ``ptp_sync(..., "scurve")`` from a
moving start (speed and acceleration) to a goal speed.

The 1-D moves are checked against Ruckig (Berscheid & Kröger 2021, the reference
implementation of the method: the same minimum time, the same synchronised duration, the
same durations reachable when it is asked for a minimum duration), and every profile against
its limits, its boundary states and its own derivatives; the planned trajectories with the
property checker of ``test_planner_properties``.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_planner_properties import (
    NAMED,
    Case,
    check_trajectory,
)
from test_replan import moving_failures, replan_case

from armlab.errors import InfeasibleError, InputError
from armlab.planning import ptp_sync
from armlab.robot import resolve_limits
from armlab.trajectory.profiles import (
    JerkMove,
    double_s_min_time,
    scurve_blocked_from_state,
    scurve_from_state,
    scurve_min_time_from_state,
    synchronised_from_state,
    synchronised_profiles,
)


def _state(rng, n: int, gap: bool):
    """Random limits and a start state the limits can hold (``v0 + a0 |a0| / 2j`` within
    ``v``); with ``gap`` a fast start towards a close goal, arriving the same way (blocked
    durations are likely)."""
    while True:
        v, a, j = rng.uniform(0.2, 3, n), rng.uniform(0.2, 10, n), rng.uniform(0.5, 50, n)
        if gap:
            v0 = rng.uniform(0.2, 1, n) * v * rng.choice([-1, 1], n)
            a0 = rng.uniform(-1, 1, n) * a * rng.choice([0.0, 0.3, 1.0], n)
            v1 = rng.uniform(0, 1, n) * v * np.sign(v0) * rng.choice([0, 1], n)
            D = np.sign(v0) * rng.uniform(0, 1, n) * (v0**2 + v1**2) / (2 * a)
        else:
            v0, a0 = rng.uniform(-1, 1, n) * v, rng.uniform(-1, 1, n) * a
            v1 = rng.uniform(-1, 1, n) * v * rng.choice([0, 1], n)
            D = rng.uniform(-3, 3, n) * rng.choice([0.02, 0.2, 1.0], n)
        if np.all(np.abs(v0 + a0 * np.abs(a0) / (2 * j)) <= v):
            return D, v0, a0, v1, v, a, j


def _ruckig(D, v0, a0, v1, v, a, j, minimum_duration=None) -> float:
    """Ruckig's time-synchronised duration of the same problem (all joints)."""
    ruckig = pytest.importorskip("ruckig")
    n = np.size(D)

    def f(x):
        return np.broadcast_to(np.asarray(x, float), (n,)).tolist()

    inp = ruckig.InputParameter(n)
    inp.current_position, inp.current_velocity = f(0.0), f(v0)
    inp.current_acceleration = f(a0)
    inp.target_position, inp.target_velocity = f(D), f(v1)
    inp.target_acceleration = f(0.0)
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = f(v), f(a), f(j)
    if minimum_duration is not None:
        inp.minimum_duration = float(minimum_duration)
    traj = ruckig.Trajectory(n)
    assert ruckig.Ruckig(n).calculate(inp, traj) == ruckig.Result.Working
    return float(traj.duration)


# ---------------------------------------------------------------------- against Ruckig
def test_one_joint_minimum_time_is_ruckigs():
    """300 random states (speeds and accelerations both ways, a third towards a close goal,
    half ending at rest): the minimum time equals Ruckig's to 1e-9."""
    rng = np.random.default_rng(15)
    for it in range(300):
        args = [float(x[0]) for x in _state(rng, 1, gap=it % 3 == 0)]
        t_min = scurve_min_time_from_state(*args)
        assert t_min == pytest.approx(_ruckig(*args), rel=1e-9), args


@pytest.mark.parametrize("gap", [False, True])
def test_six_joints_synchronised_duration_is_ruckigs(gap):
    """Six joints from random states: the common duration equals Ruckig's time-synchronised
    one to 1e-9; with fast starts towards close goals a joint's blocked interval often sets
    it (counted, so that the case is exercised)."""
    rng = np.random.default_rng([15, gap])
    moved = 0
    for _ in range(100):
        args = _state(rng, 6, gap)
        T, moves, profs, pushed = synchronised_from_state(*args)
        assert T == pytest.approx(_ruckig(*args), rel=1e-9), args
        assert all(p.duration == pytest.approx(T, rel=1e-12) for p in profs)
        moved += pushed
    assert moved >= (5 if gap else 0)


def test_blocked_intervals_are_ruckigs():
    """Asked for a minimum duration ``T``, Ruckig returns ``T`` if the move can take it and
    the next duration it can take if not: a scan of ``T`` over the minimum, the blocked
    interval and beyond agrees with :attr:`JerkMove.blocked` (and :meth:`JerkMove.profile`
    refuses exactly the blocked durations)."""
    rng = np.random.default_rng(151)
    found = 0
    while found < 12:
        args = [float(x[0]) for x in _state(rng, 1, gap=True)]
        m = JerkMove(*args)
        if not m.blocked:
            continue
        found += 1
        assert scurve_blocked_from_state(*args) == m.blocked
        (lo, hi), end = m.blocked[0], m.blocked[-1][1]
        # the ends of a blocked interval themselves are left to the rounding of either side
        Ts = np.concatenate(
            [
                np.linspace(m.t_min, lo, 5)[:-1],
                [lo * (1 - 1e-7)],
                np.linspace(lo, hi, 9)[1:-1],
                [hi * (1 + 1e-7), 1.3 * end],
            ]
        )
        for T in Ts:
            blocked = any(a * (1 + 1e-9) < T < b * (1 - 1e-9) for a, b in m.blocked)
            got = _ruckig(*args, minimum_duration=T)
            if blocked:
                assert got > T * (1 + 1e-6)
                nxt = min(b for a, b in m.blocked if a < T < b)
                assert got == pytest.approx(nxt, rel=1e-9)
                with pytest.raises(InfeasibleError, match="cannot take"):
                    m.profile(T)
            else:
                assert got == pytest.approx(T, rel=1e-9)
                assert m.profile(T).duration == pytest.approx(T, rel=1e-12)


# ---------------------------------------------------------------------- every profile
def _check_profile(p, T, D, v0, a0, v1, v, a, j):
    """Limits at every sample, knot and left limit (1e-9), exact start state, exact end,
    continuity of s, v, a at the knots, and the jerk of each phase equal to the finite
    difference of its acceleration."""
    tk = p.t_knots
    assert p.duration == pytest.approx(T, rel=1e-12)
    left = tk[1:] - 1e-12 * np.maximum(np.diff(tk), 0)
    t = np.unique(np.concatenate([np.linspace(0, T, 2001), tk, left]))
    s, sd, sdd, sddd = p.evaluate(t)
    assert np.all(np.abs(sd) <= v * (1 + 1e-9))
    assert np.all(np.abs(sdd) <= a * (1 + 1e-9))
    assert np.all(np.abs(sddd) <= j * (1 + 1e-9))
    s0, sd0, sdd0, _ = p.evaluate([0.0])
    assert s0[0] == 0 and sd0[0] == pytest.approx(v0, abs=1e-14)
    assert sdd0[0] == pytest.approx(a0, abs=1e-12 * a)
    sT, sdT, sddT, _ = p.evaluate([T])
    scale = abs(D) + v * T
    assert sT[0] == pytest.approx(D, abs=1e-9 * scale)
    assert sdT[0] == pytest.approx(v1, abs=1e-9 * v)
    assert sddT[0] == pytest.approx(0.0, abs=1e-9 * a)
    # each phase ends where the next starts: its own polynomial against the next's start
    h = p.durations
    a_end = p.accels + p.jerks * h
    v_end = p.v_knots[:-1] + p.accels * h + p.jerks * h * h / 2
    s_end = p.s_knots[:-1] + p.v_knots[:-1] * h + p.accels * h * h / 2 + p.jerks * h**3 / 6
    np.testing.assert_allclose(a_end[:-1], p.accels[1:], atol=1e-9 * a)
    np.testing.assert_allclose(v_end, p.v_knots[1:], atol=1e-9 * v)
    np.testing.assert_allclose(s_end[:-1], p.s_knots[1:-1], atol=1e-9 * scale)
    # the jerk is the derivative of the acceleration, phase by phase
    _, _, a_lo, _ = p.evaluate(tk[:-1] + 0.25 * h)
    _, _, a_hi, _ = p.evaluate(tk[:-1] + 0.75 * h)
    np.testing.assert_allclose((a_hi - a_lo) / (0.5 * h), p.jerks, atol=1e-6 * j)


def test_every_profile_holds_its_limits_and_ends_exactly():
    """Random states; the fastest move, and longer ones (1.001, 1.3, 4 times the minimum,
    blocked durations skipped) -- some of them blends of two members."""
    rng = np.random.default_rng(152)
    kinds = set()
    for it in range(200):
        args = [float(x[0]) for x in _state(rng, 1, gap=it % 2 == 0)]
        m = JerkMove(*args)
        for k in (1.0, 1.001, 1.3, 4.0):
            T = k * m.t_min
            if any(lo < T < hi for lo, hi in m.blocked):
                continue
            p = m.profile(T)
            kinds.add(p.params["family"])
            _check_profile(p, T, *args)
            if k == 1.0:  # the time-optimal move: jerk on its limits or zero
                assert np.all(np.isin(np.abs(p.jerks), [0.0, args[-1]]))
    assert {"peak", "dip"} <= kinds


def test_blends_of_two_members_hold_their_limits():
    """Where no member of a family takes ``T`` with the right distance, the move is the
    convex combination of the farthest and the nearest member in ``T``; built here for
    random states and durations, it keeps every limit and both boundary states."""
    rng = np.random.default_rng(154)
    for it in range(60):
        args = [float(x[0]) for x in _state(rng, 1, gap=it % 2 == 0)]
        m = JerkMove(*args)
        T = m.t_min * rng.uniform(1.0, 3.0)
        if any(lo <= T <= hi for lo, hi in m.blocked):
            continue
        members = [
            (P[i], fam, x[i])
            for fam, (x, P, fits) in enumerate(m._reach(T))
            for i in np.flatnonzero(fits)
        ]
        far, near = max(members), min(members)
        lam = (args[0] - near[0]) / (far[0] - near[0])
        assert 0 <= lam <= 1
        p = m._blend(m._member(far[1], far[2], T), m._member(near[1], near[2], T), lam, T)
        _check_profile(p, T, *args)


def test_minimum_time_scales_with_the_problem():
    """Time ``k`` times shorter at the same jerk (positions ``k^3``, speeds ``k^2``,
    accelerations ``k``): the minimum time and the blocked intervals scale by ``k`` -- also
    for moves of nanometres, where Ruckig's absolute tolerances (1e-8) give longer times:
    (0, 0, -4.34e-4, 0) with ``j = 527`` takes 4.39 ``|a0| / j``, Ruckig 4.56."""
    rng = np.random.default_rng(155)
    for it in range(40):
        D, v0, a0, v1, v, a, j = (float(x[0]) for x in _state(rng, 1, gap=it % 2 == 0))
        m = JerkMove(D, v0, a0, v1, v, a, j)
        for k in (1e-3, 10.0):
            s = JerkMove(D * k**3, v0 * k**2, a0 * k, v1 * k**2, v * k**2, a * k, j)
            assert s.t_min == pytest.approx(k * m.t_min, rel=1e-9)
            np.testing.assert_allclose(np.ravel(s.blocked), k * np.ravel(m.blocked), rtol=1e-9)
    a0, j = -4.341290554175575e-4, 527.4855503573783
    tau = abs(a0) / j
    t_unit = scurve_min_time_from_state(0.0, 0.0, -1.0, 0.0, 1e4, 1e4, 1.0)
    assert t_unit == pytest.approx(_ruckig(0.0, 0.0, -1.0, 0.0, 1e4, 1e4, 1.0), rel=1e-9)
    assert scurve_min_time_from_state(0.0, 0.0, a0, 0.0, 4.8, 0.62, j) == pytest.approx(
        tau * t_unit, rel=1e-9
    )
    p = scurve_from_state(0.0, 0.0, a0, 0.0, 4.8, 0.62, j, 1.5 * tau * t_unit)
    s, sd, sdd, _ = p.evaluate(np.linspace(0.0, p.duration, 50))
    assert abs(s[-1]) <= 1e-9 * np.abs(s).max() and abs(sd[-1]) <= 1e-9 * np.abs(sd).max()


def test_rest_to_rest_is_the_classic_double_s():
    """From rest to rest the new path gives the rest-to-rest double S's durations: one
    joint and the synchronised set (Biagiotti & Melchiorri §3.4)."""
    rng = np.random.default_rng(153)
    for _ in range(50):
        D = rng.uniform(0.001, 3, 6)
        v, a, j = rng.uniform(0.2, 3, 6), rng.uniform(0.2, 10, 6), rng.uniform(0.5, 50, 6)
        z = np.zeros(6)
        for i in range(6):
            assert scurve_min_time_from_state(D[i], 0, 0, 0, v[i], a[i], j[i]) == pytest.approx(
                double_s_min_time(D[i], v[i], a[i], j[i]), rel=1e-12
            )
        T, _, profs, _ = synchronised_from_state(D, z, z, z, v, a, j)
        T_classic, _, classic = synchronised_profiles(D, v, a, j)
        assert T == pytest.approx(T_classic, rel=1e-12)
        t = np.linspace(0, T, 101)
        for p, c in zip(profs, classic, strict=True):
            np.testing.assert_allclose(p.evaluate(t)[0], c.evaluate(t)[0], atol=1e-9 * D.max())


def test_bad_states_are_named():
    with pytest.raises(InputError, match="within a_max"):
        JerkMove(1.0, 0.0, 3.0, 0.0, 1.0, 2.0, 5.0)
    with pytest.raises(InputError, match="passes v_max"):  # 0.8 + 2^2 / 10 > 1
        JerkMove(1.0, 0.8, 2.0, 0.0, 1.0, 2.0, 5.0)
    with pytest.raises(InputError, match="within v_max"):
        JerkMove(1.0, 0.0, 0.0, 1.5, 1.0, 2.0, 5.0)
    with pytest.raises(InfeasibleError, match="at least"):
        scurve_from_state(1.0, 0.0, 0.0, 0.0, 1.0, 2.0, 5.0, 0.5)


# ---------------------------------------------------------------------- through ptp_sync


@pytest.mark.parametrize("seed", range(16))
def test_replanned_scurve_holds_every_property(seed):
    """Limits (jerk too) from the first sample, exact ends, continuity of q, qd, qdd, honest
    derivatives; the start state and the goal speed exactly; or a named one-line refusal."""
    case, v0, a0, v1 = replan_case(seed, "scurve")
    try:
        traj = case.run()
    except NAMED as exc:
        assert "\n" not in str(exc)
        return
    assert moving_failures(case, traj) == [], str(case)
    np.testing.assert_array_equal(traj.qd[0], v0)
    np.testing.assert_array_equal(traj.qdd[0], a0)
    np.testing.assert_array_equal(traj.qd[-1], v1)
    np.testing.assert_array_equal(traj.qdd[-1], np.zeros(case.robot.n_joints))
    q, qd, qdd, _ = traj.at([0.0])
    np.testing.assert_allclose(qdd[0], a0, atol=1e-12)
    assert traj.qddd is not None and traj.meta["qdd_start"] == a0.tolist()


def test_replanning_mid_motion_continues_the_motion(teachbot6):
    """Cut an S-curve plan at 40 % and replan from its state (position, speed and
    acceleration): the new plan starts in that state and is no longer than the rest of the
    old one (one of the moves the minimum-time replan beats); rest to rest through the
    moving-state path (a zero start state) is the classic plan, bit for bit."""
    q0 = np.array([0.0, -0.3, 0.4, 0.0, 0.5, 0.0])
    q1 = np.array([0.8, 0.2, -0.2, 0.9, -0.4, 1.2])
    first = ptp_sync(teachbot6, q0, q1, "scurve", dt=1e-3, tau_max=False)
    tc = 0.4 * first.duration
    q, qd, qdd, _ = first.at([tc])
    again = ptp_sync(
        teachbot6, q[0], q1, "scurve", dt=1e-3, tau_max=False, qd_start=qd[0], qdd_start=qdd[0]
    )
    assert again.duration <= first.duration - tc + 1e-9
    np.testing.assert_allclose(again.at([0.0])[2][0], qdd[0], atol=1e-12)
    np.testing.assert_array_equal(again.q[-1], q1)
    z = np.zeros(6)
    same = ptp_sync(teachbot6, q0, q1, "scurve", dt=1e-3, qd_start=z, qdd_start=z)
    np.testing.assert_array_equal(same.q, ptp_sync(teachbot6, q0, q1, "scurve", dt=1e-3).q)


def test_torque_lowers_acceleration_and_jerk_from_the_same_state(teachbot6):
    """Limits high enough that torque binds: the replan lowers the acceleration and jerk
    limits (not below what the start state needs) and plans again from the same state; the
    torques hold from the first sample."""
    lo, hi = teachbot6.limits.lower_rad, teachbot6.limits.upper_rad
    w = np.array([0.5 * (lo + hi) - 0.3, 0.5 * (lo + hi) + 0.4])
    v0 = np.array([0.5, -0.4, 0.3, 0.2, -0.5, 0.6])
    a0 = np.array([1.0, -1.0, 0.5, 0.0, 0.8, -0.5])
    kw = {"v_max": 3.0, "a_max": 20.0, "j_max": 200.0}
    lim = resolve_limits(teachbot6, **kw)

    def fn():
        return ptp_sync(
            teachbot6, w[0], w[1], "scurve", tau_max=None, qd_start=v0, qdd_start=a0, **kw
        )

    traj = fn()
    slow = traj.meta["slowdown"]
    assert slow["kind"] == "torque" and slow["factor"] > 1
    assert 0 < slow["jerk_scale"] < 1 and 0 < slow["acceleration_scale"] < 1
    case = Case("ptp_scurve", 0, teachbot6, fn, lim, True, w, ptp=True)
    failures, peak = check_trajectory(case, traj)
    assert [f for f in failures if not f.startswith("does not rest")] == []
    assert peak > 0.9  # torque binds
    np.testing.assert_array_equal(traj.qdd[0], a0)


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"qdd_start": np.full(6, 1e6)}, "qdd_start: joint1 .* acceleration limit"),
        ({"qd_start": np.full(6, 1.9), "qdd_start": np.full(6, 3.0)}, "qdd_start: joint1 .*"),
        ({"qdd_start": np.full(6, 0.1), "sync": "phase"}, "sync='time'"),
        ({"qd_start": np.full(6, 0.1), "profile": "velocity"}, "'trapezoid' or 'scurve'"),
    ],
)
def test_bad_start_states_are_named(teachbot6, kw, match):
    """A start acceleration the jerk limit cannot stop before the speed passes its limit
    (``v0 + a0 |a0| / 2j > v``) is refused like a start speed above it: brake first."""
    with pytest.raises(InputError, match=match):
        ptp_sync(
            teachbot6,
            np.zeros(6),
            np.full(6, 0.3),
            **{"profile": "scurve", "v_max": 2.0, "a_max": 5.0, "j_max": 5.0, **kw},
        )


def test_scalar_and_vector_speed_changes_are_one_formula():
    """The root finders' scalar speed change and the vectorised one give the same phases
    and distance (two spellings of one formula: they must not drift apart)."""
    from armlab.trajectory.profiles.jerk_move import _speed_change, _speed_change_one

    rng = np.random.default_rng(7)
    for _ in range(500):
        a, j = rng.uniform(0.1, 5.0), rng.uniform(0.5, 50.0)
        v0, vt = rng.uniform(-2.0, 2.0, size=2)
        a0 = rng.uniform(-a, a)
        one = _speed_change_one(v0, a0, vt, a, j)
        vec = _speed_change(np.array([v0]), np.array([a0]), np.array([vt]), a, j)
        np.testing.assert_allclose(
            [float(np.ravel(x)[0]) for x in vec], one, rtol=1e-12, atol=1e-12
        )
