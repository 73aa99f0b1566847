"""One Limits type, one resolver: hardware-derived limits, tighten-only study overrides, the
speed scale and the planners' per-call keywords (armlab.robot.limits)."""

from __future__ import annotations

import json
import math
import shutil
import tomllib

import numpy as np
import pytest

import armlab
from armlab.dynamics import size
from armlab.errors import InputError, SpecError
from armlab.robot import Limits, load_robot, resolve_limits
from armlab.robot.limits import description_limits
from armlab.study import parse_study
from armlab.study.build import build_robot, controller_profile
from armlab.study.context import StudyContext
from armlab.study.stages import planning_robot
from armlab.trajectory import optimal, ptp_sync
from conftest import REPO, UR5_URDF

RPM = 2 * math.pi / 60

STUDY = """
[study]
name = "limits"
stages = ["kinematics"]
[robot]
name = "teachbot6"
[waypoints]
unit = "deg"
joint = [[0, 0, 0, 0, 0, 0], [30, 10, 20, 0, 30, 0]]
"""


def study_robot(**limits):
    doc = tomllib.loads(STUDY)
    doc["limits"] = limits
    return build_robot(parse_study(doc))


# ---------------------------------------------------------------------------- hardware
def test_teachbot6_velocity_is_min_of_urdf_and_drive_train(teachbot6):
    rows = tomllib.loads((REPO / "robot_desc/teachbot6/drives.toml").read_text())["joint"]
    urdf = description_limits(teachbot6.model).velocity_rad_s
    lim = teachbot6.limits
    for j, row in enumerate(rows):
        N = row["reducer"]["ratio"]
        cands = {
            "urdf <limit velocity>": urdf[j],
            "motor rated speed / ratio (drives.toml)": row["motor"]["rated_speed_rpm"] * RPM / N,
            "reducer max input speed / ratio (drives.toml)": (
                row["reducer"]["max_input_speed_rpm"] * RPM / N
            ),
        }
        source = min(cands, key=cands.get)
        assert lim.velocity_rad_s[j] == pytest.approx(cands[source], rel=1e-12)
        assert lim.sources["velocity"][j] == source
    # joint 3: 2200 rpm / 385 = 0.598 rad/s, below the URDF's 0.65 rad/s
    assert urdf[2] == pytest.approx(0.65)
    assert lim.velocity_rad_s[2] == pytest.approx(2200 * RPM / 385)
    assert lim.sources["velocity"][2].startswith("motor rated speed")
    # acceleration, jerk and torque from drives.toml
    assert lim.acceleration_rad_s2.tolist() == [r["acceleration_rad_s2"] for r in rows]
    assert lim.jerk_rad_s3.tolist() == [r["jerk_rad_s3"] for r in rows]
    assert lim.torque_Nm[1] == pytest.approx(0.28 * 410 * 0.6 * 0.8)
    assert lim.sources["torque"][1].startswith("available torque")


def test_a_plan_at_the_velocity_limit_passes_the_motor_speed_check(teachbot6):
    """The joint velocity limit uses the motor speed of the sizing check: joint 3 cruising at
    its limit runs its motor at exactly the rated speed (the URDF's 0.65 rad/s would not)."""
    q0 = np.zeros(6)
    q1 = np.array([0.0, 0.0, 2.5, 0.0, 0.0, 0.0])
    traj = ptp_sync(teachbot6, q0, q1, dt=0.002, tau_max=False)
    assert np.max(np.abs(traj.qd[:, 2])) == pytest.approx(teachbot6.limits.velocity_rad_s[2])
    check = size(teachbot6, traj, controller="reference_dda").joint("joint3").check("motor_speed")
    assert check.ok and check.value == pytest.approx(check.limit, rel=1e-9)


