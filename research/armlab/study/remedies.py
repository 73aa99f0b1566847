"""Advice that was tried: the remedies of a failing design, each measured by running the study
again with a few keys changed.

For a design whose verdict is ``fail``, :func:`candidate_remedies` lists the changes that can
address what failed -- the feed-forward sets of ``[tracking] feedforward``, the next drive up on
the limiting joint (``[drives.<joint>] motor``, ``reducer``), a slower motion
(``[plan] speed_scale``), a faster or slower position loop
(``[control] position_bandwidth_rad_s``), planning inside the motor envelope
(``[plan] drive_limits = true``, only for the planners that can) -- and :func:`try_remedies`
runs each as a modified study through the normal runner (:func:`armlab.study.run_spec`, in this
process, in memory, without remedies of its own), at most ``limit`` of them. A remedy whose
study cannot run (an impossible tuning spec, an infeasible plan, no catalogue pair) is not
offered. The outcomes are ranked: passing designs first, then by the TCP tracking error, then by
the number of failed checks; each is given as the study keys to change and what it measured::

    [tracking] feedforward = ["computed_torque"]: 2.14 -> 0.24 mm, PASS

``armlab run`` tries :data:`MAX_REMEDIES` (``--remedies N``, 0: none); :func:`run_spec` tries
none unless asked, so sweeps and the remedies' own runs never recurse.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from armlab.errors import ArmlabError

if TYPE_CHECKING:
    from armlab.study.context import StudyContext
    from armlab.study.verdict import DesignVerdict

__all__ = ["MAX_REMEDIES", "Remedy", "candidate_remedies", "try_remedies"]

#: remedies ``armlab run`` measures for a failing design (each a whole study run)
MAX_REMEDIES = 6

#: feed-forward sets tried for a tracking miss, most hardware-free first
FEEDFORWARD_SETS = (
    ("velocity", "acceleration", "gravity"),
    ("computed_torque",),
    ("computed_torque", "efficiency", "friction"),
)


@dataclass
class Remedy:
    """One remedy and what its study run measured.

    Attributes
    ----------
    keys : dict
        Dotted study keys and their values (``{"tracking.feedforward": ["computed_torque"]}``).
    why : str
        What it addresses (the failed check it was chosen for).
    verdict : str
        The modified study's design verdict.
    tcp_error_m, before_m : float or None
        Its TCP tracking error and the original's [m] (None where tracking did not run).
    failed_checks : list of str
        Its failed checks.
    time_s : float
        The run's wall time [s].
    """

    keys: dict[str, Any]
    why: str
    verdict: str = ""
    tcp_error_m: float | None = None
    before_m: float | None = None
    failed_checks: list[str] = field(default_factory=list)
    time_s: float = 0.0

    @property
    def passes(self) -> bool:
        return self.verdict == "pass"

    def rank(self) -> tuple:
        err = self.tcp_error_m if self.tcp_error_m is not None else float("inf")
        return (not self.passes, err, len(self.failed_checks))

    def keys_text(self) -> str:
        """The keys as study-file lines: ``[table] key = value; ...``."""
        parts = []
        for dotted, value in self.keys.items():
            table, key = dotted.rsplit(".", 1)
            parts.append(f"[{table}] {key} = {json.dumps(value)}")
        return "; ".join(parts)

    def text(self) -> str:
        """``[tracking] feedforward = ["computed_torque"]: 2.14 -> 0.24 mm, PASS``."""
        if self.tcp_error_m is not None and self.before_m is not None:
            what = f"{self.before_m * 1e3:.3g} -> {self.tcp_error_m * 1e3:.3g} mm"
        elif self.tcp_error_m is not None:
            what = f"{self.tcp_error_m * 1e3:.3g} mm"
        else:
            what = "tracking not run"
        tail = "PASS" if self.passes else f"{self.verdict.upper()} ({len(self.failed_checks)})"
        return f"`{self.keys_text()}`: {what}, {tail}"

    def to_dict(self) -> dict[str, Any]:
        return {
            "keys": dict(self.keys),
            "why": self.why,
            "verdict": self.verdict,
            "tcp_error_m": self.tcp_error_m,
            "tcp_error_before_m": self.before_m,
            "failed_checks": list(self.failed_checks),
            "time_s": round(self.time_s, 3),
            "text": self.text(),
        }


def _tracking_failed(design: DesignVerdict) -> bool:
    return any(f.startswith("tracking:") for f in design.failed_checks)


def _next_drive_up(ctx: StudyContext, joint: str) -> dict[str, Any] | None:
    """``[drives.<joint>]`` motor and reducer of the first catalogue pair by the ranking key that
    passes sizing on the study's duty cycle with more available torque or a smaller inertia
    ratio than the joint's drive (:func:`armlab.study.drive_choice.stronger`, the selection's
    rule); None when there is none."""
    from armlab.dynamics import select_drives
    from armlab.study.build import _catalogue
    from armlab.study.drive_choice import stronger
    from armlab.study.drive_stages import selection_duty

    if ctx.robot.drives is None or ctx.trajectory is None:
        return None
    now = ctx.robot.drives[joint]
    floor = (now.available_torque_Nm, now.reflected_inertia_kg_m2)
    base = ctx.robot.copy()
    if ctx.drives_selected:
        base.drives = None
    try:
        sel = select_drives(
            base,
            selection_duty(ctx),
            catalogue=_catalogue(ctx.spec),
            dt=ctx.spec.plan.check_dt_s,
            controller=ctx.controller,
            candidates={joint: lambda d: d if stronger(d, *floor) else None},
        )
    except ArmlabError:
        return None
    c = sel.joint(joint).chosen
    if c is None:
        return None
    return {f"drives.{joint}.motor": c.motor.model, f"drives.{joint}.reducer": c.reducer.model}


def _limiting_joint(ctx: StudyContext) -> str | None:
    from armlab.study.drive_choice import limiting_joint

    if ctx.tracking is None:
        return None
    return limiting_joint(ctx.robot, ctx.tracking)


def candidate_remedies(ctx: StudyContext, design: DesignVerdict) -> list[Remedy]:
    """The remedies worth measuring for the failed checks of a study run (its context and
    verdict), in the order they are tried (none for a design that does not fail)."""
    if design.verdict != "fail":
        return []
    spec = ctx.spec
    out: list[Remedy] = []
    tracking = _tracking_failed(design)
    if tracking:
        now = spec.tracking.feedforward
        now_set = set() if now is None or now == "none" else set(now)
        for ff in FEEDFORWARD_SETS:
            if set(ff) != now_set:
                out.append(Remedy({"tracking.feedforward": list(ff)}, "tracking"))
        joint = _limiting_joint(ctx)
        up = None if joint is None else _next_drive_up(ctx, joint)
        if up is not None:
            out.append(Remedy(up, f"tracking ({joint} the largest share of the TCP error)"))
    sizing = any(f.startswith(("sizing:", "plan:")) for f in design.failed_checks)
    if tracking or sizing:
        out.append(
            Remedy({"plan.speed_scale": round(0.5 * spec.plan.speed_scale, 6)}, "a slower motion")
        )
    if tracking and ctx.gains is not None:
        bw = min(g.position.crossover_rad_s for g in ctx.gains.joints.values())
        if bw > 0:
            out.append(
                Remedy({"control.position_bandwidth_rad_s": round(2 * bw, 4)}, "a faster loop")
            )
    if (
        (tracking or sizing)
        and spec.plan.planner in ("optimal", "path")
        and not (spec.plan.drive_limits)
    ):
        out.append(Remedy({"plan.drive_limits": True}, "plan inside the motor envelope"))
    return out


def try_remedies(
    ctx: StudyContext, design: DesignVerdict, limit: int = MAX_REMEDIES
) -> list[Remedy]:
    """Run up to ``limit`` of :func:`candidate_remedies` as modified studies (in memory, no
    report, no remedies of their own) and return those that ran, ranked (passing first, then
    by TCP error, then by failed checks). A remedy whose study stops with an error is left out.
    """
    from armlab.study.runner import run_spec
    from armlab.study.spec import apply_overrides, parse_study

    spec = ctx.spec
    before = None if ctx.tracking is None else ctx.tracking.tcp_max_error_m
    measured = []
    for remedy in candidate_remedies(ctx, design)[: max(0, limit)]:
        t0 = time.perf_counter()
        try:
            doc = apply_overrides(spec.document, remedy.keys)
            changed = parse_study(doc, base_dir=spec.base_dir, source=spec.source)
            run = run_spec(changed, None, report=False)
        except ArmlabError:
            continue  # it cannot run: not offered
        remedy.time_s = time.perf_counter() - t0
        remedy.verdict = run.verdict
        remedy.failed_checks = list(run.failed_checks)
        remedy.before_m = before
        tr = run.context.tracking
        remedy.tcp_error_m = None if tr is None else float(tr.tcp_max_error_m)
        measured.append(remedy)
    return sorted(measured, key=Remedy.rank)
