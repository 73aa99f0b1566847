"""The key figures of a study: one flat row of numbers per study (what a sweep keeps and plots).

:func:`key_figures` computes them once per study from the stages' typed results; summary.json's
``key_figures``, report.md's table, the one-screen summary and a sweep's row all show that one
row.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from armlab.study.context import StudyContext
    from armlab.study.verdict import DesignVerdict, StageRecord

__all__ = ["KEY_FIGURES", "key_figures"]


#: Names of the numeric key figures (the sweep's figures of merit).
KEY_FIGURES = (
    "max_reach_m",
    "duration_s",
    "peak_velocity_ratio",
    "peak_acceleration_ratio",
    "peak_jerk_ratio",
    "peak_torque_ratio",
    "min_clearance_m",
    "max_static_torque_Nm",
    "sizing_ok",
    "sizing_min_margin",
    "min_phase_margin_deg",
    "min_gain_margin_dB",
    "position_crossover_min_rad_s",
    "tracking_max_error_rad",
    "tcp_max_error_m",
    "n_cycles",
    "n_failed_checks",
)


def key_figures(
    ctx: StudyContext | None, records: Mapping[str, StageRecord], design: DesignVerdict
) -> dict[str, Any]:
    """The figures a sweep keeps per study (one flat row; NaN where a stage did not run), from
    the stages' typed results (``ctx``; None when the robot could not be built), their records
    and the design's verdict.

    ``max_reach_m``; ``duration_s``; ``peak_<kind>_ratio`` (max over joints of the plan's ratio
    to each limit, :class:`~armlab.trajectory.sampling.LimitReport`); ``min_clearance_m`` (the
    plan's smallest signed distance between the arm, payload, floor and obstacles,
    :class:`~armlab.collision.ClearanceReport`: also for a plan refused for it; negative:
    penetration; inf: nothing to collide with); ``max_static_torque_Nm``;
    ``sizing_ok`` and ``sizing_min_margin`` (smallest finite margin of every drive check) with
    ``sizing_binding`` (``joint:check``); ``min_phase_margin_deg``, ``min_gain_margin_dB``
    (every loop, continuous and discrete), ``position_crossover_min_rad_s``;
    ``tracking_max_error_rad``, ``tcp_max_error_m``; ``n_cycles`` of the set-point table; the
    status of each stage (``stage_<name>``), the design's ``verdict`` and ``n_failed_checks``.
    """

    def ran(stage: str) -> bool:
        rec = records.get(stage)
        return ctx is not None and rec is not None and rec.status == "ok"

    nan = math.nan
    out: dict[str, Any] = {"max_reach_m": ctx.max_reach_m if ran("kinematics") and ctx else nan}
    traj = ctx.trajectory if ran("plan") and ctx else None
    report = ctx.limit_report if ran("plan") and ctx else None
    out["duration_s"] = nan if traj is None else float(traj.duration)
    for kind in ("velocity", "acceleration", "jerk", "torque"):
        r = None if report is None else report.ratios.get(kind)
        out[f"peak_{kind}_ratio"] = nan if r is None else float(np.max(r))
    clear = ctx.clearance if ctx is not None else None
    out["min_clearance_m"] = nan if clear is None else float(clear.min_distance_m)
    static = ctx.static_load if ran("static_load") and ctx else None
    torques = [] if static is None else [float(x.torque_Nm) for x in static.joints]
    out["max_static_torque_Nm"] = max(torques) if torques else nan
    sizing = ctx.sizing if ran("sizing") and ctx else None
    checks = [] if sizing is None else [(j.joint, c) for j in sizing.joints for c in j.checks]
    out["sizing_ok"] = all(c.ok for _, c in checks) if checks else None
    finite = [(float(c.margin), f"{j}:{c.name}") for j, c in checks if math.isfinite(c.margin)]
    low = min(finite, key=lambda m: m[0]) if finite else (nan, "")
    out["sizing_min_margin"], out["sizing_binding"] = low
    gains = ctx.gains if ran("tuning") and ctx else None
    pm: list[float] = []
    gm: list[float] = []
    wc: list[float] = []
    for cascade in gains or ():
        for loop in ("current", "speed", "position"):
            g = getattr(cascade, loop)
            pm += [g.phase_margin_deg, g.phase_margin_discrete_deg]
            gm += [g.gain_margin_dB, g.gain_margin_discrete_dB]
            if loop == "position":
                wc.append(g.crossover_rad_s)
    out["min_phase_margin_deg"] = _nanmin(pm)
    out["min_gain_margin_dB"] = _nanmin(gm)
    out["position_crossover_min_rad_s"] = _nanmin(wc)
    res = ctx.tracking if ran("tracking") and ctx else None
    out["tracking_max_error_rad"] = nan if res is None else _nanmax(list(res.max_error_rad))
    out["tcp_max_error_m"] = nan if res is None else res.tcp_max_error_m
    table = ctx.setpoints if ran("export") and ctx else None
    out["n_cycles"] = nan if table is None else float(table.n_cycles)
    for stage, rec in records.items():
        out[f"stage_{stage}"] = rec.status
    out["verdict"] = design.verdict
    out["n_failed_checks"] = float(len(design.failed_checks))
    return out


def _nanmin(xs) -> float:
    xs = [x for x in xs if not math.isnan(x)]
    return min(xs) if xs else math.nan


def _nanmax(xs) -> float:
    xs = [x for x in xs if not math.isnan(x)]
    return max(xs) if xs else math.nan
