"""``optimal()`` replanning from a moving state (issue 15): ``qd_start``, ``qdd_start``,
``qd_goal`` -- exact boundary states, limits from the first sample, the rest-to-rest plan
unchanged, Bellman's principle on a replan from the middle of a plan, and Ruckig's exact
time-optimal durations as the reference."""

from __future__ import annotations

import numpy as np
import pytest

from armlab.errors import InfeasibleError, InputError
from armlab.planning.warmstart import fit_piecewise, integrate_piecewise
from armlab.trajectory import optimal

W = np.array([[0.0, -0.3, 0.8, 0.0, 0.6, 0.0], [1.0, 0.4, -0.2, 1.2, -0.4, 0.9]])
QD0 = np.array([0.3, -0.1, 0.2, 0.5, 0.4, -0.6])  # rad/s, within teachbot6's speed limits
QDD0 = np.array([1.0, -1.0, 0.5, 2.0, -2.0, 1.0])  # rad/s^2, within its 2.62..3.5
QD1 = np.array([0.1, 0.0, 0.0, -0.2, 0.0, 0.3])  # rad/s


@pytest.mark.parametrize("mode", ["jerk", "acceleration"])
def test_the_warm_start_refit_reaches_the_end_state_from_a_moving_start(mode):
    """fit_piecewise/integrate_piecewise from a start state: the integrated end state is the
    target exactly, and a reference that already reaches it is left unchanged."""
    rng = np.random.default_rng(3)
    h = rng.uniform(0.01, 0.1, 20)
    u_ref = rng.normal(size=(20, 2))
    start = (np.array([0.3, -0.2]), np.array([1.0, 0.5]))
    target = rng.normal(size=(3 if mode == "jerk" else 2, 2))
    u = fit_piecewise(h, u_ref, target, mode, start=start)
    q, qd, qdd = integrate_piecewise(h, u, np.zeros(2), mode, start=start)
    np.testing.assert_allclose(q[0], 0.0)
    np.testing.assert_allclose(qd[0], start[0])
    if mode == "jerk":
        np.testing.assert_allclose(qdd[0], start[1])
    end = np.vstack([q[-1], qd[-1], qdd[-1]])[: target.shape[0]]
    np.testing.assert_allclose(end, target, atol=1e-10)
    again = fit_piecewise(h, u, target, mode, start=start)
    np.testing.assert_allclose(again, u, atol=1e-10)


@pytest.mark.parametrize("j_max", [None, False], ids=["jerk-mode", "acceleration-mode"])
def test_the_boundary_states_are_exact_and_every_limit_holds(teachbot6, j_max):
    traj = optimal(teachbot6, W, qd_start=QD0, qdd_start=QDD0, qd_goal=QD1, j_max=j_max)
    # the first sample is the state given; the last the goal with its speed, at rest in qdd
    # (a tolerance stretch of at most 1 + 1e-6 scales the speeds: measured 2e-9)
    np.testing.assert_allclose(traj.q[0], W[0], atol=1e-12)
    np.testing.assert_allclose(traj.qd[0], QD0, atol=1e-8)
    np.testing.assert_allclose(traj.qdd[0], QDD0, atol=1e-8)
    np.testing.assert_allclose(traj.q[-1], W[1], atol=1e-12)
    np.testing.assert_allclose(traj.qd[-1], QD1, atol=1e-8)
    np.testing.assert_allclose(traj.qdd[-1], 0.0, atol=1e-8)
    # every limit (torque included) on the fine check, from the first sample on
    assert traj.report.ok(1e-9), traj.report.worst()
    assert traj.stats["success"]
    assert traj.stats["binding"]  # time-optimal: some limit binds
    # the motion right after the start continues the given state (Taylor, 1 ms)
    dt = 1e-3
    q, qd, _, _ = traj.at([dt])
    np.testing.assert_allclose(q[0], W[0] + QD0 * dt + QDD0 * dt**2 / 2, atol=5e-6)
    np.testing.assert_allclose(qd[0], QD0 + QDD0 * dt, atol=5e-3)
    assert traj.meta["waypoint_times_s"][0] == 0.0
    assert traj.meta["waypoint_times_s"][-1] == pytest.approx(traj.t[-1], abs=1e-12)


