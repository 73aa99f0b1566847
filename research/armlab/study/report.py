"""A study's report: ``report.md`` with its PNG plots, and the one-screen text summary.

Plots are the package's own plot functions, drawn inside :func:`armlab.plots.offscreen` (object
API and an Agg canvas: the caller's matplotlib backend is never switched) and saved beside
``report.md``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab.deploy.provenance import armlab_version
from armlab.io import atomic_open, atomic_write

if TYPE_CHECKING:
    from armlab.control.gains import ArmGains
    from armlab.control.result import TrackingResult
    from armlab.study.context import StudyContext
    from armlab.study.runner import StudyResult
    from armlab.study.verdict import DesignVerdict, StageRecord

__all__ = ["write_report", "summary_text"]


# ---------------------------------------------------------------------------- plots
def _weakest_joint(gains: ArmGains) -> str | None:
    """The joint whose loops have the smallest phase margin (continuous or discrete)."""
    from armlab.control.gains import LOOPS

    worst, joint = math.inf, None
    for cascade in gains:
        for loop in LOOPS:
            g = getattr(cascade, loop)
            for v in (g.phase_margin_deg, g.phase_margin_discrete_deg):
                if v < worst:  # NaN (not computed) never is
                    worst, joint = v, cascade.joint
    return joint


def _plant(ctx: StudyContext, joint: str):
    """A factory of the joint's plant with the inertia range the tuning used."""

    def make():
        from armlab.control import joint_plant

        n = ctx.spec.control.n_inertia_samples
        if n is None:
            return joint_plant(ctx.robot, joint, seed=ctx.spec.study.seed)
        return joint_plant(ctx.robot, joint, seed=ctx.spec.study.seed, n_samples=n)

    return make


def _figures(ctx: StudyContext) -> list[tuple[str, str, Callable[[], Any]]]:
    """(file name, caption, figure factory) of every plot the study can draw."""
    from armlab.kinematics.forward import tool_positions
    from armlab.plots import (
        bode_figure,
        plot_accuracy,
        plot_joint_loads,
        plot_joints,
        plot_limit_profiles,
        plot_operating_points,
        plot_phase_plane,
        plot_tcp_path,
        plot_torque_ratio,
        plot_workspace,
        step_figure,
        tracking_figure,
    )

    out: list[tuple[str, str, Callable[[], Any]]] = []  # (file name, caption, draw)
    traj, robot = ctx.trajectory, ctx.robot
    if ctx.workspace is not None:
        out.append(
            (
                "kinematics_workspace.png",
                "Monte-Carlo workspace",
                functools.partial(plot_workspace, ctx.workspace),
            )
        )
    if ctx.accuracy is not None:
        out.append(
            (
                "kinematics_accuracy.png",
                "Monte-Carlo positioning error",
                functools.partial(plot_accuracy, ctx.accuracy),
            )
        )
    if traj is not None:
        optimised = ctx.spec.plan.planner in ("optimal", "path")
        joints = plot_limit_profiles if optimised else plot_joints
        out.append(
            (
                "plan_profiles.png",
                "Joint profiles with the limits (dashed)",
                lambda: joints(traj, robot),
            )
        )
        if ctx.spec.plan.planner == "path":
            out.append(
                (
                    "plan_phase_plane.png",
                    "Path parameterisation: phase plane with its limit curves",
                    lambda: plot_phase_plane(traj),
                )
            )
        points = tool_positions(robot, ctx.waypoints_q)
        out.append(
            (
                "plan_tool_path.png",
                "Tool path and waypoints",
                lambda: plot_tcp_path(robot, traj, points),
            )
        )
        if robot.limits.torque_Nm is not None:
            dt = max(traj.duration / 2000, 1e-3)
            out.append(
                (
                    "plan_torque_ratio.png",
                    "Torque / effort limit along the plan",
                    lambda: plot_torque_ratio(traj, robot, dt=dt),
                )
            )
    if ctx.gains is not None:
        joint = _weakest_joint(ctx.gains)
        if joint is not None:
            plant = _plant(ctx, joint)
            g = ctx.gains[joint]
            out.append(
                (
                    f"control_bode_{joint}.png",
                    f"Speed-loop Bode plot of {joint} (smallest phase margin) over its "
                    "inertia range",
                    lambda: bode_figure(plant(), g, "speed"),
                )
            )
            out.append(
                (
                    f"control_steps_{joint}.png",
                    f"Step responses of the {joint} loops",
                    lambda: step_figure(plant(), g),
                )
            )
    if ctx.tracking is not None:
        out.append(
            (
                "tracking_error.png",
                "Closed-loop tracking error (joints and TCP)",
                lambda: tracking_figure(ctx.tracking),
            )
        )
        out.append(
            (
                "tracking_drive_model.png",
                "TCP error with and without the reducer's efficiency and friction and the "
                "amplifier's supply limit (the verdict uses both), and with their feed-forward; "
                "below, the full model's armature voltages against the supply",
                lambda: _drive_model_figure(ctx),
            )
        )
    loads = ctx.sizing.loads if ctx.sizing is not None else None
    if loads is not None:
        for plot_loads, name, caption in (
            (
                plot_joint_loads,
                "sizing_loads.png",
                "Joint torque, speed and power along the plan, with the limits",
            ),
            (
                plot_operating_points,
                "sizing_operating_points.png",
                "Motor operating points on the speed-torque plane",
            ),
        ):
            out.append((name, caption, functools.partial(plot_loads, loads, robot)))
    return out


