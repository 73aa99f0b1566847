"""The figures of a tuned cascade over the inertia range (:func:`check_cascade`).

For each loop and each inertia case (min, nominal, max), continuous and discrete: the gain
crossover, phase and gain margins (:mod:`armlab.control.margins` on a 1500-point grid), the
unit-step overshoot and 2 % settling time (:mod:`armlab.control.steps`, simulated over
``40 / w_c``, the position loop ``12 / w_c``) and closed-loop stability. The headline figure
of each loop is its worst case (crossover: at the nominal inertia).
"""

from __future__ import annotations

import math
from typing import Any

from armlab.control.gains import CascadeGains, LoopGains
from armlab.control.loops import CascadeModel
from armlab.control.plant import INERTIA_CASES, JointPlant

__all__ = ["check_cascade"]


def _rows(plant: JointPlant, loops: dict, n_grid: int) -> dict[str, list[dict]]:
    """Per loop the robustness rows (one per inertia case) of :func:`check_cascade`."""
    model = CascadeModel(plant, loops, INERTIA_CASES)
    out = {}
    for name in loops:
        rows: list[dict[str, Any]] = [
            {"label": case, "inertia_kg_m2": plant.J_motor(case)} for case in INERTIA_CASES
        ]
        for disc in (False, True):
            sfx = "_discrete" if disc else ""
            mgs = model.margins(name, disc, n=n_grid)
            span = 12.0 if name == "position" else 40.0
            t_end = [
                span / m.crossover_rad_s
                if math.isfinite(m.crossover_rad_s) and m.crossover_rad_s > 0
                else 1.0
                for m in mgs
            ]
            figs = model.step_figures(name, disc, t_end)
            stable = model.stable(name, disc)
            for row, mg, (os_, ts), st in zip(rows, mgs, figs, stable, strict=True):
                row.update(
                    {
                        f"crossover{sfx}_rad_s": mg.crossover_rad_s,
                        f"phase_margin{sfx}_deg": mg.phase_margin_deg,
                        f"gain_margin{sfx}_dB": mg.gain_margin_dB,
                        f"overshoot{sfx}_pct": os_,
                        f"settling_time{sfx}_s": ts,
                        f"stable{sfx}": st,
                    }
                )
        out[name] = rows
    return out


def check_cascade(plant: JointPlant, gains: CascadeGains, *, n_grid: int = 1500) -> CascadeGains:
    """Recompute every loop's figures over the inertia range (module docstring).

    Parameters
    ----------
    plant : JointPlant
        The joint's plant with its inertia range.
    gains : CascadeGains
    n_grid : int
        Frequency points of the margins.

    Returns
    -------
    CascadeGains
        A copy with the worst-case figures and the ``robustness`` rows filled in.
    """
    loops = {name: LoopGains.from_dict(lg.to_dict()) for name, lg in gains.loops().items()}
    all_rows = _rows(plant, loops, n_grid)
    for name, lg in loops.items():
        rows = all_rows[name]
        nom = rows[INERTIA_CASES.index("nominal")]
        lg.crossover_rad_s = nom["crossover_rad_s"]
        lg.crossover_discrete_rad_s = nom["crossover_discrete_rad_s"]
        for sfx in ("", "_discrete"):
            for key in (f"phase_margin{sfx}_deg", f"gain_margin{sfx}_dB"):
                setattr(lg, key, min(r[key] for r in rows))
            for key in (f"overshoot{sfx}_pct", f"settling_time{sfx}_s"):
                setattr(lg, key, max(r[key] for r in rows))
        lg.robustness = rows
    return CascadeGains(joint=gains.joint, plant=gains.plant, spec=gains.spec, **loops)
