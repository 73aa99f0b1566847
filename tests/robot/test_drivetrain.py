"""The drive-train model (armlab.robot.drivetrain) against hand computations, its inverse, the
CasADi twin, and the bad-input errors of the new drives.toml keys."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest

import armlab
from armlab.robot import drivetrain as dtm
from armlab.robot.drives import Drive, Encoder, Motor, Reducer, available_torque_Nm
from armlab.robot.drives_file import motor_from_dict, read_drives, reducer_from_dict


def _drive(**reducer_kw) -> Drive:
    motor = Motor(
        "m",
        stall_torque_Nm=0.1,
        rated_speed_rpm=3000,
        current_A=1.0,
        torque_constant_Nm_A=0.05,
        back_emf_V_s_rad=0.05,
        resistance_ohm=1.0,
        inductance_H=1e-3,
        rotor_inertia_kg_m2=8e-6,
        viscous_friction_Nm_s_rad=1e-4,
        supply_voltage_V=24.0,
        peak_torque_Nm=0.3,
    )
    kw = dict(
        ratio=100,
        efficiency=0.5,
        rated_torque_Nm=4.0,
        peak_torque_Nm=8.0,
        max_input_speed_rpm=6000,
        inertia_kg_m2=2e-6,
        back_efficiency=0.8,
        coulomb_friction_Nm=0.3,
        viscous_friction_Nm_s_rad=0.1,
    )
    kw.update(reducer_kw)
    return Drive("j", motor, Reducer("r", **kw), Encoder(1000, 4), 1.0, 10.0)


def test_motor_torque_by_hand_in_every_quadrant():
    dt = dtm.DriveTrain.from_drives([_drive()])
    # N = 100, eta = 0.5, eta_b = 0.8, J = 1e-5, b_m = 1e-4, F_c = 0.3, F_v = 0.1
    tau = np.array([[2.0], [-2.0], [-2.0], [0.1], [0.1], [2.0]])
    qd = np.array([[1.0], [1.0], [-1.0], [0.0], [0.0], [-1.0]])
    qdd = np.array([[2.0], [0.0], [0.0], [1.0], [0.0], [0.0]])
    t_m, motoring = dtm.motor_torque(tau, qd, qdd, dt)
    expected = [
        2.4 / 50
        + 1e-5 * 100 * 2
        + 1e-4 * 100,  # driving: (2 + 0.3 + 0.1) / (N eta) + J N qdd + b w
        -1.6 * 0.8 / 100 + 1e-4 * 100,  # back-driven: friction helps, x eta_b / N
        -2.4 / 50 - 1e-4 * 100,  # driving backwards
        0.4 / 50 + 1e-5 * 100,  # break-away from rest: Coulomb along qdd
        0.1 / 50,  # holding counts as driving; no friction at rest without acceleration
        1.6 * 0.8 / 100 - 1e-4 * 100,  # lowering against the load: back-driven
    ]
    assert t_m[:, 0] == pytest.approx(expected, rel=1e-12)
    assert motoring[:, 0].tolist() == [True, False, True, True, True, False]
    assert dtm.motor_speed(qd, dt)[:, 0] == pytest.approx([100, 100, -100, 0, 0, -100])


def test_inverse_is_exact_on_random_motions():
    dt = dtm.DriveTrain.from_drives([_drive(), _drive(back_efficiency=math.nan)])
    rng = np.random.default_rng(3)
    tau, qd, qdd = (rng.normal(size=(200, 2)) * s for s in (3.0, 1.0, 5.0))
    qd[::7] = 0.0  # rest samples: break-away friction
    t_m, _ = dtm.motor_torque(tau, qd, qdd, dt)
    back = dtm.joint_torque_delivered(t_m, qd, qdd, dt)
    assert back == pytest.approx(tau, abs=1e-12)
    # no back_efficiency given: derived equal to the motoring efficiency
    assert dt.back_efficiency.tolist() == [0.8, 0.5]


def test_available_torque_rule_is_the_model_at_rest():
    robot = armlab.load_robot("teachbot6")
    dt = dtm.drive_train(robot)
    z = np.zeros((1, robot.n_joints))
    delivered = dtm.joint_torque_delivered(dt.continuous_motor_torque_Nm[None, :], z, z, dt)[0]
    for j, name in enumerate(robot.joint_names):
        d = robot.drives[name]
        rule = available_torque_Nm(
            d.motor.stall_torque_Nm, d.reducer.ratio, d.reducer.efficiency, d.derating
        )
        assert delivered[j] == pytest.approx(rule, rel=1e-12)
        assert d.available_torque_Nm == pytest.approx(rule, rel=1e-12)


def test_envelope_by_hand():
    dt = dtm.DriveTrain.from_drives([_drive()])
    # Kt (U - Ke |w|) / R = 0.05 (24 - 0.05 |w|): 0.95 at 100 rad/s (peak 0.3 binds), 0.075 at
    # 450 rad/s, -0.05 at 500 rad/s (beyond no-load 480 rad/s: no torque left)
    w = np.array([[100.0], [-450.0], [450.0], [500.0]])
    assert dtm.voltage_line_torque(w, dt)[:, 0] == pytest.approx([0.95, 0.075, 0.075, -0.05])
    assert dtm.envelope_torque(w, dt)[:, 0] == pytest.approx([0.3, 0.075, 0.075, -0.05])
    t = np.array([[0.15], [0.06], [-0.09], [0.001]])  # generating at -450 counts the same
    r = dtm.envelope_ratio(t, w, dt)[:, 0]
    assert r[:3] == pytest.approx([0.5, 0.8, 1.2])
    assert r[3] == np.inf


def test_drive_ratios_by_hand():
    dt = dtm.DriveTrain.from_drives(
        [_drive(coulomb_friction_Nm=0.0, viscous_friction_Nm_s_rad=0.0)]
    )
    tau = np.array([[2.0], [4.0]])
    qd = np.array([[1.0], [4.5]])
    qdd = np.zeros_like(tau)
    w = np.array([3.0, 1.0])
    r = dtm.drive_ratios(tau, qd, qdd, w, dt)
    t_m = np.array([2.0 / 50 + 0.01, 4.0 / 50 + 0.045])
    assert r["motor_envelope"][0] == pytest.approx(max(t_m[0] / 0.3, t_m[1] / 0.075))
    assert r["motor_speed"][0] == pytest.approx(450 / (3000 * 2 * np.pi / 60))
    assert r["motor_rms"][0] == pytest.approx(np.sqrt((3 * t_m[0] ** 2 + t_m[1] ** 2) / 4) / 0.1)


def test_symbolic_twin_agrees_with_the_numeric_model():
    ca = pytest.importorskip("casadi")
    dt = dtm.DriveTrain.from_drives([_drive()])
    coeffs = dt.symbolic_coefficients()[0]
    x = ca.SX.sym("x", 4)
    expr = dtm.motor_torque_symbolic(
        x[0], x[1], x[2], x[3], list(coeffs), float(dt.quadrant_band_rad_s[0])
    )
    f = ca.Function("tm", [x], [expr])
    rng = np.random.default_rng(5)
    tau, qd, qdd = (rng.normal(size=(100, 1)) * s for s in (3.0, 1.0, 5.0))
    qd[::5] = 0.0
    direction = dtm.friction_direction(qd, qdd)
    num, _ = dtm.motor_torque(tau, qd, qdd, dt)
    sym = np.array(
        [float(f([tau[k, 0], qd[k, 0], qdd[k, 0], direction[k, 0]])) for k in range(100)]
    )
    assert sym == pytest.approx(num[:, 0], rel=1e-12, abs=1e-15)
    # the branches: the motor torque lies between them (a blend inside the quadrant band);
    # beyond the band it is the max of the two moving forward, the min backwards
    mot, back = dtm.motor_torque_branches(tau, qd, qdd, direction, list(coeffs))
    tol = 1e-12 * np.abs(num)
    assert np.all(num >= np.minimum(mot, back) - tol) and np.all(num <= np.maximum(mot, back) + tol)
    out = np.abs(qd) >= dt.quadrant_band_rad_s
    fwd, bwd = (qd > 0) & out, (qd < 0) & out
    assert fwd.sum() > 20 and bwd.sum() > 20
    assert np.maximum(mot, back)[fwd] == pytest.approx(num[fwd])
    assert np.minimum(mot, back)[bwd] == pytest.approx(num[bwd])


@pytest.mark.parametrize(
    "key, value, message",
    [
        ("efficiency", 1.2, "reducer.efficiency: 1.2 is not in (0, 1]"),
        ("efficiency", 0.0, "reducer.efficiency: 0.0 is not in (0, 1]"),
        ("back_efficiency", 1.5, "reducer.back_efficiency: 1.5 is not in (0, 1]"),
        ("coulomb_friction_Nm", -0.1, "reducer.coulomb_friction_Nm: -0.1 is not >= 0"),
        ("viscous_friction_Nm_s_rad", -1.0, "reducer.viscous_friction_Nm_s_rad: -1.0 is not >= 0"),
    ],
)
def test_bad_reducer_values_are_one_line_errors(key, value, message):
    data = dict(
        model="r", ratio=100, efficiency=0.6, rated_torque_Nm=4, peak_torque_Nm=8,
        max_input_speed_rpm=3000,
    )  # fmt: skip
    data[key] = value
    with pytest.raises(armlab.RobotDescriptionError) as err:
        reducer_from_dict(data, "drives.toml joint 'j'", "reducer")
    assert str(err.value) == f"drives.toml joint 'j' {message}"
    assert "\n" not in str(err.value)


def test_supply_below_back_emf_at_rated_speed_is_an_error():
    data = dict(
        model="m", stall_torque_Nm=0.1, rated_speed_rpm=3000, current_A=1.0,
        torque_constant_Nm_A=0.05, back_emf_V_s_rad=0.05, resistance_ohm=1.0, inductance_H=1e-3,
        rotor_inertia_kg_m2=0.0, supply_voltage_V=12.0,
    )  # fmt: skip
    # Ke x 3000 rpm = 0.05 x 314.16 = 15.7 V > 12 V
    with pytest.raises(armlab.RobotDescriptionError, match=r"motor\.supply_voltage_V: 12 V"):
        motor_from_dict(data, "drives.toml joint 'j'", "motor")
    data["supply_voltage_V"] = 16.0
    assert motor_from_dict(data).supply_voltage_V == 16.0


def test_drives_file_with_a_negative_friction_names_joint_and_key(tmp_path):
    src = armlab.robot.model.robot_desc_dir() / "teachbot6"
    for f in src.iterdir():
        if f.is_file():
            shutil.copy(f, tmp_path / f.name)
    text = (tmp_path / "drives.toml").read_text()
    key = "\ncoulomb_friction_Nm = "
    if key in text:  # joint1's reducer is the first to list it
        start = text.index(key) + 1
        text = text[:start] + "coulomb_friction_Nm = -0.5" + text[text.index("\n", start) :]
    else:
        first = text.index("[joint.reducer]") + len("[joint.reducer]")
        text = text[:first] + "\ncoulomb_friction_Nm = -0.5" + text[first:]
    (tmp_path / "drives.toml").write_text(text)
    robot = armlab.load_robot("teachbot6")
    with pytest.raises(armlab.RobotDescriptionError) as err:
        read_drives(tmp_path / "drives.toml", robot.joint_names)
    assert "joint 'joint1'" in str(err.value)
    assert "reducer.coulomb_friction_Nm: -0.5 is not >= 0" in str(err.value)


# --------------------------------------------------------------------------- planning inside
def _independent_envelope(robot, traj, dt_s):
    """Peak |T_m| / envelope and RMS / rating per joint, per sample on a uniform grid: the
    drive-train model evaluated here, not through the planners' own check."""
    fine = traj.sample(dt_s)
    tau = armlab.robot.rigid_body.inverse_dynamics(robot, fine.q, fine.qd, fine.qdd)
    dt = dtm.drive_train(robot)
    t_m, _ = dtm.motor_torque(tau, fine.qd, fine.qdd, dt)
    w_m = fine.qd * dt.ratio
    line = dt.torque_constant_Nm_A * (dt.supply_voltage_V - dt.back_emf_V_s_rad * np.abs(w_m))
    env = dt.derating * np.minimum(dt.peak_torque_Nm, line / dt.resistance_ohm)
    w = np.full(fine.t.size, dt_s)
    w[[0, -1]] = dt_s / 2
    rms = np.sqrt((w[:, None] * t_m**2).sum(0) / w.sum())
    return (np.abs(t_m) / env).max(axis=0), rms / (dt.stall_torque_Nm * dt.derating)