def _drive_model_figure(ctx: StudyContext):
    """The study's motion under each drive model: the tracking stage's result and its
    variants (:func:`armlab.control.diagnosis.tracking_variants`; those the stage's diagnosis
    ran are reused, the others simulated here and kept on the context)."""
    from armlab.control.diagnosis import tracking_variants
    from armlab.plots.servo import drive_model_figure

    res = ctx.tracking
    assert res is not None  # drawn only after the tracking stage
    v = tracking_variants(
        ctx.robot,
        ctx.trajectory,
        ctx.gains,
        DRIVE_MODEL_VARIANTS,
        known=dict(ctx.tracking_variants),
        **ctx.tracking_options,
    )
    ctx.tracking_variants.update(v)
    runs = {
        "ideal drive": v["ideal"],
        "+ efficiency and friction": v["no_voltage_limit"],
        "+ supply limit (full model)": res,
    }
    if "with_loss_feedforward" in v:
        extra = [f for f in ("friction", "efficiency") if f not in res.feedforward]
        runs[f"full model, feed-forward + {', '.join(extra)}"] = v["with_loss_feedforward"]
    return drive_model_figure(runs)


#: the drive models of the report's drive-model plot beside the study's full model
#: (:data:`armlab.control.diagnosis.DRIVE_VARIANTS`)
DRIVE_MODEL_VARIANTS = ("ideal", "no_voltage_limit", "with_loss_feedforward")
#: resolution of the report's PNG plots
PLOT_DPI = 110
#: zlib level of the report's PNG files: 1 instead of PIL's 6 -- 13 % less time per plot for
#: files ~10 % larger (issue 15, measured on the 18-panel loads plot: 0.43 -> 0.37 s, 390 -> 432 kB)
PNG_COMPRESS_LEVEL = 1


def _draw_one(name: str, make: Callable[[], Any], out_dir: Path) -> Path:
    """Draw one plot and write it atomically (a plot that fails raises its error)."""
    from armlab.plots import offscreen

    with offscreen():  # object API + Agg canvas: the caller's backend and pyplot untouched
        fig = make()
    path = out_dir / name
    fmt = path.suffix[1:] or "png"
    extra = {"pil_kwargs": {"compress_level": PNG_COMPRESS_LEVEL}} if fmt == "png" else {}
    with atomic_open(path, "wb") as f:
        fig.savefig(f, format=fmt, dpi=PLOT_DPI, **extra)
    return path


