"""Robot descriptions: DH tables, URDF generation, drive trains (and their model,
:mod:`armlab.robot.drivetrain`), controller profiles and the
:class:`Robot`."""

from armlab.robot.controller import (
    DEFAULT_PROFILE,
    ControllerProfile,
    list_profiles,
    load_profile,
)
from armlab.robot.dh import DHTable, LumpedMass, mdh_transforms, read_dh_table, urdf_from_dh
from armlab.robot.drives import Drive, Encoder, Motor, Reducer, read_drives
from armlab.robot.drivetrain import DriveTrain, drive_train
from armlab.robot.limits import Limits, description_limits, resolve_limits
from armlab.robot.model import (
    Payload,
    Robot,
    list_robots,
    load_robot,
    robot_desc_dir,
)
from armlab.robot.rigid_body import gravity_torques, mass_matrix, nonlinear_effects
from armlab.robot.symbolic import inverse_dynamics_function

__all__ = [
    "DEFAULT_PROFILE",
    "ControllerProfile",
    "list_profiles",
    "load_profile",
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
    "DriveTrain",
    "drive_train",
    "Limits",
    "description_limits",
    "resolve_limits",
    "Payload",
    "Robot",
    "list_robots",
    "load_robot",
    "robot_desc_dir",
    "gravity_torques",
    "mass_matrix",
    "nonlinear_effects",
    "inverse_dynamics_function",
]
