"""What each stage of a study did and what the design's verdict is: typed records.

Two facts are kept apart (issue "status is not a verdict"): a stage's ``status`` -- it ran
(``ok``), was ``skipped`` (with the reason) or stopped with an ``error`` -- and its ``verdict``
on the design (``pass`` / ``fail`` with the failed checks; None where it checks nothing). The
design's verdict (:func:`design_verdict`) is made from the stages' records; ``summary.json``,
``report.md``, the one-screen summary and the exit status of ``armlab run`` all render these
records, none reads them back from the summary.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from armlab.study.spec import STAGES

__all__ = [
    "PASS",
    "FAIL",
    "JUDGING_STAGES",
    "StageOutput",
    "StageRecord",
    "DesignVerdict",
    "design_verdict",
]

#: Stages whose verdict the design needs; a design is "incomplete" while one did not run.
JUDGING_STAGES = ("plan", "sizing", "tuning", "tracking", "export")

#: Verdicts of a stage (and of a design that every judging stage passed or failed).
PASS, FAIL = "pass", "fail"


@dataclass
class StageOutput:
    """What a stage that ran returns: its own summary keys and what it judged.

    Attributes
    ----------
    block : dict
        The stage's summary.json keys besides ``status``, ``verdict``, ``failed_checks`` and
        ``advisories`` (DESIGN.md).
    failed_checks : list of str or None
        One line per failed check; None when the stage checks nothing (verdict None).
    advisories : list of str or None
        Findings that do not fail the design; None when the stage gives none (no key).
    """

    block: dict[str, Any]
    failed_checks: list[str] | None = None
    advisories: list[str] | None = None


@dataclass(frozen=True)
class StageRecord:
    """One stage of a study run.

    Attributes
    ----------
    stage : str
        ``robot`` or one of :data:`armlab.study.spec.STAGES`.
    status : str
        ``ok``, ``skipped`` or ``error``.
    verdict : str or None
        ``pass`` / ``fail``; None where the stage checks nothing or did not run.
    time_s : float
        The stage's wall time [s].
    failed_checks, advisories : tuple of str
        One line per failed check (decides the verdict) and per advisory (does not).
    reason : str
        Why the stage was skipped ("" otherwise).
    error, error_type : str
        The error that stopped the stage and its class ("" otherwise).
    """

    stage: str
    status: str
    verdict: str | None = None
    time_s: float = 0.0
    failed_checks: tuple[str, ...] = ()
    advisories: tuple[str, ...] = ()
    reason: str = ""
    error: str = ""
    error_type: str = ""

    @classmethod
    def ran(cls, stage: str, out: StageOutput, time_s: float) -> StageRecord:
        """The record of a stage that ran and returned ``out``."""
        failed = out.failed_checks
        return cls(
            stage=stage,
            status="ok",
            verdict=None if failed is None else (FAIL if failed else PASS),
            time_s=time_s,
            failed_checks=tuple(failed or ()),
            advisories=tuple(out.advisories or ()),
        )

    @property
    def note(self) -> str:
        """Why a stage did not run: the reason it was skipped, or its error ("" when ok)."""
        return self.reason if self.status == "skipped" else self.error

    def to_dict(self) -> dict[str, Any]:
        """``summary["study"]["stages"][stage]``."""
        return {"status": self.status, "verdict": self.verdict, "time_s": round(self.time_s, 6)}

    def block(self, out: StageOutput | None = None) -> dict[str, Any]:
        """The stage's summary.json block: its status and verdict, then ``out``'s keys (a stage
        that ran) or why it did not run."""
        head: dict[str, Any] = {"status": self.status, "verdict": self.verdict}
        if out is not None:
            head["failed_checks"] = list(self.failed_checks)
            if out.advisories is not None:
                head["advisories"] = list(self.advisories)
            return {**head, **out.block}
        if self.status == "skipped":
            return {**head, "reason": self.reason}
        return {**head, "error": self.error, "error_type": self.error_type}


@dataclass(frozen=True)
class DesignVerdict:
    """The design's verdict (``summary["design"]``).

    Attributes
    ----------
    verdict : str
        ``pass``, ``fail`` or ``incomplete`` (:func:`design_verdict`).
    failed_checks, not_judged, advisories : list of str
    """

    verdict: str
    failed_checks: list[str] = field(default_factory=list)
    not_judged: list[str] = field(default_factory=list)
    advisories: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {
            "verdict": self.verdict,
            "failed_checks": list(self.failed_checks),
            "not_judged": list(self.not_judged),
            "advisories": list(self.advisories),
        }

    def lines(self) -> list[str]:
        """The verdict in words, its failed checks and advisories (one line each)."""
        failed = self.failed_checks
        words = {
            "pass": "the design PASSES every check the study ran",
            "fail": f"the design FAILS {len(failed)} check(s)",
            "incomplete": "the design is NOT JUDGED: " + "; ".join(self.not_judged),
        }.get(self.verdict, f"design verdict {self.verdict}")
        return (
            [f"design: {words}"]
            + [f"  FAILED  {f}" for f in failed]
            + [f"  advisory  {a}" for a in self.advisories]
        )


def design_verdict(records: Mapping[str, StageRecord], stages: tuple[str, ...]) -> DesignVerdict:
    """The design's verdict from the stages' records.

    ``fail`` when any stage failed a check; otherwise ``incomplete`` when a stage of
    :data:`JUDGING_STAGES` that the study asked for (``stages``) did not run (skipped, no drive
    data, or the study stopped before it), so nothing was checked there; otherwise ``pass``.
    Advisories (worst-case requirement checks beside the study's duty cycle) are listed but do
    not decide the verdict.
    """
    failed: list[str] = []
    advisories: list[str] = []
    unjudged: list[str] = []
    for stage in STAGES:
        rec = records.get(stage)
        if rec is not None:
            failed += rec.failed_checks
            advisories += rec.advisories
        judged = rec is not None and rec.verdict in (PASS, FAIL)
        if stage in JUDGING_STAGES and stage in stages and not judged:
            why = "not run" if rec is None else (rec.reason or rec.status)
            unjudged.append(f"{stage} ({why})")
    verdict = FAIL if failed else ("incomplete" if unjudged else PASS)
    return DesignVerdict(verdict, failed, unjudged, advisories)