def test_ur5_with_a_drives_file_is_capped_by_its_motors(tmp_path):
    """A plain URDF planned with 3.15 rad/s although its drives allow less: with drives.toml
    beside it the motor speed / ratio bounds the joint."""
    folder = tmp_path / "ur5"
    folder.mkdir()
    shutil.copy(UR5_URDF, folder / "ur5.urdf")
    joint = """
[[joint]]
name = "{name}"
acceleration_rad_s2 = 3.0
jerk_rad_s3 = 30.0
[joint.motor]
model = "m"
stall_torque_Nm = 1.0
rated_speed_rpm = 3000
current_A = 5.0
torque_constant_Nm_A = 0.2
back_emf_V_s_rad = 0.2
resistance_ohm = 1.0
inductance_H = 0.001
rotor_inertia_kg_m2 = 1e-5
supply_voltage_V = 72.0  # above the back-EMF at rated speed (0.2 x 314 rad/s = 62.8 V)
[joint.reducer]
model = "r"
ratio = 211
efficiency = 0.8
rated_torque_Nm = 200
peak_torque_Nm = 400
max_input_speed_rpm = 6000
[joint.encoder]
pulses_per_rev = 1000
"""
    plain = load_robot(UR5_URDF)
    text = "version = 1\n" + "".join(joint.format(name=n) for n in plain.joint_names)
    (folder / "drives.toml").write_text(text)
    ur5 = load_robot(folder)
    assert plain.limits.velocity_rad_s[0] == pytest.approx(3.15)
    assert plain.limits.sources["velocity"][0] == "urdf <limit velocity>"
    np.testing.assert_allclose(ur5.limits.velocity_rad_s, 3000 * RPM / 211)  # 1.489 rad/s
    assert set(ur5.limits.sources["velocity"]) == {"motor rated speed / ratio (drives.toml)"}
    np.testing.assert_allclose(ur5.limits.torque_Nm, 1.0 * 211 * 0.8)
    with pytest.raises(SpecError, match=r"limits\.velocity_rad_s of shoulder_pan_joint: 3\.15"):
        resolve_limits(
            description_limits(ur5.model), ur5.drives, overrides={"velocity_rad_s": 3.15}
        )


# ---------------------------------------------------------------------------- study overrides
def test_study_override_above_the_hardware_is_refused_naming_the_key():
    with pytest.raises(SpecError) as err:
        study_robot(velocity_rad_s=1e12)
    msg = str(err.value)
    assert msg.startswith("limits.velocity_rad_s of joint1: 1e+12 rad/s is above the URDF's")
    assert "0.56 rad/s" in msg
    # joint 3 is capped by its motor: 0.62 rad/s passes the URDF's 0.65 but not the drive's
    with pytest.raises(SpecError, match=r"joint3: 0\.62 rad/s is above the drive train's 0\.59"):
        study_robot(velocity_rad_s=[0.1, 0.1, 0.62, 0.1, 0.1, 0.1])
    with pytest.raises(SpecError, match=r"limits\.effort_Nm of joint2: 100 N m .*available"):
        study_robot(effort_Nm=[1, 100, 1, 1, 1, 1])


def test_study_override_below_the_hardware_is_taken(teachbot6):
    robot = study_robot(velocity_rad_s=0.1, acceleration_rad_s2=[1, 1, 1, 1, 1, 2.0])
    lim = robot.limits
    assert np.all(lim.velocity_rad_s == 0.1)
    assert lim.acceleration_rad_s2.tolist() == [1, 1, 1, 1, 1, 2.0]
    assert set(lim.sources["velocity"]) == {"study [limits] velocity_rad_s"}
    np.testing.assert_array_equal(lim.jerk_rad_s3, teachbot6.limits.jerk_rad_s3)
    # a plan of the study honours them
    traj = ptp_sync(robot, np.zeros(6), np.full(6, 0.5), tau_max=False)
    assert np.max(np.abs(traj.qd)) == pytest.approx(0.1, rel=1e-9)


def test_plain_urdf_reports_every_missing_limit_at_once(ur5):
    with pytest.raises(InputError) as err:
        optimal(ur5, [np.zeros(6), np.full(6, 0.2)], n_intervals=8)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("optimal on ur5_robot: missing acceleration and jerk")
    for needed in ("[limits] acceleration_rad_s2", "a_max=", "[limits] jerk_rad_s3", "j_max="):
        assert needed in msg
    with pytest.raises(InputError, match="missing acceleration and jerk limits"):
        ur5.limits.require(("velocity", "acceleration", "jerk", "torque"))
    ur5.limits.require(("velocity", "torque"))  # the URDF gives these
    # a study supplies them where the hardware has none
    lim = resolve_limits(
        description_limits(ur5.model), overrides={"acceleration_rad_s2": 5.0, "jerk_rad_s3": 50}
    )
    assert np.all(lim.acceleration_rad_s2 == 5.0) and np.all(lim.jerk_rad_s3 == 50.0)
    assert lim.sources["jerk"][0] == "study [limits] jerk_rad_s3"