# ---------------------------------------------------------------------------- report.md
def _fmt(x, nd: int = 4) -> str:
    if x is None:
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, (int, float)):
        if isinstance(x, float) and math.isnan(x):
            return "-"
        return f"{x:.{nd}g}"
    return str(x)


def _table(header: list[str], rows: list[list[Any]]) -> list[str]:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(_fmt(c) for c in r) + " |" for r in rows]
    return lines + [""]


def _remedy_section(ctx: StudyContext) -> list[str]:
    """report.md's measured remedies (:mod:`armlab.study.remedies`), ranked."""
    if not ctx.remedies:
        return []
    return (
        ["## Remedies (measured)", ""]
        + _table(
            ["rank", "study keys to change", "TCP error [mm]", "verdict", "failed checks"],
            [
                [
                    k + 1,
                    f"`{r.keys_text()}`",
                    "-" if r.tcp_error_m is None else _fmt(r.tcp_error_m * 1e3),
                    r.verdict,
                    len(r.failed_checks),
                ]
                for k, r in enumerate(ctx.remedies)
            ],
        )
        + [""]
    )


def write_report(
    ctx: StudyContext,
    records: dict[str, StageRecord],
    design: DesignVerdict,
    figures: dict[str, Any],
    out_dir: Path,
) -> list[Path]:
    """Write ``report.md`` and its PNG plots into ``out_dir``, in this process, one plot after
    the other; returns the files written. A plot that fails raises its error.

    ``records`` and ``design``: the stages' records and the design's verdict; ``figures``: the
    study's key figures (:func:`armlab.study.figures.key_figures`)."""
    out_dir = Path(out_dir)
    files: list[Path] = []
    spec = ctx.spec
    lines = [
        f"# Study: {spec.study.name}",
        "",
        f"Source `{spec.source}` (sha256 `{spec.hash[:12]}`), seed {spec.study.seed}, "
        f"armlab {armlab_version()}.",
        "",
        "## Design verdict",
        "",
        *design.lines(),
        "",
        *_remedy_section(ctx),
        "## Stages",
        "",
    ]
    lines += _table(
        ["stage", "status", "verdict", "time [s]", "note"],
        [
            [s, rec.status, rec.verdict or "-", round(rec.time_s, 6), rec.note]
            for s, rec in records.items()
        ],
    )
    lines += _robot_lines(ctx)
    if records["kinematics"].status == "ok":
        lines += _kinematics_lines(ctx)
    if records["plan"].status == "ok":
        lines += _plan_lines(ctx)
    for stage, key, title in (
        ("static_load", "static_load", "Static load"),
        ("sizing", "sizing", "Drive sizing"),
        ("tuning", "control", "Servo tuning"),
        ("tracking", "tracking", "Closed-loop tracking"),
        ("export", "export", "Export"),
    ):
        lines += [f"## {title}", ""]
        rec = records.get(stage)
        if rec is None or rec.status != "ok":
            status, why = ("not run", "") if rec is None else (rec.status, rec.note)
            lines += [f"Status: {status} ({why}).", ""]
            continue
        if key == "static_load" and ctx.static_load is not None:
            lines += [ctx.static_load.to_markdown(), ""]  # the thesis' table beside (teachbot6)
        elif key == "sizing" and ctx.sizing is not None:
            lines += [ctx.sizing.to_markdown(), ""]
        elif key == "control" and ctx.gains is not None:
            lines += _control_lines(ctx.gains)
        elif key == "tracking" and ctx.tracking is not None:
            lines += _tracking_lines(ctx.tracking, ctx.diagnosis)
        elif key == "export":
            lines += _export_lines(ctx)
        if key == "sizing" and ctx.requirement_sizing is not None:
            lines += [
                "**Against each joint's worst case (the thesis' requirements).**",
                "",
                "Each joint alone from its worst static pose, accelerating at its maximum "
                "acceleration to its maximum speed and back (`armlab.dynamics."
                "requirement_moves`): the load case of thesis tables 4.2 and 4.3.",
                "",
                ctx.requirement_sizing.to_markdown(),
                "",
            ]
        if key == "sizing" and ctx.selection is not None:
            lines += [ctx.selection.to_markdown(), ""]
    lines += ["## Key figures", ""]
    lines += _table(
        ["figure", "value"], [[k, v] for k, v in figures.items() if not k.startswith("stage_")]
    )
    jobs = _figures(ctx)
    if jobs:
        lines += ["## Plots", ""]
    for name, caption, _ in jobs:
        lines += [f"![{caption}]({name})", "", f"*{caption}*", ""]
    files += [_draw_one(name, make, out_dir) for name, _, make in jobs]
    if ctx.trajectory is not None:
        motion_lines, written = _motion_file(ctx.robot, ctx.trajectory, out_dir, ctx)
        lines += motion_lines
        files += [out_dir / MOTION_FILE] if written else []
    report = out_dir / "report.md"
    atomic_write(report, "\n".join(lines))
    return [report, *files]


