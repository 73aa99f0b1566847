"""``armlab export``: set-point tables and gains of a finished study, in the controller's formats.

A study folder (written by :mod:`armlab.study`) holds ``summary.json`` (the verdict and the sha256
of every file), ``design.json`` (the resolved design: robot, drive train after the study's
overrides, limits, controller profile -- :mod:`armlab.study.record`), ``trajectory.npz``,
``gains.json`` and, for a passing design, ``setpoints.csv``. Export checks the folder against
the checksums, rebuilds the robot, its drive train and the controller from ``design.json`` alone
and re-checks rather than trusts the record (issue 24): the design's verdict is recomputed from
the stage results summary.json records (:mod:`armlab.study.recheck`; a ``design.verdict`` that does
not follow from them is refused), the sizing checks are re-run with design.json's drive train on
the recorded plan (all of them when the study sized its drives, else the limits of the hardware,
``HARDWARE_CHECKS``: peak motor and reducer torque, motor and reducer input speed, pulse
rate), and the set-point pre-flight runs against each drive train's own speed limit
(``drive_train_velocity``), and the recorded plan is checked for collisions again against the
recorded study's scene (``recleared``). A failing design is refused
unless ``force``. The study folder and ``out_dir`` are locked while export reads and writes
them (:func:`armlab.study.record.locked_folder`). It writes into ``out_dir``:

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

import errno
import math
import os
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np

from armlab._keywords import renamed_keywords
from armlab.deploy.carries import target_of
from armlab.deploy.gains_export import gains_files, load_gains
from armlab.deploy.provenance import file_sha256
from armlab.deploy.table import setpoint_table
from armlab.deploy.trajfile import load_trajectory
from armlab.errors import DesignFailure, InputError
from armlab.io import atomic_write_many
from armlab.io.lock import is_lock_file
from armlab.robot.controller import ControllerProfile, load_profile
from armlab.study.budget import check_table_rows
from armlab.study.export_target import check_target
from armlab.study.recheck import (
    drive_train_velocity,
    recleared,
    recorded_verdict,
    resized,
    same_study,
)
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


#: the first line of ``cia402_objects.csv`` (the one export file without an armlab header)
_OBJECTS_HEADER = b"axis,joint,index,subindex,name,data_type,value,unit"


def _written_by_export(path: Path) -> bool:
    """Whether ``path`` is a file ``armlab export`` writes, by its name and its own header:
    the first line names armlab (CSV, C, YAML), the JSON has an ``armlab.*`` format tag, the
    ``.npz`` an ``armlab.*`` ``meta_json``; ``cia402_objects.csv`` starts with its columns."""
    if path.name not in EXPORT_FILES or not path.is_file() or path.is_symlink():
        return False
    try:
        with open(path, "rb") as f:
            head = f.read(512)
    except OSError:
        return False
    if path.suffix == ".npz":
        import json
        import zipfile

        try:
            with zipfile.ZipFile(path) as z:
                if "meta_json.npy" not in z.namelist():
                    return False
            with np.load(path, allow_pickle=False) as z:
                meta = json.loads(str(z["meta_json"]))
        except Exception:  # not a zip, not numpy, not JSON: not armlab's
            return False
        return isinstance(meta, dict) and str(meta.get("format", "")).startswith("armlab.")
    first = head.split(b"\n", 1)[0]
    if path.name == _CIA402_FILES[1]:
        return first.rstrip(b"\r") == _OBJECTS_HEADER
    return b"armlab" in first or b'"format": "armlab.' in head


def _partial(path: Path) -> bool:
    """A temporary file of an atomic write killed before its rename (``.<name>.<hex>.tmp``)."""
    return path.name.startswith(".") and path.name.endswith(".tmp")


def _check_out_dir(out: Path, overwrite: bool) -> None:
    """Refuse an ``--out`` that is a file, or a folder holding files ``armlab export`` did not
    write (another program's ``setpoints.csv``, anything else) unless ``overwrite``: export
    would silently replace them (issue 24 item 8). With ``overwrite`` only the files of this
    export are replaced; the others are left as they are."""
    if out.exists() and not out.is_dir():  # an error of the file system: exit status 3
        raise NotADirectoryError(errno.ENOTDIR, "export --out is a file, not a folder", str(out))
    if not out.is_dir() or overwrite:
        return
    foreign = sorted(
        p.name
        for p in out.iterdir()
        if not (_written_by_export(p) or is_lock_file(p) or _partial(p))
    )
    if foreign:
        more = f" and {len(foreign) - 5} more" if len(foreign) > 5 else ""
        shown = ", ".join(foreign[:5]) + more
        raise InputError(
            f"export refused: {out} holds files armlab export did not write ({shown}); choose "
            "an empty or new folder, or --overwrite to write the export's files there anyway "
            "(the others are kept)"
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
    overwrite: bool = False,
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
    overwrite : bool
        Write into a folder that holds files export did not write (they are kept; same-named
        ones replaced). Without it such a folder is refused: only a new or empty folder, or
        one holding earlier exports (recognised by their armlab headers), is written to.

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
        Unknown format, not a study folder, an ``out_dir`` that holds files export did not
        write (without ``overwrite``), files changed since the run (checksums), the URDF
        changed, gains tuned for another servo period, a target inside the study folder, no
        gains for ``ros2``, a goal tolerance below one encoder count, a table the drive cannot
        take (CiA 402 data types), an edited summary.json (a design verdict that does not
        follow from its stage results), another client writing either folder.
    OSError
        ``out_dir`` is a file (NotADirectoryError), or the file system refuses a write
        (``armlab`` exits 3).
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
    _check_out_dir(out, overwrite)  # fail fast, before rendering
    with reading_folder(study, "armlab export"):  # no armlab run rewrites it meanwhile
        result, outputs = _render(study, fmt, controller, out, q_current, force, c_real)
        with locked_folder(out, "armlab export"):  # one writer per folder
            _check_out_dir(out, overwrite)  # again, now that no other client writes it
            result.files = list(atomic_write_many(outputs))
    return result


def _render(
    study: Path, fmt: str, controller, out: Path, q_current, force: bool, c_real: str
) -> tuple[ExportResult, list[tuple[Path, bytes | str]]]:
    """Everything :func:`export_study` writes, rendered and checked: (result, files)."""
    summary = verify_folder(study)
    record = load_design(study)
    same_study(summary, record, study)
    verdict = recorded_verdict(summary, record, study)
    robot = robot_from_design(record)  # every format needs it (table, lever arms, drives)
    robot.limits = drive_train_velocity(robot)
    tpath = study / TRAJECTORY_FILE
    traj = load_trajectory(tpath) if tpath.is_file() else None  # read once, for both uses
    study_profile = controller_from_design(record)
    again = resized(traj, summary, record, robot, study_profile)  # the drive train judged again
    again += recleared(traj, record, robot)  # and the plan against the recorded scene
    failed = list(dict.fromkeys([*verdict.failed_checks, *again]))
    result = ExportResult()
    if verdict.verdict != "pass" or failed:
        what = (
            f"fails {len(failed)} check(s): " + "; ".join(failed)
            if failed
            else "was not judged: " + "; ".join(verdict.not_judged)
        )
        if not force:
            raise DesignFailure(
                f"export refused: the design of {study} {what} (--force exports it)"
            )
        result.notes.append(f"forced export: the design {what}")
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
    # the study's gains, read once: for the gains files, the goal, and the target simulation
    gpath = study / GAINS_FILE
    wanted = fmt in (*_GAINS_FILE, "trajectory") or target_of(fmt).simulable
    gains = load_gains(gpath) if wanted and gpath.is_file() else None
    # export what was verified: the controller this format feeds (armlab.deploy.carries)
    target = check_target(
        fmt,
        summary=summary,
        record=record,
        robot=robot,
        traj=traj,
        gains=gains,
        controller=study_profile,
        force=force,
    )
    result.notes += target.notes
    source["controller"] = target.block
    if target.forced:
        source["forced_despite"] = [*source.get("forced_despite", []), *target.forced]

    table = None
    if fmt in (*_SETPOINT_FILE, "trajectory", "cia402"):
        if traj is None:
            raise InputError(f"{study}: no {TRAJECTORY_FILE}")
        check_table_rows(traj, prof, robot.n_joints)
        table = setpoint_table(robot, traj, prof, q_current=q_current, source=source)
        if fmt in _SETPOINT_FILE:
            outputs += table.files(out / _SETPOINT_FILE[fmt], fmt)

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
        gsource["controller"] = target.block
        if "forced_despite" in source:
            gsource["forced_despite"] = source["forced_despite"]

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