# ---------------------------------------------------------------------------- speed scale
def test_speed_scale_scales_v_a_j_by_s_s2_s3(teachbot6):
    lim = teachbot6.limits
    half = lim.scaled(0.5)
    np.testing.assert_allclose(half.velocity_rad_s, lim.velocity_rad_s * 0.5)
    np.testing.assert_allclose(half.acceleration_rad_s2, lim.acceleration_rad_s2 * 0.25)
    np.testing.assert_allclose(half.jerk_rad_s3, lim.jerk_rad_s3 * 0.125)
    np.testing.assert_array_equal(half.torque_Nm, lim.torque_Nm)
    assert half.sources["jerk"][0] == "drives.toml jerk_rad_s3 x speed_scale 0.5"
    np.testing.assert_array_equal(
        resolve_limits(lim, speed_scale=0.5).acceleration_rad_s2, half.acceleration_rad_s2
    )
    with pytest.raises(InputError):
        lim.scaled(1.5)  # a speed scale may not go past the hardware
    # the study's planning robot
    doc = tomllib.loads(STUDY)
    doc["plan"] = {"speed_scale": 0.8}
    spec = parse_study(doc)
    ctx = StudyContext(spec, robot=build_robot(spec), controller=controller_profile(spec))
    planned = planning_robot(ctx).limits
    # speeds scaled, then held to whole counts per controller cycle (issue 24 item 6): at most
    # floor(0.8 v x counts_per_rad x T) - 0.01 counts per cycle
    per_cycle = (
        np.array(
            [ctx.robot.drives[j].counts_per_rad(ctx.controller.decoding) for j in lim.joint_names]
        )
        * ctx.controller.cycle_s
    )
    whole = np.floor(lim.velocity_rad_s * 0.8 * per_cycle)
    np.testing.assert_allclose(planned.velocity_rad_s, (whole - 0.01) / per_cycle, rtol=1e-12)
    assert np.all(planned.velocity_rad_s <= lim.velocity_rad_s * 0.8)
    assert np.all(planned.velocity_rad_s > lim.velocity_rad_s * 0.8 - 1.01 / per_cycle)
    np.testing.assert_allclose(planned.jerk_rad_s3, lim.jerk_rad_s3 * 0.8**3)
    assert ctx.robot.limits.velocity_rad_s[0] == lim.velocity_rad_s[0]  # untouched


# ---------------------------------------------------------------------------- per call
def test_ptp_sync_and_optimal_both_take_j_max_false_as_off(teachbot6):
    q0, q1 = np.zeros(6), np.array([0.3, -0.2, 0.25, 0.4, 0.3, 0.5])
    ptp = ptp_sync(teachbot6, q0, q1, "trapezoid", j_max=False, tau_max=False)
    opt = optimal(teachbot6, [q0, q1], j_max=False, tau_max=False, n_intervals=12)
    for traj in (ptp, opt):
        assert "jerk" not in traj.report.ratios and traj.report.ok(1e-6)
    assert opt.meta["limits"]["jerk_rad_s3"] is None
    assert opt.meta["limits"]["sources"]["jerk"]["joint1"] == "off (j_max=False)"
    # with the robot's jerk limit the optimum is slower: False really switched it off
    with_jerk = optimal(teachbot6, [q0, q1], tau_max=False, n_intervals=12)
    assert opt.duration < with_jerk.duration
    # an S-curve cannot do without the jerk limit it is shaped by: the same keyword says so
    with pytest.raises(InputError, match=r"ptp_sync scurve: missing jerk limit.*j_max=False"):
        ptp_sync(teachbot6, q0, q1, "scurve", j_max=False)


def test_per_call_keywords_share_one_rule(teachbot6):
    lim = resolve_limits(teachbot6, v_max=False, a_max=2.0, j_max=np.inf)
    assert lim.velocity_rad_s is None and lim.is_off("velocity")
    assert lim.jerk_rad_s3 is None and lim.is_off("jerk")
    assert np.all(lim.acceleration_rad_s2 == 2.0)
    assert lim.sources["acceleration"][0] == "a_max argument"
    np.testing.assert_array_equal(lim.torque_Nm, teachbot6.limits.torque_Nm)  # None: robot's
    for bad in (True, -1.0, np.nan, [1.0, 2.0]):
        with pytest.raises(InputError, match="v_max"):
            resolve_limits(teachbot6, v_max=bad)