#: The planned motion's 3D animation, written beside report.md (:func:`_motion_file`).
MOTION_FILE = "motion.html"


def _motion_file(robot, trajectory, out_dir: Path, ctx=None) -> tuple[list[str], bool]:
    """Write the planned motion as a self-contained 3D animation (:data:`MOTION_FILE`, see
    :func:`armlab.viz.animate`) with the study's obstacles, floor and closest pair
    (:func:`armlab.study.environment.environment`): the report's lines linking it, and whether
    it was written; when meshcat is missing or fails, one line saying so (never an error)."""
    lines = ["## 3D motion", ""]
    try:
        import warnings

        from armlab.study.environment import environment
        from armlab.viz import animate

        env = environment(ctx) if ctx is not None else {}
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            scene = animate(robot, trajectory, out_dir / MOTION_FILE, **env)
    except Exception as exc:  # the study never fails for its 3D view
        why = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        return lines + [f"3D animation not written: {why}", ""], False
    notes = "; ".join(str(w.message) for w in caught)
    lines.append(
        f"[3D animation of the planned motion]({MOTION_FILE}) (open in a browser; "
        f"{scene.n_frames} frames at {scene.fps:g} fps)" + (f"; {notes}" if notes else ".")
    )
    if env.get("closest") is not None:
        cp = env["closest"]
        shown = [f"{len(env['obstacles'])} obstacle(s)"] if env["obstacles"] else []
        shown += [] if env["floor_z_m"] is None else ["the floor"]
        lines.append(
            (f"Drawn with {' and '.join(shown)}; the" if shown else "The")
            + f" red line marks the closest pair, {cp.a} and {cp.b}, "
            f"{cp.distance_m * 1e3:.1f} mm apart at t = {cp.time_s:.3f} s."
        )
    return lines + [""], True


def _robot_lines(ctx: StudyContext) -> list[str]:
    """The robot section: name, joints, payload, mass and the drive train."""
    r = ctx.robot
    lines = [
        "## Robot",
        "",
        f"{r.name}: {r.n_joints} joints, payload "
        f"{_fmt(r.payload.mass_kg)} kg, moving mass {_fmt(r.total_mass_kg)} kg.",
        "",
    ]
    if ctx.decisions:
        lines += ["Decided before the first stage (the study's key, its value, and why):", ""]
        lines += _table(["key", "value", "how"], [[d.key, d.value, d.how] for d in ctx.decisions])
        lines.append("")
    if r.drives is not None:
        lines += _table(
            ["joint", "motor", "reducer", "ratio", "available torque [N m]"],
            [
                [j, d.motor.model, d.reducer.model, d.reducer.ratio, d.available_torque_Nm]
                for j, d in r.drives.items()
            ],
        )
    return lines


