"""Generate a built-in arm's URDF from its DH table and drives file.

``python -m armlab.robot.generate teachbot6`` rewrites ``robot_desc/teachbot6/teachbot6.urdf``
from ``mdh.toml`` (geometry, ranges, speeds, masses, the visual primitives drawn from the table)
and ``drives.toml`` (effort = available output torque, thesis table 4.3 rule), then the
description's ``collision_pairs.toml`` (the disabled-pair analysis of the new URDF's collision
geometry, :mod:`armlab.collision.pairs`, keyed by its sha256).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from armlab.io import atomic_write
from armlab.robot.dh import read_dh_table, urdf_from_dh
from armlab.robot.drives_file import read_drives
from armlab.robot.model import robot_desc_dir

__all__ = ["description_urdf", "write_collision_pairs", "write_description_urdf"]


def description_urdf(folder: str | Path) -> str:
    """The URDF text a description folder (``mdh.toml`` + optional ``drives.toml``) generates."""
    folder = Path(folder)
    table = read_dh_table(folder / "mdh.toml")
    effort = None
    if (folder / "drives.toml").is_file():
        drives = read_drives(folder / "drives.toml", table.joint_names)
        effort = np.array([drives[n].available_torque_Nm for n in table.joint_names])
    return urdf_from_dh(table, effort_Nm=effort)


def write_description_urdf(folder: str | Path) -> Path:
    """Regenerate ``<folder>/<name>.urdf``; returns its path."""
    folder = Path(folder)
    path = folder / f"{folder.name}.urdf"
    atomic_write(path, description_urdf(folder))
    return path


def write_collision_pairs(folder: str | Path) -> Path:
    """Write ``<folder>/collision_pairs.toml``: the sampled disabled-pair analysis of the
    folder's URDF (:func:`armlab.collision.pairs.analyse_pairs`, default samples, seed 0)."""
    from armlab.collision.geometry import robot_geometry
    from armlab.collision.pairs import analyse_pairs, write_pairs
    from armlab.robot.model import load_robot

    folder = Path(folder)
    robot = load_robot(folder)
    geom = robot_geometry(robot)
    path = folder / "collision_pairs.toml"
    return write_pairs(path, analyse_pairs(robot, geom), robot.name, geom.source)


if __name__ == "__main__":  # pragma: no cover - a maintenance command
    for arg in sys.argv[1:] or ["teachbot6"]:
        folder = Path(arg) if Path(arg).is_dir() else robot_desc_dir() / arg
        print(write_description_urdf(folder))
        print(write_collision_pairs(folder))
