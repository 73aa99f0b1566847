"""The tracking simulation behaves like the drive hardware (issue 14): the amplifier's supply
limits the voltage with the back-EMF, the reducer's efficiency and friction reach the joint
through the drive-train model, the controller profile sets the D/A and the servo period.

Every check compares the simulation with an independent computation: the armature equation
``U = R i + Ke w`` (HEU thesis ch. 5), the drive-train inverse
(:func:`armlab.robot.drivetrain.joint_torque_delivered`) with Pinocchio's RNEA, Pinocchio's
gravity torques, or the data-sheet values the motor constants come from.
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest

from armlab.control import simulate_tracking, tune_arm
from armlab.control.diagnosis import diagnose_tracking
from armlab.errors import InputError, RobotDescriptionError
from armlab.robot import drivetrain as dtm
from armlab.robot import rigid_body
from armlab.robot.controller import load_profile
from armlab.robot.drives import RPM_TO_RAD_S
from armlab.robot.drives_file import motor_from_dict, reducer_from_dict
from armlab.trajectory import Trajectory, ptp_sync

FF = ("velocity", "acceleration", "gravity")


@pytest.fixture(scope="module")
def gains(teachbot6):
    return tune_arm(teachbot6, n_inertia_samples=200, controller="reference_dda")


@pytest.fixture(scope="module")
def move(teachbot6):
    """A synchronised move of every joint at its speed and acceleration limits (2 s)."""
    q0 = np.array([0.0, -0.3, 0.4, 0.0, 0.5, 0.0])
    q1 = np.array([0.8, 0.2, -0.2, 0.9, -0.4, 1.2])
    return ptp_sync(teachbot6, q0, q1, "trapezoid", dt=1e-3)


@pytest.fixture(scope="module")
def full(teachbot6, move, gains):
    return simulate_tracking(
        teachbot6, move, gains, feedforward=FF, t_after_s=0.1, controller="reference_dda"
    )


def test_joint_torque_is_the_drive_train_inverse_of_the_motor_current(teachbot6, full):
    """Where the joints move, the rigid-body torque that produced the simulated acceleration
    (RNEA of q, qd and the acceleration read back from qd) equals what the drive-train model's
    inverse delivers from the simulated motor current: efficiency by quadrant, rotor inertia,
    motor and joint friction all accounted for, by an independent implementation."""
    dt = dtm.drive_train(teachbot6)
    T = full.sample_time_s
    q, v = full.q[:-1], full.qd[:-1]
    a = np.diff(full.qd, axis=0) / T
    tau_rb = rigid_body.inverse_dynamics(teachbot6, q, v, a)
    t_m = dt.torque_constant_Nm_A * full.current_A[:-1]
    delivered = dtm.joint_torque_delivered(t_m, v, a, dt)
    # the simulation picks the reducer's quadrant from the previous period's acceleration:
    # compare where that choice and the exact one agree, and where the joint really moves
    N, J = dt.ratio, dt.inertia_motor_side_kg_m2
    t_in = t_m - dt.viscous_Nm_s_rad * N * v
    a_prev = np.vstack([np.zeros((1, a.shape[1])), a[:-1]])
    same = ((t_in - J * N * a) * v >= 0) == ((t_in - J * N * a_prev) * v >= 0)
    # moving, beyond the quadrant band where the drive model passes through standstill
    moving = (np.abs(v) > 1e-2) & (np.abs(v) > dt.quadrant_band_rad_s)
    ok = same & moving
    assert ok.sum() > 0.5 * moving.sum() > 1000
    scale = np.abs(tau_rb).max(axis=0)
    err = np.abs(tau_rb - delivered)[ok] / np.broadcast_to(scale, tau_rb.shape)[ok]
    assert err.max() < 1e-6


def test_amplifier_voltage_stays_within_the_supply_and_obeys_the_armature_equation(
    teachbot6, move, gains, full
):
    U = np.array([teachbot6.drives[n].motor.supply_voltage_V for n in teachbot6.joint_names])
    assert np.array_equal(full.supply_voltage_V, U)
    assert np.all(np.abs(full.voltage_V) <= U + 1e-9)
    # the loops ask for more than the supply on some joint: that is where saturation is counted
    over = full.peak_voltage_demand_V > U
    assert over.any()
    assert np.all(full.saturation_time_s[over] > 0)
    assert np.all(full.saturation_time_s[~over] == 0)
    # armature equation U = R i + Ke w (HEU thesis ch. 5) over the periods where the current
    # hardly changes (over the two periods before and the one after: L di/dt ~ 0; one period
    # before is not enough: the first sample after a current swing still holds part of it,
    # 0.13 V on joint 1 once the GP22C inertia of joint 6 is at the input, issue 25): mean
    # voltage = R x mean current + back-EMF of the motor speed
    drives = [teachbot6.drives[n] for n in teachbot6.joint_names]
    R = np.array([d.motor.resistance_ohm for d in drives])
    Ke = np.array([d.motor.back_emf_V_s_rad for d in drives])
    N = np.array([d.reducer.ratio for d in drives])
    di = np.abs(np.diff(full.current_A, axis=0))
    steady = np.zeros(full.current_A.shape, bool)
    steady[2:-1] = (di[:-2] < 2e-3) & (di[1:-1] < 2e-3) & (di[2:] < 2e-3)
    resid = full.voltage_V - R * full.current_A - Ke * N * full.qd
    assert steady.sum() > 1000
    assert np.abs(resid[steady]).max() < 0.1  # V; the back-EMF alone is up to 16 V here
    assert (Ke * N * np.abs(full.qd)).max() > 10.0
    # without the limit the amplifier applies what the loops ask for, above the supply
    free = simulate_tracking(
        teachbot6,
        move,
        gains,
        feedforward=FF,
        t_after_s=0.1,
        voltage_limit=False,
        controller="reference_dda",
    )
    assert np.all(free.saturation_time_s == 0)
    assert (free.peak_voltage_demand_V > U).any()
    out = full.to_dict()
    j = teachbot6.joint_names[int(np.argmax(full.saturation_time_s))]
    assert out["joints"][j]["time_in_saturation_s"] > 0
    assert out["joints"][j]["peak_voltage_V"] <= out["joints"][j]["supply_voltage_V"] + 1e-9
    assert out["model"]["voltage_limit"] and out["model"]["losses"]


def test_lifting_costs_current_lowering_saves_it(teachbot6, gains):
    """Mid-cruise of a slow move (qdd = 0) joint 2 lifts the arm (motoring) and joint 3 lowers
    its load (back-driven). The current the cascade settles to is what the drive-train model
    says the motion needs (:func:`~armlab.robot.drivetrain.motor_torque` of the RNEA torque),
    1 / eta above the ideal ``tau / N`` when lifting and eta below it when lowering -- with
    only the ideal feed-forward, the loops find the difference themselves."""
    q0 = np.array([0.0, 1.2, -0.2, 0.0, 0.0, 0.0])
    q1 = np.array([0.0, 0.5, 0.6, 0.0, 0.0, 0.0])
    mv = ptp_sync(teachbot6, q0, q1, "trapezoid", dt=1e-3)
    res = simulate_tracking(
        teachbot6, mv, gains, feedforward=FF, t_after_s=0.0, tcp=False, controller="reference_dda"
    )
    dt = dtm.drive_train(teachbot6)
    k = np.abs(res.t - mv.duration / 2) < 0.05
    assert np.abs(mv.at(res.t[k])[2]).max() == 0.0  # cruising
    zero = np.zeros((int(k.sum()), 6))
    tau = rigid_body.inverse_dynamics(teachbot6, res.q[k], res.qd[k], zero)
    need, motoring = dtm.motor_torque(tau, res.qd[k], zero, dt)
    got = (dt.torque_constant_Nm_A * res.current_A[k]).mean(axis=0)
    ideal = (tau / dt.ratio).mean(axis=0)
    assert motoring[:, 1].all() and not motoring[:, 2].any()
    for j in (1, 2):
        assert got[j] == pytest.approx(need[:, j].mean(), rel=0.02)
    assert got[1] / ideal[1] == pytest.approx(1 / dt.efficiency[1], rel=0.03)
    assert got[2] / ideal[2] == pytest.approx(dt.back_efficiency[2], rel=0.03)


@pytest.mark.parametrize("feedforward", [("gravity",), ("gravity", "efficiency")])
def test_reducer_static_friction_holds_the_arm(teachbot6, gains, feedforward):
    """At rest the reducer transmits any torque in its band [eta N T, N T / eta_b]: both the
    ideal gravity feed-forward (N Kt i = g) and the one through the efficiency
    (eta N Kt i = g, the motoring quadrant of holding) keep the arm still."""
    q = np.array([0.3, -0.6, 0.9, 0.2, 0.7, 0.0])
    rest = Trajectory(np.array([0.0, 0.1]), np.vstack([q, q]), np.zeros((2, 6)), np.zeros((2, 6)))
    res = simulate_tracking(
        teachbot6,
        rest,
        gains,
        feedforward=feedforward,
        quantise=False,
        t_after_s=0.0,
        tcp=False,
        controller="reference_dda",
    )
    drives = [teachbot6.drives[n] for n in teachbot6.joint_names]
    NKt = np.array([d.reducer.ratio * d.motor.torque_constant_Nm_A for d in drives])
    eta = np.array([d.reducer.efficiency for d in drives])
    model = teachbot6.model
    g = pin.computeGeneralizedGravity(model, model.createData(), q)
    k = eta if "efficiency" in feedforward else 1.0
    assert np.abs(res.current_A * NKt * k - g).max() < 1e-6 * np.abs(g).max()
    assert np.abs(res.q - q).max() < 1e-9


def test_dac_resolution_and_servo_period_come_from_the_controller_profile(teachbot6, gains, move):
    coarse = load_profile(None).replace(dac_bits=8)
    short = move.sample(1e-3)
    res = simulate_tracking(teachbot6, short, gains, feedforward=FF, controller=coarse)
    lsb = 2 * coarse.dac_range_V / 2**8
    codes = res.da_V / lsb
    assert np.abs(codes - np.rint(codes)).max() < 1e-9
    assert res.model["dac_bits"] == 8 and res.model["controller_source"] == "given"
    with pytest.raises(InputError, match="servo_period_s"):
        simulate_tracking(
            teachbot6, short, gains, controller=load_profile(None).replace(servo_period_s=2e-3)
        )


def test_diagnosis_names_the_limiting_factor_and_measures_the_fix(teachbot6, gains, full, move):
    """A budget the full model misses: the diagnosis re-simulates without each effect and
    with the loss feed-forward, and its numbers are those re-simulations'."""
    tight = full.tcp_max_error_m * 0.5
    d = diagnose_tracking(
        teachbot6, move, gains, full, feedforward=FF, t_after_s=0.1, controller="reference_dda"
    )
    no_loss = simulate_tracking(
        teachbot6,
        move,
        gains,
        feedforward=FF,
        t_after_s=0.1,
        losses=False,
        controller="reference_dda",
    ).tcp_max_error_m
    assert d["tcp_max_error_m"]["no_losses"] == pytest.approx(no_loss, rel=1e-12)
    assert d["tcp_max_error_m"]["full"] == full.tcp_max_error_m
    gains_by = {
        "amplifier supply voltage": full.tcp_max_error_m - d["tcp_max_error_m"]["no_voltage_limit"],
        "reducer efficiency and friction": full.tcp_max_error_m - no_loss,
    }
    best = max(gains_by, key=gains_by.__getitem__)
    if gains_by[best] < 0.1 * full.tcp_max_error_m:  # neither effect matters on this move
        best = "the feedback itself"
    assert d["limiting_factor"].startswith(best)
    assert "feed-forward of friction and efficiency measured" in d["offer"]
    assert tight < d["tcp_max_error_m"]["full"]