def _kinematics_lines(ctx: StudyContext) -> list[str]:
    """The kinematics section: the waypoints, the reach and each waypoint's tool position."""
    assert ctx.tcp_positions_m is not None  # the kinematics stage ran
    lines = [
        "## Kinematics",
        "",
        f"{len(ctx.tcp_positions_m)} waypoints ({ctx.waypoints_from}),"
        f" all inside the joint ranges; max reach {ctx.max_reach_m * 1000:.1f} mm.",
        "",
    ]
    return lines + _table(
        ["waypoint", "x [mm]", "y [mm]", "z [mm]"],
        [[k, *(f"{x:.1f}" for x in 1000 * p + 0.0)] for k, p in enumerate(ctx.tcp_positions_m)],
    )


def _plan_lines(ctx: StudyContext) -> list[str]:
    """The trajectory section: planner, duration and the peak ratio to each limit."""
    traj, report, plan = ctx.trajectory, ctx.limit_report, ctx.spec.plan
    assert traj is not None and report is not None and ctx.waypoints_q is not None
    lines = [
        "## Trajectory",
        "",
        f"Planner `{plan.planner}` ({traj.method}): "
        f"{traj.duration:.4f} s through {len(ctx.waypoints_q)} waypoints, speed scale "
        f"{plan.speed_scale:g}; checked every {plan.check_dt_s * 1000:g} ms.",
        "",
        "Peak ratio to each limit (<= 1 is feasible):",
        "",
    ]
    kinds = list(report.ratios)
    return lines + _table(
        ["joint", *kinds],
        [
            [j, *(float(report.ratios[k][i]) for k in kinds)]
            for i, j in enumerate(report.joint_names)
        ],
    )


def _tracking_lines(res: TrackingResult, diagnosis: dict[str, Any] | None) -> list[str]:
    """The tracking section: the simulation's setting, the TCP error against the budget, the
    drive model, the diagnosis of a miss, and per joint error, voltage and current."""
    quantised = bool(res.meta.get("quantise", True))
    lines = [
        f"Feed-forward {', '.join(res.feedforward) or 'none'}; "
        f"{_fmt(float(res.t[-1] - res.t[0]))} s simulated at "
        f"{_fmt(1e3 * res.sample_time_s)} ms"
        f"{' with D/A and encoder quantisation' if quantised else ''}.",
        "",
        f"TCP error: max {_fmt(1e3 * res.tcp_max_error_m)} mm, final "
        f"{_fmt(1e3 * float(res.tcp_error_m[-1]))} mm; servo budget "
        f"{_fmt(1e3 * res.accuracy_m)} mm -> "
        f"{'within' if res.within_accuracy else 'OUTSIDE'} the budget.",
        "",
    ]
    model = res.model
    if model:
        lines += [
            "Drive model: "
            + ", ".join(
                [
                    "supply-voltage limit with back-EMF"
                    if model.get("voltage_limit")
                    else "NO supply-voltage limit",
                    "reducer efficiency and friction"
                    if model.get("losses")
                    else "NO reducer losses",
                    f"controller `{model.get('controller')}` "
                    f"({model.get('dac_bits')}-bit +-{_fmt(model.get('dac_range_V'))} V D/A, "
                    "current loop every "
                    f"{_fmt(1e6 * model.get('current_sample_time_s', 0))} us)",
                ]
            )
            + ".",
            "",
        ]
    if diagnosis is not None:
        lines += [
            f"Limiting factor: {diagnosis.get('limiting_factor')}.",
            f"What fixes it: {diagnosis.get('offer')}.",
            "",
        ]

    def per_joint(x: np.ndarray | None, k: int) -> float | None:
        return None if x is None else float(x[k])

    return lines + _table(
        [
            "joint",
            "max error [rad]",
            "final error [rad]",
            "peak voltage [V]",
            "asked [V]",
            "supply [V]",
            "saturated [s]",
            "peak current [A]",
        ],
        [
            [
                joint,
                float(res.max_error_rad[k]),
                float(res.final_error_rad[k]),
                per_joint(res.peak_voltage_V, k),
                per_joint(res.peak_voltage_demand_V, k),
                per_joint(res.supply_voltage_V, k),
                float(res.saturation_time_s[k]),
                per_joint(res.peak_current_A, k),
            ]
            for k, joint in enumerate(res.joint_names)
        ],
    )


