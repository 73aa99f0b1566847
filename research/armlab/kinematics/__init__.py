"""Kinematics: forward kinematics, Jacobians, inverse kinematics, workspace and accuracy.

* :mod:`~armlab.kinematics.forward` — ``fk``, ``fk_batch``, ``jacobian``, ``analytic_jacobian``;
* :mod:`~armlab.kinematics.analytic_ik` — closed-form IK of spherical-wrist 6R arms (teachbot6):
  ``ik_all``, ``ik_all_batch``, ``ik_nearest``;
* :mod:`~armlab.kinematics.numerical_ik` — damped least-squares IK of any URDF (OSQP):
  ``ik``, ``ik_solve`` -> ``IKResult``, ``ik_batch``;
* :mod:`~armlab.kinematics.workspace` — Monte-Carlo reach cloud, ``max_reach_m``;
* :mod:`~armlab.kinematics.accuracy` — Monte-Carlo positioning accuracy (thesis 3.7);
* figures of the two studies: :mod:`armlab.plots.kinematics`.

Poses are tool poses in the world: ``T_base_in_world @ T_tool_in_base`` (thesis 3.5).
"""

from armlab.kinematics.accuracy import (
    LINK_TOLERANCES_M,
    REDUCER_ANGLE_ERROR_RAD,
    AccuracyResult,
    accuracy_study,
)
from armlab.kinematics.analytic_ik import (
    IK_REASONS,
    check_poses,
    has_analytic_ik,
    ik_all,
    ik_all_batch,
    ik_all_batch_reasons,
    ik_nearest,
)
from armlab.kinematics.forward import analytic_jacobian, fk, fk_batch, jacobian, tool_positions
from armlab.kinematics.numerical_ik import IKResult, IKSettings, ik, ik_batch, ik_solve
from armlab.kinematics.workspace import (
    WorkspaceResult,
    max_reach_m,
    tool_points_in_base,
    workspace_cloud,
)

__all__ = [
    "fk",
    "fk_batch",
    "jacobian",
    "analytic_jacobian",
    "tool_positions",
    "ik_all",
    "ik_all_batch",
    "ik_all_batch_reasons",
    "ik_nearest",
    "has_analytic_ik",
    "check_poses",
    "IK_REASONS",
    "ik",
    "ik_solve",
    "ik_batch",
    "IKResult",
    "IKSettings",
    "max_reach_m",
    "workspace_cloud",
    "WorkspaceResult",
    "tool_points_in_base",
    "accuracy_study",
    "AccuracyResult",
    "REDUCER_ANGLE_ERROR_RAD",
    "LINK_TOLERANCES_M",
]
