"""Forward kinematics and Jacobians (Pinocchio).

``fk(robot, q)`` returns ``T_tool_in_world = T_base_in_world @ oMf[tool]`` (thesis 3.5).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["fk", "fk_batch", "jacobian", "analytic_jacobian", "tool_positions", "rpy_to_matrix"]


def fk(robot: Robot, q, frame: str | None = None) -> np.ndarray:
    """Pose of the tool (or ``frame``) in the world, (4, 4).

    Parameters
    ----------
    robot : Robot
    q : array (n_joints,)
        Joint positions in [rad].
    frame : str, optional
        Any frame of the model; default the robot's tool frame.
    """
    q = robot.check_q(q)
    fid = robot.frame_id(frame)
    pin.framesForwardKinematics(robot.model, robot.data, q)
    return robot.transform_base_to_world @ robot.data.oMf[fid].homogeneous


def fk_batch(robot: Robot, q, frame: str | None = None) -> np.ndarray:
    """Poses of the tool (or ``frame``) for many configurations: (n, 4, 4) from q (n, n_joints)."""
    q = robot.check_q(q, batch=True)
    q2 = np.atleast_2d(q)
    fid = robot.frame_id(frame)
    out = np.empty((q2.shape[0], 4, 4))
    model, data = robot.model, robot.data
    for k in range(q2.shape[0]):
        pin.forwardKinematics(model, data, q2[k])
        out[k] = pin.updateFramePlacement(model, data, fid).homogeneous
    return robot.transform_base_to_world @ out


def tool_positions(robot: Robot, q) -> np.ndarray:
    """Tool-point positions in the world, (n, 3) in [m], for q (n, n_joints)."""
    return fk_batch(robot, q)[:, :3, 3]


def jacobian(robot: Robot, q, frame: str | None = None, reference: str = "world") -> np.ndarray:
    """Geometric Jacobian (6, n_joints): ``[v; omega] = J qd``.

    ``reference="world"``: linear velocity of the frame origin and angular velocity, both in
    the world axes (Pinocchio LOCAL_WORLD_ALIGNED, rotated by the base transform);
    ``reference="local"``: both in the frame's own axes (Pinocchio LOCAL).
    """
    q = robot.check_q(q)
    fid = robot.frame_id(frame)
    rf = {"world": pin.LOCAL_WORLD_ALIGNED, "local": pin.LOCAL}[reference]
    J = pin.computeFrameJacobian(robot.model, robot.data, q, fid, rf)
    if reference == "world":
        R = robot.transform_base_to_world[:3, :3]
        J = np.vstack([R @ J[:3], R @ J[3:]])
    return J


def _rpy_rate_matrix(rpy: np.ndarray) -> np.ndarray:
    """E(rpy) with omega = E rpy_dot for R = Rz(y) Ry(p) Rx(r) (URDF roll-pitch-yaw)."""
    r, p, y = rpy
    cy, sy, cp, sp = np.cos(y), np.sin(y), np.cos(p), np.sin(p)
    return np.array([[cy * cp, -sy, 0.0], [sy * cp, cy, 0.0], [-sp, 0.0, 1.0]])


def analytic_jacobian(robot: Robot, q, frame: str | None = None) -> np.ndarray:
    """Analytic Jacobian (6, n_joints) for [position; roll-pitch-yaw] of the frame in the world:
    ``d/dt [p; r, p, y] = J_a qd``, with ``J_a = blockdiag(I, E(rpy)^-1) J``.

    Singular where the pitch is +-90 deg (the representation, not the arm).
    """
    J = jacobian(robot, q, frame)
    T = fk(robot, q, frame)
    rpy = pin.rpy.matrixToRpy(T[:3, :3])
    E = _rpy_rate_matrix(rpy)
    return np.vstack([J[:3], np.linalg.solve(E, J[3:])])


def rpy_to_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll) (URDF / ROS fixed-axis convention)."""
    cr, sr, cp, sp, cy, sy = (
        math.cos(roll),
        math.sin(roll),
        math.cos(pitch),
        math.sin(pitch),
        math.cos(yaw),
        math.sin(yaw),
    )
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )
