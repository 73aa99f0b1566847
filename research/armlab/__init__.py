"""armlab — design, sizing, motion planning and servo tuning of small robot arms.

The front door: the chain's verbs, each importable from ``armlab`` itself --

==================  =====================================================================
step                names
==================  =====================================================================
robot, controller   :func:`load_robot`, :func:`load_profile` (:class:`Robot`)
kinematics          :func:`fk`, :func:`ik_all` (analytic, every solution), :func:`ik`
plan                :func:`ptp_sync`, :func:`cubic_via`, :func:`quintic_via`,
                    :func:`follow_path`, :func:`optimal`, :func:`time_optimal_path`
static load, size   :func:`static_load`, :func:`size`
tune, simulate      :func:`tune_arm`, :func:`simulate_tracking`
set-point table     :func:`setpoint_table`
a whole study       :func:`run_study`
==================  =====================================================================

Every function whose result depends on the joint controller takes it one way: the keyword
``controller=`` (a :class:`~armlab.robot.ControllerProfile` from :func:`load_profile`, or a
profile name). Each name is exported by one package (its ``__all__``); ``armlab`` re-exports the
verbs above from there, imported on first use, so ``import armlab`` loads neither Pinocchio nor
CasADi.

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

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

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

if TYPE_CHECKING:  # the names _VERBS resolves on first use (for type checkers and IDEs)
    from armlab.control import simulate_tracking, tune_arm
    from armlab.deploy import setpoint_table
    from armlab.dynamics import size
    from armlab.dynamics.static_load import static_load
    from armlab.kinematics import fk, ik, ik_all
    from armlab.planning import (
        cubic_via,
        follow_path,
        optimal,
        ptp_sync,
        quintic_via,
        time_optimal_path,
    )
    from armlab.robot import Robot, load_profile, load_robot
    from armlab.study import run_study

__version__ = "0.1.0"

# name -> the package that exports it (its one home in the public API)
_VERBS = {
    "Robot": "armlab.robot",
    "load_profile": "armlab.robot",
    "load_robot": "armlab.robot",
    "fk": "armlab.kinematics",
    "ik": "armlab.kinematics",
    "ik_all": "armlab.kinematics",
    "cubic_via": "armlab.planning",
    "follow_path": "armlab.planning",
    "optimal": "armlab.planning",
    "ptp_sync": "armlab.planning",
    "quintic_via": "armlab.planning",
    "time_optimal_path": "armlab.planning",
    "size": "armlab.dynamics",
    "static_load": "armlab.dynamics",
    "simulate_tracking": "armlab.control",
    "tune_arm": "armlab.control",
    "setpoint_table": "armlab.deploy",
    "run_study": "armlab.study",
}

_PACKAGES = frozenset(
    {
        "control",
        "deploy",
        "dynamics",
        "io",
        "kinematics",
        "planning",
        "plots",
        "robot",
        "study",
        "sweep",
        "trajectory",
    }
)

__all__ = [
    "ArmlabError",
    "DesignFailure",
    "InfeasibleError",
    "InputError",
    "LimitViolation",
    "Robot",
    "RobotDescriptionError",
    "SpecError",
    "UnreachableError",
    "__version__",
    "cubic_via",
    "fk",
    "follow_path",
    "ik",
    "ik_all",
    "load_profile",
    "load_robot",
    "optimal",
    "ptp_sync",
    "quintic_via",
    "run_study",
    "setpoint_table",
    "simulate_tracking",
    "size",
    "static_load",
    "time_optimal_path",
    "tune_arm",
]


def __getattr__(name: str) -> Any:
    """A verb of :data:`_VERBS` (imported from its package on first use, then cached) or a
    subpackage (``armlab.study`` without ``import armlab.study``)."""
    if name in _VERBS:
        value = getattr(importlib.import_module(_VERBS[name]), name)
        globals()[name] = value
        return value
    if name in _PACKAGES:
        return importlib.import_module(f"armlab.{name}")
    raise AttributeError(f"module 'armlab' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_VERBS) | _PACKAGES)
