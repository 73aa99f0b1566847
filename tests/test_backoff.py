"""The one back-off loop of the optimising planners (armlab.planning.timescale.backoff_solve),
with a stand-in solver: what is re-solved, what is kept, what is counted."""

from __future__ import annotations

import numpy as np
import pytest

from armlab.errors import InfeasibleError
from armlab.planning.timescale import (
    BACKOFF_MARGIN,
    CHECK_TOL,
    backoff_solve,
    over_limits,
    tighten_limits,
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
