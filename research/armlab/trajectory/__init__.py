"""Joint trajectories: the :class:`Trajectory` type, classical interpolators and optimisers."""

from armlab.trajectory.core import LIMIT_KINDS, LimitReport, Trajectory

__all__ = ["Trajectory", "LimitReport", "LIMIT_KINDS"]
