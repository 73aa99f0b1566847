"""The key figures of a study: one flat row of numbers per study (what a sweep keeps and plots).

:func:`key_figures` reads them from a summary (summary.json content), so a sweep row, the
one-screen summary and a notebook all read the same numbers.
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["KEY_FIGURES", "key_figures", "joint_items"]


def _get(d: Any, *path, default=math.nan):
    for p in path:
        if not isinstance(d, dict) or p not in d:
            return default
        d = d[p]
    return d


def _num(x) -> float:
    if isinstance(x, bool):
        return float(x)
    if isinstance(x, (int, float)):
        return float(x)
    if x == "inf":
        return math.inf
    return math.nan


def _walk_loops(control: dict):
    """(joint, loop, figures) of every loop in a summary's "control" block."""
    for joint, loops in control.items():
        if isinstance(loops, dict):
            for loop, fig in loops.items():
                if isinstance(fig, dict) and "phase_margin_deg" in fig:
                    yield joint, loop, fig


#: Names of the numeric key figures (the sweep's figures of merit).
KEY_FIGURES = (
    "max_reach_m",
    "duration_s",
    "peak_velocity_ratio",
    "peak_acceleration_ratio",
    "peak_jerk_ratio",
    "peak_torque_ratio",
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


def key_figures(summary: dict[str, Any]) -> dict[str, Any]:
    """The figures a sweep keeps per study (one flat row; NaN where a stage did not run).

    ``duration_s``; ``peak_<kind>_ratio`` (max over joints of the plan's ratio to each limit);
    ``max_static_torque_Nm``; ``sizing_ok`` and ``sizing_min_margin`` (smallest margin of every
    drive check) with ``sizing_binding`` (``joint:check``); ``min_phase_margin_deg``,
    ``min_gain_margin_dB`` (every loop, continuous and discrete), ``position_crossover_min_rad_s``;
    ``tracking_max_error_rad``, ``tcp_max_error_m``; ``n_cycles`` of the set-point table; and the
    status of each stage (``stage_<name>``).
    """
    out: dict[str, Any] = {}
    out["max_reach_m"] = _num(_get(summary, "kinematics", "max_reach_m"))
    traj = summary.get("trajectory", {})
    out["duration_s"] = _num(traj.get("duration_s"))
    for kind in ("velocity", "acceleration", "jerk", "torque"):
        out[f"peak_{kind}_ratio"] = _num(_get(traj, "peak_ratio", kind))
    # static load: per joint {torque_Nm, ...}
    static = summary.get("static_load", {})
    torques = [_num(_get(v, "torque_Nm")) for v in _joint_blocks(static)]
    out["max_static_torque_Nm"] = max(torques) if torques else math.nan
    # sizing: per joint {checks: [{name, value, limit, margin, ok}]}
    sizing = summary.get("sizing", {})
    margins: list[float] = []
    ok_all, binding = True, ""
    for joint, block in joint_items(sizing):
        for check in block.get("checks", []) if isinstance(block, dict) else []:
            m = _num(check.get("margin"))
            if not check.get("ok", True):
                ok_all = False
            if not math.isnan(m) and (not margins or m < min(margins)):
                binding = f"{joint}:{check.get('name', '?')}"
            margins.append(m)
    out["sizing_ok"] = ok_all if margins else None
    finite = [m for m in margins if not math.isnan(m)]
    out["sizing_min_margin"] = min(finite) if finite else math.nan
    out["sizing_binding"] = binding
    control = summary.get("control", {})
    pm, gm, wc = [], [], []
    for _joint, loop, fig in _walk_loops(control):
        pm += [_num(fig.get("phase_margin_deg")), _num(fig.get("phase_margin_discrete_deg"))]
        gm += [_num(fig.get("gain_margin_dB")), _num(fig.get("gain_margin_discrete_dB"))]
        if loop == "position":
            wc.append(_num(fig.get("crossover_rad_s")))
    out["min_phase_margin_deg"] = _nanmin(pm)
    out["min_gain_margin_dB"] = _nanmin(gm)
    out["position_crossover_min_rad_s"] = _nanmin(wc)
    tracking = summary.get("tracking", {})
    errs = [_num(_get(v, "max_error_rad")) for v in _joint_blocks(tracking)]
    out["tracking_max_error_rad"] = _nanmax(errs)
    out["tcp_max_error_m"] = _num(_get(tracking, "tcp", "max_error_m"))
    if math.isnan(out["tcp_max_error_m"]):
        out["tcp_max_error_m"] = _num(tracking.get("tcp_max_error_m"))
    n = _get(summary, "export", "n_cycles", default=None)
    out["n_cycles"] = math.nan if n is None else float(n)
    for stage, info in summary.get("study", {}).get("stages", {}).items():
        out[f"stage_{stage}"] = info.get("status", "")
    design = summary.get("design", {})
    out["verdict"] = design.get("verdict", "")
    out["n_failed_checks"] = float(len(design.get("failed_checks", [])))
    return out


def joint_items(block: dict):
    """(joint, dict) entries of a per-joint block (``{"joints": {...}}`` or joints at top)."""
    if not isinstance(block, dict):
        return []
    inner = block.get("joints", block)
    if isinstance(inner, list):
        return [(b.get("joint", str(i)), b) for i, b in enumerate(inner) if isinstance(b, dict)]
    return [(k, v) for k, v in inner.items() if isinstance(v, dict)]


def _joint_blocks(block: dict):
    return [v for _, v in joint_items(block)]


def _nanmin(xs) -> float:
    xs = [x for x in xs if not math.isnan(x)]
    return min(xs) if xs else math.nan


def _nanmax(xs) -> float:
    xs = [x for x in xs if not math.isnan(x)]
    return max(xs) if xs else math.nan
