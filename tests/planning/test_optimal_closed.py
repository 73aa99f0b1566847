"""The closed form behind optimal() and ptp_sync() (armlab.planning.optimal_closed, issue 26):
the same minimum duration as the transcription (IPOPT, build_optimal().solve()), every limit
held, and stats that say which method planned."""

from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np
import pytest

from armlab.errors import InputError
from armlab.planning import optimal, ptp_sync
from armlab.planning.optimal_closed import closed_form_optimal, exact_report
from armlab.planning.optimiser import build_optimal
from armlab.planning.timescale import CHECK_TOL
from armlab.trajectory.profiles import synchronised_scurves
from cases import in_threads

#: the closed form against IPOPT's optimum on the same problem, in [s]: IPOPT meets its
#: constraints to 1e-9 and its objective carries a 1e-7 smoothness term (measured 4e-8)
SAME_S = 1e-6


def _cases(robot, n_cases, seed):
    lo, hi = robot.limits.lower_rad, robot.limits.upper_rad
    rng = np.random.default_rng(seed)
    return [lo + (hi - lo) * (0.15 + 0.7 * rng.random((2, robot.n_joints))) for _ in range(n_cases)]


def _within_limits(traj, lim, tol=1e-9):
    """Every limit on a fine grid of the exact pieces, evaluated here from the knots (cubic
    Taylor polynomials of the left knot), independently of check_limits."""
    t = np.linspace(0.0, traj.duration, 3001)
    k = np.clip(np.searchsorted(traj.t, t, side="right") - 1, 0, traj.t.size - 2)
    h = (t - traj.t[k])[:, None]
    q0, v0, a0, j0 = traj.q[k], traj.qd[k], traj.qdd[k], traj.qddd[k]
    q = q0 + v0 * h + a0 * h**2 / 2 + j0 * h**3 / 6
    v = v0 + a0 * h + j0 * h**2 / 2
    a = a0 + j0 * h
    assert np.all(np.abs(v) <= lim.velocity_rad_s * (1 + tol))
    assert np.all(np.abs(a) <= lim.acceleration_rad_s2 * (1 + tol))
    assert np.all(np.abs(traj.qddd) <= lim.jerk_rad_s3 * (1 + tol))
    assert np.all(q >= lim.lower_rad - 1e-12) and np.all(q <= lim.upper_rad + 1e-12)
    return q


def test_closed_form_equals_the_transcription_optimum(teachbot6):
    """Rest to rest between 2 waypoints, v/a/j, no torque: the closed form's duration is
    IPOPT's on the same problem, and the motion is within every limit."""
    for w in _cases(teachbot6, 3, 26):
        fast = optimal(teachbot6, w, tau_max=False)
        ref = build_optimal(teachbot6, w, tau_max=False).solve()  # the engine: transcription
        assert fast.stats["method"] == "closed_form"
        assert fast.stats["duration_s"] == pytest.approx(ref.stats["duration_s"], abs=SAME_S)
        assert fast.duration == pytest.approx(fast.stats["duration_s"], abs=1e-12)
        assert fast.report.ok(1e-9)
        q = _within_limits(fast, teachbot6.limits)
        np.testing.assert_allclose(q[0], w[0], atol=1e-12)
        np.testing.assert_allclose(q[-1], w[1], atol=1e-9)
        np.testing.assert_allclose(fast.qd[[0, -1]], 0.0, atol=1e-12)
        # time-optimal: the slowest joint reaches a limit
        assert fast.stats["binding"]


#: one joint moves 1.5 rad with v 0.5, a 2, j 10 (the others stay): the 7-phase double S
#: lasts D/v + v/a + a/j (Biagiotti & Melchiorri 2008, 3.4; v j >= a^2, D >= v (v/a + a/j))
ONE_MOVE = dict(v_max=0.5, a_max=2.0, j_max=10.0)
ONE_MOVE_S = 1.5 / 0.5 + 0.5 / 2.0 + 2.0 / 10.0


def _one_move(robot):
    w = np.zeros((2, robot.n_joints))
    w[:, 0] = [-0.75, 0.75]
    return w


def test_closed_form_against_a_hand_calculation(teachbot6):
    traj = optimal(teachbot6, _one_move(teachbot6), tau_max=False, **ONE_MOVE)
    assert traj.stats["method"] == "closed_form"
    assert traj.duration == pytest.approx(ONE_MOVE_S, abs=1e-12)
    assert traj.q[-1, 0] == pytest.approx(0.75, abs=1e-12)
    np.testing.assert_allclose(traj.q[:, 1:], 0.0, atol=1e-15)  # the others stay


