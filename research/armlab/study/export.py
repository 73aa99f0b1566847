"""``armlab export``: set-point tables and gains of a finished study, in the controller's formats.

A study folder (written by :mod:`armlab.study`) holds ``summary.json`` (the verdict and the sha256
of every file), ``design.json`` (the resolved design: robot, drive train after the study's
overrides, limits, controller profile -- :mod:`armlab.study.record`), ``trajectory.npz``,
``gains.json`` and, for a passing design, ``setpoints.csv``. Export checks the folder against
the checksums, refuses a failing design unless ``force``, rebuilds the robot and the controller
from ``design.json`` alone, and writes into ``out_dir``:

==========  ==========================================================================
format      files
==========  ==========================================================================
csv         ``setpoints.csv``
json        ``setpoints.json``, ``gains.json`` (with provenance, numbers only)
npz         ``setpoints.npz``
c           ``setpoints.h`` + ``setpoints.c``, ``gains.h`` + ``gains.c``
ros2        ``ros2_controllers.yaml`` (controller_manager + joint_trajectory_controller:
            gains, constraints; :mod:`armlab.deploy.ros2`)
trajectory  ``joint_trajectory.json`` (the plan as a FollowJointTrajectory goal)
cia402      ``cia402_csp.csv``, ``cia402_objects.csv`` (CiA 402 cyclic synchronous
            position; :mod:`armlab.deploy.cia402`)
==========  ==========================================================================

Gains files are written when the study has ``gains.json`` (required for ``ros2``, whose
controller drives the joints that have gains, in the robot's order). The ros2
constraints and the goal's tolerances come from the study's accuracy budget: the tracking
stage's ``accuracy_m`` (``summary.json``), else the study's ``[tracking] accuracy_m``, else
armlab's servo share of the thesis' accuracy (0.5 mm); ``ff_velocity_scale`` is 1 when the
tracking fed the planned velocity forward (or ran without a tracking stage, armlab's default).
Everything is rendered and checked before the first byte is written; the files are written
atomically together, so a refused export (a pre-flight :class:`~armlab.LimitViolation`) leaves
nothing behind.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, fields
from pathlib import Path

from armlab._keywords import renamed_keywords
from armlab.deploy.gains_export import gains_files, load_gains
from armlab.deploy.provenance import file_sha256
from armlab.deploy.table import setpoint_table
from armlab.deploy.trajfile import load_trajectory
from armlab.errors import DesignFailure, InputError
from armlab.io import atomic_write_many
from armlab.robot.controller import ControllerProfile, load_profile
from armlab.study.record import (
    controller_from_design,
    load_design,
    locked_folder,
    reading_folder,
    robot_from_design,
    verify_folder,
)

__all__ = [
    "EXPORT_FORMATS",
    "EXPORT_FILES",
    "TRAJECTORY_FILE",
    "GAINS_FILE",
    "ExportResult",
    "export_study",
    "profile_differences",
]

EXPORT_FORMATS = ("csv", "json", "npz", "c", "ros2", "trajectory", "cia402")
TRAJECTORY_FILE = "trajectory.npz"
GAINS_FILE = "gains.json"

_SETPOINT_FILE = {
    "csv": "setpoints.csv",
    "json": "setpoints.json",
    "npz": "setpoints.npz",
    "c": "setpoints.h",
}
_GAINS_FILE = {
    "json": ("gains.json", "json"),
    "c": ("gains.h", "c"),
    "ros2": ("ros2_controllers.yaml", "ros2"),
}
_GOAL_FILE = "joint_trajectory.json"
_CIA402_FILES = ("cia402_csp.csv", "cia402_objects.csv")
#: Every file name ``armlab export`` may write (any format).
EXPORT_FILES = tuple(
    dict.fromkeys(
        [*_SETPOINT_FILE.values(), "setpoints.c"]
        + [n for n, _ in _GAINS_FILE.values()]
        + ["gains.c", _GOAL_FILE, *_CIA402_FILES]
    )
)


@dataclass
class ExportResult:
    """What :func:`export_study` wrote (``files``) and what the user should know (``notes``:
    a profile other than the study's and how it differs, a forced export)."""

    files: list[Path] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def profile_differences(study: ControllerProfile, other: ControllerProfile) -> list[str]:
    """``"cycle_s 0.001 -> 0.01"`` for every field in which two controller profiles differ."""
    out = []
    for f in fields(ControllerProfile):
        if f.name in ("name", "description", "source"):
            continue
        a, b = getattr(study, f.name), getattr(other, f.name)
        if a != b:
            out.append(f"{f.name} {a} -> {b}")
    return out


def _accuracy_budget(summary: dict, record: dict) -> tuple[float, str]:
    """The study's TCP accuracy budget [m] and where it comes from (module docstring)."""
    tcp = (summary.get("tracking") or {}).get("tcp") or {}
    v = tcp.get("accuracy_m")
    if isinstance(v, (int, float)) and math.isfinite(v) and v > 0:
        return float(v), "the study's tracking budget (summary.json tracking.tcp.accuracy_m)"
    doc = ((record.get("study") or {}).get("document") or {}).get("tracking") or {}
    v = doc.get("accuracy_m")
    if isinstance(v, (int, float)) and math.isfinite(v) and v > 0:
        return float(v), "the study's [tracking] accuracy_m"
    from armlab.control.result import POSITIONING_ACCURACY_M, SERVO_SHARE

    return (
        POSITIONING_ACCURACY_M * SERVO_SHARE,
        "armlab's servo budget: half of the thesis' 1 mm positioning accuracy",
    )


def _ff_velocity_scale(summary: dict) -> float:
    """1.0 when the study's tracking fed the planned velocity forward (or did not run)."""
    ff = (summary.get("tracking") or {}).get("feedforward")
    if isinstance(ff, list):
        return 1.0 if "velocity" in ff else 0.0
    return 1.0


@renamed_keywords(profile="controller=")
def export_study(
    study_dir: str | os.PathLike,
    fmt: str = "csv",
    controller=None,
    out_dir: str | os.PathLike | None = None,
    *,
    q_current=None,
    force: bool = False,
    c_real: str = "double",
) -> ExportResult:
    """Export a finished study's set-points (and gains) for the real controller.

    With the study's own controller the table is the one ``armlab run`` wrote, bit for bit
    (same robot, drive train, limits and controller, rebuilt from ``design.json``).

    Parameters
    ----------
    study_dir : path
        Folder of a finished study (``armlab run``).
    fmt : {"csv", "json", "npz", "c", "ros2", "trajectory", "cia402"}
        See the module docstring for the files of each.
    controller : str, path, ControllerProfile or None
        Controller profile (:func:`armlab.robot.load_profile`); None: the study's own controller
        (its profile with the study's ``[controller]`` keys). Another profile re-checks the table
        against it; the differences are listed in the result's notes.
    out_dir : path, optional
        Output folder (created if needed; never the study folder); default ``study_dir/export``.
    q_current : array (n_joints,), optional
        The robot's current pose [rad]: the table must start there.
    force : bool
        Export a design that fails checks; the exported table records the failed checks.
    c_real : {"double", "float"}
        C type of the gains (format ``c``).

    Returns
    -------
    ExportResult
        The files written and the notes.

    Raises
    ------
    DesignFailure
        The study's design fails checks (named in the message) and ``force`` is False.
    LimitViolation
        A pre-flight check fails (first failing cycle, joint and limit in the message);
        nothing is written.
    InputError
        Unknown format, not a study folder, files changed since the run (checksums), the URDF
        changed, gains tuned for another servo period, a target inside the study folder, no
        gains for ``ros2``, a goal tolerance below one encoder count, a table the drive cannot
        take (CiA 402 data types).
    """
    study = Path(study_dir)
    fmt = str(fmt).lower()
    if fmt not in EXPORT_FORMATS:
        raise InputError(f"unknown export format {fmt!r} (one of {', '.join(EXPORT_FORMATS)})")
    if not study.is_dir():
        raise InputError(f"study folder {study} not found")
    out = Path(out_dir) if out_dir is not None else study / "export"
    if out.resolve() == study.resolve():
        raise InputError(
            f"refusing to write into the study folder {study}: its files are the study's "
            "record; choose another --out folder"
        )
    with reading_folder(study, "armlab export"):  # no armlab run rewrites it meanwhile
        result, outputs = _render(study, fmt, controller, out, q_current, force, c_real)
        with locked_folder(out, "armlab export"):  # one writer per folder
            result.files = list(atomic_write_many(outputs))
    return result


def _render(
    study: Path, fmt: str, controller, out: Path, q_current, force: bool, c_real: str
) -> tuple[ExportResult, list[tuple[Path, bytes | str]]]:
    """Everything :func:`export_study` writes, rendered and checked: (result, files)."""
    summary = verify_folder(study)
    design = summary.get("design", {})
    failed = list(design.get("failed_checks", []))
    result = ExportResult()
    if design.get("verdict") != "pass":
        what = (
            f"fails {len(failed)} check(s): " + "; ".join(failed)
            if failed
            else "was not judged: " + "; ".join(design.get("not_judged", []))
        )
        if not force:
            raise DesignFailure(
                f"export refused: the design of {study} {what} (--force exports it)"
            )
        result.notes.append(f"forced export: the design {what}")
    record = load_design(study)
    study_profile = controller_from_design(record)
    prof = study_profile if controller is None else load_profile(controller)
    if controller is not None:
        diff = profile_differences(study_profile, prof)
        if diff:
            result.notes.append(
                f"controller profile {prof.name!r} instead of the study's "
                f"{study_profile.name!r}: " + ", ".join(diff) + " (the table is checked against it)"
            )
    outputs: list[tuple[Path, bytes | str]] = []
    study_info = record.get("study") or {}
    source: dict = {
        "study": study_info.get("source"),
        "study_sha256": study_info.get("sha256"),
    }
    if failed:
        source["forced_despite"] = failed
    robot = robot_from_design(record)  # every format needs it (table, lever arms, drives)

    table = None
    if fmt in (*_SETPOINT_FILE, "trajectory", "cia402"):
        tpath = study / TRAJECTORY_FILE
        if not tpath.is_file():
            raise InputError(f"{study}: no {TRAJECTORY_FILE}")
        traj = load_trajectory(tpath)
        table = setpoint_table(robot, traj, prof, q_current=q_current, source=source)
        if fmt in _SETPOINT_FILE:
            outputs += table.files(out / _SETPOINT_FILE[fmt], fmt)

    gains = None
    gpath = study / GAINS_FILE
    if fmt in (*_GAINS_FILE, "trajectory") and gpath.is_file():
        gains = load_gains(gpath)
    if fmt in _GAINS_FILE and gains is not None:
        periods = {lg.sample_time_s for g in gains.joints.values() for lg in (g.speed, g.position)}
        if any(abs(p - prof.servo_period_s) > 1e-12 for p in periods):
            raise InputError(
                f"{study}: the gains were tuned for a servo period of "
                f"{sorted(periods)} s, controller profile {prof.name!r} has "
                f"{prof.servo_period_s} s: run the study with this controller"
            )
    elif fmt == "ros2":
        raise InputError(f"{study}: no {GAINS_FILE} to export as ros2_control YAML")
    gsource: dict[str, object] | None = None
    if gains is not None:
        gsource = {"file": GAINS_FILE, "sha256": file_sha256(gpath)}
        if failed:
            gsource["forced_despite"] = failed

    constraints = None
    if fmt in ("ros2", "trajectory"):
        from armlab.deploy.ros2 import jtc_constraints

        accuracy_m, how = _accuracy_budget(summary, record)
        constraints = jtc_constraints(
            robot, gains, accuracy_m=accuracy_m, controller=prof, accuracy_source=how
        )

    if fmt in ("json", "c") and gains is not None:
        name, gfmt = _GAINS_FILE[fmt]
        outputs += gains_files(out / name, gains, gfmt, source=gsource, real=c_real)
    elif fmt == "ros2":
        assert gains is not None
        joints = [j for j in robot.joint_names if j in gains.joints]
        untuned = [j for j in robot.joint_names if j not in gains.joints]
        if untuned:
            result.notes.append(
                f"no gains for joint(s) {', '.join(untuned)}: the ros2 controller leaves them out"
            )
        outputs += gains_files(
            out / _GAINS_FILE["ros2"][0],
            gains,
            "ros2",
            source=gsource,
            joints=joints,
            constraints=constraints,
            ff_velocity_scale=_ff_velocity_scale(summary),
        )
    elif fmt == "trajectory":
        from armlab.deploy.ros2 import render_follow_joint_trajectory

        outputs.append(
            (out / _GOAL_FILE, render_follow_joint_trajectory(table, constraints, source=source))
        )
    elif fmt == "cia402":
        from armlab.deploy.cia402 import cia402_csp

        assert table is not None
        outputs += cia402_csp(robot, table, prof, source=source).files(out)

    return result, outputs
