"""The design record of a study folder (``design.json``): everything the tables were made from.

A study folder is one consistent record. ``design.json`` holds the fully resolved design the
stages used -- the URDF (path and content sha256), locked joints, tool frame, mounting of the base,
payload, the resolved limits with their sources, the drive train after the study's overrides and
the controller profile after the study's ``[controller]`` keys -- with armlab's version and the
study document itself. ``armlab export`` rebuilds the robot and the controller from this record
alone (the URDF is read again and must still have the recorded checksum), so it reproduces the
tables of ``armlab run`` bit for bit; it never rebuilds from ``robot_desc/`` defaults.

``summary.json`` lists the sha256 of every file the run wrote (``files``); :func:`verify_folder`
refuses a folder whose files no longer match.
"""

from __future__ import annotations

import errno
import json
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import asdict
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab.deploy.provenance import armlab_version, file_sha256
from armlab.errors import InputError
from armlab.io.lock import FolderLock, is_lock_file
from armlab.robot.controller import ControllerProfile
from armlab.robot.drives import Drive, Encoder
from armlab.robot.drives_file import amplifier_from_dict, motor_from_dict, reducer_from_dict

if TYPE_CHECKING:
    from armlab.robot.limits import Limits
    from armlab.robot.model import Robot
    from armlab.study.spec import StudySpec

__all__ = [
    "DESIGN_FILE",
    "DESIGN_FORMAT",
    "SUMMARY_FILE",
    "OUTPUT_FILES",
    "design_record",
    "load_design",
    "robot_from_design",
    "controller_from_design",
    "verify_folder",
    "prepare_out_dir",
    "locked_folder",
    "reading_folder",
]

DESIGN_FILE = "design.json"
SUMMARY_FILE = "summary.json"
DESIGN_FORMAT = "armlab.design/1"

#: Files (and patterns) a study run writes into its folder; a re-run removes them first.
OUTPUT_FILES = (
    SUMMARY_FILE,
    DESIGN_FILE,
    "report.md",
    "setpoints.csv",
    "gains.json",
    "trajectory.npz",
    "motion.html",
    "*.png",
    ".*.tmp",
)


def _arr(x: Any) -> Any:
    if x is None:
        return None
    return np.asarray(x, dtype=float).tolist()


def design_record(
    robot: Robot, controller: ControllerProfile, spec: StudySpec | None = None
) -> dict:
    """The resolved design of a study as JSON-able data (``design.json``).

    ``spec`` is the study it comes from (None: a design assembled in code, such as a notebook's).
    """
    urdf = Path(robot.urdf_path)
    return {
        "format": DESIGN_FORMAT,
        "armlab_version": armlab_version(),
        "study": None
        if spec is None
        else {"source": spec.source, "sha256": spec.hash, "document": spec.document},
        "robot": {
            "name": robot.name,
            "urdf_path": str(urdf.resolve()),
            "urdf_sha256": file_sha256(urdf),
            "joint_names": list(robot.joint_names),
            "lock_joints": [] if spec is None else list(spec.robot.lock_joints),
            "tool_frame": robot.tool_frame,
            "transform_base_to_world": _arr(robot.transform_base_to_world),
            "payload": {
                "mass_kg": float(robot.payload.mass_kg),
                "com_m": _arr(robot.payload.com_m),
                "inertia_kg_m2": _arr(robot.payload.inertia_kg_m2),
            },
        },
        "limits": robot.limits.to_dict(),
        "drives": None
        if robot.drives is None
        else {name: asdict(robot.drives[name]) for name in robot.joint_names},
        "controller": controller.to_dict(),
    }


def load_design(folder: str | os.PathLike) -> dict:
    """Read ``folder/design.json``; :class:`InputError` if it is missing or not a design record."""
    path = Path(folder) / DESIGN_FILE
    if not path.is_file():
        raise InputError(
            f"{folder}: no {DESIGN_FILE} (not a study folder written by this armlab: run the "
            "study again with armlab run)"
        )
    try:
        record = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: not readable JSON ({exc})") from None
    if not isinstance(record, dict) or record.get("format") != DESIGN_FORMAT:
        raise InputError(f"{path}: not an armlab design record (format {DESIGN_FORMAT!r})")
    return record


def _nan_for_null(part: dict) -> dict:
    """A drive part read back from JSON without its ``null`` values (how an unknown, NaN, figure
    is written): the part's own default -- NaN, "not given" -- applies again."""
    return {k: v for k, v in part.items() if v is not None}