def test_zero_states_give_the_rest_to_rest_plan(teachbot6):
    w = np.vstack([W[0], [0.5, 0.1, 0.3, 0.6, 0.1, 0.4], W[1]])
    rest = optimal(teachbot6, w, n_intervals=12)
    z = np.zeros(6)
    zero = optimal(teachbot6, w, n_intervals=12, qd_start=z, qdd_start=z, qd_goal=z)
    assert zero.stats["duration_s"] == pytest.approx(rest.stats["duration_s"], abs=1e-6)
    np.testing.assert_allclose(zero.q, rest.q, atol=1e-9)


def test_a_replan_from_the_middle_keeps_the_remaining_time_and_splices(teachbot6):
    """Bellman's principle: the rest of a time-optimal plan is time-optimal from its state, so a
    replan from t = T/3 to the same goal takes the remaining 2T/3 (measured: within 2e-9; each
    grid holds the switching instants of its own warm start) and continues the plan at the
    splice."""
    plan = optimal(teachbot6, W)
    T = plan.duration
    q, qd, qdd, _ = plan.at([T / 3])
    replan = optimal(teachbot6, [q[0], W[1]], qd_start=qd[0], qdd_start=qdd[0])
    remaining = T - T / 3
    assert replan.duration <= remaining * (1 + 1e-4)
    assert replan.duration >= remaining * (1 - 1e-4)
    # continuous with the original at the splice: position, speed, acceleration
    np.testing.assert_allclose(replan.q[0], q[0], atol=1e-12)
    np.testing.assert_allclose(replan.qd[0], qd[0], atol=1e-8)
    np.testing.assert_allclose(replan.qdd[0], qdd[0], atol=1e-8)
    np.testing.assert_allclose(replan.q[-1], W[1], atol=1e-12)
    assert replan.report.ok(1e-9)


def _ruckig_duration(w, qd0, qdd0, qd1, v, a, j) -> float:
    ruckig = pytest.importorskip("ruckig")
    n = w.shape[1]
    otg, inp, out = ruckig.Ruckig(n), ruckig.InputParameter(n), ruckig.Trajectory(n)
    inp.current_position, inp.target_position = w[0].tolist(), w[1].tolist()
    inp.current_velocity, inp.current_acceleration = qd0.tolist(), qdd0.tolist()
    inp.target_velocity, inp.target_acceleration = qd1.tolist(), [0.0] * n
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = v.tolist(), a.tolist(), j.tolist()
    otg.calculate(inp, out)
    return float(out.duration)


def test_durations_against_ruckig_from_a_moving_state(teachbot6):
    """Ruckig is exactly time-optimal with piecewise-constant jerk; ours is a discretised
    approximation of the same problem: never shorter (beyond 1e-3). Its grid holds the switching
    instants of the synchronised moves from the state (the warm start), so the optimum is
    representable: within 1e-3 (measured on 42 random teachbot6 cases: within 1e-8; with the
    rest-to-rest warm start refitted to the state, +0.4 % median and +1.5 % max)."""
    lim = teachbot6.limits
    v, a, j = lim.velocity_rad_s, lim.acceleration_rad_s2, lim.jerk_rad_s3
    rng = np.random.default_rng(7)
    lo, hi = lim.lower_rad, lim.upper_rad
    mid, half = (lo + hi) / 2, (hi - lo) / 2 * 0.6
    for case in range(3):
        w = mid + half * (2 * rng.random((2, 6)) - 1)
        qd0 = v * rng.uniform(-0.6, 0.6, 6)
        qdd0 = a * rng.uniform(-0.5, 0.5, 6)
        qd1 = v * rng.uniform(-0.3, 0.3, 6) if case else np.zeros(6)
        peer = _ruckig_duration(w, qd0, qdd0, qd1, v, a, j)
        ours = optimal(teachbot6, w, tau_max=False, qd_start=qd0, qdd_start=qdd0, qd_goal=qd1)
        assert ours.report.ok(1e-9)
        ratio = ours.stats["duration_s"] / peer
        assert 1 - 1e-3 <= ratio <= 1 + 1e-3, (case, ratio)