def test_switching_kinds_off_keeps_a_full_limits(teachbot6):
    """Switching kinds off (``tau_max=False``, ``j_max=False``: the copy that skips the
    re-checks) gives a Limits like one built from scratch: the other kinds and the range the
    robot's, the sources saying off, and it still derives and checks as any other."""
    lim = resolve_limits(teachbot6, tau_max=False, j_max=False)
    base = teachbot6.limits
    assert isinstance(lim, Limits) and lim is not base
    assert lim.torque_Nm is None and lim.jerk_rad_s3 is None
    assert lim.is_off("torque") and lim.is_off("jerk")
    assert lim.sources["torque"] == ("off (tau_max=False)",) * 6
    assert lim.sources["velocity"] == base.sources["velocity"]
    np.testing.assert_array_equal(lim.velocity_rad_s, base.velocity_rad_s)
    np.testing.assert_array_equal(lim.lower_rad, base.lower_rad)
    assert base.torque_Nm is not None and not base.is_off("torque")  # the robot's unchanged
    rebuilt = Limits(
        joint_names=lim.joint_names,
        lower_rad=lim.lower_rad,
        upper_rad=lim.upper_rad,
        velocity_rad_s=lim.velocity_rad_s,
        acceleration_rad_s2=lim.acceleration_rad_s2,
        sources=lim.sources,
    )
    assert rebuilt.to_dict() == lim.to_dict()
    half = lim.scaled(0.5)
    np.testing.assert_allclose(half.velocity_rad_s, 0.5 * base.velocity_rad_s, rtol=1e-15)
    assert half.torque_Nm is None
    with pytest.raises(InputError, match="v_max"):
        resolve_limits(lim, v_max=-1.0)
    with pytest.raises(InputError, match="lower_rad"):  # a range is never switched off
        lim.with_values("test", lower_rad=None)


# ---------------------------------------------------------------------------- checkers
def test_check_limits_takes_a_limits(teachbot6):
    traj = ptp_sync(teachbot6, np.zeros(6), np.full(6, 0.3), tau_max=False)
    full = traj.check_limits(teachbot6, torque=False)
    half = traj.check_limits(teachbot6, torque=False, limits=teachbot6.limits.scaled(0.5))
    np.testing.assert_allclose(half.ratios["velocity"], 2 * full.ratios["velocity"])
    np.testing.assert_allclose(half.ratios["acceleration"], 4 * full.ratios["acceleration"])
    assert full.ok(1e-9) and not half.ok(1e-9)
    no_acc = resolve_limits(teachbot6, a_max=False)
    assert "acceleration" not in traj.check_limits(teachbot6, limits=no_acc).ratios
    with pytest.raises(InputError, match="Limits"):
        traj.check_limits(teachbot6, limits={"velocity_rad_s": 1.0})


def test_setpoint_preflight_needs_a_velocity_limit(teachbot6):
    from armlab.deploy import setpoint_table

    # planned within the speeds whose rounded counts keep the robot's limits (issue 24 item 6)
    v = armlab.robot.load_profile("reference_dda").sendable_velocity_rad_s(
        teachbot6, teachbot6.limits.velocity_rad_s
    )
    traj = ptp_sync(teachbot6, np.zeros(6), np.full(6, 0.05), tau_max=False, v_max=v)
    setpoint_table(teachbot6, traj, controller="reference_dda")  # the robot's limits: fine
    blind = teachbot6.with_limits(velocity_rad_s=None)
    with pytest.raises(InputError, match="set-point pre-flight: missing velocity limit"):
        setpoint_table(blind, traj, controller="reference_dda")


def test_limits_type_contract(teachbot6):
    lim = teachbot6.limits
    assert isinstance(lim, Limits) and armlab.robot.Limits is Limits
    d = lim.to_dict()
    json.dumps(d)
    assert d["velocity_rad_s"]["joint3"] == pytest.approx(2200 * RPM / 385)
    assert d["sources"]["velocity"]["joint3"].startswith("motor rated speed")
    with pytest.raises(ValueError):
        lim.velocity_rad_s[0] = 10.0  # read-only: the robot's limits cannot drift
    sub = lim.subset([2, 0])
    assert sub.joint_names == ("joint3", "joint1")
    assert sub.velocity_rad_s.tolist() == [lim.velocity_rad_s[2], lim.velocity_rad_s[0]]
    assert lim.effort_Nm is lim.torque_Nm


