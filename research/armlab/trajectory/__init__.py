"""Joint trajectories: the :class:`Trajectory` type and its primitives.

* :mod:`.core` -- :class:`Trajectory` (the one currency between planners and consumers);
* :mod:`.sampling` -- where a trajectory is evaluated for its limits (sample grids, the exact
  limit samples) and the :class:`LimitReport` a check returns;
* :mod:`.profiles` -- the timing primitives (trapezoid and double-S motion profiles; batches
  of time-synchronised rest-to-rest S-curves in closed form, :func:`synchronised_scurves`);
* :mod:`.waypoints` -- the one validation of joint waypoints.

The planners live in :mod:`armlab.planning`. Their stable names of the design notes --
``armlab.trajectory.optimal``, ``ptp_sync``, ``time_optimal_path``... -- are still reachable
here: they are looked up in :mod:`armlab.planning` on first use (so importing this package
imports no planner and no CasADi).
"""

from __future__ import annotations

from typing import Any

from armlab.trajectory.core import Trajectory
from armlab.trajectory.profiles import (
    MotionProfile,
    double_s_profile,
    synchronised_scurves,
    trapezoid_profile,
)
from armlab.trajectory.sampling import LimitReport
from armlab.trajectory.waypoints import validate_waypoints

__all__ = [
    "LimitReport",
    "MotionProfile",
    "Trajectory",
    "double_s_profile",
    "synchronised_scurves",
    "trapezoid_profile",
    "validate_waypoints",
]


def __getattr__(name: str) -> Any:
    """``armlab.trajectory.optimal`` and the other planners of :data:`armlab.planning.__all__`
    (their home), looked up on first use."""
    import armlab.planning

    if name in armlab.planning.__all__:
        return getattr(armlab.planning, name)
    raise AttributeError(f"module 'armlab.trajectory' has no attribute {name!r}")
