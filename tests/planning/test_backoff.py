"""The one back-off loop of the optimising planners (armlab.planning.timescale.backoff_solve),
with a stand-in solver: what is re-solved, what is kept, what is counted."""

from __future__ import annotations

import numpy as np
import pytest

from armlab.errors import InfeasibleError
from armlab.planning.timescale import (
    BACKOFF_MARGIN,
    CHECK_TOL,
    HOLD_RTOL,
    backoff_solve,
    held_over_limit,
    over_limits,
    tighten_limits,
    torque_stretch,
)


class FakeSolver:
    """``limits`` is a number; the fine check sees ``limits * overshoot[k]`` on solve k."""

    def __init__(self, overshoot, fails=()):
        self.overshoot, self.fails, self.calls = list(overshoot), set(fails), []

    def solve(self, limits, previous):
        k = len(self.calls)
        self.calls.append((limits, previous))
        info = {"success": k not in self.fails, "iterations": 10 + k, "solve_time_s": 0.5}
        return (k, limits), info

    def check(self, result):
        k, limits = result
        return {"torque": np.array([self.overshoot[k], 0.5]), "position": np.array([2.0, 2.0])}


def halve(limits, over, rounds, margin):
    return limits / 2


def fail(result, info):
    raise InfeasibleError("first solve failed")


def test_no_violation_needs_one_solve():
    s = FakeSolver([1.0 + CHECK_TOL / 2])  # within the tolerance; positions are not backed off
    out = backoff_solve(s.solve, 1.0, s.check, max_rounds=4, fail=fail, tighten=halve)
    assert out.rounds == 0 and out.result == (0, 1.0) and out.limits == 1.0
    assert out.iterations == 10 and out.solve_time_s == 0.5


def test_rounds_tighten_and_warm_start_from_the_last_solution():
    s = FakeSolver([1.2, 1.1, 1.0])
    out = backoff_solve(s.solve, 1.0, s.check, max_rounds=4, fail=fail, tighten=halve)
    assert out.rounds == 2 and out.result == (2, 0.25) and out.limits == 0.25
    assert s.calls == [(1.0, None), (0.5, (0, 1.0)), (0.25, (1, 0.5))]
    assert out.iterations == 10 + 11 + 12 and out.solve_time_s == 1.5


def test_at_most_max_rounds():
    s = FakeSolver([1.2] * 10)
    out = backoff_solve(s.solve, 1.0, s.check, max_rounds=3, fail=fail, tighten=halve)
    assert out.rounds == 3 and len(s.calls) == 4 and out.result == (3, 0.125)


def test_a_failed_re_solve_keeps_the_last_good_one_and_a_failed_first_raises():
    s = FakeSolver([1.2, 1.2, 1.0], fails={2})
    out = backoff_solve(s.solve, 1.0, s.check, max_rounds=4, fail=fail, tighten=halve)
    assert out.result == (1, 0.5) and out.limits == 0.5 and out.rounds == 2
    assert out.info["success"] is False and out.iterations == 10 + 11 + 12
    s = FakeSolver([1.0], fails={0})
    with pytest.raises(InfeasibleError, match="first solve failed"):
        backoff_solve(s.solve, 1.0, s.check, max_rounds=4, fail=fail, tighten=halve)


def test_tighten_limits_backs_off_only_the_joints_over_their_limit(teachbot6):
    lim = teachbot6.limits
    ratios = {
        "torque": np.array([1.5, 1.0, 0.2, 1 + CHECK_TOL / 2, 1.01, 0.9]),
        "velocity": np.full(6, 0.5),
        "position": np.full(6, 3.0),
    }
    over = over_limits(ratios)
    assert list(over) == ["torque"]
    new = tighten_limits(lim, over)
    want = lim.torque_Nm.copy()
    want[0] *= (1 - BACKOFF_MARGIN) / 1.5
    want[4] *= (1 - BACKOFF_MARGIN) / 1.01
    np.testing.assert_allclose(new.torque_Nm, want, rtol=1e-15)
    np.testing.assert_array_equal(new.velocity_rad_s, lim.velocity_rad_s)
    assert "back-off" in new.sources["torque"][0] and "back-off" not in new.sources["torque"][1]