def _control_lines(gains: ArmGains) -> list[str]:
    """The tuning section: per joint and loop the gains and the worst-case figures."""
    from armlab.control.gains import LOOPS

    rows = []
    for cascade in gains:
        for loop in LOOPS:
            g = getattr(cascade, loop)
            rows.append(
                [
                    cascade.joint,
                    loop,
                    g.kp,
                    g.ki,
                    g.crossover_rad_s,
                    g.phase_margin_deg,
                    g.gain_margin_dB,
                    g.phase_margin_discrete_deg,
                    g.overshoot_pct,
                    g.sample_time_s,
                ]
            )
    return _table(
        [
            "joint",
            "loop",
            "kp",
            "ki",
            "crossover [rad/s]",
            "PM [deg]",
            "GM [dB]",
            "PM discrete [deg]",
            "overshoot [%]",
            "T [s]",
        ],
        rows,
    ) + _resonance_lines(gains)


def _resonance_lines(gains: ArmGains) -> list[str]:
    """Each joint's first resonance and anti-resonance (reducer stiffness K1, per inertia case
    min / nominal / max) beside its speed and position crossovers."""

    def cases(d: dict) -> str:
        vals = [d.get(c) for c in ("min", "nominal", "max")]
        return " / ".join("-" if v is None else f"{v:.4g}" for v in vals)

    rows = []
    for cascade in gains:
        res = cascade.summary().get("resonance")
        if not isinstance(res, dict):
            continue
        rows.append(
            [
                cascade.joint,
                cases(res["first_rad_s"]),
                cases(res["anti_rad_s"]),
                cascade.speed.crossover_rad_s,
                cascade.position.crossover_rad_s,
                "two-mass" if res["compliant"] else "rigid",
            ]
        )
    if not rows:
        return []
    return [
        "Joint resonances (reducer stiffness K1; min / nominal / max inertia; - : no stiffness "
        "data):",
        "",
        *_table(
            [
                "joint",
                "first resonance [rad/s]",
                "anti-resonance [rad/s]",
                "speed crossover [rad/s]",
                "position crossover [rad/s]",
                "tuned on",
            ],
            rows,
        ),
    ]


def _export_lines(ctx: StudyContext) -> list[str]:
    """The export section: the set-point table's cycles and the files written with their
    sha256, or the controller limit the table breaks."""
    prof = ctx.controller
    table = ctx.setpoints
    if table is None:
        broken = [f for f in ctx.failed_so_far if f.startswith("export:")]
        return [
            f"No set-point table for controller profile `{prof.name}` "
            f"({_fmt(1e3 * prof.cycle_s)} ms cycle): {'; '.join(broken) or 'not built'}.",
            "",
        ]
    lines = [
        f"{_fmt(table.n_cycles)} cycles of {_fmt(1e3 * prof.cycle_s)} ms "
        f"for controller profile `{prof.name}`; every cycle passed the "
        "pre-flight checks (range, speed, pulses per cycle, continuity).",
        "",
    ]
    if ctx.exported:
        lines += _table(["file", "sha256"], [[n, f"`{h}`"] for n, h in ctx.exported.items()])
    return lines


# ---------------------------------------------------------------------------- text
def _stage_line(result: StudyResult, stage: str) -> str:
    """One stage's line of the one-screen summary: status, verdict and its key figures."""
    rec = result.stages.get(stage)
    if rec is None:  # the study stopped before it
        return f"  {stage:<12}{'-':<9}{'-':<6}"
    ctx, kf = result.context, result.key_figures()
    text = rec.note
    if rec.status == "ok":
        text = _stage_figures(stage, ctx, kf)
    if len(text) > 56:
        text = text[:53] + "..."
    verdict = rec.verdict or "-"
    return f"  {stage:<12}{rec.status:<9}{verdict.upper():<6}{text}"


