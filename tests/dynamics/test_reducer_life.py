"""Reducer life, momentary torque and output-bearing tilting moment (issue 28).

Independent references: a harmonic-reducer maker's worked example of the average load torque
(Honpine, "How to select a harmonic reduction gear": T_av = 89 N m for the four-phase cycle
below, the Harmonic Drive CSF/CSG selection procedure's formula), Harmonic Drive's life rule
restated with its numbers by hand, and a point mass on a one-joint arm whose bearing moment is
m g L by hand.
"""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pinocchio as pin
import pytest

from armlab.dynamics import size
from armlab.dynamics.reducer_life import (
    average_input_speed_rpm,
    average_torque_Nm,
    tilting_moments_Nm,
)
from armlab.robot.drives import RPM_TO_RAD_S, Reducer
from armlab.study.drive_stages import sizing_failures
from cases import cosine_motion, quick_study

# the maker's cycle: (output torque N m, time s, output speed rpm) per phase
PHASES = [(150.0, 0.2, 10.0), (82.0, 3.0, 20.0), (130.0, 0.3, 10.0), (0.0, 0.2, 0.0)]


def _phases():
    tau = np.array([[p[0]] for p in PHASES])
    qd = np.array([[p[2] * RPM_TO_RAD_S] for p in PHASES])
    weights = np.array([p[1] for p in PHASES])
    return tau, qd, weights


def test_average_torque_matches_the_makers_worked_example():
    tau, qd, w = _phases()
    # the worked example's result, 89 N m (rounded to 1 N m on the page)
    assert average_torque_Nm(tau, qd, w)[0] == pytest.approx(89.0, abs=0.5)
    # mean output speed with the pause counted: 65 rpm s / 3.7 s = 17.57 rpm; input x 100
    assert average_input_speed_rpm(qd, w, [100.0])[0] == pytest.approx(1756.8, abs=0.1)


def test_life_by_hand():
    # L_h = L_n (T_r / T_av)^3 (n_r / n_av), CSF L_10 7000 h at 2000 rpm, rated 87 N m:
    # 7000 x (87 / 89.387)^3 x (2000 / 1756.76) = 7347.7 h (hand calculation)
    red = Reducer("r", 100, 0.8, 87.0, 200.0, 7000, rated_life_h=7000, rated_input_speed_rpm=2000)
    tau, qd, w = _phases()
    t_av = float(average_torque_Nm(tau, qd, w)[0])
    n_av = float(average_input_speed_rpm(qd, w, [100.0])[0])
    assert red.life_h(t_av, n_av) == pytest.approx(7347.7, rel=1e-3)
    # no rating: not a number (the check then says "not checked")
    assert math.isnan(replace(red, rated_life_h=math.nan).life_h(t_av, n_av))


def _one_joint_arm(gravity, offset_m=0.0):
    """A revolute joint about z with a point mass of 2 kg at x = 0.5 m."""
    model = pin.Model()
    jid = model.addJoint(0, pin.JointModelRZ(), pin.SE3.Identity(), "j")
    inertia = pin.Inertia(2.0, np.array([0.5, 0.0, 0.0]), np.eye(3) * 1e-9)
    model.appendBodyToJoint(jid, inertia, pin.SE3.Identity())
    model.gravity.linear = np.asarray(gravity, float)
    robot = SimpleNamespace(model=model, drives=None, joint_names=["j"])
    z = np.zeros((1, 1))
    return tilting_moments_Nm(robot, SimpleNamespace(q=z, qd=z, qdd=z), [offset_m])[0]


def test_tilting_moment_by_hand():
    g = 9.81
    # vertical axis, mass on a horizontal lever: the bearing carries m g L as a tilting moment
    assert _one_joint_arm([0, 0, -g]) == pytest.approx(2.0 * g * 0.5, rel=1e-9)
    # horizontal axis (gravity along -y): the moment is the joint torque, not a tilt; the radial
    # force m g on the 0.04 m offset to the bearing's centre plane tilts it: 0.04 m g
    assert _one_joint_arm([0, -g, 0]) == pytest.approx(0.0, abs=1e-9)
    assert _one_joint_arm([0, -g, 0], offset_m=0.04) == pytest.approx(0.04 * 2.0 * g, rel=1e-9)


