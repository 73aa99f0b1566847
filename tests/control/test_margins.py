"""armlab.control.margins: a loop with known margins, python-control's stability_margins, and
the plain one-crossing-at-a-time reading (``tests/oracles/margins_scalar.py``)."""

from __future__ import annotations

import math

import control as ct
import numpy as np
import pytest

from armlab.control import CascadeModel, joint_plant
from armlab.control.margins import freq_grid, margins, margins_many
from oracles.cascade_pc import Cascade
from oracles.margins_scalar import margins_scalar


def test_margins_of_a_known_loop():
    """L = k e^{-s tau}/s: crossover k, PM = 90 - k tau (deg), GM at w = pi/(2 tau)."""
    k, tau = 10.0, 0.02
    w = np.logspace(-1, 3, 20000)
    mg = margins(w, k * np.exp(-1j * w * tau) / (1j * w))
    assert mg.crossover_rad_s == pytest.approx(k, rel=1e-3)
    assert mg.phase_margin_deg == pytest.approx(90 - math.degrees(k * tau), abs=0.05)
    assert mg.gain_margin_dB == pytest.approx(20 * math.log10(math.pi / (2 * tau) / k), abs=0.02)
    assert mg.phase_crossover_rad_s == pytest.approx(math.pi / (2 * tau), rel=1e-3)


def test_margins_agree_with_python_control(teachbot6, arm_gains, inertias):
    """The engine's grid margins vs python-control's stability_margins on the loops the oracle
    builds (an independent computation of both the loop and the margins): PM within 0.3 deg,
    crossover 0.5 %, GM 0.1 dB (the grid's interpolation)."""
    plant = joint_plant(teachbot6, "joint2", inertias=inertias)
    model = CascadeModel(plant, arm_gains["joint2"])
    oracle = Cascade(plant.at("nominal"), arm_gains["joint2"])
    nominal = model.cases.index("nominal")
    for loop in ("speed", "position"):
        for disc in (False, True):
            L = oracle.open_loop(loop, disc)
            ours = model.margins(loop, disc)[nominal]
            frd = ct.frd(L, freq_grid(L.dt or None, n=4000))
            gm, pm, _, _, wc, _ = ct.stability_margins(frd)
            assert ours.phase_margin_deg == pytest.approx(pm, abs=0.3), (loop, disc)
            assert ours.crossover_rad_s == pytest.approx(wc, rel=5e-3), (loop, disc)
            if math.isfinite(ours.gain_margin_dB):
                assert ours.gain_margin_dB == pytest.approx(20 * math.log10(gm), abs=0.1)


def test_margins_are_the_one_crossing_at_a_time_reading():
    """Random rational loops with several crossings, a loop that never crosses, one still
    above 1 at the end of the grid: every figure within 1e-12 (relative) of the oracle's."""
    rng = np.random.default_rng(3)
    w = freq_grid(None, n=800)
    s = 1j * w
    rows = []
    for _ in range(12):
        k, a, b, c = rng.uniform(0.5, 5e3), *rng.uniform(1, 1e4, 3)
        rows.append(k * (s / c + 1) / (s * (s / a + 1) ** 2 * (s / b + 1)))
    rows.append(1e-3 / (s + 1))  # never crosses
    rows.append(1e7 / (s + 1))  # |L| > 1 up to the end
    L = np.array(rows)
    pm, gm, wc, wpc = margins_many(w, L)
    for i, row in enumerate(L):
        ref = margins_scalar(w, row)
        one = margins(w, row)
        for ours, single, theirs in zip(
            (pm[i], gm[i], wc[i], wpc[i]),
            (
                one.phase_margin_deg,
                one.gain_margin_dB,
                one.crossover_rad_s,
                one.phase_crossover_rad_s,
            ),
            (
                ref.phase_margin_deg,
                ref.gain_margin_dB,
                ref.crossover_rad_s,
                ref.phase_crossover_rad_s,
            ),
            strict=True,
        ):
            for x in (float(ours), single):
                if math.isnan(theirs) or math.isinf(theirs):
                    assert x == theirs or (math.isnan(x) and math.isnan(theirs)), i
                else:
                    assert x == pytest.approx(theirs, rel=1e-12), i
    assert math.isinf(pm[-2]) and pm[-2] > 0  # never crosses: no constraint
    assert pm[-1] == -math.inf  # above 1 at Nyquist: no usable margin
