"""Classical joint-space interpolators: SHU controller paper step lengths, 1-D profiles,
synchronised PTP (Jiang 1987, eq. 1-5), cubic/quintic via points (HEU thesis, 6.3.2)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from armlab.errors import InfeasibleError, InputError, LimitViolation
from armlab.planning.via_points import via_velocities
from armlab.robot import resolve_limits, rigid_body
from armlab.trajectory import (
    cubic_via,
    double_s_profile,
    ptp_sync,
    quintic_via,
    trapezoid_profile,
    trapezoid_steps,
)
from armlab.trajectory.core import Trajectory
from armlab.trajectory.profiles import (
    double_s_min_time,
    double_s_profile_for_duration,
    trapezoid_min_time,
    trapezoid_profile_for_duration,
)
from armlab.trajectory.sampling import MERGE_FRACTION, sample_times

# ------------------------------------------------------- SHU controller paper, table 1


def test_steps_table_values_with_cruise():
    # V = 0.1, a1 = 1, a2 = 0.5, T = 10 ms: t1/T = 10 and t2/T = 20 are whole (the table's case)
    p = trapezoid_steps(1.0, 0.1, 1.0, 0.5, 0.01)
    T = 0.01
    k1, k2 = np.arange(1, 11), np.arange(1, 21)
    acc = (2 * k1 - 1) * 1.0 * T**2 / 2  # S1k = (2k-1) a1 T^2 / 2
    dec = 0.1 * T - (2 * k2 - 1) * 0.5 * T**2 / 2  # S2k = V T - (2k-1) a2 T^2 / 2
    n3 = round((1.0 - 0.1**2 / 2 - 0.1**2 / 1.0) / (0.1 * T))  # S3 / (V T) = 985
    assert (p.n_acc, p.n_cruise, p.n_dec) == (10, n3, 20) == (10, 985, 20)
    assert p.a_acc == 1.0 and p.a_dec == 0.5 and p.leftover == 0.0 and p.cruise
    np.testing.assert_allclose(p.lengths[:10], acc, rtol=0, atol=1e-16)
    np.testing.assert_allclose(p.lengths[10:995], 0.1 * T, rtol=0, atol=1e-16)
    np.testing.assert_allclose(p.lengths[995:], dec, rtol=0, atol=1e-16)
    assert p.lengths.sum() == pytest.approx(1.0, abs=1e-13)
    assert p.duration == pytest.approx(1015 * T)


@pytest.mark.parametrize(
    "length, index, case",
    [
        (0.1037, 10 + 96 + 4, "between steps 4 and 5"),  # dL = 2e-4 between 3e-4 and 1e-4
        (0.10445, 10 + 96 + 0, "before step 1"),  # dL = 9.5e-4 >= S2_1 = 9e-4
        (0.10355, 10 + 96 + 5, "after the last step"),  # dL = 5e-5 < S2_5 = 1e-4
    ],
)
def test_steps_leftover_inserted_where_decreasing(length, index, case):
    # V = 0.1, a1 = 1, a2 = 2, T = 10 ms: S1 = 5e-3, S2 = 2.5e-3, dec steps 9,7,5,3,1 e-4
    p = trapezoid_steps(length, 0.1, 1.0, 2.0, 0.01)
    dL = length - 0.0075 - 96 * 1e-3
    assert p.n_cruise == 96
    assert p.leftover == pytest.approx(dL, abs=1e-15), case
    assert p.leftover_index == index, case
    assert p.phases[index] == "extra"
    dec_part = p.lengths[10 + 96 :]
    assert np.all(np.diff(dec_part) <= 1e-18), "deceleration steps stay non-increasing"
    np.testing.assert_allclose(
        np.delete(dec_part, index - 106), 1e-3 - (2 * np.arange(1, 6) - 1) * 1e-4, atol=1e-16
    )
    assert p.lengths.sum() == pytest.approx(length, abs=1e-14)


def test_steps_short_move_has_no_cruise():
    # L < S1 + S2 = 0.015: triangle with a lower peak
    p = trapezoid_steps(0.0123, 0.1, 1.0, 0.5, 0.01)
    assert not p.cruise and p.n_cruise == 0
    assert p.v_peak < 0.1
    assert p.v_peak <= math.sqrt(2 * 0.0123 * 1.0 * 0.5 / 1.5) + 1e-15
    assert p.a_acc <= 1.0 and p.a_dec <= 0.5
    T = 0.01
    np.testing.assert_allclose(
        p.lengths[: p.n_acc], (2 * np.arange(1, p.n_acc + 1) - 1) * p.a_acc * T**2 / 2
    )
    assert p.lengths.sum() == pytest.approx(0.0123, abs=1e-15)
    # the ramps end exactly at the peak: V = n1 a1' T = n2 a2' T
    assert p.n_acc * p.a_acc * T == pytest.approx(p.v_peak)
    assert p.n_dec * p.a_dec * T == pytest.approx(p.v_peak)


def test_steps_degenerate_inputs():
    p = trapezoid_steps(0.0, 0.1, 1.0, 1.0, 0.01)
    assert p.n_steps == 0 and p.lengths.sum() == 0
    for bad in [
        (-1, 0.1, 1, 1, 0.01),
        (1, 0, 1, 1, 0.01),
        (1, 0.1, -1, 1, 0.01),
        (1, 0.1, 1, 1, 0),
        (float("nan"), 0.1, 1, 1, 0.01),
    ]:
        with pytest.raises(InputError):
            trapezoid_steps(*bad)


@settings(max_examples=150, deadline=None)
@given(
    L=st.floats(1e-5, 5.0),
    V=st.floats(0.01, 2.0),
    a1=st.floats(0.05, 20.0),
    a2=st.floats(0.05, 20.0),
    T=st.floats(1e-3, 0.05),
)
def test_steps_properties(L, V, a1, a2, T):
    p = trapezoid_steps(L, V, a1, a2, T)
    x = p.lengths
    assert x.sum() == pytest.approx(L, rel=1e-11, abs=1e-15)
    assert np.all(x >= 0)
    assert p.v_peak <= V * (1 + 1e-12) and p.a_acc <= a1 * (1 + 1e-12)
    assert p.a_dec <= a2 * (1 + 1e-12)
    # discrete acceleration (second difference of positions, rest before and after)
    acc = np.diff(np.concatenate([[0.0], x, [0.0]])) / T**2
    assert acc.max() <= a1 * (1 + 1e-9) + 1e-9 and -acc.min() <= a2 * (1 + 1e-9) + 1e-9
    assert np.all(x <= p.v_peak * T * (1 + 1e-12))
    k = np.arange(1, p.n_acc + 1)
    np.testing.assert_allclose(x[: p.n_acc], (2 * k - 1) * p.a_acc * T**2 / 2, rtol=1e-12)


# ---------------------------------------------------------------------- 1-D profiles


def test_trapezoid_and_double_s_closed_forms():
    p = trapezoid_profile(1.0, 0.5, 2.0)
    assert p.duration == pytest.approx(1.0 / 0.5 + 0.5 / 2.0)  # L/v + v/a
    p = trapezoid_profile(0.01, 0.5, 2.0)  # triangle
    assert p.duration == pytest.approx(2 * math.sqrt(0.01 / 2.0))
    # double S, a reached, v reached: T = L/v + v/a + a/j
    p = double_s_profile(1.0, 0.5, 2.0, 10.0)
    assert p.duration == pytest.approx(1.0 / 0.5 + 0.5 / 2.0 + 2.0 / 10.0)
    # double S, a not reached (v j < a^2): Ta = 2 sqrt(v/j)
    p = double_s_profile(1.0, 0.1, 2.0, 10.0)
    assert p.duration == pytest.approx(1.0 / 0.1 + 2 * math.sqrt(0.1 / 10.0))


@settings(max_examples=60, deadline=None)
@given(
    L=st.floats(1e-4, 3.0),
    v=st.floats(0.05, 2.0),
    a=st.floats(0.1, 10.0),
    j=st.floats(0.5, 100.0),
    stretch=st.floats(1.0, 3.0),
)
def test_profiles_respect_limits_and_durations(L, v, a, j, stretch):
    for prof, tmin, limits in (
        (trapezoid_profile(L, v, a), trapezoid_min_time(L, v, a), (v, a, None)),
        (double_s_profile(L, v, a, j), double_s_min_time(L, v, a, j), (v, a, j)),
    ):
        assert prof.duration == pytest.approx(tmin, rel=1e-12)
        t = np.linspace(0, prof.duration, 2001)
        s, sd, sdd, sddd = prof.evaluate(t)
        assert s[-1] == L and s[0] == 0.0
        assert np.all(np.diff(s) >= -1e-15)
        assert np.abs(sd).max() <= limits[0] * (1 + 1e-9)
        assert np.abs(sdd).max() <= limits[1] * (1 + 1e-9)
        if limits[2] is not None:
            assert np.abs(sddd).max() <= limits[2] * (1 + 1e-9)
    T = stretch * trapezoid_min_time(L, v, a)
    p = trapezoid_profile_for_duration(L, T, a, v_max=v)
    assert p.duration == pytest.approx(T, rel=1e-9) and p.length == pytest.approx(L, rel=1e-9)
    T = stretch * double_s_min_time(L, v, a, j)
    p = double_s_profile_for_duration(L, T, a, j, v_max=v)
    assert p.duration == pytest.approx(T, rel=1e-9) and p.length == pytest.approx(L, rel=1e-9)
    with pytest.raises(InfeasibleError):
        trapezoid_profile_for_duration(L, 0.9 * trapezoid_min_time(L, v, a), a, v_max=v)


@settings(max_examples=100, deadline=None)
@given(
    T=st.floats(0.0, 5.0),
    dt=st.floats(1e-3, 0.1),
    knots=st.lists(st.floats(-1.0, 6.0), max_size=8),
)
def test_sample_times(T, dt, knots):
    t = sample_times(T, dt, knots)
    assert t[0] == 0.0 and t[-1] == max(T, 0.0)
    if t.size == 1:
        return
    tiny = 8 * np.finfo(float).eps * T
    steps = np.diff(t)
    assert steps.min() > tiny
    assert steps.max() <= dt * (1 + MERGE_FRACTION) * (1 + 1e-9)
    kept = [k for k in knots if tiny < k < T - tiny]
    for k in kept:  # every knot is a sample (or merged into one within rounding)
        assert np.min(np.abs(t - k)) <= tiny
    # the other samples are the regular grid, none within MERGE_FRACTION dt of a knot or the end
    fixed = np.array(kept + [T])
    for g in t[1:-1]:
        if np.min(np.abs(fixed - g)) > tiny:
            assert abs(g / dt - round(g / dt)) < 1e-9 * max(1.0, g / dt)
            assert np.min(np.abs(fixed - g)) >= MERGE_FRACTION * dt * (1 - 1e-9)


def _knotted(profiles, scales, times, jerk):
    """A Trajectory of 1-D profiles, one per joint, sampled at ``times`` (which hold every
    switching time)."""
    cols = [p.evaluate(times) for p in profiles]
    q, qd, qdd, qddd = (
        np.column_stack([c[i] * k for c, k in zip(cols, scales, strict=True)]) for i in range(4)
    )
    return Trajectory(times, q, qd, qdd, qddd if jerk else None)


@pytest.mark.parametrize("shape", ["trapezoid", "double_s"])
def test_evaluation_is_exact_between_knots(shape):
    # knots at the switching times: each piece is the Taylor polynomial of its left knot, so
    # at() reproduces the profiles to rounding anywhere, with a coarse grid and a knot pair
    if shape == "trapezoid":
        profs = [trapezoid_profile(1.0, 0.5, 2.0), trapezoid_profile(0.3, 0.7, 0.9, 3.0)]
    else:
        profs = [double_s_profile(1.0, 0.5, 2.0, 10.0), double_s_profile(0.3, 0.7, 0.9, 5.0)]
    T = max(p.duration for p in profs)
    profs = [p.stretched(T / p.duration) for p in profs]
    knots = np.concatenate([p.corners for p in profs] + [[0.3, 0.3 + 1e-9]])
    times = sample_times(T, 0.37, knots)
    traj = _knotted(profs, (1.0, -1.0), times, jerk=shape == "double_s")
    t = np.random.default_rng(0).uniform(0, T, 2000)
    got = traj.at(t)
    want = _knotted(profs, (1.0, -1.0), np.sort(t), True)
    order = np.argsort(t)
    for i, scale in enumerate((1.0, 1.0, 10.0, 100.0)):
        if i == 3 and shape == "trapezoid":
            assert np.all(got[3] == 0.0)  # constant acceleration: no jerk inside a piece
            continue
        x = (want.q, want.qd, want.qdd, want.qddd)[i]
        np.testing.assert_allclose(got[i][order], x, rtol=0, atol=1e-12 * scale)
    # the evaluation's left limits close onto the next knot
    q_l, qd_l, _, _ = traj.left_limits()
    np.testing.assert_allclose(q_l, traj.q[1:], rtol=0, atol=1e-14)
    np.testing.assert_allclose(qd_l, traj.qd[1:], rtol=0, atol=1e-13)


def test_concat_join_takes_the_next_motions_acceleration(teachbot6):
    q_mid = np.array([0.4, 0.2, 0.5, 1.0, 0.5, -0.3])
    a = ptp_sync(teachbot6, Q0, q_mid, "trapezoid")
    b = ptp_sync(teachbot6, q_mid, Q1, "trapezoid")
    traj = a.concat(b)
    k = a.n_samples - 1  # the join
    np.testing.assert_array_equal(traj.qdd[k], b.qdd[0])
    np.testing.assert_array_equal(traj.q[k], a.q[-1])
    # just after the join the second motion's acceleration, just before the first one's
    t_join = traj.t[k]
    _, _, after, _ = traj.at([t_join + 1e-6])
    np.testing.assert_allclose(after[0], b.qdd[0], rtol=1e-12)
    _, _, before, _ = traj.left_limits()
    np.testing.assert_allclose(before[k - 1], a.qdd[-1], rtol=1e-9)


# ---------------------------------------------------------------------- synchronised PTP
Q0 = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0])
Q1 = np.array([1.0, -0.5, 0.8, 2.0, -1.0, 0.3])


def _arrival_index(traj, q_goal, tol=1e-9):
    """First sample from which each joint stays at its goal."""
    at = np.abs(traj.q - q_goal) <= tol
    out = []
    for j in range(traj.n_joints):
        moving = np.flatnonzero(~at[:, j])
        out.append(int(moving[-1]) + 1 if moving.size else 0)
    return np.array(out)


@pytest.mark.parametrize("profile", ["trapezoid", "scurve", "velocity"])
@pytest.mark.parametrize("sync", ["time", "phase"])
def test_ptp_joints_finish_together(teachbot6, profile, sync):
    traj = ptp_sync(teachbot6, Q0, Q1, profile, sync=sync)
    arrival = _arrival_index(traj, Q1)[Q1 != Q0]
    # all at once, to one sample (a knot just before the end may already be within 1e-9 rad)
    assert arrival.max() - arrival.min() <= 1 and arrival.min() >= traj.n_samples - 2, arrival
    np.testing.assert_array_equal(traj.q[0], Q0)
    np.testing.assert_array_equal(traj.q[-1], Q1)
    assert traj.method == f"ptp_{profile}"
    report = traj.check_limits(teachbot6)
    assert report.ok(1e-9), report.violations()
    # the binding joint uses its full speed (velocity-limited moves here)
    if profile != "velocity":
        b = teachbot6.joint_index(traj.meta["binding"]["joint"])
        assert traj.meta["binding"]["limit"] == "velocity"
        assert report.ratios["velocity"][b] == pytest.approx(1.0, abs=1e-9)
    assert (traj.qddd is not None) == (profile == "scurve")


@pytest.mark.parametrize("profile", ["trapezoid", "scurve", "velocity"])
def test_ptp_resamples_within_limits(teachbot6, profile):
    # every switching time is a knot and each piece is evaluated from its left knot:
    # resampling at another rate does not invent peaks, also across the join of two motions
    q_mid = np.array([0.4, 0.2, 0.5, 1.0, 0.5, -0.3])
    traj = ptp_sync(teachbot6, Q0, q_mid, profile).concat(ptp_sync(teachbot6, q_mid, Q1, profile))
    for dt in (1e-3, 7.7e-4):
        r = traj.check_limits(teachbot6, dt=dt)
        assert r.ok(1e-9), r.violations()
        fine = traj.sample(dt)
        lim = teachbot6.limits
        assert np.all(np.abs(fine.qd) <= lim.velocity_rad_s * (1 + 1e-9))
        assert np.all(np.abs(fine.qdd) <= lim.acceleration_rad_s2 * (1 + 1e-9))
        if profile == "scurve":
            assert np.all(np.abs(fine.qddd) <= lim.jerk_rad_s3 * (1 + 1e-9))
        assert (fine.qddd is not None) == (profile == "scurve")


def test_ptp_velocity_is_jiang1987_eq_4(teachbot6):
    # velocity limits only (a_max = inf): T = max |dQ_i| / w_i (eq. 3), w_i = dQ_i / T (eq. 4)
    dt = 0.1
    traj = ptp_sync(teachbot6, Q0, Q1, "velocity", dt=dt, a_max=np.inf)
    v = teachbot6.limits.velocity_rad_s
    T = np.max(np.abs(Q1 - Q0) / v)
    assert traj.duration == pytest.approx(T + dt)  # plus one ramp period
    mid = np.argmin(np.abs(traj.t - traj.duration / 2))
    np.testing.assert_allclose(traj.qd[mid], (Q1 - Q0) / T, rtol=1e-12)
    # eq. 5: during the cruise, each 100 ms step moves every joint by (Qd - Qc) dt / T
    grid = np.arange(1, int(T / dt)) * dt + dt / 2
    q, _, _, _ = traj.at(grid)
    np.testing.assert_allclose(
        np.diff(q, axis=0), np.tile((Q1 - Q0) * dt / T, (grid.size - 1, 1)), atol=1e-12
    )


def test_ptp_velocity_meets_acceleration_limit_by_slowing(teachbot6):
    traj = ptp_sync(teachbot6, Q0, Q1, "velocity")  # default 100 ms ramps
    assert traj.meta["binding"]["limit"] == "acceleration"
    assert traj.check_limits(teachbot6).ok(1e-9)
    assert traj.check_limits(teachbot6).ratios["acceleration"].max() == pytest.approx(1.0)


def test_ptp_takes_tau_max_like_every_planner(teachbot6):
    """Issue 23, item 10: ``tau_max`` (None: the robot's, False: off, a value: that limit) as
    in optimal and time_optimal_path; the old ``torque=`` keyword is one line naming both."""
    q0, q1 = np.zeros(6), np.array([0.8, 0.6, -0.5, 0.9, -0.4, 1.2])
    free = ptp_sync(teachbot6, q0, q1, "trapezoid", tau_max=False)
    assert "torque" not in free.report.ratios
    own = ptp_sync(teachbot6, q0, q1, "trapezoid")
    assert own.report.ok(1e-9) and "torque" in own.report.ratios
    # a limit between gravity and the free plan's peak: the plan slows down and holds it
    fine = free.sample(free.duration / 2000)
    tau = np.abs(fine.torques(teachbot6)).max(axis=0)
    g = np.abs(rigid_body.gravity_torques(teachbot6, fine.q)).max(axis=0)
    tight = np.maximum(0.8 * tau, 1.05 * g)
    assert np.any(tight < tau)  # what it tests: the free plan breaks the value
    held = ptp_sync(teachbot6, q0, q1, "trapezoid", tau_max=tight)
    assert held.duration > free.duration
    assert held.check_limits(teachbot6, limits=resolve_limits(teachbot6, tau_max=tight)).ok(1e-9)
    with pytest.raises(InputError, match=r"ptp_sync\(\): torque= is now tau_max="):
        ptp_sync(teachbot6, q0, q1, torque=False)


def test_ptp_degenerate_and_bad_input(teachbot6, ur5):
    traj = ptp_sync(teachbot6, Q1, Q1)
    assert traj.n_samples == 1 and traj.duration == 0 and traj.meta["zero_length"]
    far = Q1.copy()
    far[2] = 3.0  # joint3 range is -90..160 deg
    with pytest.raises(InputError, match=r"ptp_sync q_goal: joint3 = 3 rad is outside its range"):
        ptp_sync(teachbot6, Q0, far)
    with pytest.raises(InputError, match="profile"):
        ptp_sync(teachbot6, Q0, Q1, "cubic")
    with pytest.raises(InputError, match="shape"):
        ptp_sync(teachbot6, Q0[:5], Q1)
    with pytest.raises(InputError, match="a_max"):  # a plain URDF has no acceleration limits
        ptp_sync(ur5, np.zeros(6), np.full(6, 0.3))
    traj = ptp_sync(ur5, np.zeros(6), np.full(6, 0.3), a_max=2.0)
    assert traj.check_limits(ur5, limits=resolve_limits(ur5, a_max=2.0)).ok(1e-9)


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    seed=st.integers(0, 2**31 - 1),
    profile=st.sampled_from(["trapezoid", "scurve", "velocity"]),
    sync=st.sampled_from(["time", "phase"]),
)
def test_ptp_random_moves_respect_limits(teachbot6, seed, profile, sync):
    rng = np.random.default_rng(seed)
    q0, q1 = teachbot6.random_q(rng, 2)
    if rng.random() < 0.3:
        q1[2] = q0[2]  # a joint that does not move
    try:
        traj = ptp_sync(teachbot6, q0, q1, profile, sync=sync)
    except LimitViolation as exc:
        # some poses need more holding torque than joint 4 has: the planner must say so
        assert "gravity alone" in str(exc)
        return
    assert traj.check_limits(teachbot6).ok(1e-9)
    np.testing.assert_array_equal(traj.q[-1], q1)
    np.testing.assert_allclose(traj.q[0], q0, atol=1e-15)
    arrival = _arrival_index(traj, q1)[np.abs(q1 - q0) > 1e-6]
    # all joints arrive together, to one sample (the last step may be a short one)
    assert arrival.max() - arrival.min() <= 1 and arrival.max() >= traj.n_samples - 2


# ---------------------------------------------------------------------- via points


def test_cubic_single_segment_is_thesis_formula(teachbot6):
    W = np.array([Q0, Q0 + 0.2])
    T = 2.0
    traj = cubic_via(teachbot6, W, durations=[T], dt=0.05)
    t = traj.t[:, None]
    d = W[1] - W[0]
    # v0 = v1 = 0: c2 = 3 d / T^2, c3 = -2 d / T^3
    np.testing.assert_allclose(traj.q, W[0] + 3 * d * t**2 / T**2 - 2 * d * t**3 / T**3, atol=1e-14)
    np.testing.assert_allclose(traj.qd, 6 * d * t / T**2 - 6 * d * t**2 / T**3, atol=1e-14)


def test_heuristic_via_velocities():
    W = np.array([[0.0], [1.0], [3.0], [2.0], [2.0]])
    T = np.array([1.0, 2.0, 1.0, 1.0])
    V = via_velocities(W, T, "heuristic")
    # slopes 1, 1, -1, 0: mean where the sign is kept, zero where it changes or is zero
    np.testing.assert_allclose(V[:, 0], [0.0, 1.0, 0.0, 0.0, 0.0])


@pytest.mark.parametrize(
    "fn, kw, smooth",
    [(cubic_via, {}, False), (cubic_via, {"velocities": "spline"}, True), (quintic_via, {}, True)],
)
def test_via_points_pass_and_respect_limits(teachbot6, fn, kw, smooth):
    W = np.array(
        [Q0, [0.5, -0.3, 0.4, 1, 0.2, 0], [0.8, 0.2, 0.9, 0.5, -0.5, 1], [0.2, 0.1, 0.3, 0, 0, 0]]
    )
    traj = fn(teachbot6, W, **kw)
    knots = np.asarray(traj.meta["knot_times_s"])
    idx = np.searchsorted(traj.t, knots)
    np.testing.assert_array_equal(traj.t[idx], knots)
    np.testing.assert_array_equal(traj.q[idx], W)
    np.testing.assert_allclose(traj.qd[[0, -1]], 0.0, atol=1e-12)
    assert traj.check_limits(teachbot6).ok(1e-9)
    assert traj.meta["slowdown"] is not None  # the durations were stretched to the limits
    assert traj.check_limits(teachbot6).worst()[2] == pytest.approx(1.0, abs=1e-6)
    # continuity of the acceleration at the interior via points
    eps = 1e-7
    _, _, a_left, _ = traj.at(knots[1:-1] - eps)
    _, _, a_right, _ = traj.at(knots[1:-1] + eps)
    jump = np.abs(a_right - a_left).max()
    assert (jump < 1e-4) == smooth
    assert (traj.qddd is not None) == smooth


def test_via_point_errors(teachbot6):
    W = np.array([Q0, Q1, Q0])
    with pytest.raises(LimitViolation, match="joint"):
        cubic_via(teachbot6, W, durations=[0.5, 0.5])
    with pytest.raises(InputError, match="durations"):
        cubic_via(teachbot6, W, durations=[1.0])
    with pytest.raises(InputError, match="waypoints"):
        cubic_via(teachbot6, W[:1])
    # a given via velocity that overshoots the range of joint 3 (upper limit 160 deg)
    hi = teachbot6.limits.upper_rad[2]
    W2 = np.array([Q0, Q0, Q0])
    W2[1, 2] = hi - 0.01
    V = np.zeros_like(W2)
    V[1, 2] = 0.5
    with pytest.raises(LimitViolation, match="joint3"):
        cubic_via(teachbot6, W2, durations=[4.0, 4.0], velocities=V, v_max=10, a_max=10)
    # repeated waypoints merge; all identical -> one sample at rest
    traj = cubic_via(teachbot6, np.array([Q0, Q0, Q1, Q1]))
    assert traj.meta["merged_waypoints"] == 2
    assert cubic_via(teachbot6, np.array([Q1, Q1])).n_samples == 1
