"""armlab.control.loops: the cascade engine against the loops built with python-control
(``tests/oracles/cascade_pc.py``), on teachbot6's six joints and other plants.

Tolerances (relative unless said): open-loop responses 1e-8 (worst seen 1.8e-9, the discrete
speed loop near z = 1 where the encoder's difference cancels the angle's integrator), margins
and crossovers 1e-9 (seen 2e-14), settling time 1e-9, overshoot 1e-6 percentage points;
stability flags equal.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import armlab
from armlab.control import (
    CascadeModel,
    LoopGains,
    TuningSpec,
    check_cascade,
    inertia_range,
    joint_plant,
    tune_cascade,
)
from armlab.control.margins import freq_grid, margins
from armlab.control.plant import JointPlant
from armlab.control.robust import tune_loops
from armlab.errors import SpecError
from armlab.robot.drives import RPM_TO_RAD_S, Drive, Encoder, Motor, Reducer
from oracles.cascade_pc import Cascade, response, step_figures

LOOPS = ("current", "speed", "position")


def _rel(a: float, b: float) -> float:
    if math.isinf(a) or math.isinf(b) or math.isnan(a) or math.isnan(b):
        return 0.0 if (a == b or (math.isnan(a) and math.isnan(b))) else math.inf
    return abs(a - b) / max(abs(b), 1e-300)


def disagreements(plant: JointPlant, gains, n: int = 600) -> list[str]:
    """Every figure of every loop, continuous and discrete, at every inertia case, engine vs
    oracle; the ones outside the module's tolerances."""
    model = CascadeModel(plant, gains)
    loops = gains.loops() if hasattr(gains, "loops") else gains
    bad = []
    for loop in LOOPS:
        for disc in (False, True):
            w = freq_grid(loops[loop].sample_time_s if disc else None, n=n)
            ours = model.open_response(loop, w, disc)
            mg = model.margins(loop, disc, n=n)
            t_end = (12.0 if loop == "position" else 40.0) / mg[1].crossover_rad_s
            figs = model.step_figures(loop, disc, t_end)
            stable = model.stable(loop, disc)
            for i, case in enumerate(model.cases):
                where = f"{plant.joint} {loop} {'disc' if disc else 'cont'} {case}"
                oracle = Cascade(plant.at(case), gains)
                R = response(oracle.open_loop(loop, disc), w)
                if np.max(np.abs(ours[i] - R) / np.abs(R)) > 1e-8:
                    bad.append(f"{where}: response")
                ref = margins(w, R)
                for key in ("phase_margin_deg", "gain_margin_dB", "crossover_rad_s"):
                    if _rel(getattr(mg[i], key), getattr(ref, key)) > 1e-9:
                        bad.append(f"{where}: {key} {getattr(mg[i], key)} vs {getattr(ref, key)}")
                os_, ts = step_figures(oracle.closed_loop(loop, disc), t_end)
                if not abs(figs[i][0] - os_) <= 1e-6:
                    bad.append(f"{where}: overshoot {figs[i][0]} vs {os_}")
                if _rel(figs[i][1], ts) > 1e-9:
                    bad.append(f"{where}: settling {figs[i][1]} vs {ts}")
                if stable[i] != oracle.stable(loop, disc):
                    bad.append(f"{where}: stability")
    return bad


@pytest.mark.parametrize("joint", [f"joint{k}" for k in range(1, 7)])
def test_teachbot6_loops_are_python_controls(teachbot6, arm_gains, inertias, joint):
    plant = joint_plant(teachbot6, joint, inertias=inertias)
    assert disagreements(plant, arm_gains[joint]) == []


def _odd_gains(plant):
    """A cascade with terms the tuner never makes: PI position loop, filtered PID speed loop,
    two computation delays."""
    return {
        "current": LoopGains(
            "current", "PI", kp=4e3 * plant.L, ki=4e3 * plant.R, sample_time_s=5e-5
        ),
        "speed": LoopGains(
            "speed",
            "PID",
            kp=0.02,
            ki=0.4,
            kd=2e-6,
            derivative_filter_s=2e-4,
            sample_time_s=1e-3,
            delay_samples=2.0,
        ),
        "position": LoopGains("position", "PI", kp=20.0, ki=5.0, sample_time_s=1e-3),
    }


