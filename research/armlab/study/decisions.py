"""What a study decided before its first stage, and why: the resolved design, stated.

A study file of nine lines leaves most choices to armlab: which frame is the tool, which
controller drives the axes, where each limit and each drive comes from, what a continuous
joint becomes. :func:`resolve_controller` and :func:`design_decisions` make those choices once,
before any stage runs, validate them against the robot (a controller that cannot drive the
arm's axis count is refused here, not at export after every stage ran) and say each one with
the rule that made it: ``armlab run`` prints them first, ``summary.json`` keeps them under
``robot.decisions``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from armlab.errors import ArmlabError, SpecError
from armlab.robot.controller import ControllerProfile, load_profile

if TYPE_CHECKING:
    from armlab.robot.model import Robot
    from armlab.study.spec import StudySpec

__all__ = [
    "Decision",
    "resolve_controller",
    "design_decisions",
    "print_decisions",
    "N_AXIS_PROFILE",
]

#: The built-in profile a robot gets when the default (reference) controller cannot drive its
#: axes: the same DDA cards of the SHU controller paper, as many as the arm needs.
N_AXIS_PROFILE = "dda_n_axis"


@dataclass(frozen=True)
class Decision:
    """One resolved choice: the study key it answers, its value and how it was made (``"study"``
    when the study file set it, else the rule that derived it)."""

    key: str
    value: str
    how: str

    def line(self) -> str:
        """``robot.tool_frame = tool0 (the frame named tool0)``."""
        return f"{self.key} = {self.value} ({self.how})"

    def to_dict(self) -> dict[str, str]:
        return {"key": self.key, "value": self.value, "how": self.how}


def _tune(prof: ControllerProfile, spec: StudySpec) -> ControllerProfile:
    """The profile with the study's ``[controller]`` overrides."""
    c = spec.controller
    if c.cycle_s is not None:
        prof = prof.with_cycle(c.cycle_s)
    if c.pulse_limit is not None:
        prof = prof.replace(max_pulses_per_cycle=c.pulse_limit)
    if c.servo_period_s is not None:
        prof = prof.replace(servo_period_s=c.servo_period_s)
    return prof


def resolve_controller(
    spec: StudySpec, robot: Robot | None = None
) -> tuple[ControllerProfile, str]:
    """The study's controller and how it was chosen.

    ``[controller] profile`` when the study names one; else the reference controller (two
    3-axis DDA cards, 6 axes), or, for a robot it cannot drive (another joint count),
    :data:`N_AXIS_PROFILE` -- the same cards for any axis count. With ``robot`` the choice is
    validated against it (axis count, order, signs).

    Raises
    ------
    SpecError
        The named profile cannot drive the robot's joints (``controller.profile`` in the
        message, with the profiles that can).
    """
    c = spec.controller
    if c.profile is not None:
        prof = _tune(load_profile(spec.resolve(c.profile)), spec)
        how = "study"
        if robot is not None:
            try:
                prof.axes(robot)
            except ArmlabError as exc:
                raise SpecError(
                    f"controller.profile: {exc}; a profile for any axis count: {N_AXIS_PROFILE}"
                ) from None
        return prof, how
    prof = _tune(load_profile(None), spec)
    if robot is None:
        return prof, "default: the reference controller"
    try:
        prof.axes(robot)
    except ArmlabError:
        derived = _tune(load_profile(N_AXIS_PROFILE), spec)
        derived.axes(robot)  # drives any axis count
        return derived, (
            f"derived: {robot.name} has {robot.n_joints} joints, the reference controller "
            f"{prof.name!r} drives {prof.max_axes} axes; {N_AXIS_PROFILE!r} is the same "
            "controller with as many cards as the arm needs (set [controller] profile to choose)"
        )
    return prof, "default: the reference controller (SHU controller paper)"


def _deg(x: float) -> str:
    return f"{math.degrees(x):.6g}"


def _limit_sources(robot: Robot) -> list[Decision]:
    """One decision per limit kind: where each joint's value comes from."""
    out = []
    lim = robot.limits
    for kind, sources in lim.sources.items():
        if kind == "position":
            continue
        groups: dict[str, list[str]] = {}
        for joint, src in zip(lim.joint_names, sources, strict=True):
            groups.setdefault(src, []).append(joint)
        value = "; ".join(
            f"{src} ({len(js)} joint{'s' if len(js) > 1 else ''})" for src, js in groups.items()
        )
        out.append(Decision(f"limits.{kind}", value, "resolved: the tightest source per joint"))
    return out


def _drives_decision(spec: StudySpec, robot: Robot) -> Decision:
    """Where the drive train comes from."""
    changed = sorted(spec.drives)
    if spec.sizing.select:
        how = "[sizing] select = true: chosen in the sizing stage"
        value = "catalogue selection"
        if changed:
            value += f", with the study's [drives] for {', '.join(changed)}"
        return Decision("drives", value, how)
    if robot.drives is None:
        return Decision("drives", "none", "no drives file: the drive stages are skipped")
    if spec.robot.drives is not None:
        src = f"drives file {spec.robot.drives}"
    else:
        src = "the description's drives.toml"
    if changed:
        src += f", changed by [drives] for {', '.join(changed)}"
    return Decision("drives", src, "study" if spec.robot.drives or changed else "description")


def design_decisions(spec: StudySpec, robot: Robot, controller_how: str) -> list[Decision]:
    """Every choice the study leaves to armlab, resolved for ``robot``, with its rule."""
    r = robot
    out = [
        Decision(
            "robot.name",
            f"{r.name} ({r.n_joints} moving joints: {', '.join(r.joint_names)})",
            "study",
        ),
        Decision(
            "robot.lock_joints",
            ", ".join(spec.robot.lock_joints) or "none",
            "study" if spec.robot.lock_joints else "default: every joint of the URDF moves",
        ),
        Decision(
            "robot.tool_frame",
            r.tool_frame,
            "study" if spec.robot.tool_frame is not None else f"default: {r.tool_frame_from}",
        ),
    ]
    for joint, bounded in r.continuous_joints.items():
        i = r.joint_names.index(joint)
        lo, hi = r.limits.lower_rad[i], r.limits.upper_rad[i]
        value = (
            f"revolute over [{_deg(lo)}, {_deg(hi)}] deg"
            if bounded
            else "unbounded (no position limit in the plan and the tables)"
        )
        out.append(
            Decision(
                f"joint {joint}",
                value,
                "continuous in the URDF" + (" with <limit lower upper>" if bounded else ""),
            )
        )
    p = spec.payload
    out.append(
        Decision(
            "payload.mass_kg",
            f"{r.payload.mass_kg:g} kg at {r.tool_frame}",
            "study" if p.mass_kg is not None else "default: the description's payload",
        )
    )
    out.append(_drives_decision(spec, r))
    out += _limit_sources(r)
    return out


def print_decisions(decisions: list[Decision]) -> None:
    """Print what armlab decided for the study (``armlab run``, :func:`armlab.study.run_study`):
    every decision the study file did not make itself (those are in summary.json too), flushed
    so they come before the first stage's output."""
    lines = [d.line() for d in decisions if d.how != "study"] or ["nothing: the study set it all"]
    print("decided before the first stage:\n" + "\n".join(f"  {s}" for s in lines), flush=True)


def controller_decision(prof: ControllerProfile, how: str) -> Decision:
    """The controller's decision line."""
    return Decision("controller.profile", prof.name, how)