def test_problems_the_closed_form_does_not_solve_are_transcribed(teachbot6):
    """A torque limit, a third waypoint or another objective: the transcription plans."""
    w = _one_move(teachbot6)
    w3 = np.vstack([w[:1], w.mean(axis=0) + 0.1, w[1:]])
    torque = optimal(teachbot6, w, n_intervals=8, **ONE_MOVE)  # the robot's torque limits
    three = optimal(teachbot6, w3, tau_max=False, n_intervals=8, **ONE_MOVE)
    smooth = optimal(
        teachbot6, w, tau_max=False, objective="time+smooth", n_intervals=8, **ONE_MOVE
    )
    for traj in (torque, three, smooth):
        assert traj.stats["method"] == "transcription"
        assert traj.report.ok(1e-6)
    # the smoothness term costs time: the closed form is the minimum
    assert smooth.duration > ONE_MOVE_S + 1e-3


@pytest.mark.parametrize("profile", ["scurve", "trapezoid"])
def test_ptp_sync_says_closed_form(teachbot6, profile):
    """ptp_sync rest to rest without torque: the closed-form profiles, within every limit, the
    duration the closed form of optimal() gives for the S-curve."""
    w = _cases(teachbot6, 1, 7)[0]
    traj = ptp_sync(teachbot6, w[0], w[1], profile, tau_max=False)
    assert traj.stats["method"] == "closed_form"
    assert traj.report.ok(1e-9)
    if profile == "scurve":
        best = optimal(teachbot6, w, tau_max=False)
        assert traj.duration == pytest.approx(best.duration, abs=1e-9)
    assert math.isclose(traj.stats["duration_s"], traj.duration, abs_tol=1e-12)


def _same_report(exact, sampled, tol=1e-12):
    assert set(exact.ratios) == set(sampled.ratios)
    for kind, r in sampled.ratios.items():
        np.testing.assert_allclose(exact.ratios[kind], r, rtol=tol, atol=tol, err_msg=kind)


@pytest.mark.parametrize("profile", ["optimal", "scurve", "trapezoid"])
def test_exact_check_is_the_sample_check(teachbot6, profile):
    """The report of a closed-form plan comes from the phase data (exact_report); the sample
    check of the returned Trajectory (knots, left limits, interior extremes of its pieces,
    Trajectory.check_limits) finds the same peak ratios."""
    for w in _cases(teachbot6, 4, 31):
        if profile == "optimal":
            traj = optimal(teachbot6, w, tau_max=False)
        else:
            traj = ptp_sync(teachbot6, w[0], w[1], profile, tau_max=False)
        assert traj.stats["limit_check"].startswith("exact")
        assert 0.0 <= traj.stats["arrival_residual"] < 1e-12
        lim = teachbot6.limits
        sampled = traj.check_limits(teachbot6, limits=lim, torque=False)
        _same_report(traj.report, sampled)


def test_a_grid_asked_for_is_sampled(teachbot6):
    w = _cases(teachbot6, 1, 3)[0]
    traj = optimal(teachbot6, w, tau_max=False, check_dt=0.01)
    assert traj.stats["method"] == "closed_form"
    assert traj.stats["limit_check"].startswith("samples")
    assert traj.stats["arrival_residual"] is None
    assert traj.report.ok(1e-9)


def test_exact_report_refuses_phase_data_that_do_not_arrive(teachbot6):
    """Phase data whose end is not the goal at rest (a cruise 1 % too long) are not reported
    exactly: None, and the caller checks the samples."""
    w = _cases(teachbot6, 1, 5)[0]
    lim = teachbot6.limits
    args = (np.diff(w, axis=0), lim.velocity_rad_s, lim.acceleration_rad_s2, lim.jerk_rad_s3)
    good = synchronised_scurves(*args)
    assert exact_report(good, w[0], w[1], lim, teachbot6.joint_names) is not None
    bad = dataclasses.replace(synchronised_scurves(*args), tv=good.tv * 1.01)
    assert exact_report(bad, w[0], w[1], lim, teachbot6.joint_names) is None