def test_a_limits_is_immutable_so_what_is_derived_from_it_is_kept(teachbot6):
    lim = teachbot6.limits
    with pytest.raises(TypeError, match="read-only"):
        lim.sources["velocity"] = ("mine",) * lim.n_joints
    with pytest.raises(TypeError, match="read-only"):
        lim.sources.update(velocity=("mine",) * lim.n_joints)
    assert isinstance(lim.sources, dict)
    json.dumps(lim.sources)
    # to_dict is kept with the Limits and handed out as a copy: changing one does not change
    # the next (nor a planner's meta["limits"])
    d = lim.to_dict()
    d["velocity_rad_s"]["joint1"] = 99.0
    d["sources"]["velocity"]["joint1"] = "mine"
    d["joint_names"].append("joint7")
    fresh = lim.to_dict()
    assert fresh["velocity_rad_s"]["joint1"] == float(lim.velocity_rad_s[0])
    assert fresh["sources"]["velocity"]["joint1"] == lim.sources["velocity"][0]
    assert fresh["joint_names"] == list(lim.joint_names)
    # centre and half range: the properties' values, read-only
    centre, half = lim.centre_half_rad()
    np.testing.assert_array_equal(centre, 0.5 * (lim.lower_rad + lim.upper_rad))
    np.testing.assert_array_equal(half, 0.5 * (lim.upper_rad - lim.lower_rad))
    with pytest.raises(ValueError):
        centre[0] = 1.0


def test_copies_and_derived_limits_make_their_own_derived_data(teachbot6):
    import copy
    import pickle

    lim = teachbot6.limits
    request = resolve_limits(teachbot6, tau_max=False)
    assert request is resolve_limits(teachbot6, tau_max=False)  # kept with the robot's limits
    for other in (pickle.loads(pickle.dumps(lim)), copy.copy(lim), copy.deepcopy(lim)):
        assert other.to_dict() == lim.to_dict()
        again = resolve_limits(other, tau_max=False)
        assert again is not request and again.to_dict() == request.to_dict()
        with pytest.raises(TypeError, match="read-only"):
            other.sources["torque"] = ()
    # a kind switched off (the copy without re-checks) does not take over the derived data
    # of the Limits it was made from
    no_jerk = lim.with_values("test", jerk_rad_s3=None)
    assert lim.to_dict()["jerk_rad_s3"] is not None
    assert no_jerk.to_dict()["jerk_rad_s3"] is None
    assert no_jerk.to_dict()["sources"]["jerk"]["joint1"] == "unknown"
    assert request.to_dict()["torque_Nm"] is None
    assert request.to_dict()["sources"]["torque"]["joint1"] == "off (tau_max=False)"
    assert lim.to_dict()["torque_Nm"] is not None


def test_a_changed_robot_is_not_served_the_old_limits(teachbot6):
    robot = teachbot6.copy()
    lo, hi = robot.limits.lower_rad, robot.limits.upper_rad
    w = np.stack([lo + 0.3 * (hi - lo), lo + 0.7 * (hi - lo)])
    before = optimal(robot, w, tau_max=False)
    old_request = resolve_limits(robot, tau_max=False)
    # half the speed, acceleration and jerk: the same motion twice as long (time scaling
    # t -> 2t: v/2, a/4, j/8)
    lim = robot.limits
    robot.limits = lim.with_values(
        "test",
        velocity_rad_s=lim.velocity_rad_s / 2,
        acceleration_rad_s2=lim.acceleration_rad_s2 / 4,
        jerk_rad_s3=lim.jerk_rad_s3 / 8,
    )
    request = resolve_limits(robot, tau_max=False)
    assert request is not old_request
    np.testing.assert_array_equal(request.velocity_rad_s, lim.velocity_rad_s / 2)
    after = optimal(robot, w, tau_max=False)
    assert after.duration == pytest.approx(2 * before.duration, rel=1e-9)
    assert after.meta["limits"]["velocity_rad_s"]["joint1"] == float(lim.velocity_rad_s[0] / 2)
    assert after.meta["limits"]["sources"]["velocity"]["joint1"] == "test"
    assert after.report.ratios["velocity"].max() <= 1 + 1e-9
    slow = ptp_sync(robot, w[0], w[1], "scurve", tau_max=False)
    assert slow.duration == pytest.approx(after.duration, rel=1e-12)
    # a narrower range refuses a waypoint the old one took
    robot.limits = robot.limits.with_values("test", upper_rad=np.maximum(lo, w[1] - 0.01))
    with pytest.raises(InputError, match=r"waypoints\[1\]: joint1 = .* is outside its range"):
        optimal(robot, w, tau_max=False)
    with pytest.raises(InputError, match="ptp_sync q_goal: joint1 = .* is outside its range"):
        ptp_sync(robot, w[0], w[1], "scurve", tau_max=False)
