"""A robot's URDF geometry (visual or collision) on the robot's own joints.

The 3D views (:mod:`armlab.viz`) and the collision check (:mod:`armlab.collision.geometry`)
both find the URDF's meshes (:func:`mesh_search_dirs`, :func:`resolve_mesh`), build a Pinocchio
``GeometryModel`` and reduce it to the joints the robot moves (locked joints at 0):
:func:`reduced_geometry`.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import pinocchio as pin

from armlab.errors import RobotDescriptionError
from armlab.robot.urdf_check import revolute_continuous

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["reduced_geometry", "mesh_search_dirs", "resolve_mesh"]


def mesh_search_dirs(urdf: Path, package_dirs: Sequence[str | os.PathLike]) -> list[Path]:
    """Folders in which ``package://PKG/...`` is looked up as ``<folder>/PKG/...``."""
    dirs = [Path(d) for d in package_dirs]
    dirs += list(urdf.resolve().parents)
    try:  # the Python part of example-robot-data, where installed
        from example_robot_data.robots_loader import EXAMPLE_ROBOT_DATA_MODEL_DIR

        dirs.append(Path(EXAMPLE_ROBOT_DATA_MODEL_DIR).parent.parent)
    except (ImportError, AttributeError):
        pass
    for entry in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
        if entry:
            dirs += [Path(entry), Path(entry).parent]
    return list(dict.fromkeys(dirs))


def resolve_mesh(filename: str, urdf: Path, dirs: list[Path]) -> Path | None:
    """The file a URDF mesh ``filename`` names, or None if it is not found."""
    if filename.startswith("package://"):
        rest = filename[len("package://") :]
        for d in dirs:
            cand = d / rest
            if cand.is_file():
                return cand
        return None
    if filename.startswith("file://"):
        filename = filename[len("file://") :]
    path = Path(filename)
    if not path.is_absolute():
        path = urdf.parent / path
    return path if path.is_file() else None


def reduced_geometry(
    robot: Robot,
    text: str,
    kind: pin.GeometryType,
    source: str,
    package_dirs: list[str] | None = None,
) -> tuple[pin.Model, pin.GeometryModel]:
    """The URDF ``text``'s model and ``kind`` geometry, reduced to ``robot``'s joints.

    Continuous joints are built as the robot's loader builds them
    (:func:`armlab.robot.urdf_check.revolute_continuous`), so the model's joints are the
    robot's.

    Raises
    ------
    RobotDescriptionError
        Pinocchio cannot build the geometry (its first line), or the joints are not the
        robot's (one line naming the URDF and ``source``).
    """
    urdf = Path(robot.urdf_path)
    text, _ = revolute_continuous(text)
    try:
        full = pin.buildModelFromXML(text)
        if package_dirs is None:
            geom = pin.buildGeomFromUrdfString(full, text, kind)
        else:
            geom = pin.buildGeomFromUrdfString(full, text, kind, package_dirs=package_dirs)
    except Exception as exc:  # pinocchio: ValueError/RuntimeError with XML details
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise RobotDescriptionError(
            f"{urdf}: cannot build its {source} geometry ({first})"
        ) from None
    wanted = list(robot.model.names)
    locked = [j for j in range(1, full.njoints) if full.names[j] not in wanted]
    model = full
    if locked:
        model, geoms = pin.buildReducedModel(full, [geom], locked, pin.neutral(full))
        geom = geoms[0]
    if list(model.names) != wanted:
        raise RobotDescriptionError(
            f"{urdf}: its joints {list(model.names[1:])} are not the robot's {wanted[1:]}"
        )
    return model, geom