# ---------------------------------------------------------------------------- motor data
def test_motor_constants_agree_with_the_data_sheet_values_they_come_from(teachbot6):
    """drives.toml's decision (README "Motor data"): the table speed is the no-load speed at
    the supply (U / Ke within +5 %), the table stall torque the continuous rating, below the
    stall torque the supply can force (Kt U / R, 1.0-3 x)."""
    for name in teachbot6.joint_names:
        m = teachbot6.drives[name].motor
        no_load = m.supply_voltage_V / m.back_emf_V_s_rad
        assert 1.0 < no_load / (m.rated_speed_rpm * RPM_TO_RAD_S) < 1.06, name
        peak = m.torque_constant_Nm_A * m.supply_voltage_V / m.resistance_ohm
        assert 1.0 <= peak / m.stall_torque_Nm < 3.0, name
        if name != "joint6":  # the LY motors' constants are estimated from table 4.3
            assert m.torque_constant_Nm_A == pytest.approx(m.stall_torque_Nm / m.current_A, 1e-4)
            assert m.resistance_ohm == pytest.approx(m.power_W / m.current_A**2, 1e-4)


_MOTOR = {
    "model": "36LYX04",
    "stall_torque_Nm": 0.0294,
    "rated_speed_rpm": 3300,
    "current_A": 1.65,
    "torque_constant_Nm_A": 0.0178182,
    "back_emf_V_s_rad": 0.0178182,
    "resistance_ohm": 1.42883,
    "inductance_H": 0.00142883,
    "rotor_inertia_kg_m2": 4.44401e-06,
    "supply_voltage_V": 6.2,
}
_REDUCER = {
    "model": "XB1 harmonic",
    "ratio": 80,
    "efficiency": 0.6,
    "rated_torque_Nm": 6.5,
    "peak_torque_Nm": 13,
    "max_input_speed_rpm": 3500,
}


