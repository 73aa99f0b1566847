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

from armlab.kinematics.accuracy import AccuracyResult, accuracy_study
from armlab.kinematics.analytic_ik import has_analytic_ik, ik_all, ik_all_batch, ik_nearest
from armlab.kinematics.forward import fk, fk_batch, jacobian
from armlab.kinematics.numerical_ik import IKResult, IKSettings, ik, ik_batch, ik_solve
from armlab.kinematics.workspace import WorkspaceResult, max_reach_m, workspace_cloud

__all__ = [
    "AccuracyResult",
    "IKResult",
    "IKSettings",
    "WorkspaceResult",
    "accuracy_study",
    "fk",
    "fk_batch",
    "has_analytic_ik",
    "ik",
    "ik_all",
    "ik_all_batch",
    "ik_batch",
    "ik_nearest",
    "ik_solve",
    "jacobian",
    "max_reach_m",
    "workspace_cloud",
]
