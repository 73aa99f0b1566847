"""Robot descriptions: DH tables, URDF generation, drive trains and the :class:`Robot`."""

from armlab.robot.dh import DHTable, LumpedMass, mdh_transforms, read_dh_table, urdf_from_dh
from armlab.robot.drives import Drive, Encoder, Motor, Reducer, read_drives
from armlab.robot.model import (
    JointLimits,
    Payload,
    Robot,
    list_robots,
    load_robot,
    robot_desc_dir,
)

__all__ = [
    "DHTable",
    "LumpedMass",
    "mdh_transforms",
    "read_dh_table",
    "urdf_from_dh",
    "Drive",
    "Encoder",
    "Motor",
    "Reducer",
    "read_drives",
    "JointLimits",
    "Payload",
    "Robot",
    "list_robots",
    "load_robot",
    "robot_desc_dir",
]