@pytest.mark.parametrize(
    ("part", "key", "value"),
    [
        ("motor", "supply_voltage_V", 6.0),  # back-EMF at 3300 rpm is 6.16 V
        ("reducer", "efficiency", 1.2),
        ("reducer", "efficiency", 0.0),
        ("reducer", "coulomb_friction_Nm", -0.1),
    ],
)
def test_bad_drive_data_is_one_line_naming_the_key(part, key, value):
    data = dict(_MOTOR if part == "motor" else _REDUCER)
    data[key] = value
    build = motor_from_dict if part == "motor" else reducer_from_dict
    with pytest.raises(RobotDescriptionError, match=rf"{part}\.{key}") as exc:
        build(data, "drives.toml joint 'joint4'", part)
    assert "\n" not in str(exc.value)
    assert build(dict(_MOTOR if part == "motor" else _REDUCER), "x", part) is not None
    assert math.isfinite(value)


def test_linear_periods_are_the_sub_step_loop(teachbot6, gains, move, monkeypatch):
    """Servo periods without voltage saturation are jumped over with precomputed linear maps;
    the result is the amplifier's sub-step loop's (to round-off; without quantisation, whose
    floor() would let round-off flip an encoder count)."""
    import armlab.control.amplifier as amplifier

    kw = {"feedforward": FF, "quantise": False, "t_after_s": 0.0, "tcp": False}
    kw["controller"] = "reference_dda"
    fast = simulate_tracking(teachbot6, move, gains, **kw)
    monkeypatch.setattr(amplifier, "LINEAR_PERIODS", False)
    slow = simulate_tracking(teachbot6, move, gains, **kw)
    np.testing.assert_allclose(fast.q, slow.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fast.current_A, slow.current_A, rtol=0, atol=1e-9)
    np.testing.assert_allclose(fast.voltage_V, slow.voltage_V, rtol=0, atol=1e-8)
    np.testing.assert_array_equal(fast.saturated_share, slow.saturated_share)
    np.testing.assert_allclose(fast.peak_voltage_demand_V, slow.peak_voltage_demand_V, atol=1e-9)
    assert fast.saturation_time_s.sum() > 0  # both paths were taken


