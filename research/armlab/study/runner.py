"""Run a study: the chain of stages from a :class:`StudySpec` to an output folder.

``run_study(path, out_dir)`` is what ``armlab run`` calls; :func:`run_spec` is the same without
the file reading and printing (sweeps and notebooks use it). Outputs in ``out_dir``
(DESIGN.md): ``summary.json``, ``design.json`` (the resolved design, :mod:`armlab.study.record`),
``report.md`` with PNG plots beside it, ``setpoints.csv`` (only for a design that passes, or with
``force``), ``gains.json`` and ``trajectory.npz`` (the inputs of ``armlab export``).

The result separates two facts: each stage's ``status`` (it ran, was skipped, or stopped with an
error) and the design's ``verdict`` (``pass`` / ``fail`` with the failed checks, or
``incomplete`` when a stage that judges the design did not run). ``armlab run`` exits 0 when the
design passes, 1 when it fails, 2 on bad input.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from armlab.deploy.provenance import armlab_version
from armlab.errors import ArmlabError
from armlab.io import write_json
from armlab.study.build import build_robot
from armlab.study.context import NotApplicable, StudyContext
from armlab.study.decisions import (
    Decision,
    controller_decision,
    design_decisions,
    print_decisions,
    resolve_controller,
)
from armlab.study.figures import key_figures
from armlab.study.record import (
    DESIGN_FILE,
    SUMMARY_FILE,
    design_record,
    locked_folder,
    prepare_out_dir,
)
from armlab.study.spec import STAGES, StudySpec, load_study
from armlab.study.stages import NEEDS, STAGE_FUNCTIONS, SUMMARY_KEY, robot_block
from armlab.study.verdict import (
    DesignVerdict,
    StageOutput,
    StageRecord,
    design_verdict,
)

if TYPE_CHECKING:
    from armlab.control import ArmGains
    from armlab.robot.model import Robot
    from armlab.trajectory import Trajectory

__all__ = ["StudyResult", "run_study", "run_spec"]


@dataclass
class StudyResult:
    """What a study produced: each stage's record, the design's verdict, the objects behind
    them and the summary rendered from them (summary.json content).

    Attributes
    ----------
    spec : StudySpec
    stages : dict of str to StageRecord
        ``robot`` and every stage of :data:`~armlab.study.spec.STAGES`, in run order.
    design : DesignVerdict
    figures : dict
        The key figures (:func:`~armlab.study.figures.key_figures`): the sweep's row.
    summary : dict
        The summary.json content (DESIGN.md keys), rendered from the records and the stages'
        blocks.
    context : StudyContext
        The robot, controller, trajectory, sizing report, gains, tracking result... (None where a
        stage did not run).
    out_dir : Path or None
    files : list of Path
        Files written.
    """

    spec: StudySpec
    stages: dict[str, StageRecord]
    design: DesignVerdict
    figures: dict[str, Any]
    summary: dict[str, Any]
    context: StudyContext
    out_dir: Path | None
    files: list[Path]

    @property
    def robot(self) -> Robot:
        return self.context.robot

    @property
    def trajectory(self) -> Trajectory | None:
        return self.context.trajectory

    @property
    def gains(self) -> ArmGains | None:
        return self.context.gains

    @property
    def verdict(self) -> str:
        """``"pass"``, ``"fail"`` or ``"incomplete"`` (see :func:`design_verdict`)."""
        return self.design.verdict

    @property
    def failed_checks(self) -> list[str]:
        """One line per failed check of the design."""
        return list(self.design.failed_checks)

    def key_figures(self) -> dict[str, Any]:
        return dict(self.figures)


def _progress(total: int, enabled: bool | None, desc: str):
    from armlab._progress import tqdm  # tqdm.auto; on in Jupyter

    # disable=None: tqdm switches itself off when stderr is not a terminal (CI)
    return tqdm(
        total=total,
        desc=desc,
        unit="stage",
        disable=None if enabled is None else not enabled,
        leave=False,
        file=sys.stderr,
    )


def run_spec(
    spec: StudySpec,
    out_dir: str | Path | None = None,
    *,
    progress: bool | None = False,
    report: bool | None = None,
    force: bool = False,
    overwrite: bool = False,
    announce: Callable[[list[Decision]], None] | None = None,
    remedies: int = 0,
) -> StudyResult:
    """Run every stage of a study.

    Parameters
    ----------
    spec : StudySpec
    out_dir : str or Path, optional
        Output folder (created). None: run in memory and write nothing (sweeps); the export
        stage still builds the set-point table, so its pre-flight checks run. A folder that holds
        an earlier run of the same study is cleared of its outputs first; one that holds
        another study's outputs is refused unless ``overwrite``
        (:func:`armlab.study.record.prepare_out_dir`).
    progress : bool or None
        Progress bar over the stages: True, False, or None = only on a terminal.
    report : bool, optional
        Write report.md and its plots (default ``study.report``; never without ``out_dir``).
    force : bool
        Write the set-point table even when the design fails a check (recorded in the table).
    overwrite : bool
        Clear an output folder that holds another study's outputs.
    announce : callable, optional
        Called once, before the first stage, with the study's decisions
        (:mod:`armlab.study.decisions`: tool frame, controller, drives, limits ... each with the
        rule that chose it); ``armlab run`` prints them (:func:`print_decisions`).
    remedies : int
        For a failing design, measure up to this many remedies, each a modified study run in
        memory (:func:`armlab.study.remedies.try_remedies`; summary ``remedies``). 0 (the
        default, and what sweeps use): none.

    Raises
    ------
    ArmlabError
        The first stage that fails, with the stage's name in front of its message; the
        summary.json written so far records it.
    InputError
        Another client (``armlab run``, ``armlab export``) holds the output folder's lock.

    Notes
    -----
    A study runs in this process, its stages and then its report's plots one after the other;
    parallelism is across studies (``armlab sweep --workers``). The output folder is locked
    while the study runs (:func:`armlab.study.record.locked_folder`): one writer per folder.
    """
    if out_dir is None:
        return _run(
            spec,
            None,
            progress=progress,
            report=report,
            force=force,
            announce=announce,
            remedies=remedies,
        )
    with locked_folder(out_dir, "armlab run") as folder:
        out = prepare_out_dir(folder, spec.hash, overwrite=overwrite)
        return _run(
            spec,
            out,
            progress=progress,
            report=report,
            force=force,
            announce=announce,
            remedies=remedies,
        )


def _run(
    spec: StudySpec,
    out: Path | None,
    *,
    progress: bool | None,
    report: bool | None,
    force: bool,
    announce: Callable[[list[Decision]], None] | None = None,
    remedies: int = 0,
) -> StudyResult:
    """:func:`run_spec` into the prepared (and locked) folder ``out``, or in memory."""
    written: dict[str, str] = {}  # file name -> path, of every data file the run wrote
    records: dict[str, StageRecord] = {}
    ctx: StudyContext | None = None  # made once the robot is built
    summary: dict[str, Any] = {
        "study": {
            "name": spec.study.name,
            "source": spec.source,
            "hash": spec.hash,
            "seed": spec.study.seed,
            "armlab_version": armlab_version(),
            "stages": {},
        },
    }
    files: list[Path] = []
    bar = _progress(len(STAGES) + 1, progress, spec.study.name)

    def record(
        stage: str,
        t0: float,
        output: StageOutput | None = None,
        *,
        status: str = "ok",
        reason: str = "",
        error: str = "",
        error_type: str = "",
    ) -> None:
        """Record a stage: its ``output`` when it ran, else its status and reason or error."""
        time_s = time.perf_counter() - t0
        if output is not None:
            rec = StageRecord.ran(stage, output, time_s)
        else:
            rec = StageRecord(
                stage, status, time_s=time_s, reason=reason, error=error, error_type=error_type
            )
        records[stage] = rec
        summary[SUMMARY_KEY.get(stage, stage)] = rec.block(output)
        summary["study"]["stages"][stage] = rec.to_dict()

    def stopped(stage: str, t0: float, exc: ArmlabError) -> ArmlabError:
        record(stage, t0, status="error", error=str(exc), error_type=type(exc).__name__)
        return fail(stage, exc)

    def judge() -> tuple[DesignVerdict, dict[str, Any]]:
        design = design_verdict(records, tuple(spec.study.stages))
        figures = key_figures(ctx, records, design)
        summary["design"], summary["key_figures"] = design.to_dict(), dict(figures)
        return design, figures

    def finish() -> tuple[DesignVerdict, dict[str, Any]]:
        judged = judge()
        if out is not None:
            summary["files"] = {name: sha for name, sha in _checksums(out, written).items()}
            files.insert(0, write_json(out / SUMMARY_FILE, summary))
        return judged

    def fail(stage: str, exc: ArmlabError):
        finish()
        bar.close()
        return type(exc)(f"{stage}: {exc}")

    try:
        t0 = time.perf_counter()
        bar.set_postfix_str("robot")
        try:
            robot = build_robot(spec)
            controller, controller_how = resolve_controller(spec, robot)
        except ArmlabError as exc:
            raise stopped("robot", t0, exc) from None
        decisions = [
            *design_decisions(spec, robot, controller_how),
            controller_decision(controller, controller_how),
        ]
        if announce is not None:
            announce(decisions)
        ctx = StudyContext(
            spec,
            robot=robot,
            controller=controller,
            out_dir=out,
            force=force,
            decisions=tuple(decisions),
            records=records,
            files=written,
        )
        record("robot", t0, StageOutput(robot_block(ctx)))
        summary["robot"]["decisions"] = [d.to_dict() for d in decisions]
        if out is not None:
            path = write_json(out / DESIGN_FILE, design_record(robot, controller, spec))
            written[DESIGN_FILE] = str(path)
        bar.update()
        for stage in STAGES:
            t0 = time.perf_counter()
            bar.set_postfix_str(stage)
            missing = [n for n in NEEDS.get(stage, ()) if records[n].status != "ok"]
            if stage not in spec.study.stages:
                record(stage, t0, status="skipped", reason="not in study.stages")
            elif missing:
                why = ", ".join(f"{n}: {records[n].status}" for n in missing)
                record(stage, t0, status="skipped", reason=f"needs {', '.join(missing)} ({why})")
            else:
                try:
                    output = STAGE_FUNCTIONS[stage](ctx)
                except NotApplicable as exc:
                    record(stage, t0, status="skipped", reason=str(exc))
                except ArmlabError as exc:
                    raise stopped(stage, t0, exc) from None
                else:
                    record(stage, t0, output)
                    if ctx.replanned is not None:  # the selection re-planned with its drives
                        plan, plan_s = ctx.replanned
                        record("plan", time.perf_counter() - plan_s, plan)
                        ctx.replanned = None
            bar.update()
        if ctx.drives_selected:  # the sizing stage gave the robot its drive train
            summary["robot"].update(robot_block(ctx))
            summary["robot"]["drives_from"] = "catalogue selection (sizing stage)"
            if out is not None:
                record_ = design_record(ctx.robot, ctx.controller, spec)
                written[DESIGN_FILE] = str(write_json(out / DESIGN_FILE, record_))
        if remedies > 0:
            _measure_remedies(ctx, judge()[0], remedies, summary, bar)
        if out is not None and (spec.study.report if report is None else report):
            from armlab.study.report import write_report

            bar.set_postfix_str("report")
            design, figures = judge()  # the report shows the verdict and the key figures
            files += write_report(ctx, records, design, figures, out)
        design, figures = finish()
        files += [Path(p) for p in written.values()]
    finally:
        bar.close()
    return StudyResult(
        spec=spec,
        stages=records,
        design=design,
        figures=figures,
        summary=summary,
        context=ctx,
        out_dir=out,
        files=files,
    )


def _measure_remedies(ctx: StudyContext, design: DesignVerdict, limit: int, summary, bar) -> None:
    """summary ``remedies`` of a failing design: the measured remedies, ranked
    (:func:`armlab.study.remedies.try_remedies`); nothing for a design that does not fail."""
    from armlab.study.remedies import candidate_remedies, try_remedies

    if design.verdict != "fail":
        return
    bar.set_postfix_str("remedies")
    n = len(candidate_remedies(ctx, design))
    measured = try_remedies(ctx, design, limit)
    ctx.remedies = measured
    summary["remedies"] = {
        "limit": limit,
        "candidates": n,
        "measured": [r.to_dict() for r in measured],
    }


def _checksums(out: Path, written: dict[str, str]) -> dict[str, str]:
    """sha256 of every data file the run wrote (relative names), for export's verification."""
    from armlab.deploy.provenance import file_sha256

    return {Path(p).name: file_sha256(p) for p in written.values() if Path(p).is_file()}


