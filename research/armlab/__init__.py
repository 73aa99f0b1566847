"""armlab — design, sizing, motion planning and servo tuning of small robot arms.

Conventions (used everywhere in the package)
--------------------------------------------
* SI units inside: m, rad, s, kg, N m, V, A. Other units appear only at the edges and are named
  in the variable (``speed_rpm``, ``a_mm``, ``counts``).
* Joint arrays have shape ``(n_joints,)``; time series ``(n_samples, n_joints)``.
* Frames: ``transform_a_to_b`` is the (4, 4) homogeneous transform that maps coordinates in
  frame ``a`` to frame ``b`` (the pose of ``a`` in ``b``); Pinocchio's ``oMf`` (pose of frame f
  in the base ``o``) is used inside dense math. A pose handed to the kinematics is the tool in
  the world: ``T_base_in_world @ T_tool_in_base`` (thesis 3.5).
* Errors are :class:`armlab.ArmlabError` subclasses with a one-line message naming the problem.
"""

from armlab.errors import (
    ArmlabError,
    DesignFailure,
    InfeasibleError,
    InputError,
    LimitViolation,
    RobotDescriptionError,
    SpecError,
    UnreachableError,
)
from armlab.robot import Limits, Robot, load_robot, resolve_limits

__version__ = "0.1.0"

__all__ = [
    "ArmlabError",
    "DesignFailure",
    "InfeasibleError",
    "InputError",
    "LimitViolation",
    "RobotDescriptionError",
    "SpecError",
    "UnreachableError",
    "Robot",
    "Limits",
    "load_robot",
    "resolve_limits",
    "__version__",
]