@pytest.mark.parametrize("linear", [True, False])
def test_variants_simulated_together_are_each_simulated_alone(
    teachbot6, gains, move, full, monkeypatch, linear
):
    """The drive-model variants run in one time loop (every operation element-wise over
    variant and joint; each variant jumps over its own linear sub-steps) and give, bit for
    bit, what each gives alone -- quantisation on, so one flipped encoder count would show."""
    import armlab.control.amplifier as amplifier
    import armlab.control.diagnosis as diag

    monkeypatch.setattr(amplifier, "LINEAR_PERIODS", linear)
    names = ("ideal", "no_voltage_limit", "no_losses", "with_loss_feedforward")
    opts = {"feedforward": FF, "t_after_s": 0.1, "controller": "reference_dda"}
    together = diag.tracking_variants(teachbot6, move, gains, names, **opts)
    assert set(together) == set(names)
    for name in names:
        kw = {**opts, **diag.DRIVE_VARIANTS[name]}
        if name == "with_loss_feedforward":
            kw["feedforward"] = (*FF, "friction", "efficiency")
        alone = simulate_tracking(teachbot6, move, gains, **kw)
        got = together[name]
        assert got.model == alone.model and got.feedforward == alone.feedforward
        for key in ("q", "qd", "current_A", "da_V", "voltage_V", "saturated_share"):
            np.testing.assert_array_equal(getattr(got, key), getattr(alone, key), err_msg=key)
        np.testing.assert_array_equal(got.peak_voltage_demand_V, alone.peak_voltage_demand_V)
    # the variants differ from each other and from the full model (the test can fail)
    assert together["ideal"].saturation_time_s.sum() == 0 < full.saturation_time_s.sum()
    assert not np.array_equal(together["no_losses"].q, full.q)


