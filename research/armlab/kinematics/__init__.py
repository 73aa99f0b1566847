"""Kinematics: forward kinematics, Jacobians, inverse kinematics, workspace and accuracy."""

from armlab.kinematics.forward import analytic_jacobian, fk, fk_batch, jacobian, tool_positions
from armlab.kinematics.workspace import max_reach_m

__all__ = ["fk", "fk_batch", "jacobian", "analytic_jacobian", "tool_positions", "max_reach_m"]