def _stage_figures(stage: str, ctx: StudyContext, kf: dict[str, Any]) -> str:
    """The key figures of a stage that ran, from its typed result."""
    if stage == "kinematics" and ctx.waypoints_q is not None:
        return f"{len(ctx.waypoints_q)} waypoints in range; reach {kf['max_reach_m'] * 1000:.0f} mm"
    if stage == "plan" and ctx.trajectory is not None and ctx.limit_report is not None:
        kind, joint, ratio = ctx.limit_report.worst()
        return (
            f"{ctx.trajectory.method or ctx.spec.plan.planner} {ctx.trajectory.duration:.3f} s;"
            f" worst {kind} {ratio:.3f} ({joint})"
        )
    if stage == "static_load" and ctx.static_load is not None:
        worst = max(ctx.static_load.joints, key=lambda x: x.torque_Nm)
        return f"max {worst.torque_Nm:.4g} N m ({worst.joint})"
    if stage == "sizing":
        return (
            ("all checks pass" if kf.get("sizing_ok") else "CHECKS FAIL")
            + f"; min margin {_fmt(kf.get('sizing_min_margin'), 3)}"
            + f" ({kf.get('sizing_binding')})"
        )
    if stage == "tuning":
        return (
            f"min PM {_fmt(kf.get('min_phase_margin_deg'), 3)} deg, min GM "
            f"{_fmt(kf.get('min_gain_margin_dB'), 3)} dB"
        )
    if stage == "tracking" and ctx.tracking is not None:
        res = ctx.tracking
        return (
            f"max joint error {_fmt(1e3 * float(res.max_error_rad.max()), 3)} "
            f"mrad; TCP {_fmt(1e3 * res.tcp_max_error_m, 3)} mm (budget "
            f"{_fmt(1e3 * res.accuracy_m, 3)} mm)"
        )
    if stage == "export":
        n = "-" if ctx.setpoints is None else _fmt(ctx.setpoints.n_cycles)
        return f"{n} cycles of {ctx.controller.cycle_s * 1000:g} ms ({ctx.controller.name})"
    return ""


def remedies_lines(block: dict[str, Any] | None) -> list[str]:
    """The measured remedies of summary ``remedies``, ranked (none: no lines)."""
    if not block:
        return []
    measured = block["measured"]
    head = (
        f"remedies: {len(measured)} of {block['candidates']} candidate(s) measured "
        f"(limit {block['limit']}), each a study run with the keys changed; best first"
    )
    if not measured:
        return [head + ": none could run"]
    return [head] + [f"  {k + 1}. {r['text']}" for k, r in enumerate(measured)]


def summary_text(result: StudyResult) -> str:
    """The one-screen summary ``armlab run`` prints: each stage, its key figures, the files."""
    from armlab.study.spec import STAGES

    robot, spec = result.robot, result.spec
    lines = [
        f"armlab study {spec.study.name!r}: robot {robot.name} ({robot.n_joints} "
        f"joints), payload {_fmt(robot.payload.mass_kg)} kg",
        f"  {'stage':<12}{'status':<9}{'check':<6}key figures",
    ]
    lines += [_stage_line(result, s) for s in STAGES]
    lines += result.design.lines()
    lines += remedies_lines(result.summary.get("remedies"))
    if result.files:
        names = list(dict.fromkeys(Path(f).name for f in result.files))
        pngs = [n for n in names if n.endswith(".png")]
        names = [n for n in names if not n.endswith(".png")]
        if pngs:
            names.append(f"{len(pngs)} PNG plots")
        where = f"{result.out_dir}/" if result.out_dir is not None else ""
        lines.append(f"files in {where}: " + ", ".join(names))
    return "\n".join(lines)
