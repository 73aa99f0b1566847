"""The two-body thermal model (armlab.dynamics.thermal) against hand calculations."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from armlab.dynamics import thermal
from armlab.dynamics.thermal import ThermalModel, winding_temperature, with_dwell
from armlab.errors import InputError
from armlab.trajectory import Trajectory

# a maxon-like motor (numbers of the order of an EC-i 40's data sheet; the test needs no source:
# the oracle is the closed form below)
R1, R2, TAU_W, TAU_M, T_MAX = 2.0, 6.0, 20.0, 900.0, 155.0
R25, KT = 1.0, 0.05


def _model(n=1, **kw) -> ThermalModel:
    vals = dict(
        r_wh_K_W=R1,
        r_ha_K_W=R2,
        tau_w_s=TAU_W,
        tau_m_s=TAU_M,
        max_winding_degC=T_MAX,
        resistance_ohm=R25,
        torque_constant_Nm_A=KT,
    )
    vals.update(kw)
    return ThermalModel(**{k: np.full(n, float(v)) for k, v in vals.items()})


def _constant(torque_Nm, duration_s, n=601):
    w = np.full(n, duration_s / (n - 1))
    w[0] = w[-1] = 0.5 * duration_s / (n - 1)
    return np.full((n, 1), torque_Nm), w


def _step_oracle(P, t):
    """Winding rise of the two-body model at time t for a constant loss P from ambient: the
    closed form of the two-time-constant system (eigenvalues of the 2x2 system matrix from the
    quadratic formula; coefficients from x_w(0) = 0 and x_w'(0) = P / C_w)."""
    c_w, c_h = TAU_W / R1, TAU_M / R2
    a11, a12, a21, a22 = -1 / (R1 * c_w), 1 / (R1 * c_w), 1 / (R1 * c_h), -(1 / R1 + 1 / R2) / c_h
    tr, det = a11 + a22, a11 * a22 - a12 * a21
    l1 = 0.5 * (tr + math.sqrt(tr * tr - 4 * det))
    l2 = 0.5 * (tr - math.sqrt(tr * tr - 4 * det))
    S = P * (R1 + R2)  # steady rise
    A1 = (P / c_w + l2 * S) / (l1 - l2)
    A2 = -S - A1
    return S + A1 * math.exp(l1 * t) + A2 * math.exp(l2 * t)


@pytest.mark.parametrize("duration_s", [5.0, 60.0, 600.0])
def test_step_response_matches_the_closed_form(monkeypatch, duration_s):
    monkeypatch.setattr(thermal, "ALPHA_CU_PER_K", 0.0)  # a constant loss: the oracle's case
    torque, w = _constant(0.2, duration_s)
    res = winding_temperature(torque, w, _model(), ambient_degC=25.0, cycles=1)
    P = (0.2 / KT) ** 2 * R25  # 16 W
    expected = 25.0 + _step_oracle(P, duration_s)
    assert res.peak_winding_degC[0] == pytest.approx(expected, abs=2e-3)


def test_periodic_state_of_a_constant_current_is_the_hot_steady_state():
    # hand calculation with the copper resistance rising: x = I^2 R25 (1 + a (Ta + x - 25)) Rth
    I, Ta = 0.2 / KT, 40.0
    a, Rth = thermal.ALPHA_CU_PER_K, R1 + R2
    rise = I**2 * R25 * (1 + a * (Ta - 25.0)) * Rth / (1 - I**2 * R25 * a * Rth)
    torque, w = _constant(0.2, 2.0, n=21)
    res = winding_temperature(torque, w, _model(), ambient_degC=Ta)
    assert res.peak_winding_degC[0] == pytest.approx(Ta + rise, abs=1e-6)
    assert res.end_housing_degC[0] == pytest.approx(Ta + rise * R2 / Rth, abs=1e-6)


def test_fast_cycle_periodic_peak_is_the_rms_loss(monkeypatch):
    # a cycle far shorter than the time constants: the winding sits at the mean loss x Rth
    monkeypatch.setattr(thermal, "ALPHA_CU_PER_K", 0.0)
    n = 400
    torque = np.where(np.arange(n) < n // 4, 0.4, 0.0)[:, None]
    w = np.full(n, 0.5 / n)
    res = winding_temperature(torque, w, _model(), ambient_degC=25.0)
    p_mean = 0.25 * (0.4 / KT) ** 2 * R25
    # ripple bounded by the winding's share of a half-cycle's heat: P_peak dt / C_w
    ripple = (0.4 / KT) ** 2 * R25 * 0.125 / (TAU_W / R1)
    assert 25.0 + p_mean * (R1 + R2) <= res.peak_winding_degC[0] <= 25 + p_mean * 8 + ripple


def test_runaway_and_no_data():
    # I^2 R a Rth >= 1: the copper loss outgrows what the motor sheds
    I = 1.05 / math.sqrt(R25 * thermal.ALPHA_CU_PER_K * (R1 + R2))
    torque, w = _constant(I * KT, 1.0, n=11)
    m = _model(n=2)
    m = ThermalModel(**{**vars(m), "r_wh_K_W": np.array([R1, np.nan])})
    res = winding_temperature(np.hstack([torque, torque]), w, m)
    assert math.isinf(res.peak_winding_degC[0]) and math.isnan(res.peak_winding_degC[1])


def test_dwell_is_a_rest_at_the_last_pose():
    q = np.array([[0.0, 0.1], [0.2, 0.3]])
    tr = Trajectory([0.0, 1.0], q, np.ones_like(q), np.zeros_like(q))
    assert with_dwell([tr], 0.0) == [tr]
    out = with_dwell([tr], 2.5)
    hold = out[-1]
    assert len(out) == 2 and hold.duration == pytest.approx(2.5)
    assert np.allclose(hold.q, q[-1]) and not hold.qd.any() and not hold.qdd.any()
    # after the motion, before a selection's single-sample holds
    held = Trajectory([0.0], q[:1] + 1.0, np.zeros((1, 2)), np.zeros((1, 2)))
    out = with_dwell([tr, held], 1.0)
    assert [x.n_samples for x in out] == [2, 2, 1] and np.allclose(out[1].q, q[-1])
    with pytest.raises(InputError, match="sizing.dwell_s"):
        with_dwell([tr], -1.0)


def _catalogue_text(parts) -> str:
    lines = ['currency = "EUR"']
    for kind, part in parts:
        lines.append(f"[[{kind}]]")
        for k, v in dataclasses.asdict(part).items():
            if not (isinstance(v, float) and math.isnan(v)):
                lines.append(f"{k} = {json.dumps(v)}")
    return "\n".join(lines) + "\n"


def test_selection_skips_a_motor_that_overheats(tmp_path, teachbot6):
    # two copies of joint 2's motor: the lighter one sheds its heat 50 x worse (housing to
    # ambient); holding the upper arm 40 deg from upright, the selection must take the heavier
    # one, every other check being the same for both
    from armlab.dynamics import select_drives

    d = teachbot6.drives["joint2"]
    r_ha = d.motor.thermal_resistance_housing_ambient_K_W
    hot = dataclasses.replace(
        d.motor, model="hot", thermal_resistance_housing_ambient_K_W=50 * r_ha, mass_kg=0.5
    )
    hot = dataclasses.replace(hot, price=1.0)
    cool = dataclasses.replace(d.motor, model="cool", mass_kg=1.0, price=1.0)
    red = dataclasses.replace(d.reducer, mass_kg=0.5, price=1.0)
    cat = tmp_path / "cat.toml"
    cat.write_text(_catalogue_text([("motor", hot), ("motor", cool), ("reducer", red)]))
    q = np.radians([[0.0, 40.0, 0.0, 0.0, 0.0, 0.0]] * 2)
    hold = Trajectory([0.0, 10.0], q, np.zeros_like(q), np.zeros_like(q))
    sel = select_drives(teachbot6, hold, cat, controller="reference_dda")
    js = sel.joint("joint2")
    assert js.chosen is not None and js.chosen.motor.model == "cool", js.why_none()
    winding = {c.name: c for c in js.chosen.checks}["winding_temperature_rise"]
    assert winding.ok and winding.value > 0.5  # it heats, within its limit
    assert js.n_passing == 1 and js.n_candidates == 2  # the hot copy fails (only) the heat


def test_a_motor_without_thermal_data_is_not_checked(teachbot6):
    from armlab.dynamics.checks import SizingOptions, binding, checks_for_column, evaluate_checks
    from armlab.robot import load_profile
    from armlab.robot.drivetrain import DriveTrain

    d = teachbot6.drives["joint2"]
    bare = dataclasses.replace(
        d,
        motor=dataclasses.replace(
            d.motor, max_winding_temperature_degC=math.nan, source="data sheet X p. 3"
        ),
    )
    train = DriveTrain.from_drives([d, bare])
    tau = np.array([[5.0, 5.0], [5.0, 5.0]])
    res = evaluate_checks(
        tau,
        np.zeros_like(tau),
        np.zeros_like(tau),
        np.ones(2),
        train,
        np.array([0.5, 0.5]),
        SizingOptions(load_profile()),
    )
    made, missing = ({c.name: c for c in checks_for_column(res, k, drives=train)} for k in (0, 1))
    assert made["winding_temperature_rise"].checked and made["winding_temperature_rise"].ok
    c = missing["winding_temperature_rise"]
    assert not c.checked and c.note == "not checked: no thermal data (data sheet X p. 3)"
    assert c.to_dict()["ok"] is None and c.describe().endswith("(data sheet X p. 3)")
    assert binding(list(missing.values())).name != "winding_temperature_rise"


def test_cycles_from_ambient_approach_the_periodic_state():
    # a 2 s cycle (0.3 N m for a quarter of it), repeated: the slow mode's time constant is
    # about tau_m (R1 + R2) / R2 = 1200 s, lengthened to ~1700 s by the copper's resistance
    # rising (mean I^2 R25 alpha Rth = 0.28); after 20 000 cycles (40 000 s) the state is
    # periodic to e^-23 of the rise
    n = 40
    torque = np.where(np.arange(n) < n // 4, 0.3, 0.0)[:, None]
    w = np.full(n, 2.0 / n)
    periodic = winding_temperature(torque, w, _model()).peak_winding_degC[0]
    one = winding_temperature(torque, w, _model(), cycles=1).peak_winding_degC[0]
    many = winding_temperature(torque, w, _model(), cycles=20000).peak_winding_degC[0]
    assert 25.0 < one < many and many == pytest.approx(periodic, abs=1e-3)
