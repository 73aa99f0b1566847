"""The compliant joint (issue 28): the reducer's stiffness curve, the two-mass plant's
resonances against their closed forms, and a tuning that keeps its margins on it.

Independent references: Harmonic Drive's worked torsion-angle example (engineering data, size 32:
T1 29 N m, T2 108 N m, K1 6.7e4, K2 1.1e5, K3 1.2e5 N m/rad; 60 N m winds up 7.15e-4 rad =
2.5 arcmin) and the two-mass closed forms ``sqrt(K/J_L)``, ``sqrt(K (J_M + J_L)/(J_M J_L))``.
"""

from __future__ import annotations

import math
from dataclasses import replace

import control as ct
import numpy as np
import pytest

from armlab.control.plant import inertia_range, joint_plant
from armlab.robot.drives import Reducer

HD32 = Reducer(
    "CSF-32 (worked example)",
    100,
    0.8,
    137,
    333,
    4500,
    stiffness_Nm_rad=(6.7e4, 1.1e5, 1.2e5),
    stiffness_torque_Nm=(29.0, 108.0),
)


def test_windup_matches_the_makers_worked_example():
    # phi = T1/K1 + (T - T1)/K2 = 29/6.7e4 + 31/1.1e5 = 7.15e-4 rad = 2.5 arcmin
    assert HD32.windup_rad(60.0) == pytest.approx(7.15e-4, abs=0.01e-4)
    assert math.degrees(HD32.windup_rad(60.0)) * 60 == pytest.approx(2.5, abs=0.05)
    # odd, and the spring torque is its inverse on every segment
    T = np.array([-200.0, -60.0, -10.0, 0.0, 5.0, 29.0, 100.0, 150.0])
    assert np.allclose(HD32.windup_rad(-T), -HD32.windup_rad(T))
    assert np.allclose(HD32.spring_torque_Nm(HD32.windup_rad(T)), T, rtol=1e-12, atol=1e-9)
    # tangent stiffness by segment
    assert list(HD32.torsional_stiffness_Nm_rad(np.array([10.0, 60.0, 150.0]))) == [
        6.7e4,
        1.1e5,
        1.2e5,
    ]


@pytest.fixture(scope="module")
def plant(teachbot6):
    rng = inertia_range(teachbot6, n_samples=50, seed=0)
    return replace(joint_plant(teachbot6, "joint1", inertias=rng), compliant=True)


def test_two_mass_plant_resonances_match_the_closed_forms(plant):
    d = plant.drive
    assert plant.two_mass
    N = d.reducer.ratio
    K = 1.0e4  # joint 1 K1, N m/rad at the output (drives.toml, ESTIMATED)
    J_M = d.motor_side_inertia_kg_m2 * N**2  # motor side at the joint
    apart = 0
    for case in ("min", "nominal", "max"):
        J = plant.J_motor(case)
        J_L = (J - d.motor_side_inertia_kg_m2) * N**2  # arm at the joint
        anti, first = math.sqrt(K / J_L), math.sqrt(K * (J_M + J_L) / (J_M * J_L))
        A, B, C, D = plant.mechanics_ss(J)
        sys = ct.ss(A, B, C, D)
        poles = np.abs(sys.poles())
        zeros = np.abs(sys.zeros())
        # the resonance pole pair and the anti-resonance zero pair (motor viscous friction
        # 1e-6 N m s/rad moves them by far less than the tolerance)
        assert np.max(poles) == pytest.approx(first, rel=1e-3)
        assert np.max(zeros) == pytest.approx(anti, rel=1e-3)
        # the drive's own answers (what the summary reports)
        r = plant.resonances_rad_s()
        assert r["first"][case] == pytest.approx(first, rel=1e-9)
        assert r["anti"][case] == pytest.approx(anti, rel=1e-9)
        # the frequency response: a notch at the anti-resonance, a peak at the resonance
        # (where they are apart: a light arm on a heavy rotor nearly cancels them)
        if first < 1.2 * anti:
            continue
        apart += 1
        w = np.array([anti, first])
        mag = np.abs(plant.mechanics_response(w, [J])[0])
        rigid = np.abs(plant.Kt / (1j * w * J))
        assert mag[0] < 0.5 * rigid[0] and mag[1] > 2.0 * rigid[1]
    assert apart >= 1  # joint 1 at its largest arm inertia: 58 and 160 rad/s


def test_rigid_plant_is_unchanged(plant):
    rigid = replace(plant, compliant=False)
    w = np.geomspace(1.0, 1e4, 50)
    J = rigid.J_motor("max")
    assert np.allclose(rigid.mechanics_response(w, [J])[0], rigid.Kt / (1j * w * J + rigid.B))


