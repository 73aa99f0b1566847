"""Robot descriptions: DH tables, URDF generation, drive trains (and their model,
:mod:`armlab.robot.drivetrain`), controller profiles and the
:class:`Robot`."""

from armlab.robot.controller import ControllerProfile, list_profiles, load_profile
from armlab.robot.dh import DHTable, read_dh_table, urdf_from_dh
from armlab.robot.drives import Drive, Encoder, Motor, Reducer
from armlab.robot.drives_file import read_drives
from armlab.robot.drivetrain import DriveTrain, drive_train
from armlab.robot.limits import Limits, resolve_limits
from armlab.robot.model import Payload, Robot, list_robots, load_robot

__all__ = [
    "ControllerProfile",
    "DHTable",
    "Drive",
    "DriveTrain",
    "Encoder",
    "Limits",
    "Motor",
    "Payload",
    "Reducer",
    "Robot",
    "drive_train",
    "list_profiles",
    "list_robots",
    "load_profile",
    "load_robot",
    "read_dh_table",
    "read_drives",
    "resolve_limits",
    "urdf_from_dh",
]
