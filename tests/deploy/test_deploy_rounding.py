"""Pre-flight on what is sent (issue 24 item 6): the controller receives rounded integer counts,
so the speed check runs on the counts of each cycle, and a study plans within speeds whose
rounded counts keep the limit. The oracles round the plan themselves (numpy), independently of
armlab.deploy."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from test_deploy import trapezoid_move

from armlab.deploy import setpoint_table
from armlab.errors import LimitViolation
from armlab.robot import load_profile
from armlab.study import run_spec
from armlab.study.spec import parse_study
from cases import quick_study

T = 1e-3  # reference_dda cycle [s]
TOL = 1e-6  # reference_dda speed_tolerance


def _cycles(tr) -> np.ndarray:
    return np.arange(int(math.ceil(tr.duration / T - 1e-9)) + 1) * T


def test_rounded_counts_over_the_speed_limit_are_refused(teachbot6):
    """Joint 1 cruising at exactly its 0.56 rad/s limit moves 44.56 counts per 1 ms cycle; the
    controller is sent 45 on most cycles, 0.5655 rad/s (x1.0098). The plan keeps the limit,
    the counts do not: refused, naming the joint, the cycle and the limit."""
    v = float(teachbot6.limits.velocity_rad_s[0])
    a = float(teachbot6.limits.acceleration_rad_s2[0])
    tr = trapezoid_move(teachbot6, "joint1", v, a, cruise_s=0.5)
    t = _cycles(tr)
    q, qd, _, _ = tr.at(t)
    assert np.abs(qd[:, 0]).max() <= v * (1 + TOL)  # the plan itself keeps the limit
    with pytest.raises(LimitViolation) as ei:
        setpoint_table(teachbot6, tr, "reference_dda")
    f = ei.value.failure
    cpr = teachbot6.drives["joint1"].counts_per_rad(4)
    counts = np.round(q[:, 0] * cpr)
    sent = np.abs(np.diff(counts)) / (cpr * T)
    first = int(np.argmax(sent > v * (1 + TOL))) + 1
    assert (f.check, f.joint, f.cycle) == ("speed", "joint1", first)
    assert f.value == pytest.approx(45 / (cpr * T), rel=1e-12)
    assert f.value / v == pytest.approx(1.0098, abs=1e-4)
    msg = str(ei.value)
    assert "\n" not in msg
    assert f"cycle {first}" in msg and "joint joint1" in msg and "speed limit" in msg
    assert "45 counts in one 0.001 s cycle" in msg


def test_a_plan_at_the_sendable_speed_is_sent_within_the_limit(teachbot6):
    """ControllerProfile.sendable_velocity_rad_s: within one count per cycle of the limit, and a
    plan cruising at it is sent (the table's own integer counts) at most the limit."""
    prof = load_profile("reference_dda")
    v = teachbot6.limits.velocity_rad_s
    vs = prof.sendable_velocity_rad_s(teachbot6, v)
    for j, name in enumerate(teachbot6.joint_names):
        cpr = teachbot6.drives[name].counts_per_rad(prof.decoding)
        per_cycle = v[j] * cpr * T  # counts per cycle at the limit
        assert math.floor(per_cycle) - 1 < vs[j] * cpr * T < math.floor(per_cycle)
        a = float(teachbot6.limits.acceleration_rad_s2[j])
        table = setpoint_table(teachbot6, trapezoid_move(teachbot6, name, vs[j], a, 0.3), prof)
        sent = np.abs(table.dcounts[:, j]) / (cpr * T)
        assert sent.max() <= v[j]
        assert sent.max() >= vs[j] * 0.99  # it does cruise there


def test_a_study_plans_within_speeds_its_counts_keep(tmp_path):
    """A PTP study moving joint 1 by 60 deg cruises at its speed limit: its table is sent at
    most the limit on every joint (before, joint 1 was sent 45 counts per cycle, x1.0098)."""
    text = quick_study(stages=("kinematics", "plan", "export")).replace(
        "[[0, 0, 0, 0, 0, 0], [20, 10, 10, 0, 20, 0]]", "[[0, 0, 0, 0, 0, 0], [60, 5, 5, 0, 5, 0]]"
    )
    res = run_spec(parse_study(tomllib.loads(text)))
    assert res.summary["design"]["verdict"] == "pass", res.summary["design"]
    table = res.context.setpoints
    robot = res.context.robot
    sent = np.abs(table.dcounts) / (table.counts_per_rad * table.cycle_s)
    v = robot.limits.velocity_rad_s[: table.n_axes]
    assert np.all(sent.max(axis=0) <= v)
    assert sent[:, 0].max() / v[0] > 0.98  # joint 1 does run near its limit


def test_a_position_rounded_past_the_joint_range_is_refused(teachbot6):
    """A move ending exactly at joint 5's upper limit whose end count rounds up: the plan keeps
    the range, the count sent does not (by less than half a count, more than the 1e-9 rad
    slack)."""
    j = 4
    cpr = teachbot6.drives["joint5"].counts_per_rad(4)
    v = 0.5 * float(teachbot6.limits.velocity_rad_s[j])
    a = float(teachbot6.limits.acceleration_rad_s2[j])
    for cruise in np.linspace(0.2, 0.3, 101):
        tr = trapezoid_move(teachbot6, "joint5", v, a, float(cruise))
        x = float(tr.at(_cycles(tr))[0][-1, j]) * cpr
        if 0.1 < np.rint(x) - x < 0.5:  # rounds up by 0.1 .. 0.5 count
            break
    else:
        pytest.fail("no end position rounding up")
    q_end = x / cpr
    upper = teachbot6.limits.upper_rad.copy()
    upper[j] = q_end
    robot = teachbot6.with_limits(upper_rad=upper)
    with pytest.raises(LimitViolation) as ei:
        setpoint_table(robot, tr, "reference_dda")
    f = ei.value.failure
    assert (f.check, f.joint) == ("joint range", "joint5")
    assert f.value == pytest.approx(np.rint(x) / cpr, rel=1e-15) and f.value > q_end + 1e-9
    assert "sent as counts" in str(ei.value)
    # the same move with the limit one count further is sent
    upper[j] = q_end + 1.0 / cpr
    setpoint_table(teachbot6.with_limits(upper_rad=upper), tr, "reference_dda")