def thesis_plant() -> JointPlant:
    """The thesis' joint-6 motor (5.4.1: Ra 2.27 ohm, La 0.11 mH, Cm 5.9e-3 N m/A,
    Ce 0.62e-3 V/rpm, J 3.81e-7 kg m^2) on a 1:50 reducer driving a wide arm-inertia range;
    a 3 A current limit (peak torque 3 Kt, ASSUMED) and an 800 rad/s input limit (ASSUMED)."""
    motor = Motor(
        model="thesis joint 6",
        stall_torque_Nm=5.9e-3,
        rated_speed_rpm=3000.0,
        current_A=1.0,
        torque_constant_Nm_A=5.9e-3,
        back_emf_V_s_rad=0.62e-3 / RPM_TO_RAD_S,
        resistance_ohm=2.27,
        inductance_H=0.11e-3,
        rotor_inertia_kg_m2=3.81e-7,
        viscous_friction_Nm_s_rad=1e-7,
        supply_voltage_V=24.0,
        peak_torque_Nm=3.0 * 5.9e-3,
    )
    reducer = Reducer(
        model="1:50",
        ratio=50.0,
        efficiency=0.8,
        rated_torque_Nm=1.0,
        peak_torque_Nm=2.0,
        max_input_speed_rpm=800.0 / RPM_TO_RAD_S,
        inertia_kg_m2=1e-7,
    )
    drive = Drive("thesis", motor, reducer, Encoder(1000))
    plant = JointPlant.of_drive(drive, {"min": 2e-4, "nominal": 1e-3, "max": 4e-3})
    assert plant.current_limit_A == pytest.approx(3.0, rel=1e-12)
    assert plant.speed_limit_rad_s == pytest.approx(800.0, rel=1e-12)
    return plant


def test_other_plants_loops_are_python_controls(teachbot6):
    """A heavier payload (teachbot6 with 1.5 kg, joints 1 and 2), the thesis motor on a plant
    built by hand (tuned here), and an odd cascade the tuner would not produce."""
    heavy = armlab.load_robot("teachbot6", payload_kg=1.5)
    inertias = inertia_range(heavy, n_samples=60, seed=2)
    bad = []
    for joint in ("joint1", "joint2"):
        g = tune_cascade(heavy, joint, inertias=inertias)
        bad += disagreements(joint_plant(heavy, joint, inertias=inertias), g)
    plant = thesis_plant()
    cur, spd, pos = tune_loops(plant, TuningSpec(), 600)
    gains = {"current": cur, "speed": spd, "position": pos}
    bad += disagreements(plant, gains)
    odd = joint_plant(teachbot6, "joint2", inertias=inertia_range(teachbot6, n_samples=40))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # python-control on the double delay
        bad += disagreements(odd, _odd_gains(odd))
    assert bad == []


def test_systems_handed_over_are_the_engines(teachbot6, arm_gains, inertias):
    """``open_loop``/``closed_loop`` give python-control systems of the engine's own matrices:
    python-control's evaluation of them is the engine's response (rel 1e-9), and the closed
    loop is ``L / (1 + L)``."""
    plant = joint_plant(teachbot6, "joint3", inertias=inertias)
    model = CascadeModel(plant, arm_gains["joint3"])
    for loop in LOOPS:
        for disc in (False, True):
            dt = arm_gains["joint3"].loops()[loop].sample_time_s if disc else None
            w = freq_grid(dt, n=25)
            x = np.exp(1j * w * dt) if disc else 1j * w
            L = model.open_loop(loop, disc, "max")
            T = model.closed_loop(loop, disc, "max")
            assert (L.dt or None) == dt
            ours = model.open_response(loop, w, disc)[model.cases.index("max")]
            np.testing.assert_allclose(L(x), ours, rtol=1e-9)
            np.testing.assert_allclose(T(x), ours / (1 + ours), rtol=1e-9)
    # the default case is the plant's own
    at_min = CascadeModel(plant.at("min"), arm_gains["joint3"]).open_loop("speed")
    np.testing.assert_allclose(
        at_min(1j * 100.0), model.open_loop("speed", False, "min")(1j * 100.0), rtol=1e-12
    )


def test_bad_cascades_are_refused_in_one_line(teachbot6, arm_gains, inertias):
    """A derivative without its filter (no state-space form), a loop without gains, position
    and speed loops on different periods: a SpecError naming the key."""
    plant = joint_plant(teachbot6, "joint4", inertias=inertias)
    g = arm_gains["joint4"]
    improper = g.replace_loop(g.position.with_gains(g.position.kp, 0.0, 1e-3))
    with pytest.raises(SpecError, match="derivative_filter_s"):
        check_cascade(plant, improper)
    with pytest.raises(SpecError, match="joint4: the position loop has no gains yet"):
        CascadeModel(plant, {"current": g.current, "speed": g.speed}).margins("position")
    slow = LoopGains("position", "P", kp=g.position.kp, sample_time_s=2e-3)
    with pytest.raises(SpecError, match="share a sample time"):
        CascadeModel(plant, g.replace_loop(slow)).stable("position", True)
