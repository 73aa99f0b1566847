"""``armlab export``: set-point tables and gains of a finished study, in the controller's formats.

A study folder (written by :mod:`armlab.study`) holds ``trajectory.npz`` (written with
:func:`armlab.deploy.save_trajectory`), ``gains.json`` (``ArmGains.to_json()``),
``setpoints.csv`` and ``summary.json``. Export writes into ``out_dir``:

=======  ==========================================================
format   files
=======  ==========================================================
csv      ``setpoints.csv``
json     ``setpoints.json``, ``gains.json`` (with provenance)
npz      ``setpoints.npz``
c        ``setpoints.h``, ``gains.h``
ros2     ``gains_ros2.yaml`` (joint_trajectory_controller gains)
=======  ==========================================================

Gains files are written when the study has ``gains.json`` (required for ``ros2``). Everything is
rendered and checked before the first byte is written; each file is written atomically, so a
refused export (a pre-flight :class:`~armlab.LimitViolation`) leaves nothing behind.
"""

from __future__ import annotations

import os
from pathlib import Path

from armlab.deploy.gains_export import load_gains, render_gains
from armlab.deploy.profiles import load_profile
from armlab.deploy.provenance import atomic_write_many, file_sha256
from armlab.deploy.table import setpoint_table
from armlab.deploy.trajfile import load_trajectory, trajectory_robot
from armlab.errors import InputError

__all__ = ["EXPORT_FORMATS", "TRAJECTORY_FILE", "GAINS_FILE", "export_study"]

EXPORT_FORMATS = ("csv", "json", "npz", "c", "ros2")
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
    "ros2": ("gains_ros2.yaml", "ros2"),
}


def export_study(
    study_dir: str | os.PathLike,
    fmt: str = "csv",
    profile=None,
    out_dir: str | os.PathLike | None = None,
    *,
    q_current=None,
) -> list[Path]:
    """Export a finished study's set-points (and gains) for the real controller.

    Parameters
    ----------
    study_dir : path
        Folder of a finished study (``trajectory.npz``, ``gains.json``).
    fmt : {"csv", "json", "npz", "c", "ros2"}
    profile : str, path, ControllerProfile or None
        Controller profile (:func:`armlab.deploy.load_profile`); None: the seed-002 DDA card.
    out_dir : path, optional
        Output folder (created if needed); default ``study_dir/export``.
    q_current : array (n_joints,), optional
        The robot's current pose [rad]: the table must start there.

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    LimitViolation
        A pre-flight check fails (first failing cycle, joint and limit in the message);
        nothing is written.
    InputError
        Unknown format, missing study files, a target that would overwrite a source file.
    """
    study = Path(study_dir)
    fmt = str(fmt).lower()
    if fmt not in EXPORT_FORMATS:
        raise InputError(f"unknown export format {fmt!r} (one of {', '.join(EXPORT_FORMATS)})")
    if not study.is_dir():
        raise InputError(f"study folder {study} not found")
    out = Path(out_dir) if out_dir is not None else study / "export"
    prof = load_profile(profile)
    outputs: list[tuple[Path, bytes | str]] = []

    if fmt in _SETPOINT_FILE:
        tpath = study / TRAJECTORY_FILE
        if not tpath.is_file():
            raise InputError(
                f"{study}: no {TRAJECTORY_FILE} (the study runner saves it with "
                "armlab.deploy.save_trajectory)"
            )
        traj = load_trajectory(tpath)
        robot = trajectory_robot(traj)
        table = setpoint_table(
            robot,
            traj,
            prof,
            q_current=q_current,
            source={"file": TRAJECTORY_FILE, "sha256": traj.meta["file_sha256"]},
        )
        outputs.append((out / _SETPOINT_FILE[fmt], table.render(fmt)))

    if fmt in _GAINS_FILE:
        gpath = study / GAINS_FILE
        if gpath.is_file():
            gains = load_gains(gpath)
            name, gfmt = _GAINS_FILE[fmt]
            outputs.append(
                (
                    out / name,
                    render_gains(
                        gains, gfmt, source={"file": GAINS_FILE, "sha256": file_sha256(gpath)}
                    ),
                )
            )
        elif fmt == "ros2":
            raise InputError(f"{study}: no {GAINS_FILE} to export as ros2_control YAML")

    sources = {(study / TRAJECTORY_FILE).resolve(), (study / GAINS_FILE).resolve()}
    for path, _ in outputs:
        if path.resolve() in sources:
            raise InputError(
                f"refusing to overwrite the study's own {path.name}: choose another --out folder"
            )
    out.mkdir(parents=True, exist_ok=True)
    return atomic_write_many(outputs)