def run_study(
    study: str | Path | None,
    out_dir: str | Path,
    *,
    overrides: dict[str, Any] | None = None,
    progress: bool | None = None,
    quiet: bool = False,
    force: bool = False,
    overwrite: bool = False,
    remedies: int | None = None,
) -> dict[str, Any]:
    """Run a study file into ``out_dir`` and print a one-screen summary (``armlab run``).

    Parameters
    ----------
    study : str, Path or None
        STUDY.toml; None: the built-in teachbot6 demo study (``armlab/data/demo_study.toml``).
    out_dir : str or Path
        Output folder: summary.json, design.json, report.md + PNGs, setpoints.csv, gains.json,
        trajectory.npz.
    overrides : dict, optional
        Dotted study keys to change (``{"payload.mass_kg": 1.0}``).
    progress : bool or None
        Stage progress bar; None: only on a terminal.
    quiet : bool
        Do not print the summary.
    force : bool
        Write the set-point table of a failing design (the table records the failed checks).
    overwrite : bool
        Clear an output folder that holds another study's outputs.
    remedies : int, optional
        Remedies to measure for a failing design (default
        :data:`armlab.study.remedies.MAX_REMEDIES`, as ``armlab run``; 0: none).

    Returns
    -------
    dict
        The summary (summary.json content); ``summary["design"]["verdict"]`` is the design's
        verdict.
    """
    from armlab.study.remedies import MAX_REMEDIES

    spec = load_study(study, overrides)

    result = run_spec(
        spec,
        out_dir,
        progress=progress,
        force=force,
        overwrite=overwrite,
        announce=None if quiet else print_decisions,
        remedies=MAX_REMEDIES if remedies is None else remedies,
    )
    if not quiet:
        from armlab.study.report import summary_text

        print(summary_text(result))
    return result.summary
