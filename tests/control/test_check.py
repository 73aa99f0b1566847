"""armlab.control.check: every figure of a tuned cascade over the inertia range, against the
loops built with python-control (``tests/oracles/cascade_pc.py``).

Tolerances: margins and crossovers 1e-9 relative (the figures are read from the responses on
the same 1500-point grid), settling time 1e-9 relative, overshoot 1e-6 percentage points,
stability flags equal; the headline figure of a loop is the worst row (crossover: nominal).
"""

from __future__ import annotations

import json
import math

import pytest

from armlab.control import ArmGains, check_cascade, joint_plant
from armlab.control.margins import freq_grid, margins
from armlab.control.plant import INERTIA_CASES
from oracles.cascade_pc import Cascade, response, step_figures


def _close(a: float, b: float, rel: float) -> bool:
    if math.isinf(b) or math.isnan(b):
        return a == b or (math.isnan(a) and math.isnan(b))
    return abs(a - b) <= rel * abs(b)


@pytest.mark.parametrize("joint", ["joint1", "joint4", "joint6"])
def test_robustness_rows_are_python_controls(teachbot6, arm_gains, inertias, joint):
    """Each row of each loop recomputed from the gains alone by the oracle: the widest inertia
    range (joint 1), a wrist, the thesis motor (joint 6)."""
    plant = joint_plant(teachbot6, joint, inertias=inertias)
    g = check_cascade(plant, arm_gains[joint])
    bad = []
    for loop, lg in g.loops().items():
        assert [r["label"] for r in lg.robustness] == list(INERTIA_CASES)
        for row in lg.robustness:
            oracle = Cascade(plant.at(row["label"]), g)
            assert row["inertia_kg_m2"] == pytest.approx(plant.J_motor(row["label"]), rel=1e-15)
            for disc, sfx in ((False, ""), (True, "_discrete")):
                w = freq_grid(lg.sample_time_s if disc else None, n=1500)
                ref = margins(w, response(oracle.open_loop(loop, disc), w))
                span = 12.0 if loop == "position" else 40.0
                os_, ts = step_figures(oracle.closed_loop(loop, disc), span / ref.crossover_rad_s)
                for key, theirs, rel in (
                    (f"crossover{sfx}_rad_s", ref.crossover_rad_s, 1e-9),
                    (f"phase_margin{sfx}_deg", ref.phase_margin_deg, 1e-9),
                    (f"gain_margin{sfx}_dB", ref.gain_margin_dB, 1e-9),
                    (f"settling_time{sfx}_s", ts, 1e-9),
                ):
                    if not _close(row[key], theirs, rel):
                        bad.append(f"{loop} {row['label']} {key}: {row[key]} vs {theirs}")
                if not abs(row[f"overshoot{sfx}_pct"] - os_) <= 1e-6:
                    bad.append(
                        f"{loop} {row['label']} overshoot{sfx}: {row[f'overshoot{sfx}_pct']}"
                    )
                if row[f"stable{sfx}"] != oracle.stable(loop, disc):
                    bad.append(f"{loop} {row['label']} stable{sfx}")
        rows = lg.robustness
        assert lg.phase_margin_discrete_deg == min(r["phase_margin_discrete_deg"] for r in rows)
        assert lg.overshoot_pct == max(r["overshoot_pct"] for r in rows)
        assert lg.crossover_rad_s == rows[INERTIA_CASES.index("nominal")]["crossover_rad_s"]
    assert bad == []


def test_gains_json_round_trip_reproduces_the_margins(teachbot6, arm_gains, inertias):
    text = arm_gains.to_json()
    back = ArmGains.from_json(text)
    assert back.to_json() == text
    assert json.loads(text)["joints"]["joint6"]["speed"]["gain_units"]["kp"] == "A/(rad/s)"
    json.loads(text, parse_constant=lambda c: pytest.fail(f"non-strict JSON {c}"))
    plant = joint_plant(teachbot6, "joint6", inertias=inertias)
    rechecked = check_cascade(plant, back["joint6"])
    for name, lg in rechecked.loops().items():
        stored = arm_gains["joint6"].loops()[name]
        for key in (
            "crossover_rad_s",
            "phase_margin_deg",
            "gain_margin_dB",
            "phase_margin_discrete_deg",
            "gain_margin_discrete_dB",
            "overshoot_pct",
        ):
            a, b = getattr(lg, key), getattr(stored, key)
            assert a == pytest.approx(b, rel=1e-9) or (math.isinf(a) and math.isinf(b)), key
    # the summary.json "control" block (DESIGN.md)
    block = arm_gains.summary()["joint1"]
    for loop in ("current", "speed", "position"):
        for key in (
            "gains",
            "crossover_rad_s",
            "phase_margin_deg",
            "gain_margin_dB",
            "overshoot_pct",
            "settling_time_s",
            "sample_time_s",
        ):
            assert key in block[loop]
    assert block["speed"]["sample_time_s"] == 1e-3 and block["current"]["sample_time_s"] == 5e-5
