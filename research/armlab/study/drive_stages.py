"""The stages of a study that judge the drives: static load, sizing (with the catalogue
selection), servo tuning and closed-loop tracking (:mod:`armlab.study.stages` holds the chain
and the other stages; its docstring says what a stage returns)."""

from __future__ import annotations

import inspect
import math
from typing import Any

from armlab.study.build import _catalogue
from armlab.study.context import NotApplicable, StudyContext, jsonable, jsonable_block
from armlab.study.verdict import StageOutput

__all__ = [
    "stage_static_load",
    "stage_sizing",
    "stage_tuning",
    "stage_tracking",
    "select_and_install",
    "selection_duty",
    "sizing_failures",
    "sizing_options",
    "sizing_keywords",
    "tuning_options",
    "tracking_options",
]


def stage_static_load(ctx: StudyContext) -> StageOutput:
    """Worst-case static holding torque per joint (HEU thesis 4.2.1) with the payload.

    The worst case is a requirement of the drive train, not of the study's motion: a joint whose
    worst-case torque exceeds its torque limit is listed under ``advisories`` (and in the
    summary), while the verdict judges the planned duty cycle (sizing stage).
    """
    from armlab.dynamics import static_load

    res = static_load(ctx.robot, seed=ctx.spec.study.seed)
    ctx.static_load = res
    limit = ctx.robot.limits.effort_Nm
    advisories = []
    for j, x in enumerate(res.joints):
        lim = float(limit[j]) if limit is not None else math.inf
        if math.isfinite(lim) and x.torque_Nm > lim * (1 + 1e-9):
            advisories.append(
                f"static_load: {x.joint} worst-case {x.torque_Nm:.4g} N m > {lim:.4g} N m "
                "available (torque limit)"
            )
    return StageOutput(jsonable_block(res), advisories=advisories)


def _needs_drives(ctx: StudyContext) -> None:
    if ctx.robot.drives is None:
        raise NotApplicable(
            f"{ctx.robot.name} has no drive train (no drives.toml: give [robot] drives = "
            "<drives file>, [drives.<joint>] catalogue names, or [sizing] select = true)"
        )


def sizing_options(ctx: StudyContext, *, duty: bool = True) -> dict[str, Any]:
    """The :func:`~armlab.dynamics.size` (and :func:`~armlab.dynamics.select_drives`) options
    of the study's ``[sizing]`` table: the duty cycle's dwell (``duty``: the study's cycle;
    False for the worst-case requirement moves, which have none), the thermal check's cycles
    and ambient, the inertia-ratio rule (left out: reported only), the reducers' required life
    (none for the requirement moves) and momentary load case."""
    return sizing_keywords(ctx.spec.sizing, duty=duty)


def sizing_keywords(s, *, duty: bool = True) -> dict[str, Any]:
    """:func:`sizing_options` of a :class:`~armlab.study.spec.SizingSpec` (also what
    ``armlab export`` re-checks a recorded design with)."""
    opts: dict[str, Any] = {
        "ambient_degC": s.ambient_degC,
        "max_inertia_ratio": math.inf if s.max_inertia_ratio is None else s.max_inertia_ratio,
        "momentary_load": s.momentary_load,
        # life is a figure of the repeated duty cycle: the worst-case moves ask none (0 h)
        "required_life_h": s.required_life_h if duty else 0.0,
    }
    if duty:
        opts.update(dwell_s=s.dwell_s, cycles=s.cycles)
    return opts


def _thermal_block(ctx: StudyContext) -> dict[str, Any]:
    """What the thermal and inertia-ratio checks assumed (summary ``sizing.thermal``)."""
    s = ctx.spec.sizing
    return {
        "ambient_degC": s.ambient_degC,
        "ambient_source": "study"
        if "ambient_degC" in ctx.spec.document.get("sizing", {})
        else "ASSUMED 25 degC: the motor makers' rating condition",
        "dwell_s": s.dwell_s,
        "dwell_at": "the cycle's last pose, at rest, before the cycle repeats",
        "cycles": "periodic" if s.cycles is None else s.cycles,
        "max_inertia_ratio": s.max_inertia_ratio,
    }


def selection_duty(ctx: StudyContext) -> list:
    """The duty cycle a selection is made for: the planned motion plus a 1 s hold at each
    joint's worst static pose (:func:`armlab.dynamics.selection.hold_trajectories`; the static
    load stage's result, computed here if that stage did not run)."""
    from armlab.dynamics import static_load
    from armlab.dynamics.selection import hold_trajectories

    static = ctx.static_load
    if static is None:
        static = static_load(ctx.robot, seed=ctx.spec.study.seed)
    return [ctx.trajectory, *hold_trajectories(ctx.robot, static)]


def select_and_install(ctx: StudyContext) -> list:
    """Select every joint's motor + reducer from the catalogue so that the study's later stages
    pass with them (:func:`armlab.study.drive_choice.choose_drives`: select -> limits -> plan
    until stable, tunable loops, the tracking verdict) and make them the robot's drive train.
    Returns the duty cycle of the final plan (:func:`selection_duty`).

    Raises
    ------
    InfeasibleError
        A joint for which no catalogue entry passes, naming the check every candidate fails, or
        a choice that does not settle.
    """
    from armlab.study.drive_choice import choose_drives

    assert ctx.controller is not None  # run_study sets it before the stages
    choose_drives(ctx)
    return selection_duty(ctx)