def test_study_verdict_names_the_limiting_factor_when_the_budget_fails():
    """The tracking stage judges the full model; a budget it misses fails the design with the
    limiting factor and the measured effect of the loss feed-forward in the failed check."""
    from armlab.study import load_study, run_spec

    spec = load_study(
        None,
        {
            "study.report": False,
            "study.stages": ["kinematics", "plan", "tuning", "tracking"],
            "plan.planner": "ptp",
            "waypoints.joint": [[0, 0, 0, 0, 0, 0], [20, 10, 15, 10, 20, 30]],
            "kinematics.workspace_samples": 0,
            "kinematics.accuracy_samples": 0,
            "control.n_inertia_samples": 20,
            "tracking.accuracy_m": 1e-6,
            # the thesis' feed-forward (the demo study adds the losses): the check offers them
            "tracking.feedforward": ["velocity", "acceleration", "gravity"],
        },
    )
    res = run_spec(spec, None)
    block = res.summary["tracking"]
    assert block["model"]["voltage_limit"] and block["model"]["losses"]
    assert block["model"]["controller"] == "reference_dda"
    assert block["verdict"] == "fail"
    diag = block["diagnosis"]
    assert diag["tcp_max_error_m"]["full"] == block["tcp"]["max_error_m"]
    (failed,) = [f for f in res.summary["design"]["failed_checks"] if f.startswith("tracking")]
    assert f"limiting factor: {diag['limiting_factor']}" in failed
    assert "feed-forward of friction and efficiency measured" in failed


def test_variant_loops_group_the_variants_by_the_supply_limit():
    """The variants :func:`tracking_variants` runs in one time loop: those with the supply
    limit, then those without; an empty group is left out."""
    import armlab.control.diagnosis as diag

    names = ("ideal", "no_voltage_limit", "no_losses", "with_loss_feedforward")
    assert diag.variant_loops(names) == [
        ("no_losses", "with_loss_feedforward"),
        ("ideal", "no_voltage_limit"),
    ]
    assert diag.variant_loops(("ideal",)) == [("ideal",)]
