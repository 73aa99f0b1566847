"""The drive engineer's checks in a study (issue 28): winding temperature over the cycle with
its dwell, inertia ratio, amplifier currents and braking energy -- each shown in the summary and
the report, and each made to fail by one changed study value, with a one-line verdict."""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest

from armlab.errors import SpecError
from armlab.study import parse_study, run_spec

QUICK = """
[study]
name = "drive checks"
stages = ["kinematics", "plan", "sizing"]
report = false
[robot]
name = "teachbot6"
[payload]
mass_kg = 0.5
[waypoints]
unit = "deg"
joint = [[0, 0, 0, 0, 0, 0], [30, 10, 20, 0, 30, 0], [60, 20, 10, 45, -20, 90]]
[plan]
planner = "ptp"
check_dt_s = 0.002
"""

#: an amplifier that regenerates, for joint 2 (which lowers the arm: braking energy)
AMP = {
    "model": "test amplifier",
    "continuous_current_A": 2.0,
    "peak_current_A": 6.0,
    "bus_voltage_V": 24.0,
    "regenerates": True,
    "bus_capacitance_F": 0.01,
    "brake_threshold_V": 30.0,
}


def _run(tmp_path=None, *, sizing=None, drives=None, report=False):
    doc = tomllib.loads(QUICK)
    doc["study"]["report"] = report
    if sizing is not None:
        doc["sizing"] = sizing
    if drives is not None:
        doc["drives"] = drives
    return run_spec(parse_study(doc), tmp_path, progress=None)


def test_dwell_thermal_and_inertia_ratio_in_summary_and_report(tmp_path):
    moving = _run()
    res = _run(tmp_path, sizing={"dwell_s": 2.0})
    s = res.summary["sizing"]
    assert s["thermal"]["dwell_s"] == 2.0 and s["thermal"]["cycles"] == "periodic"
    assert s["thermal"]["ambient_degC"] == 25.0 and "ASSUMED" in s["thermal"]["ambient_source"]
    loads = res.context.sizing.loads
    no_dwell = moving.summary["sizing"]["joint1"]
    for j in [f"joint{i}" for i in range(1, 7)]:
        row, row0 = s[j], moving.summary["sizing"][j]
        assert 25.0 <= row["winding_peak_temperature_degC"] < 130.0
        assert 0 < row["inertia_ratio_min"] <= row["inertia_ratio_max"]
        names = {c["name"]: c for c in row["checks"]}
        assert names["winding_temperature_rise"]["ok"] and "inertia_ratio" not in names
        # the dwell is part of the duty cycle: RMS^2 (T + d) = RMS0^2 T + T_hold^2 d, with the
        # holding torque that of the plan's last sample (at rest)
        k = int(j[-1]) - 1
        hold = loads.motor_torque_Nm[-1, k]
        T = res.context.trajectory.duration
        expected = np.sqrt((row0["motor_rms_torque_Nm"] ** 2 * T + hold**2 * 2.0) / (T + 2.0))
        assert row["motor_rms_torque_Nm"] == pytest.approx(expected, rel=1e-6)
    assert no_dwell["winding_peak_temperature_degC"] > 25.0
    # the report's sizing section (report.md renders this markdown; writing the report's plots
    # takes seconds)
    report = res.context.sizing.to_markdown()
    assert "peak winding [degC]" in report and "inertia ratio min" in report
    assert "2 s dwell at its last pose" in report
    json.loads((tmp_path / "summary.json").read_text())  # plain JSON


def _failed(res) -> list[str]:
    return res.summary["design"]["failed_checks"]


@pytest.mark.parametrize(
    "change, check",
    [
        # the allowed rise shrinks to 0.2 K (maximum 130 degC): the winding check fails
        ({"sizing": {"ambient_degC": 129.8}}, "winding_temperature_rise"),
        ({"sizing": {"max_inertia_ratio": 0.01}}, "inertia_ratio"),
        # joint 2's peak motor current is 1.12 A
        (
            {
                "drives": {
                    "joint2": {
                        "amplifier": {**AMP, "continuous_current_A": 0.5, "peak_current_A": 1.0}
                    }
                }
            },
            "amplifier_peak_current",
        ),
        # its RMS motor current is 0.29 A
        (
            {"drives": {"joint2": {"amplifier": {**AMP, "continuous_current_A": 0.2}}}},
            "amplifier_continuous_current",
        ),
        # a brake resistor rated 1 mW takes what a 0.1 mF bus cannot (about 0.1 W on average)
        (
            {
                "drives": {
                    "joint2": {
                        "amplifier": {
                            **AMP,
                            "bus_capacitance_F": 1e-4,
                            "brake_resistor_ohm": 10.0,
                            "brake_resistor_power_W": 1e-3,
                        }
                    }
                }
            },
            "brake_resistor_power",
        ),
        # its largest braking stretch returns 1.24 J: 10 mF from 24 to 30 V take 1.62 J, 0.1 mF
        # 0.016 J
        (
            {"drives": {"joint2": {"amplifier": {**AMP, "bus_capacitance_F": 1e-4}}}},
            "bus_capacitor_energy",
        ),
    ],
)
def test_one_changed_value_fails_each_new_check(change, check):
    # the study with the amplifier AMP on joint 2 passes (test_the_amplified_study_passes)
    failed = _failed(_run(**change))
    assert failed and all("\n" not in f for f in failed)
    assert any(f.startswith("sizing: ") and check in f for f in failed), failed


def test_the_amplified_study_passes():
    res = _run(drives={"joint2": {"amplifier": AMP}})
    assert _failed(res) == [] and res.summary["sizing"]["joint2"]["amplifier"] == AMP["model"]
    names = [c["name"] for c in res.summary["sizing"]["joint2"]["checks"]]
    assert {"amplifier_peak_current", "bus_capacitor_energy"} <= set(names)


def test_bad_sizing_and_amplifier_values_name_the_key():
    with pytest.raises(SpecError, match="sizing.dwell_s"):
        _run(sizing={"dwell_s": -1.0})
    with pytest.raises(SpecError, match="sizing.max_inertia_ratio"):
        _run(sizing={"max_inertia_ratio": 0})
    with pytest.raises(SpecError, match=r"drives.joint2.*amplifier\.bus_voltage_V"):
        _run(drives={"joint2": {"amplifier": {**AMP, "bus_voltage_V": -1.0}}})


def test_export_judges_the_new_checks_again(tmp_path, capsys):
    """A study failing the inertia-ratio rule of its [sizing] table, its verdicts edited to
    pass (checksums put right): ``armlab export`` re-runs the sizing with the recorded
    [sizing] options and refuses, naming the check."""
    from armlab.cli import main
    from cases import one_line, quick_study

    study = tmp_path / "ratio.toml"
    stages = ("kinematics", "plan", "sizing", "export")
    study.write_text(quick_study("ratio", stages) + "[sizing]\nmax_inertia_ratio = 0.01\n")
    out = tmp_path / "ratio"
    assert main(["run", str(study), "--out", str(out)]) == 1
    summary = json.loads((out / "summary.json").read_text())
    assert any("inertia_ratio" in f for f in summary["design"]["failed_checks"])
    summary["design"].update(verdict="pass", failed_checks=[])
    summary["sizing"].update(verdict="pass", failed_checks=[])
    summary["study"]["stages"]["sizing"]["verdict"] = "pass"
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    capsys.readouterr()
    assert main(["export", str(out), "--out", str(tmp_path / "exp")]) == 1
    line = one_line(capsys)
    assert "export refused" in line and "inertia_ratio" in line