# ------------------------------------------------ the front gate (optimal_closed.direct)
def _same_result(a, b, tol=1e-15):
    """Two plans equal: arrays within ``tol`` of each one's scale, every stats value
    (but the time taken) and meta value, the report."""
    for x, y in ((a.t, b.t), (a.q, b.q), (a.qd, b.qd), (a.qdd, b.qdd), (a.qddd, b.qddd)):
        assert x.shape == y.shape
        np.testing.assert_allclose(x, y, rtol=0, atol=tol * max(1.0, np.abs(y).max()))
    sa = {k: v for k, v in a.stats.items() if k != "solve_time_s"}
    sb = {k: v for k, v in b.stats.items() if k != "solve_time_s"}
    assert list(a.stats) == list(b.stats) and sa.keys() == sb.keys()
    for k in sa:
        if isinstance(sa[k], float):
            assert sa[k] == pytest.approx(sb[k], rel=tol, abs=tol), k
        elif k == "binding":
            assert [x[:2] for x in sa[k]] == [x[:2] for x in sb[k]]
        else:
            assert sa[k] == sb[k], k
    assert list(a.meta) == list(b.meta)
    for k in a.meta:
        if isinstance(a.meta[k], np.ndarray):
            np.testing.assert_allclose(a.meta[k], b.meta[k], rtol=0, atol=tol * 100)
        else:
            assert a.meta[k] == b.meta[k], k
    assert a.joint_names == b.joint_names and a.method == b.method
    assert list(a.report.ratios) == list(b.report.ratios)
    for k in a.report.ratios:
        np.testing.assert_allclose(a.report.ratios[k], b.report.ratios[k], rtol=0, atol=tol)
        np.testing.assert_allclose(a.report.at_s[k], b.report.at_s[k], rtol=0, atol=tol * 100)


def test_the_front_gate_gives_the_closed_form_of_the_built_problem(teachbot6):
    """optimal() with every keyword at its default takes the gate (no transcription problem
    built); its result is closed_form_optimal's of the same request, key for key."""
    for w in _cases(teachbot6, 20, 34):
        fast = optimal(teachbot6, w, tau_max=False)
        built = closed_form_optimal(build_optimal(teachbot6, w, tau_max=False))
        assert fast.stats["method"] == "closed_form"
        assert fast.stats["ok"] == fast.report.ok(CHECK_TOL)  # the graph's verdict, the report's
        _same_result(fast, built)
    # tau_max=None: teachbot6's torque limits are not the closed form's problem
    assert optimal(teachbot6, _one_move(teachbot6)).stats["method"] == "transcription"
    # the caller's array is copied, not kept
    w = _cases(teachbot6, 1, 35)[0]
    fast = optimal(teachbot6, w, tau_max=False)
    w += 0.1
    assert not np.allclose(fast.meta["waypoints"], w)
    np.testing.assert_allclose(fast.q[0], w[0] - 0.1, atol=1e-12)


@pytest.mark.parametrize(
    "bad",
    [
        "nan",
        "range",
        "coincide",
        "shape",
        "text",
    ],
)
def test_the_front_gate_names_bad_waypoints_as_the_ordinary_path(teachbot6, bad):
    """Waypoints the gate cannot plan go the ordinary way: the same one-line error."""
    w = _cases(teachbot6, 1, 36)[0]
    if bad == "nan":
        w[1, 2] = math.nan
    elif bad == "range":
        w[0, 4] = teachbot6.limits.upper_rad[4] + 1e-6
    elif bad == "coincide":
        w[1] = w[0] + 1e-13
    elif bad == "shape":
        w = w[:, :5]
    else:
        w = [["a"] * 6, ["b"] * 6]
    with pytest.raises(InputError) as gate:
        optimal(teachbot6, w, tau_max=False)
    with pytest.raises(InputError) as built:
        build_optimal(teachbot6, w, tau_max=False)
    assert str(gate.value) == str(built.value)


def test_the_front_gate_follows_the_robots_limits(teachbot6):
    """New limits on the robot (a new Limits) are planned with, never the ones before; an
    edit of a result's meta does not reach the next result."""
    robot = copy.deepcopy(teachbot6)
    w = _one_move(robot)
    first = optimal(robot, w, tau_max=False)
    first.meta["limits"]["velocity_rad_s"]["joint1"] = 123.0
    robot.limits = robot.limits.with_values(
        "test",
        velocity_rad_s=np.full(6, 0.5),
        acceleration_rad_s2=np.full(6, 2.0),
        jerk_rad_s3=np.full(6, 10.0),
    )
    second = optimal(robot, w, tau_max=False)
    assert second.stats["method"] == "closed_form"
    assert second.duration == pytest.approx(ONE_MOVE_S, abs=1e-12)
    assert second.duration != pytest.approx(first.duration, abs=1e-3)
    assert second.meta["limits"]["velocity_rad_s"]["joint1"] == 0.5
    again = optimal(robot, w, tau_max=False)
    assert again.meta["limits"]["velocity_rad_s"]["joint1"] == 0.5


def test_the_front_gate_from_threads(teachbot6):
    """Two threads planning at once get the plans of a serial run."""
    cases = _cases(teachbot6, 40, 37)
    serial = [optimal(teachbot6, w, tau_max=False) for w in cases]
    out: dict[int, list] = {0: [], 1: []}

    def run(k):
        for _ in range(5):
            out[k] = [optimal(teachbot6, w, tau_max=False) for w in cases[k::2]]

    in_threads(run, 2)
    for k in (0, 1):
        for got, ref in zip(out[k], serial[k::2], strict=True):
            _same_result(got, ref, tol=0.0)