@pytest.fixture(scope="module")
def heavy():
    return armlab.load_robot("teachbot6").with_payload(1.0)


# joint 3 travels far enough to reach its speed limit, where its motor has almost no torque left
MOVE = np.array([[0, -0.5, -0.6, 0, 0.3, 0], [0.3, 0.2, 0.9, 0.5, -0.5, 0.8]])


def test_optimal_with_drive_limits_stays_in_the_envelope(heavy):
    from armlab.planning import optimal

    box = optimal(heavy, MOVE, a_max=False, j_max=False, n_intervals=16)
    plan = optimal(heavy, MOVE, a_max=False, j_max=False, n_intervals=16, drive_limits=True)
    env_box, _ = _independent_envelope(heavy, box, box.duration / 4000)
    env, rms = _independent_envelope(heavy, plan, plan.duration / 4000)
    assert env_box.max() > 1.5  # the torque box plan breaks joint 3's envelope
    assert env.max() <= 1 + 1e-6 and rms.max() <= 1 + 1e-6
    assert plan.stats["drive_limits"] and plan.stats["ok"]
    assert np.max(plan.stats["drive_ratios"]["motor_envelope"]) > 0.99  # it binds
    # each joint moves monotonically (the direction the envelope rows assume)
    d = np.sign(MOVE[1] - MOVE[0])
    assert np.all(plan.qd * d >= -1e-9)


