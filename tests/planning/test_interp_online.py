"""Real-time single-step interpolator with speed override (Li, Meng, Chen), and the plots."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from matplotlib.figure import Figure

from armlab.errors import InfeasibleError, InputError
from armlab.kinematics import fk
from armlab.plots import plot_joints, plot_online, plot_tcp_path
from armlab.trajectory import (
    JointPath,
    LinePath,
    OnlineInterpolator,
    line,
    ptp_sync,
)
from armlab.trajectory.profiles import trapezoid_min_time

PERIOD = 0.004


def _check_run(run, a_max, period, v_end, length):
    dv = np.abs(np.diff(run.v))
    assert dv.max() <= a_max * period * (1 + 1e-9)  # the acceleration limit, every period
    assert np.all(np.diff(run.s) >= -1e-15) and np.all(run.v >= 0)
    assert run.s[-1] == length and run.v[-1] == v_end  # the end, exactly
    # no jumps in s: each step lies between the slowest and fastest speed the period can hold
    ds = np.diff(run.s)
    dt = np.diff(run.t)
    vmax = np.maximum(run.v[:-1], run.v[1:]) + a_max * dt / 2
    vmin = np.maximum(np.minimum(run.v[:-1], run.v[1:]) - a_max * dt / 2, 0.0)
    assert np.all(ds <= vmax * dt * (1 + 1e-9) + 1e-15)
    last = len(ds) - 1  # the last period may end early (t_end)
    assert np.all(ds[:last] >= vmin[:last] * dt[:last] * (1 - 1e-9) - 1e-15)


def test_rest_to_rest_is_the_exact_trapezoid():
    # the exact per-period integration reproduces the continuous trapezoid's duration
    L, vc, a = 1.0, 0.3, 1.0
    oi = OnlineInterpolator(L, vc, a)
    t_end = None
    while not oi.done:
        smp = oi.step(PERIOD)
        t_end = smp.t - PERIOD + smp.t_end if smp.done else None
    assert t_end == pytest.approx(trapezoid_min_time(L, vc, a), abs=1e-12)


def test_override_100_30_100_mid_motion():
    L, vc, a = 1.0, 0.3, 1.0
    oi = OnlineInterpolator(L, vc, a)

    def override(t):
        return 0.3 if 1.0 <= t < 2.5 else 1.0

    run = oi.run(PERIOD, override)
    _check_run(run, a, PERIOD, 0.0, L)
    # the speed reaches 30 % of the cruise speed and is back at 100 % after
    during = (run.t > 1.0 + 0.21 + PERIOD) & (run.t <= 2.5)
    np.testing.assert_allclose(run.v[during], 0.3 * vc, atol=1e-12)
    after = (run.t > 2.5 + 0.21 + PERIOD) & (run.s < L - vc**2 / (2 * a) - 1e-9)
    assert after.any()
    np.testing.assert_allclose(run.v[after], vc, atol=1e-12)
    # never above the cruise speed; while the override is 30 % the speed never rises
    assert run.v.max() <= vc * (1 + 1e-12)
    low = np.flatnonzero(run.override == 0.3)
    assert np.all(np.diff(run.v[low]) <= 1e-15)


def test_target_moved_mid_motion():
    L, vc, a = 1.0, 0.3, 1.0
    oi = OnlineInterpolator(L, vc, a, v_end=0.1)
    for _ in range(250):
        oi.step(PERIOD)
    assert oi.v == pytest.approx(vc)
    oi.set_target(1.4)  # further away
    oi.set_target(1.2, v_end=0.0)  # then back, still far enough to stop
    run = oi.run(PERIOD)
    _check_run(run, a, PERIOD, 0.0, 1.2)
    # too close to stop: refused, state unchanged
    oi = OnlineInterpolator(L, vc, a)
    for _ in range(250):
        oi.step(PERIOD)
    s, v = oi.s, oi.v
    with pytest.raises(InfeasibleError, match="cannot stop"):
        oi.set_target(s + 0.01)
    assert (oi.s, oi.v, oi.length) == (s, v, L)
    with pytest.raises(InfeasibleError, match="behind"):
        oi.set_target(s - 0.1)


def test_end_speed_above_cruise_and_flyby():
    # v_end > velo: the end segment accelerates (Li, Meng, Chen, step 4)
    oi = OnlineInterpolator(0.5, 0.1, 0.5, v_start=0.0, v_end=0.4)
    run = oi.run(PERIOD)
    _check_run(run, 0.5, PERIOD, 0.4, 0.5)
    # a FlyBy chain: the next segment starts with the previous end speed
    oi2 = OnlineInterpolator(0.3, 0.4, 0.5, v_start=0.4, v_end=0.0)
    run2 = oi2.run(PERIOD)
    _check_run(run2, 0.5, PERIOD, 0.0, 0.3)
    assert run2.v[0] == run.v[-1]


def test_zero_override_holds_and_bad_input():
    oi = OnlineInterpolator(1.0, 0.3, 1.0)
    for _ in range(100):
        oi.step(PERIOD)
    for _ in range(200):
        oi.step(PERIOD, 0.0)
    s = oi.s
    assert oi.v == 0.0
    oi.step(PERIOD, 0.0)
    assert oi.s == s  # holds still
    run = oi.run(PERIOD)
    _check_run(run, 1.0, PERIOD, 0.0, 1.0)
    with pytest.raises(InputError, match="override"):
        oi.step(PERIOD, 1.5)
    with pytest.raises(InfeasibleError, match="cannot reach"):
        OnlineInterpolator(0.01, 1.0, 1.0, v_start=0.0, v_end=1.0)
    with pytest.raises(InputError):
        OnlineInterpolator(1.0, 0.0, 1.0)
    done = OnlineInterpolator(0.0, 0.3, 1.0)
    assert done.done and done.step(PERIOD).s == 0.0


@settings(max_examples=80, deadline=None)
@given(
    L=st.floats(1e-4, 1.0),
    vc=st.floats(0.05, 1.0),
    a=st.floats(0.05, 5.0),
    v0=st.floats(0.0, 1.0),
    v1=st.floats(0.0, 1.0),
    period=st.floats(4e-3, 0.02),
    ovs=st.lists(st.floats(0.2, 1.0), min_size=1, max_size=6),
)
def test_online_properties(L, vc, a, v0, v1, period, ovs):
    assume(abs(v0**2 - v1**2) / (2 * a) <= L)
    oi = OnlineInterpolator(L, vc, a, v0, v1)
    n = len(ovs)

    def override(t):
        return ovs[min(int(t / 0.2), n - 1)]

    run = oi.run(period, override, max_steps=100_000)
    _check_run(run, a, period, v1, L)
    assert run.v.max() <= max(vc, v0, v1) * (1 + 1e-12)


def test_online_along_paths(teachbot6):
    q0 = np.zeros(6)
    q1 = np.array([0.5, -0.3, 0.4, 1.0, 0.2, 0.0])
    path = JointPath(q0, q1)
    v_s, a_s = path.speed_limits(
        teachbot6.limits.velocity_rad_s, teachbot6.limits.acceleration_rad_s2
    )
    oi = OnlineInterpolator(path, v_s, a_s)
    run = oi.run(0.01, keep_points=True)
    Q = np.array(run.points)
    np.testing.assert_array_equal(Q[-1], q1)
    qd = np.diff(np.vstack([q0, Q]), axis=0) / 0.01
    assert np.all(np.abs(qd) <= teachbot6.limits.velocity_rad_s * (1 + 1e-9))
    # a Cartesian line
    T0 = fk(teachbot6, np.array([0.3, 0.3, 0.9, 0.5, 0.7, 0.2]))
    T1 = T0.copy()
    T1[:3, 3] += [0.05, 0.0, 0.02]
    oi = OnlineInterpolator(LinePath(T0, T1), 0.05, 0.5)
    smp = None
    while not oi.done:
        smp = oi.step(0.01)
    np.testing.assert_allclose(smp.point, T1, atol=1e-12)
    # moving the target along the same line: accepted; a path elsewhere: refused
    oi = OnlineInterpolator(LinePath(T0, T1), 0.05, 0.5)
    for _ in range(20):
        oi.step(0.01)
    T2 = T0.copy()
    T2[:3, 3] += 2 * np.array([0.05, 0.0, 0.02])
    oi.set_target(LinePath(T0, T2))
    T3 = T0.copy()
    T3[:3, 3] += [0.0, 0.1, 0.0]
    with pytest.raises(InputError, match="does not pass"):
        oi.set_target(LinePath(T0, T3))
    while not oi.done:
        smp = oi.step(0.01)
    np.testing.assert_allclose(smp.point, T2, atol=1e-12)


def test_plots_return_figures(teachbot6):
    traj = ptp_sync(teachbot6, np.zeros(6), np.array([0.5, -0.3, 0.4, 1.0, 0.2, 0.0]))
    fig = plot_joints(traj, teachbot6)
    assert isinstance(fig, Figure) and len(fig.axes) == 3
    q0 = np.array([0.3, 0.3, 0.9, 0.5, 0.7, 0.2])
    T0 = fk(teachbot6, q0)
    T1 = T0.copy()
    T1[:3, 3] += [0.05, 0.0, 0.02]
    fig = plot_tcp_path(teachbot6, line(teachbot6, T0, T1, 0.05, q_start=q0))
    assert isinstance(fig, Figure) and fig.axes[0].name == "3d"
    oi = OnlineInterpolator(1.0, 0.3, 1.0)
    assert isinstance(plot_online(oi.run(0.01, lambda t: 0.5 if t > 1 else 1.0)), Figure)