def test_compliant_tuning_keeps_its_margins_on_the_two_mass_plant(teachbot6):
    from armlab.control import tune_cascade
    from armlab.control.loops import CascadeModel

    g = tune_cascade(teachbot6, "joint2", n_inertia_samples=50, compliant=True)
    assert g.plant.compliant
    res = g.summary()["resonance"]
    assert res["compliant"] and res["first_rad_s"]["max"] < res["first_rad_s"]["min"]
    # recomputed here on the two-mass plant, every inertia case, continuous and discrete
    rng = inertia_range(teachbot6, n_samples=50, seed=0)
    p = replace(joint_plant(teachbot6, "joint2", inertias=rng), compliant=True)
    model = CascadeModel(p, g)
    for loop in ("speed", "position"):
        for discrete in (False, True):
            for m in model.margins(loop, discrete):
                assert m.phase_margin_deg >= 50.0 - 0.5 and m.gain_margin_dB >= 6.0 - 0.2


def test_compliant_hold_sags_by_the_windup_of_gravity(teachbot6, arm_gains):
    """Holding a pose, the motor encoder keeps the motor on the set-point: the link sags by the
    reducer's windup under its gravity torque (hand rule: q - q_d = -windup(g)), within the
    hysteresis element's half loop; the rigid joint holds the set-point."""
    from armlab.control import simulate_tracking
    from armlab.robot import rigid_body
    from armlab.trajectory import Trajectory

    pose = np.array([0.3, 0.6, -0.4, 0.2, 0.5, 0.0])
    t = np.array([0.0, 0.4])
    z = np.zeros((2, 6))
    hold = Trajectory(t, np.tile(pose, (2, 1)), z, z, joint_names=teachbot6.joint_names)
    ff = ("velocity", "acceleration", "gravity", "friction", "efficiency")
    opts = {"controller": "reference_dda", "feedforward": ff, "t_after_s": 0.0, "tcp": False}
    soft = simulate_tracking(teachbot6, hold, arm_gains, compliant=True, **opts)
    rigid = simulate_tracking(teachbot6, hold, arm_gains, **opts)
    assert soft.model["compliant"] and not rigid.model["compliant"]
    g = rigid_body.gravity_torques(teachbot6, pose)
    for j, name in enumerate(teachbot6.joint_names):
        red = teachbot6.drives[name].reducer
        err = soft.q[-1, j] - pose[j]
        if not red.stiffness_given:  # joint 6's planetary gearhead: rigid
            assert abs(err) < 1e-4
            continue
        half_loop = 0.5 * red.hysteresis_rad  # the element: +-K1 h/2 of torque, h/2 of windup
        sag = red.windup_rad(g[j])
        assert err == pytest.approx(-sag, abs=half_loop + 0.05 * abs(sag) + 1e-5)
        # the rigid joint holds the set-point far closer than the windup
        assert abs(rigid.q[-1, j] - pose[j]) < 0.2 * abs(sag) + 3e-5  # + an encoder count


@pytest.mark.parametrize(
    "bad, message",
    [
        ({"stiffness_Nm_rad": [1e4, 2e4]}, "reducer.stiffness_torque_Nm: 0 breakpoint(s) for 2"),
        (
            {"stiffness_Nm_rad": [1e4, -2e4], "stiffness_torque_Nm": [3.0]},
            "reducer.stiffness_Nm_rad: -20000.0 is not > 0",
        ),
        (
            {"stiffness_Nm_rad": [1e4, 2e4, 3e4], "stiffness_torque_Nm": [5.0, 3.0]},
            "reducer.stiffness_torque_Nm: [5.0, 3.0] is not increasing",
        ),
        ({"stiffness_Nm_rad": 1e4}, "reducer.stiffness_Nm_rad: 10000.0 is not a list"),
    ],
)
def test_bad_stiffness_is_one_line_naming_the_key(bad, message):
    from armlab.errors import RobotDescriptionError
    from armlab.robot.drives_file import reducer_from_dict

    data = {
        "model": "x",
        "ratio": 100,
        "efficiency": 0.8,
        "rated_torque_Nm": 10,
        "peak_torque_Nm": 20,
        "max_input_speed_rpm": 3000,
        **bad,
    }
    with pytest.raises(RobotDescriptionError) as err:
        reducer_from_dict(data, "drives.toml joint 'j'", "reducer")
    assert str(err.value).startswith(f"drives.toml joint 'j' {message}")
    assert "\n" not in str(err.value)