def test_topp_with_drive_limits_stays_in_the_envelope(heavy):
    from armlab.planning.topp import time_optimal_path

    plan = time_optimal_path(heavy, MOVE, a_max=False, j_max=False, n_grid=40, drive_limits=True)
    env, rms = _independent_envelope(heavy, plan, plan.duration / 4000)
    assert env.max() <= 1 + 1e-6 and rms.max() <= 1 + 1e-6
    assert np.max(plan.stats["drive_ratios"]["motor_envelope"]) > 0.99


def test_planned_motion_keeps_the_amplifiers_peak_current(heavy):
    """An amplifier whose peak current is below the motor's peak torque caps the drive: the
    drive-limited plan keeps ``|T_m| <= Kt I_peak`` (the current, computed here from the
    amplifier's data), where the plan without the amplifier goes above it."""
    import dataclasses

    from armlab.planning import optimal
    from armlab.robot.drives import Amplifier

    d2 = heavy.drives["joint2"]
    i_peak = 0.6  # [A]: Kt I = 0.09 N m; the plan without it needs 0.87 A (0.13 N m)
    amp = Amplifier("test amp", 0.6, i_peak, bus_voltage_V=d2.supply_voltage_V)  # same line
    capped = heavy.with_payload(1.0)
    capped.drives = {**heavy.drives, "joint2": dataclasses.replace(d2, amplifier=amp)}
    kt = d2.motor.torque_constant_Nm_A
    assert capped.drives["joint2"].peak_motor_torque_Nm == pytest.approx(kt * i_peak)
    assert capped.drives["joint2"].current_limit_A == pytest.approx(i_peak)

    def peak_current(robot, traj):
        fine = traj.sample(traj.duration / 4000)
        tau = armlab.robot.rigid_body.inverse_dynamics(robot, fine.q, fine.qd, fine.qdd)
        t_m, _ = dtm.motor_torque(tau, fine.qd, fine.qdd, dtm.drive_train(robot))
        return np.abs(t_m[:, 1]).max() / kt

    free = optimal(heavy, MOVE, a_max=False, j_max=False, n_intervals=16, drive_limits=True)
    plan = optimal(capped, MOVE, a_max=False, j_max=False, n_intervals=16, drive_limits=True)
    assert peak_current(heavy, free) > 1.2 * i_peak  # without the amplifier it needs more
    assert peak_current(capped, plan) <= i_peak * (1 + 1e-6)
    assert plan.duration > free.duration and plan.stats["ok"]


