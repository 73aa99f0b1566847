"""A value changed in the study file reaches every stage that depends on it.

One base study (plan, static load, sizing, tuning, export), then one change at a time -- a reducer
ratio, the controller cycle and servo period, the payload, the base mounting -- and each stage's
result is compared with the base run's by an independent expectation (a ratio scales the motor
speed and the counts, a cycle scales the counts per cycle, a payload raises torques, a tilted base
moves gravity). A stage that ignored the study value would give the base run's number.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from armlab.study import parse_study, run_spec

BASE = """
[study]
name = "propagation"
stages = ["kinematics", "plan", "static_load", "sizing", "tuning", "export"]
report = false
[robot]
name = "teachbot6"
[payload]
mass_kg = 0.5
[waypoints]
unit = "deg"
joint = [[0, 10, 10, 0, 0, 0], [30, 30, 30, 30, 30, 30]]
[plan]
planner = "ptp"
profile = "scurve"
[control]
n_inertia_samples = 20
"""


def run(tmp_path, name, change=None):
    doc = tomllib.loads(BASE)
    if change:
        change(doc)
    spec = parse_study(doc, base_dir=tmp_path, source=name)
    return run_spec(spec, tmp_path / name)


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    return run(tmp_path_factory.mktemp("base"), "base")


def _joint(res, name):
    return next(j for j in res.context.sizing.joints if j.joint == name)


def _check(res, joint, check):
    return next(c for c in _joint(res, joint).checks if c.name == check)


def test_ratio_reaches_sizing_plant_table_and_record(base, tmp_path):
    old = base.context.robot.drives["joint5"].reducer.ratio
    new_ratio = 2 * old

    def change(doc):
        doc["drives"] = {"joint5": {"ratio": new_ratio}}

    res = run(tmp_path, "ratio", change)
    assert res.verdict in ("pass", "fail")
    # sizing: motor speed = ratio x joint speed
    b, r = _joint(base, "joint5"), _joint(res, "joint5")
    assert r.motor_peak_speed_rpm / r.peak_speed_rad_s == pytest.approx(
        2 * b.motor_peak_speed_rpm / b.peak_speed_rad_s
    )
    # tuning: the plant of joint 5 is the new drive train
    assert res.context.gains.joints["joint5"].plant.ratio == new_ratio
    assert base.context.gains.joints["joint5"].plant.ratio == old
    # table: counts per radian doubled
    j = res.context.robot.joint_names.index("joint5")
    cpr_b = base.context.controller.counts_per_rad(base.context.robot)[j]
    cpr_r = res.context.controller.counts_per_rad(res.context.robot)[j]
    assert cpr_r == pytest.approx(2 * cpr_b)
    assert abs(res.context.setpoints.counts[-1, j]) == pytest.approx(
        2 * abs(base.context.setpoints.counts[-1, j]), abs=1
    )
    # limits: the available torque (a drive-train limit) follows the ratio
    k = res.context.robot.joint_names.index("joint5")
    assert res.context.robot.limits.torque_Nm[k] == pytest.approx(
        2 * base.context.robot.limits.torque_Nm[k]
    )


def test_cycle_and_servo_period_reach_sizing_table_tuning_and_gains(base, tmp_path):
    def change(doc):
        doc["controller"] = {"cycle_s": 0.004, "servo_period_s": 0.002}

    res = run(tmp_path, "cycle", change)
    for name in res.context.robot.joint_names:
        b = _check(base, name, "encoder_pulse_rate").value
        # peak counts per cycle = peak speed x counts_per_rad x cycle; the plan keeps whole
        # counts per cycle within the speed limit (issue 24 item 6), so its peak speed depends
        # on the cycle too (within one count per 1 ms cycle)
        speed = _joint(res, name).peak_speed_rad_s / _joint(base, name).peak_speed_rad_s
        assert 1 - 1e-9 <= speed <= 1.03
        assert _check(res, name, "encoder_pulse_rate").value == pytest.approx(4 * b * speed)
    assert res.context.setpoints.cycle_s == pytest.approx(0.004)
    assert res.summary["export"]["cycle_s"] == pytest.approx(0.004)
    for g in res.context.gains.joints.values():
        assert g.speed.sample_time_s == 0.002 and g.position.sample_time_s == 0.002
    for g in base.context.gains.joints.values():
        assert g.speed.sample_time_s == 0.001
    # the gains file written by the study carries the servo period
    import json

    gains = json.loads((tmp_path / "cycle" / "gains.json").read_text())
    assert gains["joints"]["joint1"]["speed"]["sample_time_s"] == 0.002


def test_payload_reaches_static_load_sizing_tuning_and_record(base, tmp_path):
    def change(doc):
        doc["payload"]["mass_kg"] = 1.5

    res = run(tmp_path, "payload", change)
    sb, sr = base.context.static_load, res.context.static_load
    assert sr.joints[1].torque_Nm > sb.joints[1].torque_Nm + 1.0  # 1 kg more at ~0.5 m
    assert _joint(res, "joint2").peak_torque_Nm > _joint(base, "joint2").peak_torque_Nm
    assert res.context.gains.joints["joint2"].plant.payload_kg == pytest.approx(1.5)
    from armlab.study.record import load_design

    assert load_design(tmp_path / "payload")["robot"]["payload"]["mass_kg"] == 1.5


def test_base_mounting_reaches_every_torque(base, tmp_path):
    def change(doc):
        doc["robot"]["base_rpy_deg"] = [0.0, 30.0, 0.0]  # a 30 deg tilted table
        doc["plan"]["torque_limits"] = False

    res = run(tmp_path, "tilted", change)
    robot = res.context.robot
    g = robot.model.gravity.linear
    # g_base = R^T g_world with R = Ry(30 deg), g_world = (0, 0, -9.81)
    s30, c30 = math.sin(math.radians(30)), math.cos(math.radians(30))
    assert g == pytest.approx([9.81 * s30, 0.0, -9.81 * c30], abs=1e-9)
    # joint 1 carries gravity on a tilted base: static load and sizing see it
    assert (
        res.context.static_load.joints[0].torque_Nm
        > base.context.static_load.joints[0].torque_Nm + 1.0
    )
    assert _joint(res, "joint1").peak_torque_Nm > _joint(base, "joint1").peak_torque_Nm + 1.0
    # the tuning's gravity-independent plant is unchanged, the record holds the mounting
    from armlab.study.record import load_design

    T = np.array(load_design(tmp_path / "tilted")["robot"]["transform_base_to_world"])
    assert T[:3, :3] == pytest.approx(robot.transform_base_to_world[:3, :3])
