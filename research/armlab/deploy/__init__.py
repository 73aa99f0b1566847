"""Deployment: set-point tables and servo gains for the real controller, with safety checks.

Sources: SHU controller paper, §1 (DDA controller: 1 ms .. 2 s interpolation period, 0..4095
pulses per axis per period, x2/x4 encoder decoding, 12-bit +-10 V D/A); HR SJ-1 control-software
paper, §8 (fault handling: over-speed, over-limit -> made into pre-flight checks); DESIGN.md
"Set-point table".

* the controller is :func:`armlab.robot.load_profile` (``data/profiles/*.toml``, e.g.
  ``reference_dda``), handed as ``controller=`` to each function that depends on it.
* :func:`setpoint_table` — a trajectory sampled per controller cycle, in encoder counts, with
  positions, velocities and accelerations, checked on every cycle; :meth:`SetpointTable.write`
  to CSV/JSON/NPZ/C (header + data file), :func:`read_setpoints`.
* :func:`write_gains`, :func:`load_gains` — servo gains as JSON, ros2_control YAML, C.
* :mod:`armlab.deploy.ros2` — the ros2_control controllers YAML (controller_manager +
  joint_trajectory_controller with gains and constraints) and the plan as a
  FollowJointTrajectory goal.
* :mod:`armlab.deploy.cia402` — CiA 402 cyclic synchronous position set-points (target
  position, velocity and torque offsets per cycle) and object dictionary values.
* :func:`save_trajectory`, :func:`load_trajectory` — a study's ``trajectory.npz``.
"""

from armlab.deploy.cia402 import Cia402Csp, cia402_csp, read_cia402_csp, read_cia402_objects
from armlab.deploy.gains_export import load_gains, write_gains
from armlab.deploy.ros2 import (
    jtc_constraints,
    render_follow_joint_trajectory,
    ros2_controllers_yaml,
)
from armlab.deploy.table import SetpointTable, read_setpoints, setpoint_table
from armlab.deploy.trajfile import load_trajectory, save_trajectory

__all__ = [
    "Cia402Csp",
    "SetpointTable",
    "cia402_csp",
    "jtc_constraints",
    "load_gains",
    "load_trajectory",
    "read_cia402_csp",
    "read_cia402_objects",
    "read_setpoints",
    "render_follow_joint_trajectory",
    "ros2_controllers_yaml",
    "save_trajectory",
    "setpoint_table",
    "write_gains",
]