def _drive_from_dict(d: dict, where: str) -> Drive:
    return Drive(
        joint=d["joint"],
        motor=motor_from_dict(_nan_for_null(d["motor"]), f"{where} motor"),
        reducer=reducer_from_dict(_nan_for_null(d["reducer"]), f"{where} reducer"),
        encoder=Encoder(**d["encoder"]),
        acceleration_rad_s2=float(d["acceleration_rad_s2"]),
        jerk_rad_s3=float(d["jerk_rad_s3"]),
        derating=float(d.get("derating", 1.0)),
        amplifier=None
        if d.get("amplifier") is None
        else amplifier_from_dict(_nan_for_null(d["amplifier"]), f"{where} amplifier"),
    )


def robot_from_design(record: dict) -> Robot:
    """Rebuild the study's robot from its design record.

    The URDF is loaded from the recorded path and must have the recorded sha256; joints are
    locked, the tool frame, base mounting (and so gravity) and payload restored; the drive train
    and the limits are the recorded ones (study overrides included), not the description's.

    Raises
    ------
    InputError
        The URDF is gone or changed since the study ran.
    """
    from armlab.robot import load_robot

    r = record["robot"]
    urdf = Path(r["urdf_path"])
    if not urdf.is_file():
        raise InputError(f"design.json: the study's URDF {urdf} is gone")
    sha = file_sha256(urdf)
    if sha != r["urdf_sha256"]:
        raise InputError(
            f"design.json: the URDF {urdf} changed since the study ran (sha256 {sha[:12]}..., "
            f"recorded {r['urdf_sha256'][:12]}...): run the study again"
        )
    robot = load_robot(
        urdf,
        tool_frame=r["tool_frame"],
        lock_joints=list(r["lock_joints"]),
        transform_base_to_world=np.asarray(r["transform_base_to_world"], float),
    )
    if list(robot.joint_names) != list(r["joint_names"]):
        raise InputError(
            f"design.json: joints {r['joint_names']} differ from the URDF's {robot.joint_names}"
        )
    robot.name = r["name"]
    p = r["payload"]
    robot.attach_payload(p["mass_kg"], p["com_m"], p["inertia_kg_m2"])
    if record.get("drives") is not None:
        robot.drives = {
            name: _drive_from_dict(d, f"design.json drives.{name}")
            for name, d in record["drives"].items()
        }
    if record.get("limits") is not None:
        robot.limits = limits_from_dict(record["limits"])
    return robot


def limits_from_dict(d: dict) -> Limits:
    """The :class:`~armlab.robot.limits.Limits` of :meth:`Limits.to_dict` (a JSON round trip)."""
    from armlab.robot.limits import Limits

    names = list(d["joint_names"])

    def arr(key: str) -> np.ndarray | None:
        v = d.get(key)
        return None if v is None else np.array([float(v[n]) for n in names])

    def required(key: str) -> np.ndarray:  # the joint range is always written
        a = arr(key)
        if a is None:
            raise InputError(f"design.json limits: no {key}")
        return a

    return Limits(
        joint_names=tuple(names),
        lower_rad=required("lower_rad"),
        upper_rad=required("upper_rad"),
        velocity_rad_s=arr("velocity_rad_s"),
        acceleration_rad_s2=arr("acceleration_rad_s2"),
        jerk_rad_s3=arr("jerk_rad_s3"),
        torque_Nm=arr("torque_Nm"),
        sources={k: tuple(v[n] for n in names) for k, v in d.get("sources", {}).items()},
    )


def controller_from_design(record: dict) -> ControllerProfile:
    """The study's controller profile (after its ``[controller]`` keys) from the record."""
    return ControllerProfile(**record["controller"])