def sizing_failures(report, only: tuple[str, ...] | None = None) -> list[str]:
    """One line per failed sizing check of a :class:`~armlab.dynamics.SizingReport` (of the
    checks named in ``only``, if given)."""
    return [
        f"sizing: {j.joint} {c.describe()}"
        for j in report.joints
        for c in j.checks
        if not c.ok and (only is None or c.name in only)
    ]


def stage_sizing(ctx: StudyContext) -> StageOutput:
    """Drive sizing checks along the planned trajectory, against the study's controller (encoder
    checks at its cycle and pulse limit); the worst-case requirement moves of HEU thesis tables
    4.2/4.3 beside them (advisories); optional selection from a catalogue.

    A robot without a drive train and ``[sizing] select = true``: the drives are first selected
    from the catalogue (:func:`select_and_install`) against the planned motion plus a hold at
    each joint's worst static pose, become the robot's drive train for the later stages, and are
    sized on that same duty cycle.
    """
    from armlab.dynamics import requirement_moves, select_drives, size

    assert ctx.controller is not None  # run_study sets it before the stages
    duty = [ctx.trajectory]
    if ctx.robot.drives is None and ctx.spec.sizing.select:
        duty = select_and_install(ctx)
    _needs_drives(ctx)
    res = size(
        ctx.robot,
        duty,
        dt=ctx.spec.plan.check_dt_s,
        controller=ctx.controller,
        **sizing_options(ctx),
    )
    ctx.sizing = res
    block = jsonable_block(res)
    block["thermal"] = _thermal_block(ctx)
    advisories = None
    if ctx.drives_selected:
        block["duty_cycle"] = (
            "planned motion + 1 s hold at each joint's worst static pose (the selection's)"
        )
        block["selection"] = {"status": "ok", "installed": True, **jsonable_block(ctx.selection)}
    if ctx.static_load is not None:
        # HEU thesis tables 4.2/4.3: the drives against each joint's worst case (full speed and
        # acceleration from its worst static pose), beside the planned cycle
        moves = requirement_moves(ctx.robot, ctx.static_load)
        ctx.requirement_sizing = size(
            ctx.robot, moves, controller=ctx.controller, **sizing_options(ctx, duty=False)
        )
        adv = [
            f.replace("sizing:", "worst-case move:", 1)
            for f in sizing_failures(ctx.requirement_sizing)
        ]
        block["requirement_moves"] = {
            "ok": bool(ctx.requirement_sizing.ok),
            "failures": [f"{joint}:{check}" for joint, check in ctx.requirement_sizing.failures()],
        }
        advisories = adv
    if ctx.spec.sizing.select and not ctx.drives_selected:
        sel = select_drives(
            ctx.robot,
            [ctx.trajectory],
            catalogue=_catalogue(ctx.spec),
            dt=ctx.spec.plan.check_dt_s,
            controller=ctx.controller,
            **sizing_options(ctx),
            allow_estimated=ctx.spec.sizing.allow_estimated,
        )
        ctx.selection = sel
        block["selection"] = {"status": "ok", **jsonable_block(sel)}
    return StageOutput(block, failed_checks=sizing_failures(res), advisories=advisories)


# ---------------------------------------------------------------------------- control
def _tuning_failures(gains, spec: dict) -> list[str]:
    """Loops whose worst-case margins miss the spec (continuous or discrete)."""
    pm_req = float(spec.get("phase_margin_deg", math.nan))
    gm_req = float(spec.get("gain_margin_dB", math.nan))
    out = []
    for joint, loops in gains.summary().items():
        for loop, fig in loops.items():
            if not isinstance(fig, dict):
                continue
            for key, req, unit in (
                ("phase_margin_deg", pm_req, "deg"),
                ("phase_margin_discrete_deg", pm_req, "deg"),
                ("gain_margin_dB", gm_req, "dB"),
                ("gain_margin_discrete_dB", gm_req, "dB"),
            ):
                v = fig.get(key)
                if isinstance(v, (int, float)) and math.isfinite(req) and v < req - 1e-6:
                    out.append(f"tuning: {joint} {loop} {key} {v:.4g} < {req:.4g} {unit}")
    return out


def tuning_options(ctx: StudyContext) -> dict[str, Any]:
    """The :func:`~armlab.control.tune_arm` options of the study's ``[control]`` table (those
    it sets; the others keep ``tune_arm``'s defaults) and seed."""
    c = ctx.spec.control
    options = {
        "position_bandwidth_rad_s": c.position_bandwidth_rad_s,
        "rise_time_s": c.rise_time_s,
        "phase_margin_deg": c.phase_margin_deg,
        "gain_margin_dB": c.gain_margin_dB,
        "overshoot_pct": c.overshoot_pct,
        "method": c.method,
        "current_sample_time_s": c.current_sample_time_s,
        "n_inertia_samples": c.n_inertia_samples,
        "seed": ctx.spec.study.seed,
        # the two-mass joint: [control] compliant, else as [tracking] compliant
        "compliant": (
            (c.compliant if c.compliant is not None else ctx.spec.tracking.compliant) or None
        ),
    }
    return {k: v for k, v in options.items() if v is not None}


