"""What ``armlab export`` re-checks instead of trusting a study folder (issue 24, item 3).

A study folder's files are checksummed in its summary.json, but summary.json is not: whoever can
edit the folder can put the checksums right. So export rebuilds and judges again what it can:

* :func:`same_study`: summary.json and design.json are of one study (their study sha256);
* :func:`recorded_verdict`: the design's verdict recomputed from the stage results summary.json
  records, never its ``design.verdict`` -- a verdict that does not follow from them is refused;
* :func:`resized`: the sizing checks re-run on the recorded plan with design.json's drive train
  (every check when the study sized its drives, else the hardware's own limits,
  :data:`HARDWARE_CHECKS`);
* :func:`drive_train_velocity`: the set-point pre-flight's speed limit held to each drive's own
  (``Drive.motor_speed_limit_rad_s / ratio``: motor speed limit and reducer input speed).

An edited record so ends in a refusal or in a table right for the edited design.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from armlab.errors import InputError
from armlab.study.budget import check_samples
from armlab.study.spec import STAGES, PlanSpec, SizingSpec
from armlab.study.verdict import FAIL, PASS, DesignVerdict, StageRecord, design_verdict

if TYPE_CHECKING:
    from armlab.robot.limits import Limits
    from armlab.robot.model import Robot

__all__ = [
    "HARDWARE_CHECKS",
    "same_study",
    "recorded_verdict",
    "drive_train_velocity",
    "resized",
]


def same_study(summary: dict, record: dict, study: Path) -> None:
    """Refuse a folder whose summary.json and design.json come from two studies (their study
    sha256 differ: two runs wrote into one folder, issue 24 item 2)."""
    ran = (summary.get("study") or {}).get("hash")
    designed = (record.get("study") or {}).get("sha256")
    if ran is not None and designed is not None and ran != designed:
        raise InputError(
            f"{study}: summary.json is of study {str(ran)[:12]}..., design.json of study "
            f"{str(designed)[:12]}... (two runs wrote into this folder): run the study again"
        )


def recorded_verdict(summary: dict, record: dict, study: Path) -> DesignVerdict:
    """The design's verdict recomputed from the stage results summary.json records
    (:func:`~armlab.study.verdict.design_verdict` over each stage's block), never its
    ``design.verdict`` / ``failed_checks``.

    A stage block is failed when its verdict or the stages table says ``fail`` or it lists
    failed checks; the stages the study asked for are those of the study document in
    design.json (checksummed; for a design assembled in code, without a study document, the
    stages summary.json records as run).

    Raises
    ------
    InputError
        summary.json's ``design.verdict`` is not the one its stage results give (an edited
        record): one line naming both.
    """
    from armlab.study.stages import SUMMARY_KEY

    table = (summary.get("study") or {}).get("stages") or {}
    records: dict[str, StageRecord] = {}
    for stage in STAGES:
        block = summary.get(SUMMARY_KEY.get(stage, stage))
        if not isinstance(block, dict) or "status" not in block:  # no stage result
            continue
        row = table.get(stage)
        row = row if isinstance(row, dict) else {}
        checks = block.get("failed_checks") or []
        failed = [str(c) for c in checks] if isinstance(checks, list) else [str(checks)]
        says_fail = FAIL in (block.get("verdict"), row.get("verdict"))
        if says_fail and not failed:
            failed = [f"{stage}: verdict fail (summary.json {SUMMARY_KEY.get(stage, stage)})"]
        verdict = block.get("verdict") if block.get("verdict") in (PASS, FAIL) else None
        records[stage] = StageRecord(
            stage,
            str(block["status"]),
            verdict=FAIL if failed else verdict,
            failed_checks=tuple(failed),
            reason=str(block.get("reason", "")),
        )
    if isinstance(record.get("study"), dict):
        doc = (record["study"].get("document") or {}).get("study") or {}
        asked = doc.get("stages", STAGES)
        asked = asked if isinstance(asked, list) else STAGES
    else:  # a design assembled in code (no study document): the stages it records
        asked = [s for s, r in records.items() if r.status != "skipped"]
    stages = tuple(s for s in STAGES if s in asked)
    verdict = design_verdict(records, stages)
    claimed = (summary.get("design") or {}).get("verdict")
    if claimed != verdict.verdict:
        raise InputError(
            f"{study}: summary.json says the design {claimed!r}, its stage results say "
            f"{verdict.verdict!r} ({'; '.join(verdict.failed_checks or verdict.not_judged)}): "
            "the record was edited; run the study again"
        )
    return verdict


def drive_train_velocity(robot: Robot) -> Limits:
    """``robot.limits`` with each joint's velocity limit at most its drive train's own,
    ``Drive.motor_speed_limit_rad_s / ratio`` (motor speed limit and reducer input speed,
    :class:`~armlab.robot.drives.Drive`): the set-point pre-flight of an export checks the
    table against the drive train in design.json, not only against the recorded limits.
    For a design as the study recorded it nothing changes (its limits came from the same
    drives)."""
    lim = robot.limits
    if robot.drives is None:
        return lim
    drive = np.array(
        [
            robot.drives[n].motor_speed_limit_rad_s / robot.drives[n].reducer.ratio
            for n in robot.joint_names
        ]
    )
    recorded = lim.velocity_rad_s
    if recorded is not None and not np.any(drive < recorded):
        return lim
    v = drive if recorded is None else np.minimum(recorded, drive)
    return lim.with_values(
        "design.json drive train: motor speed limit / ratio (armlab export)", velocity_rad_s=v
    )


#: The sizing checks that are limits of the hardware at each instant (what the drive can give or
#: take), re-checked by every export of a design with a drive train; the others (RMS and average
#: torque, the thesis rules, encoder resolution) judge a design only where the study sized it.
HARDWARE_CHECKS = (
    "motor_peak_torque",
    "motor_speed",
    "reducer_peak_torque",
    "reducer_input_speed",
    "encoder_pulse_rate",
)


def resized(traj, summary: dict, record: dict, robot: Robot, controller) -> list[str]:
    """The sizing checks re-run on the recorded plan with design.json's drive train
    (:func:`armlab.dynamics.size`, ``Drive.peak_motor_torque_Nm`` and the speed limits through
    the one drive-train model) on the recorded plan: every
    check when the study ran its sizing stage, else the :data:`HARDWARE_CHECKS`. Their failed
    checks ([] without drives or trajectory). ``traj``: the study's trajectory.npz (None when
    it has none); ``controller``: design.json's."""
    if robot.drives is None or traj is None:
        return []
    from armlab.dynamics import size
    from armlab.study.drive_stages import sizing_failures

    block = summary.get("sizing")
    sized = isinstance(block, dict) and block.get("status") == "ok"
    plan = ((record.get("study") or {}).get("document") or {}).get("plan") or {}
    default = PlanSpec().check_dt_s  # the study's own default grid (one home)
    dt = plan.get("check_dt_s", default)
    if not isinstance(dt, (int, float)) or not 0 < dt <= 1:
        dt = default
    check_samples(
        traj.duration / dt,
        robot.n_joints,
        f"design.json plan.check_dt_s = {dt:g}",
        f"{traj.duration:.3g} s plan / {dt:g} s sizing grid",
    )
    report = size(robot, traj, dt=float(dt), controller=controller, **_sizing_keywords(record))
    return sizing_failures(report, None if sized else HARDWARE_CHECKS)


