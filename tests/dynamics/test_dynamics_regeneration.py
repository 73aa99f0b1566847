"""The amplifier in the drive data: current limits, four-quadrant envelope, braking energy
against the bus capacitor and the brake resistor (hand calculations)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from armlab.dynamics.checks import SizingOptions, checks_for_column, evaluate_checks
from armlab.dynamics.regeneration import regeneration
from armlab.errors import RobotDescriptionError
from armlab.robot import load_profile
from armlab.robot.catalogue import load_catalogue
from armlab.robot.drives import Amplifier, Drive, Encoder, Motor, Reducer
from armlab.robot.drives_file import drives_toml, read_drives
from armlab.robot.drivetrain import DriveTrain

AMP = Amplifier(
    "test amp",
    continuous_current_A=0.15,
    peak_current_A=0.5,
    bus_voltage_V=48.0,
    regenerates=True,
    bus_capacitance_F=1e-3,
    brake_threshold_V=56.0,
)


def _drive(amplifier=None, **motor_kw) -> Drive:
    m = dict(
        model="m",
        stall_torque_Nm=0.1,
        rated_speed_rpm=3000,
        current_A=2.0,
        torque_constant_Nm_A=0.05,
        back_emf_V_s_rad=0.05,
        resistance_ohm=1.0,
        inductance_H=1e-3,
        rotor_inertia_kg_m2=0.0,
        peak_torque_Nm=1.0,
    )
    m.update(motor_kw)
    r = Reducer("r", 100, 0.5, 4.0, 8.0, 6000)
    return Drive("j", Motor(**m), r, Encoder(1000, 4), 1.0, 10.0, amplifier=amplifier)


def _checks(drive, tau, qd, w):
    train = DriveTrain.from_drives([drive])
    tau, qd = np.asarray(tau, float), np.asarray(qd, float)
    res = evaluate_checks(
        tau, qd, np.zeros_like(tau), w, train, np.array([0.5]), SizingOptions(load_profile())
    )
    return res, {c.name: c for c in checks_for_column(res, 0, drives=train)}


def test_braking_energy_by_hand():
    # a back-driven joint at constant speed: tau = -2 N m at qd = 1 rad/s for 10 s
    # motor side (back-driven beyond the quadrant band, eta_b = eta = 0.5): T_m = -2 x 0.5 / 100
    # = -0.01 N m at w_m = 100 rad/s: 1 W in, copper (0.01 / 0.05)^2 x 1 ohm = 0.04 W,
    # 0.96 W returned, 9.6 J over 10 s (two samples of 5 s each)
    res, checks = _checks(_drive(AMP), [[-2.0], [-2.0]], [[1.0], [1.0]], np.array([5.0, 5.0]))
    cap = checks["bus_capacitor_energy"]
    assert cap.value == pytest.approx(9.6, rel=1e-9)
    # the capacitor from 48 V to 56 V: 1e-3 (56^2 - 48^2) / 2 = 0.416 J
    assert cap.limit == pytest.approx(0.416, rel=1e-12) and not cap.ok
    # with a 10 ohm / 2 W brake resistor: the excess (9.6 - 0.416) J over 10 s, and the peak
    # 0.96 W against 56^2 / 10 = 313.6 W
    amp = Amplifier(**{**vars(AMP), "brake_resistor_ohm": 10.0, "brake_resistor_power_W": 2.0})
    _, checks = _checks(_drive(amp), [[-2.0], [-2.0]], [[1.0], [1.0]], np.array([5.0, 5.0]))
    assert "bus_capacitor_energy" not in checks  # the resistor takes the excess
    assert checks["brake_resistor_power"].value == pytest.approx((9.6 - 0.416) / 10.0)
    assert checks["brake_resistor_power"].ok
    assert checks["brake_resistor_peak_power"].value == pytest.approx(0.96)
    assert checks["brake_resistor_peak_power"].limit == pytest.approx(313.6)


def test_braking_ramp_energy_closed_form():
    # a motor braking with constant torque T from w0 to rest in t: P_reg = T w - P_cu while
    # positive, w linear: E = T (w0 - w_c)^2 t / (2 w0), w_c = P_cu / T
    T, w0, t, kt, R = 0.2, 300.0, 0.5, 0.05, 1.0
    n = 20001
    tt = np.linspace(0.0, t, n)
    w = w0 * (1 - tt / t)
    weights = np.full(n, t / (n - 1))
    weights[[0, -1]] *= 0.5
    reg, stretches = regeneration(np.full((n, 1), -T), w[:, None], weights, [R], [kt])
    p_cu = (T / kt) ** 2 * R
    w_c = p_cu / T
    expected = T * (w0 - w_c) ** 2 * t / (2 * w0)
    assert reg.energy_J[0] == pytest.approx(expected, rel=1e-4)
    assert len(stretches[0]) == 1 and reg.largest_stretch_J[0] == pytest.approx(expected, rel=1e-4)
    assert reg.peak_power_W[0] == pytest.approx(T * w0 - p_cu)


def test_amplifier_currents_and_four_quadrant_envelope():
    d = _drive(AMP, resistance_ohm=10.0)
    # the current limit: peak torque / Kt = 20 A, U / R = 4.8 A, the amplifier's 0.5 A
    assert d.current_limit_A == pytest.approx(0.5)
    assert _drive(None, resistance_ohm=10.0).current_limit_A == pytest.approx(2.4)  # 24 V / 10
    # motoring 2 N m at 1 rad/s: T_m = 2 / (100 x 0.5) = 0.04 N m, 0.8 A > 0.5 A peak, and
    # RMS 0.8 A > 0.15 A continuous
    _, checks = _checks(d, [[2.0]], [[1.0]], np.ones(1))
    assert checks["amplifier_peak_current"].value == pytest.approx(0.8)
    assert not checks["amplifier_peak_current"].ok
    assert checks["amplifier_continuous_current"].limit == pytest.approx(0.15)
    # the envelope holds the amplifier's current: Kt I_peak = 0.05 x 0.5 = 0.025 N m at any
    # speed where the voltage line allows more (here braking at 300 rad/s)
    assert d.peak_motor_torque_Nm == pytest.approx(0.025)
    _, checks = _checks(d, [[-2.0]], [[3.0]], np.ones(1))
    assert checks["motor_envelope"].limit == pytest.approx(0.025)
    # with a 20 A amplifier (Kt I = 1 N m, the motor's own peak), braking at 300 rad/s (qd 3):
    # four-quadrant line Kt (U + Ke w) / R = 0.05 (48 + 15) / 10 = 0.315 N m; without
    # regeneration the two-quadrant 0.05 (48 - 15) / 10 = 0.165 N m
    big = {**vars(AMP), "peak_current_A": 20.0}
    d = _drive(Amplifier(**big), resistance_ohm=10.0)
    _, checks = _checks(d, [[-2.0]], [[3.0]], np.ones(1))
    assert checks["motor_envelope"].limit == pytest.approx(0.315)
    two_q = _drive(Amplifier(**{**big, "regenerates": False}), resistance_ohm=10.0)
    _, checks = _checks(two_q, [[-2.0]], [[3.0]], np.ones(1))
    assert checks["motor_envelope"].limit == pytest.approx(0.165)
    assert "bus_capacitor_energy" not in checks  # no regeneration: nothing to size


def test_catalogue_amplifiers_hold_the_makers_bus_energy():
    cat = load_catalogue()
    akd = cat.amplifier("Kollmorgen AKD-x00306 (230 V)")
    # Kollmorgen's table: the AKD-x00306's 940 uF store 20 Ws at 3 x 230 V mains
    assert akd.bus_energy_J == pytest.approx(20.0, abs=0.1)
    assert cat.amplifier("Kollmorgen AKD-x01206 (230 V)").bus_energy_J == pytest.approx(55, abs=0.5)
    escon = cat.amplifier("maxon ESCON Module 50/5")
    assert escon.peak_current_A == 15.0 and escon.regenerates
    # the ESCON has no bus capacitor: the check says so and names the data sheet
    _, checks = _checks(_drive(escon), [[-2.0], [-2.0]], [[1.0], [1.0]], np.array([5.0, 5.0]))
    c = checks["bus_capacitor_energy"]
    assert not c.checked and c.note.startswith("not checked") and "ESCON" in c.note
    assert c.to_dict()["ok"] is None and "not checked" in c.describe()


DRIVES = """
version = 1
[[joint]]
name = "j1"
{amp}
[joint.motor]
model = "m"
stall_torque_Nm = 0.1
rated_speed_rpm = 3000
current_A = 2.0
torque_constant_Nm_A = 0.05
back_emf_V_s_rad = 0.05
resistance_ohm = 1.0
inductance_H = 0.001
rotor_inertia_kg_m2 = 1e-6
[joint.reducer]
model = "r"
ratio = 100
efficiency = 0.5
rated_torque_Nm = 4
peak_torque_Nm = 8
max_input_speed_rpm = 6000
[joint.encoder]
pulses_per_rev = 1000
"""


def test_drives_file_names_an_amplifier(tmp_path):
    p = tmp_path / "drives.toml"
    p.write_text(DRIVES.format(amp='amplifier = "maxon ESCON Module 50/5"'))
    d = read_drives(p, ["j1"])["j1"]
    assert d.amplifier is not None and d.supply_voltage_V == 48.0
    # inline, and the round trip through drives_toml
    table = "[joint.amplifier]\nmodel = 'a'\ncontinuous_current_A = 1\npeak_current_A = 3\n"
    table += "bus_voltage_V = 24\nregenerates = true\nbus_capacitance_F = 0.001\n"
    p.write_text(DRIVES.format(amp="") + table)
    d = read_drives(p, ["j1"])["j1"]
    assert d.amplifier is not None and d.amplifier.regenerates
    # the motor's peak (its stall torque: no peak rating) 0.1 / 0.05 = 2 A binds, not the 3 A
    assert d.current_limit_A == pytest.approx(2.0) and d.supply_voltage_V == 24
    p.write_text(drives_toml({"j1": d}))
    assert read_drives(p, ["j1"])["j1"] == d
    # bad values: one line naming the key
    p.write_text(
        DRIVES.format(amp="") + table.replace("peak_current_A = 3", "peak_current_A = 0.5")
    )
    with pytest.raises(RobotDescriptionError, match=r"amplifier\.peak_current_A: 0.5 A is below"):
        read_drives(p, ["j1"])
    p.write_text(DRIVES.format(amp='amplifier = "no such amp"'))
    with pytest.raises(RobotDescriptionError, match="no amplifier 'no such amp'"):
        read_drives(p, ["j1"])
    assert math.isnan(Amplifier("x", 1, 2, 24).bus_energy_J)