def test_drive_limits_bad_input(heavy):
    from armlab.planning import optimal
    from armlab.study.spec import parse_study

    with pytest.raises(armlab.InputError, match="drive_limits must be true or false"):
        optimal(heavy, MOVE, drive_limits="yes")
    doc = {
        "robot": {"name": "teachbot6"},
        "waypoints": {"joint": MOVE.tolist()},
        "plan": {"planner": "ptp", "drive_limits": True},
    }
    with pytest.raises(armlab.SpecError) as err:
        parse_study(doc)
    assert str(err.value).startswith("plan.drive_limits")


def test_drive_check_from_the_limit_samples_is_the_fine_grid_check(heavy):
    """The drive check reads its RMS grid out of the limit samples (one motor-torque pass):
    the same numbers as the fine grid sampled and evaluated on its own (an independent
    computation here), and the peaks over the limit samples, which hold the grid."""
    from armlab.planning.timescale import drive_check
    from cases import cosine_motion

    traj = cosine_motion(heavy, duration_s=4.0, n=41)
    train = dtm.drive_train(heavy)
    dt_s = traj.duration / 500
    smp = traj.limit_samples(dt_s, robot=heavy)
    got = drive_check(traj, heavy, train, dt_s, smp)
    again = drive_check(traj, heavy, train, dt_s)  # samples computed inside
    fine = traj.sample(dt_s)
    tau = armlab.robot.rigid_body.inverse_dynamics(heavy, fine.q, fine.qd, fine.qdd)
    t_m, _ = dtm.motor_torque(tau, fine.qd, fine.qdd, train)
    w = np.zeros(fine.t.size)  # trapezoidal: half of each neighbouring step
    w[:-1] += np.diff(fine.t) / 2
    w[1:] += np.diff(fine.t) / 2
    rms = np.sqrt((w[:, None] * t_m**2).sum(0) / w.sum()) / train.continuous_motor_torque_Nm
    np.testing.assert_allclose(got["motor_rms"], rms, rtol=1e-12)
    grid_env = dtm.envelope_ratio(t_m, fine.qd * train.ratio, train).max(axis=0)
    assert np.all(got["motor_envelope"] >= grid_env)  # the grid is among the samples
    smp_env = dtm.envelope_ratio(
        dtm.motor_torque(smp.tau, smp.qd, smp.qdd, train)[0], smp.qd * train.ratio, train
    ).max(axis=0)
    np.testing.assert_allclose(got["motor_envelope"], smp_env, rtol=1e-15)
    for kind in got:
        np.testing.assert_allclose(again[kind], got[kind], rtol=1e-15)