# ---------------------------------------------------------------------------- the held-torque rule
def test_torque_stretch_is_the_smallest_factor_that_fits():
    """``tau(k) = g + (tau - g) / k^2`` at the factor of ``torque_stretch``: within the limit
    everywhere (1e-12 relative: round-off of the quadratic), on it where ``k > 1``; a factor 1e-6
    smaller breaks it there (independent of the closed form: the definition, evaluated)."""
    rng = np.random.default_rng(3)
    lim = np.array([2.0, 5.0, 0.5])
    g = rng.uniform(-0.99, 0.99, (400, 3)) * lim  # gravity within the limit
    tau = g + rng.normal(0.0, 3.0, (400, 3)) * lim
    k = torque_stretch(tau, g, lim)
    assert np.all(k >= 1.0)
    fit = np.abs(g + (tau - g) / k**2) / lim
    assert np.all(fit <= 1.0 + 1e-12)
    slowed = k > 1.0
    assert slowed.sum() > 100  # the draw exercises the rule
    np.testing.assert_allclose(fit[slowed], 1.0, rtol=1e-12)
    tighter = np.abs(g + (tau - g) / (k * (1 - 1e-6)) ** 2) / lim
    assert np.all(tighter[slowed] > 1.0)
    # where gravity alone is over the limit no factor helps: 1, left to the caller
    over = torque_stretch(np.array([[3.0]]), np.array([[2.5]]), np.array([2.0]))
    assert over[0, 0] == 1.0


def test_held_over_limit_names_the_first_sample_and_its_worst_joint():
    r = np.array([[0.5, 0.9], [1.0 + 1e-13, 0.2], [0.3, 1.2], [1.5, 1.1]])
    assert held_over_limit(r) == (2, 1)  # 1 + 1e-13 is round-off (HOLD_RTOL), not over
    assert held_over_limit(r[:2]) is None
    assert held_over_limit(np.array([1.0 + 10 * HOLD_RTOL, 0.0])) == (0, 0)


@pytest.fixture(scope="module")
def one_joint(tmp_path_factory):
    """The optimiser tests' 1 kg arm of 0.2 m on a horizontal axis (gravity matters)."""
    from test_optimal import ONE_JOINT_URDF

    import armlab

    path = tmp_path_factory.mktemp("one") / "one.urdf"
    path.write_text(ONE_JOINT_URDF)
    return armlab.load_robot(path)


def test_the_planners_refuse_one_held_pose_by_one_rule(one_joint):
    """A goal whose gravity torque is 1e-9 over the limit: the classical stretch
    (``ptp_sync``), the optimiser and TOPP refuse it by name, each through ``held_over_limit``;
    1e-9 under it, neither the stretch nor TOPP refuses it for that (they plan, or refuse
    another limit by name: TOPP's rows keep LIMIT_MARGIN from every limit)."""
    from armlab.errors import LimitViolation
    from armlab.planning import optimal, ptp_sync, time_optimal_path
    from armlab.robot import rigid_body

    q0, q1 = np.array([-1.2]), np.array([0.0])  # the arm horizontal at the goal
    g = float(abs(rigid_body.gravity_torques(one_joint, q1[None])[0, 0]))
    over = g / (1 + 1e-9)
    with pytest.raises(LimitViolation, match="gravity alone"):
        ptp_sync(one_joint.with_limits(effort_Nm=np.array([over])), q0, q1, a_max=2.0)
    with pytest.raises(InfeasibleError, match="hold waypoint 1 against gravity"):
        optimal(one_joint, np.array([q0, q1]), a_max=2.0, j_max=False, tau_max=over)
    with pytest.raises(InfeasibleError, match="against gravity"):
        time_optimal_path(one_joint, np.array([q0, q1]), a_max=2.0, j_max=False, tau_max=over)
    under = g * (1 + 1e-9)
    traj = ptp_sync(one_joint.with_limits(effort_Nm=np.array([under])), q0, q1, a_max=2.0)
    assert traj.report.ok(1e-9)
    try:  # (the optimiser's iteration limit, its refusal here, takes seconds: not run)
        out = time_optimal_path(
            one_joint, np.array([q0, q1]), a_max=2.0, j_max=False, tau_max=under
        )
        assert out.report.ok(1e-6)
    except InfeasibleError as exc:
        assert "against gravity" not in str(exc)