def verify_folder(folder: str | os.PathLike) -> dict:
    """Check a study folder: ``summary.json`` readable and every file it lists unchanged.

    Returns
    -------
    dict
        The summary.

    Raises
    ------
    InputError
        No summary (an unfinished or foreign folder), or a listed file missing or changed.
    """
    folder = Path(folder)
    path = folder / SUMMARY_FILE
    if not path.is_file():
        raise InputError(
            f"{folder}: no {SUMMARY_FILE} (the study did not finish, or this is not a study folder)"
        )
    try:
        summary = json.loads(path.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: not readable JSON ({exc})") from None
    files = summary.get("files")
    if not isinstance(files, dict) or DESIGN_FILE not in files:
        raise InputError(f"{path}: lists no checksummed files (written by an older armlab?)")
    for name, sha in files.items():
        f = folder / name
        if not f.is_file():
            raise InputError(f"{folder}: {name} listed in {SUMMARY_FILE} is missing")
        actual = file_sha256(f)
        if actual != sha:
            raise InputError(
                f"{folder}: {name} does not match the checksum in {SUMMARY_FILE} (changed or "
                "left by another run): run the study again"
            )
    return summary


def _recorded_study_hash(folder: Path) -> str | None:
    """The study sha256 an earlier run recorded in ``folder``: summary.json's, else design.json's
    (written first, so a run killed before its summary is still recognised)."""
    for name, path in ((SUMMARY_FILE, ("study", "hash")), (DESIGN_FILE, ("study", "sha256"))):
        f = folder / name
        if not f.is_file():
            continue
        try:
            value: Any = json.loads(f.read_text())
            for key in path:
                value = value.get(key) if isinstance(value, dict) else None
        except (OSError, ValueError):
            value = None
        if isinstance(value, str):
            return value
    return None


@contextmanager
def locked_folder(folder: str | os.PathLike, command: str) -> Iterator[Path]:
    """Create ``folder`` if needed and hold its lock (``folder/.armlab.lock``,
    :class:`armlab.io.lock.FolderLock`) while the block runs: one writer per study folder.

    Raises
    ------
    InputError
        Another live client (``armlab run``, ``armlab export``) holds the lock: one line
        naming its command, pid, host and start time.
    NotADirectoryError
        ``folder`` is a file (``armlab`` exits 3, as for every error of the file system).
    """
    path = Path(folder)
    if path.exists() and not path.is_dir():
        raise NotADirectoryError(errno.ENOTDIR, "--out exists and is not a folder", str(path))
    path.mkdir(parents=True, exist_ok=True)
    with FolderLock(path, command):
        yield path


@contextmanager
def reading_folder(folder: str | os.PathLike, command: str) -> Iterator[Path]:
    """Hold the lock of a study folder that is read (``armlab export``): no ``armlab run`` can
    rewrite it meanwhile. A folder this process cannot write (read-only media, another user's
    archive) is read without the lock: no writer of this kind can change it either."""
    path = Path(folder)
    try:
        lock = FolderLock(path, command)
        lock.acquire()
    except OSError as exc:
        if exc.errno in (errno.EROFS, errno.EACCES, errno.EPERM):
            yield path
            return
        raise
    try:
        yield path
    finally:
        lock.release()


def _outputs(folder: Path) -> list[Path]:
    out: set[Path] = set()
    for pattern in OUTPUT_FILES:
        out.update(p for p in folder.glob(pattern) if p.is_file() and not is_lock_file(p))
    return sorted(out)


def prepare_out_dir(folder: str | os.PathLike, study_hash: str, *, overwrite: bool) -> Path:
    """Make ``folder`` ready for a study run: create it, or clear an earlier run's outputs.

    A folder that is empty, or that holds an earlier run of the same study (its summary.json
    has the same study sha256), is cleared of the files a run writes (:data:`OUTPUT_FILES`),
    so no output of the earlier run can sit beside the new ones. Anything else is refused unless
    ``overwrite``; even then, files armlab did not write are never deleted: such a folder is
    refused. The caller holds the folder's lock (:func:`locked_folder`): one writer.

    Raises
    ------
    InputError
        The folder holds another study's outputs (without ``overwrite``) or files armlab does
        not write.
    """
    folder = Path(folder)  # made, and checked to be a folder, by locked_folder
    entries = [p for p in folder.iterdir() if not is_lock_file(p)]
    if not entries:
        return folder
    ours = set(_outputs(folder))
    foreign = sorted(
        p.name for p in entries if p not in ours and not (p.is_dir() and p.name == "export")
    )
    if foreign:
        shown = ", ".join(foreign[:5]) + (" ..." if len(foreign) > 5 else "")
        raise InputError(
            f"--out {folder}: holds files armlab did not write ({shown}): choose an empty or "
            "new folder"
        )
    recorded = _recorded_study_hash(folder)
    # a run killed after clearing the folder and before its design record leaves at most
    # partial files (.*.tmp) and no record: nobody's outputs, cleared like an empty folder
    leftovers = recorded is None and all(p.name.startswith(".") for p in ours)
    if recorded != study_hash and not leftovers and not overwrite:
        raise InputError(
            f"--out {folder}: holds the outputs of another study (or an unfinished run): "
            "choose another folder or pass --overwrite"
        )
    # the summary goes first (a kill from here on leaves no summary: export refuses the folder)
    # and the design record last (it tells a re-run that this folder is this study's)
    order = sorted(ours, key=lambda p: (p.name != SUMMARY_FILE, p.name == DESIGN_FILE, p.name))
    for p in order:
        p.unlink()
    _clear_default_exports(folder / "export")
    return folder


def _clear_default_exports(folder: Path) -> None:
    """Remove what an earlier ``armlab export`` wrote into ``folder`` (the study's default export
    folder): exports of the earlier run must not outlive it. Other files are left alone."""
    from armlab.study.export import EXPORT_FILES  # export reads this module: import on use

    if not folder.is_dir():
        return
    for name in EXPORT_FILES:
        (folder / name).unlink(missing_ok=True)
    if not any(folder.iterdir()):
        folder.rmdir()
