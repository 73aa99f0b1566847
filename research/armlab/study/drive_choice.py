"""A drive selection that passes every stage of the study it is made for.

:func:`armlab.dynamics.select_drives` ranks each joint's catalogue motor + reducer pairs by the
sizing checks on a given duty cycle. A study's later stages judge more than sizing, and the
chosen drives change the limits the motion is planned with; :func:`choose_drives` closes that
loop:

1. **select -> limits -> plan until stable.** The drives chosen on the plan become the robot's
   drive train, its limits are resolved again (motor speed / ratio, available torque) and the
   motion is planned again with them; the selection is made again on the new plan, until it
   chooses the drives the plan was made with (:attr:`Selection.rounds` counts the selections).
   Then the chosen drives pass sizing on the plan they produce -- the plan ``armlab run`` makes
   with the drives file ``armlab drives`` writes. A choice that comes back after a different one
   is a cycle: one line (:class:`InfeasibleError`), as is no stable choice in
   :data:`MAX_ROUNDS` rounds.
2. **Tunable at the controller's periods.** Each chosen drive's cascade is tuned as the tuning
   stage will (:func:`armlab.control.tune_cascade`, the study's ``[control]`` and the
   controller's periods); a pair whose loops miss the spec (e.g. a current loop at -180 deg
   phase margin at a 50 us current period) is passed over for the joint's next candidate by the
   ranking key, with the reason (:attr:`Selection.skipped`).
3. **The tracking verdict.** The final choice is tuned and its tracking simulated as the tracking
   stage will; when the TCP error misses the budget, the **limiting joint** -- the largest share
   ``max |e_j| * lever_j`` of the TCP error (joint error times its lever arm,
   :func:`armlab.dynamics.sizing.lever_arms_m`) -- gets its next candidate by the rule: *the
   first by the ranking key among the pairs with more available torque than the one that
   failed; when none of them passes, among those with more available torque or a smaller
   load-to-motor inertia ratio (more reflected inertia)* (:func:`stronger`: more torque, or an
   inertia range the robust loops span more tightly, for a faster position loop), and steps
   1-3 run again, at most :data:`MAX_TRACKING_TRIES` times.
   When none tracks within the budget, the choice with the smallest measured TCP error is kept
   (:attr:`Selection.notes`) and the tracking stage reports its miss.

A study's ``[drives.<joint>]`` tables work beside ``[sizing] select = true``
(:func:`study_rules`): a motor or reducer named there is the only one that joint is selected
from, and the numbers given (ratio, efficiency, encoder, derating) are put into every candidate
before it is checked.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab.errors import ArmlabError, InfeasibleError
from armlab.study.build import _catalogue, _resolve_robot_limits, changed_values
from armlab.study.context import StudyContext

if TYPE_CHECKING:
    from armlab.dynamics.selection import Selection
    from armlab.robot.drives import Drive
    from armlab.robot.model import Robot

__all__ = [
    "MAX_ROUNDS",
    "MAX_TRACKING_TRIES",
    "choose_drives",
    "limiting_joint",
    "stronger",
    "study_rules",
]

#: select -> limits -> plan rounds before a choice that does not settle is refused
MAX_ROUNDS = 6
#: next candidates tried on the limiting joint after a tracking miss
MAX_TRACKING_TRIES = 3

Rule = Callable[["Drive"], "Drive | None"]


def study_rules(spec, catalogue) -> dict[str, Rule]:
    """Per joint, the rule of its ``[drives.<joint>]`` table for :func:`select_drives`: only the
    motor / reducer it names (catalogue names, checked here: one line naming the key), with its
    numbers put in (:func:`armlab.study.build.changed_values`)."""
    rules: dict[str, Rule] = {}
    for joint, change in spec.drives.items():
        where = f"drives.{joint}"
        if change.motor is not None:
            catalogue.motor(change.motor, f"{where}.motor")
        if change.reducer is not None:
            catalogue.reducer(change.reducer, f"{where}.reducer")

        def rule(d, change=change):
            if change.motor is not None and d.motor.model != change.motor:
                return None
            if change.reducer is not None and d.reducer.model != change.reducer:
                return None
            return changed_values(d, change)

        rules[joint] = rule
    return rules


def _pair(d: Drive) -> str:
    return f"{d.motor.model} + {d.reducer.model}"


def stronger(d: Drive, torque_Nm: float, reflected_kg_m2: float, inertia: bool = True) -> bool:
    """The bump rule: more available torque than a pair that failed, or (``inertia``) a smaller
    load-to-motor inertia ratio: more reflected inertia ``(J_rotor + J_reducer) N^2`` against
    the same arm."""
    more_torque = d.available_torque_Nm > torque_Nm * (1 + 1e-9)
    return more_torque or (inertia and d.reflected_inertia_kg_m2 > reflected_kg_m2 * (1 + 1e-9))


@dataclass
class _Choice:
    """What the loop has learned: the study's rules, the pairs passed over (by joint) and the
    floors a tracking miss set on a joint: (available torque [N m], reflected inertia
    [kg m^2], whether the inertia counts) of each pair that failed (:func:`stronger`)."""

    rules: dict[str, Rule]
    passed_over: dict[str, set[tuple[str, str, float]]] = field(default_factory=dict)
    floors: dict[str, list[tuple[float, float, bool]]] = field(default_factory=dict)
    skipped: dict[str, list[str]] = field(default_factory=dict)
    tunable: dict[tuple[str, Drive], str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    #: the cascade gains of each tunable (joint, drive), for the tracking check's tuning
    gains: dict[tuple[str, Drive], Any] = field(default_factory=dict)

    def copy(self) -> _Choice:
        """A copy whose exclusions can change apart (the tuning verdicts are shared)."""
        return _Choice(
            self.rules,
            {j: set(v) for j, v in self.passed_over.items()},
            {j: list(v) for j, v in self.floors.items()},
            {j: list(v) for j, v in self.skipped.items()},
            self.tunable,
            list(self.notes),
            self.gains,
        )

    def rule(self, joint: str) -> Rule:
        base = self.rules.get(joint)
        out = self.passed_over.get(joint, set())
        floors = list(self.floors.get(joint, []))

        def keep(d: Drive) -> Drive | None:
            d2 = d if base is None else base(d)
            if d2 is None or (d2.motor.model, d2.reducer.model, d2.reducer.ratio) in out:
                return None
            return d2 if all(stronger(d2, *f) for f in floors) else None

        return keep

    def widen(self, joint: str) -> bool:
        """The bump rule's fallback on ``joint``: its last floor accepts a smaller inertia
        ratio too. False when it already did."""
        floors = self.floors.get(joint)
        if not floors or floors[-1][2]:
            return False
        floors[-1] = (*floors[-1][:2], True)
        return True

    def pass_over(self, joint: str, d: Drive, why: str) -> None:
        self.passed_over.setdefault(joint, set()).add(
            (d.motor.model, d.reducer.model, d.reducer.ratio)
        )
        self.skipped.setdefault(joint, []).append(f"{_pair(d)}: {why}")


def _left_out(ctx: StudyContext, catalogue) -> str:
    """What a study without ``[sizing] allow_estimated`` left out of the selection (the parts
    with values not read from a published source), so a user sees what would widen it."""
    if ctx.spec.sizing.allow_estimated:
        return ""
    n = len(catalogue.combinations(True)) - len(catalogue.combinations(False))
    if n <= 0:
        return ""
    return (
        f"; {n} catalogue pairs with estimated values were left out ([sizing] allow_estimated "
        "= true admits them, docs/catalogue.md says which values are estimated)"
    )


def _passed(state: _Choice, joint: str) -> str:
    """What a joint's pairs passed over by the later stages were (for the line of a joint
    left without one)."""
    lines = state.skipped.get(joint, [])
    if not lines:
        return ""
    return f"; {len(lines)} pair(s) passed over by the later stages, the last: {lines[-1]}"


def _installed(ctx: StudyContext, base: Robot, drives: dict) -> Robot:
    """``base`` with ``drives`` and its limits resolved again (as a drives file would give)."""
    robot = base.copy()
    robot.drives = dict(drives)
    _resolve_robot_limits(robot, ctx.spec)
    return robot


def _tuning_spec(ctx: StudyContext) -> dict[str, Any]:
    from armlab.control.spec import controller_spec
    from armlab.study.drive_stages import tuning_options

    return controller_spec(ctx.controller, tuning_options(ctx))


def _untunable(ctx: StudyContext, robot: Robot, joint: str, state: _Choice, inertias) -> str:
    """Why ``joint``'s drive on ``robot`` cannot be tuned to the study's spec ("" if it can)."""
    from armlab.control import tune_cascade

    key = (joint, robot.drive(joint))
    if key not in state.tunable:
        try:
            gains = tune_cascade(robot, joint, inertias=inertias, **_tuning_spec(ctx))
            state.tunable[key] = ""
            state.gains[key] = gains
        except ArmlabError as exc:
            state.tunable[key] = f"tuning: {exc}"
    return state.tunable[key]


def _select(ctx: StudyContext, base: Robot, catalogue, state: _Choice, inertias) -> Selection:
    """The selection on the current plan, each chosen drive tunable (step 2)."""
    from armlab.dynamics import select_drives
    from armlab.study.drive_stages import selection_duty, sizing_options

    duty = selection_duty(ctx)
    while True:
        sel = select_drives(
            base,
            duty,
            catalogue=catalogue,
            dt=ctx.spec.plan.check_dt_s,
            controller=ctx.controller,
            candidates={j: state.rule(j) for j in base.joint_names},
            allow_estimated=ctx.spec.sizing.allow_estimated,
            **sizing_options(ctx),
        )
        for js in sel.joints:
            if not js.ok:
                raise InfeasibleError(
                    f"drive selection: {js.why_none()}{_passed(state, js.joint)}"
                    f"{_left_out(ctx, catalogue)}"
                )
        drives = sel.drives(base)
        if inertias is None:
            return sel
        robot = _installed(ctx, base, drives)
        bad = False
        for joint in robot.joint_names:
            why = _untunable(ctx, robot, joint, state, inertias)
            if why:
                state.pass_over(joint, drives[joint], why)
                bad = True
        if not bad:
            return sel


def _stable(ctx: StudyContext, base: Robot, catalogue, state: _Choice, inertias) -> Selection:
    """Steps 1-2: select, install, re-plan until the selection chooses the drives the plan was
    made with. Sets ``ctx.robot``, ``ctx.trajectory`` and ``ctx.replanned``."""
    from armlab.study.stages import stage_plan

    seen: list[tuple] = []
    for rounds in range(1, MAX_ROUNDS + 1):
        sel = _select(ctx, base, catalogue, state, inertias)
        drives = sel.drives(base)
        choice = tuple(drives[j] for j in base.joint_names)
        if seen and choice == seen[-1]:
            sel.rounds = rounds
            return sel
        if choice in seen:
            k = seen.index(choice)
            changed = [
                f"{j} {_pair(seen[-1][i])} -> {_pair(choice[i])}"
                for i, j in enumerate(base.joint_names)
                if seen[-1][i] != choice[i]
            ]
            raise InfeasibleError(
                f"drive selection cycles: round {rounds} chooses the drives of round {k + 1} "
                f"again ({'; '.join(changed)}): each choice's plan selects the other"
            )
        seen.append(choice)
        ctx.robot = _installed(ctx, base, drives)
        t0 = time.perf_counter()
        output = stage_plan(ctx)  # the plan with the chosen drives' limits
        ctx.replanned = (output, time.perf_counter() - t0)
    raise InfeasibleError(
        f"drive selection: no stable choice after {MAX_ROUNDS} select -> limits -> plan rounds"
    )


def limiting_joint(robot: Robot, result) -> str:
    """The joint with the largest share ``max |e_j| * lever_j`` [m] of the TCP error."""
    from armlab.dynamics.sizing import lever_arms_m

    share = np.asarray(result.max_error_rad) * lever_arms_m(robot)
    return robot.joint_names[int(np.argmax(share))]


def _verify_tracking(ctx: StudyContext, state: _Choice):
    """Tune and simulate the installed drives as the tuning and tracking stages will (the
    joints the selection tuned already are kept); the result is kept for those stages
    (``ctx.verified``). None when they cannot run."""
    from armlab.control import simulate_tracking, tune_arm
    from armlab.study.drive_stages import tracking_options, tuning_options

    robot = ctx.robot
    assert robot.drives is not None  # installed by _stable
    known = {j: state.gains[(j, d)] for j, d in robot.drives.items() if (j, d) in state.gains}
    try:
        gains = tune_arm(robot, controller=ctx.controller, known=known, **tuning_options(ctx))
        result = simulate_tracking(
            ctx.robot,
            ctx.trajectory,
            gains,
            **tracking_options(ctx),
            compliant=bool(ctx.spec.tracking.compliant),
        )
    except ArmlabError:
        return None  # the stages report it
    ctx.verified = {"drives": ctx.robot.drives, "gains": gains, "tracking": result}
    return result


def _keep_best(ctx: StudyContext, base: Robot, catalogue, inertias, tried, stopped: str):
    """No choice tracked within the budget: the one with the smallest measured TCP error is
    chosen again (its state before its bump) and installed; ``(selection, state)``."""
    best = min(tried, key=lambda t: t[0])
    err, state, pair = best
    if best is tried[-1] and ctx.selection is not None:  # installed: the last one tried
        sel = ctx.selection
    else:
        sel = _stable(ctx, base, catalogue, state, inertias)
        _verify_tracking(ctx, state)
    others = [f"{p} ({e * 1e3:.3g} mm)" for e, _, p in tried if p != pair]
    state.notes.append(
        f"no candidate tracked within the budget ({stopped}); kept the best measured "
        f"({pair}: {err * 1e3:.3g} mm)" + (f" over {', '.join(others)}" if others else "")
    )
    return sel, state


def choose_drives(ctx: StudyContext) -> Selection:
    """Select the study robot's drive train so that it passes the study's later stages (the
    module's steps 1-3) and install it: ``ctx.robot`` gets the drives and their limits,
    ``ctx.trajectory`` the plan made with them (``ctx.replanned``: the plan stage's output
    again), ``ctx.selection`` the selection with its rounds and the candidates passed over.

    Raises
    ------
    InfeasibleError
        A joint without a passing catalogue entry (naming the check every candidate fails), or
        a choice that does not settle (one line).
    """
    from armlab.control.spec import TuningSpec
    from armlab.control.tuning import tuning_inertias

    catalogue = _catalogue(ctx.spec)
    base = ctx.robot.copy()
    state = _Choice(study_rules(ctx.spec, catalogue))
    stages = ctx.spec.study.stages
    inertias = None
    if "tuning" in stages:
        inertias = tuning_inertias(base, TuningSpec.from_kwargs("", **_tuning_spec(ctx)))
    tried: list[tuple[float, _Choice, str]] = []  # (TCP error, state before the bump, pairs)
    stopped = ""  # why the bumps ended without a choice that tracks
    attempt, joint = 0, ""
    while True:
        try:
            sel = ctx.selection = _stable(ctx, base, catalogue, state, inertias)
        except InfeasibleError as exc:
            if not tried:
                raise
            if state.widen(joint):  # no pair with more torque passes: the fallback
                continue
            stopped = f"the next pair up could not be chosen ({exc})"
            ctx.selection = None  # the state of the failed round: choose the best again
            break
        if "tracking" not in stages or inertias is None:
            break
        result = _verify_tracking(ctx, state)
        if result is None or result.within_accuracy:
            break
        joint = limiting_joint(ctx.robot, result)
        drive = ctx.robot.drive(joint)
        tried.append((result.tcp_max_error_m, state.copy(), f"{joint} {_pair(drive)}"))
        if attempt == MAX_TRACKING_TRIES:
            stopped = f"{len(tried)} tries"
            break
        attempt += 1
        state.floors.setdefault(joint, []).append(
            (drive.available_torque_Nm, drive.reflected_inertia_kg_m2, False)
        )
        state.pass_over(
            joint,
            drive,
            f"tracking {result.tcp_max_error_m * 1e3:.3g} mm > budget "
            f"{result.accuracy_m * 1e3:.3g} mm, {joint} the largest share (next: the first by "
            f"the ranking key with more than {drive.available_torque_Nm:.4g} N m available; "
            f"none passing: or more than {drive.reflected_inertia_kg_m2:.4g} kg m^2 reflected "
            "inertia)",
        )
    if stopped:
        sel, state = _keep_best(ctx, base, catalogue, inertias, tried, stopped)
    sel.skipped = {j: list(v) for j, v in state.skipped.items()}
    sel.notes = tuple(state.notes)
    ctx.selection = sel
    ctx.drives_selected = True
    return sel
