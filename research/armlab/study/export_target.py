"""Export what was verified: the controller an export format feeds, simulated when it differs
from the one the study verified (:mod:`armlab.deploy.carries`).

:func:`check_target` is called by :func:`armlab.study.export.export_study` before anything is
rendered. It returns the block every exported file carries in its provenance
(``source["controller"]``: the target, its loops, the feed-forward terms verified and run, what
differs and, when armlab simulated the target, its tracking verdict) and the notes; it refuses
(:class:`~armlab.errors.DesignFailure`) a target whose own simulation misses the study's
accuracy budget, unless ``force``.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from armlab.deploy.carries import target_of
from armlab.errors import DesignFailure

if TYPE_CHECKING:
    from armlab.robot.controller import ControllerProfile
    from armlab.robot.model import Robot
    from armlab.trajectory import Trajectory

__all__ = ["TargetCheck", "check_target", "carried_block", "verified_feedforward"]


@dataclass
class TargetCheck:
    """What :func:`check_target` found: the provenance block, notes, forced failures."""

    block: dict[str, Any]
    notes: list[str] = field(default_factory=list)
    forced: list[str] = field(default_factory=list)


def verified_feedforward(summary: dict) -> tuple[str, ...] | None:
    """The feed-forward terms of the study's tracking simulation (None: no tracking ran)."""
    block = summary.get("tracking") or {}
    if block.get("status") != "ok":
        return None
    ff = block.get("feedforward")
    return tuple(ff) if isinstance(ff, list) else ()


def carried_block(fmt: str, verified: tuple[str, ...] | None) -> dict[str, Any]:
    """The provenance block of a ``fmt`` file: its target, loops, the feed-forward terms
    verified and run and what differs (``armlab run``'s table and ``armlab export`` write the
    same one)."""
    target = target_of(fmt)
    if verified is None:
        return {
            "target": target.name,
            "loops": target.loops,
            "verified": "no tracking stage: the controller was not verified in simulation",
        }
    return dict(target.to_dict(verified))


def _simulate(
    robot: Robot,
    traj: Trajectory,
    gains,
    controller: ControllerProfile,
    feedforward: tuple[str, ...],
    summary: dict,
    record: dict,
):
    """The study's tracking simulation with another set of feed-forward terms: the same robot,
    plan, gains, controller, quantisation, settling time and budget as the tracking stage."""
    from armlab.control import simulate_tracking

    block = summary.get("tracking") or {}
    doc = ((record.get("study") or {}).get("document") or {}).get("tracking") or {}
    default = inspect.signature(simulate_tracking).parameters["t_after_s"].default
    tcp = block.get("tcp") or {}
    return simulate_tracking(
        robot,
        traj,
        gains,
        feedforward=feedforward or "none",
        quantise=bool(block.get("quantise", True)),
        t_after_s=float(doc.get("t_after_s", default)),
        accuracy_m=tcp.get("accuracy_m"),
        controller=controller,
    )


def check_target(
    fmt: str,
    *,
    summary: dict,
    record: dict,
    robot: Robot,
    traj: Trajectory | None,
    gains,
    controller: ControllerProfile,
    force: bool,
) -> TargetCheck:
    """Which parts of the verified controller ``fmt`` carries; the target simulated when it
    differs (module docstring).

    Raises
    ------
    DesignFailure
        The target, simulated as it will run, misses the accuracy budget (and not ``force``).
    """
    target = target_of(fmt)
    verified = verified_feedforward(summary)
    block = carried_block(fmt, verified)
    if verified is None:
        return TargetCheck(block, [f"{fmt}: not verified in a tracking simulation"])
    diffs = target.differences(verified)
    runs = target.feedforward(verified)
    check = TargetCheck(block)
    if not diffs:
        check.notes.append(
            f"{fmt}: {target.name} runs the verified feed-forward [{', '.join(runs) or 'none'}]"
            + ("" if target.simulable else " (computed by the controller from the table)")
        )
        return check
    what = (
        f"the verdict assumed the feed-forward [{', '.join(verified) or 'none'}]; "
        f"{target.name}: {'; '.join(diffs)}"
    )
    if not target.simulable:
        check.notes.append(f"{what} -- the controller must compute them from the table")
        return check
    if traj is None or gains is None:
        check.notes.append(f"{what} -- not simulated (no trajectory or gains in the study)")
        return check
    res = _simulate(robot, traj, gains, controller, runs, summary, record)
    err_mm, budget_mm = res.tcp_max_error_m * 1e3, res.accuracy_m * 1e3
    ok = bool(res.within_accuracy)
    block["target_tracking"] = {
        "feedforward": list(runs),
        "tcp_max_error_m": res.tcp_max_error_m,
        "accuracy_m": res.accuracy_m,
        "verdict": "pass" if ok else "fail",
    }
    outcome = (
        f"simulated as it will run (feed-forward [{', '.join(runs) or 'none'}]): TCP error "
        f"{err_mm:.4g} mm {'within' if ok else '>'} budget {budget_mm:.4g} mm"
    )
    if ok:
        check.notes.append(f"{what}; {outcome}: PASS")
        return check
    failure = f"{fmt} target: {outcome}"
    if not force:
        raise DesignFailure(
            f"export refused: {what}; {outcome} (a format that carries the terms: "
            f"{_carriers(verified)}; --force exports it)"
        )
    check.notes.append(f"forced export: {what}; {outcome}")
    check.forced.append(failure)
    return check


def _carriers(verified: tuple[str, ...]) -> str:
    """The export formats whose target runs every verified term."""
    from armlab.deploy.carries import TARGETS

    fits = [f for f, t in TARGETS.items() if not t.differences(verified)]
    return ", ".join(fits) or "none"