def test_fixed_duration_objectives_keep_the_boundary_states(teachbot6):
    fast = optimal(teachbot6, W, qd_start=QD0, qdd_start=QDD0, qd_goal=QD1, n_intervals=16)
    T = 1.3 * fast.stats["duration_s"]
    smooth = optimal(
        teachbot6,
        W,
        objective="jerk",
        duration=T,
        qd_start=QD0,
        qdd_start=QDD0,
        qd_goal=QD1,
        n_intervals=16,
    )
    assert smooth.duration == pytest.approx(T, abs=1e-8)
    np.testing.assert_allclose(smooth.qd[[0, -1]], [QD0, QD1], atol=1e-8)
    np.testing.assert_allclose(smooth.qdd[0], QDD0, atol=1e-8)
    assert smooth.report.ok(1e-6)


# ---------------------------------------------------------------------------- refusals
def test_states_beyond_a_limit_are_input_errors_naming_the_keyword_and_joint(teachbot6):
    v = teachbot6.limits.velocity_rad_s
    fast = np.zeros(6)
    fast[2] = 1.5 * v[2]
    with pytest.raises(InputError, match=r"optimal qd_start: joint3 at .* beyond its velocity"):
        optimal(teachbot6, W, qd_start=fast)
    with pytest.raises(InputError, match=r"optimal qd_goal: joint3 .* velocity limit"):
        optimal(teachbot6, W, qd_goal=fast)
    with pytest.raises(InputError, match=r"optimal qdd_start: joint1 .* acceleration limit"):
        optimal(teachbot6, W, qdd_start=[10.0, 0, 0, 0, 0, 0])
    with pytest.raises(InputError, match=r"qd_start must have shape \(6,\)"):
        optimal(teachbot6, W, qd_start=[0.1, 0.2])
    with pytest.raises(InputError, match="qd_start must be finite"):
        optimal(teachbot6, W, qd_start=[np.nan] + [0.0] * 5)
    with pytest.raises(InputError, match="drive_limits"):
        optimal(teachbot6, W, qd_start=QD0, drive_limits=True)


def test_a_start_state_that_cannot_be_braked_is_infeasible(teachbot6):
    lim = teachbot6.limits
    w = W.copy()
    w[0, 0] = lim.upper_rad[0] - 0.01  # 10 mrad before the end of its range, at full speed
    qd0 = np.zeros(6)
    qd0[0] = lim.velocity_rad_s[0]
    with pytest.raises(InfeasibleError, match=r"position limit of joint1 .*start state"):
        optimal(teachbot6, w, qd_start=qd0, tau_max=False)
    # at full speed and still accelerating: the jerk limit carries it past its speed limit
    qdd0 = np.zeros(6)
    qdd0[1] = 0.5 * lim.acceleration_rad_s2[1]
    qd0 = np.zeros(6)
    qd0[1] = 0.99 * lim.velocity_rad_s[1]
    with pytest.raises(InputError, match=r"optimal qdd_start: joint2 .*brake first"):
        optimal(teachbot6, W, qd_start=qd0, qdd_start=qdd0)
    # the torque the start state needs, above the limit
    tau = lim.effort_Nm.copy()
    tau[3] = 0.02
    qdd0 = np.zeros(6)
    qdd0[3] = 3.0
    with pytest.raises(InfeasibleError, match=r"torque limit: joint4 .*start state"):
        optimal(teachbot6, W, qdd_start=qdd0, tau_max=tau)