@pytest.fixture(scope="module")
def cycle(teachbot6):
    return cosine_motion(teachbot6, duration_s=10.0, n=1001)


def test_teachbot6_life_and_not_checked(teachbot6, cycle):
    rep = size(teachbot6, cycle, controller="reference_dda")
    for j in rep.joints:
        life = j.check("reducer_life")
        if j.drive.reducer.life_rated:
            assert life.checked and life.limit == pytest.approx(j.reducer_life_h)
        else:  # joint 6's planetary gearhead: no life rating in its data
            assert not life.checked and life.ok and life.note.startswith("not checked: no rating")
        # no teachbot6 reducer has an output bearing rating (component sets)
        assert j.check("reducer_bearing_moment").note.startswith("not checked: no rating")
    assert rep.ok


def test_each_new_check_fails_with_one_line(teachbot6, cycle):
    base = size(teachbot6, cycle, controller="reference_dda")
    shortest = min(j.reducer_life_h for j in base.joints if math.isfinite(j.reducer_life_h))
    # a required life above the shortest expected one fails that joint's life
    long = size(teachbot6, cycle, controller="reference_dda", required_life_h=2 * shortest)
    assert any(f.startswith("sizing: ") and "reducer_life" in f for f in sizing_failures(long))
    assert {c for _, c in long.failures()} == {"reducer_life"}
    # an emergency stop at the current limit: joint 2's 55LYX04 brakes with
    # 0.8 x 0.28 N m x 410 / 0.6 = 153.1 N m through a reducer ESTIMATED at 140 N m momentary
    stop = size(teachbot6, cycle, controller="reference_dda", momentary_load="stop")
    j2 = stop.joint("joint2").check("reducer_momentary_torque")
    assert not j2.ok and j2.value == pytest.approx(0.8 * 0.28 * 410 / 0.6, rel=1e-9)
    assert "joint2 reducer_momentary_torque 153.1 > 140 N m" in "\n".join(sizing_failures(stop))
    # an output bearing rated below the overturning moment the arm puts on the base joint
    d1 = teachbot6.drives["joint1"]
    rated = replace(d1, reducer=replace(d1.reducer, bearing_moment_rating_Nm=1.0))
    drives = {**teachbot6.drives, "joint1": rated}
    tilt = size(teachbot6, cycle, controller="reference_dda", drives=drives)
    b = tilt.joint("joint1").check("reducer_bearing_moment")
    assert (
        b.checked
        and not b.ok
        and b.value == pytest.approx(tilt.joint("joint1").bearing_tilting_moment_Nm)
    )
    assert [c for _, c in tilt.failures()] == ["reducer_bearing_moment"]


def _quick(tmp_path, extra: str):
    from armlab.study import load_study

    path = tmp_path / "s.toml"
    text = quick_study(stages=("kinematics", "plan", "static_load", "sizing"))
    path.write_text(text + extra)
    return load_study(path)


def test_a_study_value_fails_the_life_with_one_line(tmp_path):
    from armlab.study import run_spec

    spec = _quick(tmp_path, "[sizing]\nrequired_life_h = 1e12\n")
    assert spec.sizing.required_life_h == pytest.approx(1e12)
    summary = run_spec(spec).summary
    design = summary["design"]
    assert design["verdict"] == "fail"
    # one line per joint that turns and has a life rating (joint 6's gearhead has none)
    sizing = {j: r for j, r in summary["sizing"].items() if isinstance(r, dict) and "checks" in r}
    rated = [j for j, row in sizing.items() if row["reducer_life_h"] is not None]
    lines = design["failed_checks"]
    assert rated and lines == [
        line
        for line in lines
        if line.startswith("sizing: joint") and " reducer_life 1e+12 > " in line
    ]
    assert sorted(line.split()[1] for line in lines) == sorted(rated)


def test_bad_sizing_keys_name_the_key(tmp_path):
    from armlab.errors import SpecError

    with pytest.raises(SpecError) as err:
        _quick(tmp_path, '[sizing]\nmomentary_load = "collision"\n')
    assert str(err.value).startswith("sizing.momentary_load") and "\n" not in str(err.value)
    with pytest.raises(SpecError) as err:
        _quick(tmp_path, "[sizing]\nrequired_life_h = -1\n")
    assert str(err.value).startswith("sizing.required_life_h")
