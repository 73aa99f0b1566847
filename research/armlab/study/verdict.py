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

__all__ = ["PASS", "FAIL", "JUDGING_STAGES", "StageRecord", "DesignVerdict", "design_verdict"]

#: Stages whose verdict the design needs; a design is "incomplete" while one did not run.
JUDGING_STAGES = ("plan", "sizing", "tuning", "tracking", "export")

#: Verdicts of a stage (and of a design that every judging stage passed or failed).
PASS, FAIL = "pass", "fail"


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
    error : str
        The error that stopped the stage ("" otherwise).
    """

    stage: str
    status: str
    verdict: str | None = None
    time_s: float = 0.0
    failed_checks: tuple[str, ...] = ()
    advisories: tuple[str, ...] = ()
    reason: str = ""
    error: str = ""

    @classmethod
    def of_block(cls, stage: str, block: Mapping[str, Any], time_s: float) -> StageRecord:
        """The record of the summary block a stage returned (its ``status``, ``verdict``,
        ``failed_checks``, ``advisories``, ``reason`` and ``error`` keys)."""
        return cls(
            stage=stage,
            status=str(block["status"]),
            verdict=block.get("verdict"),
            time_s=time_s,
            failed_checks=tuple(block.get("failed_checks", ())),
            advisories=tuple(block.get("advisories", ())),
            reason=str(block.get("reason", "")),
            error=str(block.get("error", "")),
        )

    @property
    def note(self) -> str:
        """Why a stage did not run: the reason it was skipped, or its error ("" when ok)."""
        return self.reason if self.status == "skipped" else self.error

    def to_dict(self) -> dict[str, Any]:
        """``summary["study"]["stages"][stage]``."""
        return {"status": self.status, "verdict": self.verdict, "time_s": round(self.time_s, 6)}


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