def stage_tuning(ctx: StudyContext) -> StageOutput:
    """Robust cascade tuning of every joint (current PI, speed PI, position P) to the study's
    control specs, discretised at the controller's servo period and checked continuous and
    discrete over each joint's inertia range."""
    from armlab.control import tune_arm

    _needs_drives(ctx)
    done = ctx.verified
    if done is not None and done["drives"] is ctx.robot.drives:  # tuned by the selection
        gains = done["gains"]
    else:
        gains = tune_arm(ctx.robot, controller=ctx.controller, **tuning_options(ctx))
    ctx.gains = gains
    block = {"servo_period_s": ctx.controller.servo_period_s, **jsonable(gains.summary())}
    return StageOutput(block, failed_checks=_tuning_failures(gains, gains.spec))


def tracking_options(ctx: StudyContext) -> dict[str, Any]:
    """The :func:`~armlab.control.simulate_tracking` options of the study's ``[tracking]``
    table and controller: the full drive model (supply-voltage limit with back-EMF, reducer
    efficiency and friction, the controller's servo period, D/A and encoder)."""
    t = ctx.spec.tracking
    ff = t.feedforward if t.feedforward is None or t.feedforward == "none" else tuple(t.feedforward)
    opts: dict[str, Any] = {"quantise": t.quantise}
    if ff is not None:
        opts["feedforward"] = ff
    if t.t_after_s is not None:
        opts["t_after_s"] = t.t_after_s
    if t.accuracy_m is not None:
        opts["accuracy_m"] = t.accuracy_m
    opts["controller"] = ctx.controller
    return opts


def stage_tracking(ctx: StudyContext) -> StageOutput:
    """Closed-loop simulation of the arm tracking the plan with the tuned cascades; the verdict
    is the TCP error against the accuracy budget."""
    from armlab.control import simulate_tracking
    from armlab.study.budget import check_samples

    _needs_drives(ctx)
    opts = tracking_options(ctx)
    assert ctx.trajectory is not None and ctx.controller is not None  # NEEDS: plan
    # simulate_tracking's own default where the study gives none (one home)
    default = inspect.signature(simulate_tracking).parameters["t_after_s"].default
    t_after = float(opts.get("t_after_s", default))
    period = ctx.controller.servo_period_s
    check_samples(
        (ctx.trajectory.duration + t_after) / period,
        ctx.robot.n_joints,
        f"tracking.t_after_s = {t_after:g}, controller.servo_period_s = {period:g}",
        f"({ctx.trajectory.duration:.3g} s plan + {t_after:g} s after) / {period:g} s servo period",
    )
    compliant = bool(ctx.spec.tracking.compliant)
    done = ctx.verified
    if done is not None and done["drives"] is ctx.robot.drives and done["gains"] is ctx.gains:
        res = done["tracking"]  # simulated by the selection (the same plan, gains, options)
    else:
        res = simulate_tracking(ctx.robot, ctx.trajectory, ctx.gains, **opts, compliant=compliant)
    # the diagnosis' and the report's drive-model variants are of the rigid joint
    ctx.tracking, ctx.tracking_options, ctx.tracking_variants = res, opts, {}
    failed = []
    block: dict[str, Any] = {}
    if compliant:  # the rigid joint beside it, same gains and options
        rigid = simulate_tracking(ctx.robot, ctx.trajectory, ctx.gains, **opts)
        block["rigid_joint"] = {
            "tcp_max_error_m": rigid.tcp_max_error_m,
            "max_error_rad": {
                n: float(e) for n, e in zip(rigid.joint_names, rigid.max_error_rad, strict=True)
            },
        }
    if not res.within_accuracy and compliant:
        # the diagnosis' variants are of the rigid joint: name the compliance instead
        rigid_mm = block["rigid_joint"]["tcp_max_error_m"] * 1e3
        failed.append(
            f"tracking: TCP error {res.tcp_max_error_m * 1e3:.4g} mm > budget "
            f"{res.accuracy_m * 1e3:.4g} mm with the compliant joint (tracking.compliant; the "
            f"rigid joint with the same gains: {rigid_mm:.4g} mm): the reducers' windup between "
            "the motor encoder and the link"
        )
    elif not res.within_accuracy:
        from armlab.control.diagnosis import diagnose_tracking

        diag = diagnose_tracking(
            ctx.robot, ctx.trajectory, ctx.gains, res, cache=ctx.tracking_variants, **opts
        )
        block["diagnosis"] = diag
        ctx.diagnosis = diag
        failed.append(
            f"tracking: TCP error {res.tcp_max_error_m * 1e3:.4g} mm > budget "
            f"{res.accuracy_m * 1e3:.4g} mm; limiting factor: {diag['limiting_factor']}; "
            f"{diag['offer']}"
        )
    return StageOutput({**jsonable_block(res), **block}, failed_checks=failed)
