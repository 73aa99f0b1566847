"""``trajectory.npz``: the planned trajectory of a study, with the robot it was planned for.

The study runner saves the trajectory with :func:`save_trajectory`; ``armlab export`` reads it
back with :func:`load_trajectory` (the robot it rebuilds comes from the study's ``design.json``,
:mod:`armlab.study.record`, never from this file's summary of it). The file
holds ``t, q, qd, qdd`` (and ``qddd``), the joint names, the planner (``method``), the content
checksum (:func:`armlab.deploy.provenance.trajectory_sha256`, verified on loading), armlab's
version and the robot: name, URDF path, tool frame, payload and the joint limits the study
planned with.
"""

from __future__ import annotations

import io
import json
import os
import zipfile
import zlib
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from armlab.deploy.provenance import armlab_version, file_sha256, trajectory_sha256
from armlab.errors import InputError
from armlab.io import atomic_write

if TYPE_CHECKING:
    from armlab.robot.model import Robot
    from armlab.trajectory import Trajectory

__all__ = ["TRAJECTORY_FORMAT", "save_trajectory", "load_trajectory"]

TRAJECTORY_FORMAT = "armlab.trajectory/1"
#: the arrays every trajectory file holds (``qddd`` is optional)
_ARRAYS = ("t", "q", "qd", "qdd", "joint_names", "method", "sha256", "robot_json", "armlab_version")
#: what numpy / zipfile raise on a truncated or corrupt .npz
_UNREADABLE = (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error)


def _robot_info(robot) -> dict:
    lim = robot.limits
    arr = lambda a: None if a is None else [float(x) for x in a]  # noqa: E731
    return {
        "name": robot.name,
        "urdf_path": str(getattr(robot, "urdf_path", "")),
        "joint_names": list(robot.joint_names),
        "tool_frame": getattr(robot, "tool_frame", None),
        "payload_kg": float(robot.payload.mass_kg) if getattr(robot, "payload", None) else None,
        "limits": {
            "lower_rad": arr(lim.lower_rad),
            "upper_rad": arr(lim.upper_rad),
            "velocity_rad_s": arr(lim.velocity_rad_s),
            "acceleration_rad_s2": arr(lim.acceleration_rad_s2),
            "jerk_rad_s3": arr(lim.jerk_rad_s3),
        },
    }


def save_trajectory(path: str | os.PathLike, trajectory, robot: Robot | None = None) -> Path:
    """Write ``trajectory`` (and the robot it was planned for) to ``path`` (.npz), atomically.

    Parameters
    ----------
    path : path
    trajectory : Trajectory
    robot : Robot, optional
        Summarised in the file for a reader (name, URDF path, tool frame,
        payload, limits).

    Returns
    -------
    Path
    """
    arrays = {
        "format": np.array(TRAJECTORY_FORMAT),
        "t": trajectory.t,
        "q": trajectory.q,
        "qd": trajectory.qd,
        "qdd": trajectory.qdd,
        "joint_names": np.array(list(trajectory.joint_names)),
        "method": np.array(trajectory.method or ""),
        "sha256": np.array(trajectory_sha256(trajectory)),
        "armlab_version": np.array(armlab_version()),
        "robot_json": np.array(json.dumps(None if robot is None else _robot_info(robot))),
    }
    if trajectory.qddd is not None:
        arrays["qddd"] = trajectory.qddd
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return atomic_write(path, buf.getvalue())


def load_trajectory(path: str | os.PathLike) -> Trajectory:
    """Read a trajectory written by :func:`save_trajectory`.

    Returns
    -------
    Trajectory
        With ``meta["robot"]`` (dict or None), ``meta["sha256"]`` (content checksum, verified),
        ``meta["file"]`` and ``meta["file_sha256"]``.

    Raises
    ------
    InputError
        Missing, truncated, corrupt (not a zip, bad CRC) or unreadable file, not an armlab
        trajectory, checksum mismatch; one line.
    """
    from armlab.trajectory import Trajectory

    path = Path(path)
    if not path.is_file():
        raise InputError(f"trajectory file {path} not found")
    try:
        with np.load(path, allow_pickle=False) as z:
            a = {k: z[k] for k in z.files}
    except _UNREADABLE as exc:  # truncated, not a zip, corrupt member (CRC), unreadable array
        why = str(exc).strip().splitlines()[0] if str(exc).strip() else "no details"
        raise InputError(
            f"{path}: not a readable .npz, truncated or corrupt ({type(exc).__name__}: {why})"
        ) from None
    if str(a.get("format", "")) != TRAJECTORY_FORMAT:
        raise InputError(
            f"{path}: not an armlab trajectory file (format "
            f"{str(a.get('format', None))!r}, expected {TRAJECTORY_FORMAT!r})"
        )
    missing = [k for k in _ARRAYS if k not in a]
    if missing:
        raise InputError(f"{path}: corrupt trajectory file (no array(s) {missing})")
    traj = Trajectory(
        a["t"],
        a["q"],
        a["qd"],
        a["qdd"],
        a.get("qddd"),
        joint_names=[str(n) for n in a["joint_names"]],
        method=str(a["method"]),
    )
    sha = trajectory_sha256(traj)
    if sha != str(a["sha256"]):
        raise InputError(
            f"{path}: checksum mismatch (file says {str(a['sha256'])[:12]}..., "
            f"content is {sha[:12]}...): the file is corrupt or was edited"
        )
    try:
        robot_info = json.loads(str(a["robot_json"]))
    except ValueError:
        raise InputError(f"{path}: corrupt trajectory file (robot_json is not JSON)") from None
    traj.meta.update(
        {
            "robot": robot_info,
            "sha256": sha,
            "file": str(path),
            "file_sha256": file_sha256(path),
            "armlab_version": str(a["armlab_version"]),
        }
    )
    return traj