def _sizing_keywords(record: dict) -> dict:
    """The recorded study's ``[sizing]`` options of the checks (dwell, thermal cycles and
    ambient, inertia-ratio rule: :func:`~armlab.study.drive_stages.sizing_keywords`); the
    defaults where the record holds none or an unreadable table."""
    from armlab.errors import SpecError
    from armlab.study.drive_stages import sizing_keywords
    from armlab.study.spec import parse_sizing

    table = ((record.get("study") or {}).get("document") or {}).get("sizing") or {}
    try:
        spec = parse_sizing(table)
    except SpecError:
        spec = SizingSpec()
    return sizing_keywords(spec)


def recleared(traj, record: dict, robot: Robot) -> list[str]:
    """The collision check re-run on the recorded plan: the scene of the recorded study
    document (``[[obstacle]]``, floor, payload shape, pairs file, ``[plan] clearance_m``;
    relative paths from the study file's folder) with design.json's robot, through the plan
    stage's own :func:`armlab.collision.check_motion`. Its failure as a failed check ([]
    without a trajectory or a recorded study document).

    Raises
    ------
    SpecError, RobotDescriptionError
        The recorded document is not a valid study, or the geometry cannot be built (one line).
    """
    study = record.get("study") or {}
    document = study.get("document")
    if traj is None or not isinstance(document, dict):
        return []
    from armlab.collision import CollisionScene, check_motion
    from armlab.study.spec import parse_study

    source = str(study.get("source") or "")
    base = Path(source).parent if source and not source.startswith("<") else Path(".")
    spec = parse_study(document, base_dir=base, source="design.json study.document")
    report = check_motion(CollisionScene.from_study(spec, robot), traj)
    return [] if report.ok else [f"plan: {report.message('the recorded plan')}"]
