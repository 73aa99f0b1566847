"""The optimisers' last step: a plan within its solver's tolerance of a limit is slowed down
until every limit holds on its evaluation.

IPOPT meets bounds and constraints to its tolerances (bounds relaxed by about 1e-8 relative,
constraint violations up to ``constr_viol_tol``), and the fine-grid back-off of
:func:`armlab.planning.timescale.backoff_solve` accepts peak ratios up to ``1 + CHECK_TOL``
(1e-6). A plan handed out must meet its limits on the evaluation of
:class:`~armlab.trajectory.Trajectory` (ratio <= 1 + 1e-9), so an excess of at most
``CHECK_TOL`` is removed by the uniform time stretch that
:func:`~armlab.planning.timescale.stretch_needed` gives in closed form on the trajectory's
:meth:`~armlab.trajectory.Trajectory.limit_samples` (velocity / k, acceleration / k^2, jerk /
k^3, torque ``g + (tau - g) / k^2``); a larger excess is left to
:func:`~armlab.planning.timescale.refuse_violation`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from armlab.planning.timescale import CHECK_TOL, stretch_needed

if TYPE_CHECKING:
    from armlab.robot.limits import Limits
    from armlab.robot.model import Robot
    from armlab.trajectory.core import Trajectory

__all__ = ["absorb_tolerance", "STRETCH_MARGIN"]

#: the stretch factor is raised by this fraction (torque peaks between refined samples)
STRETCH_MARGIN = 1e-9


def absorb_tolerance(
    traj: Trajectory, robot: Robot, limits: Limits, *, torque: bool, dt: float | None = None
) -> tuple[Trajectory, float]:
    """``(trajectory, k)``: ``traj`` stretched in time by the smallest ``k`` (times
    ``1 + STRETCH_MARGIN``) that brings every limit within ``limits`` if that ``k`` is at most
    ``1 + CHECK_TOL``, else ``traj`` itself and ``k = 1``.

    ``dt`` [s] adds a uniform grid to the limit samples (the optimisers' fine check step).
    Times in ``meta`` are the caller's to scale by ``k``.
    """
    samples = traj.limit_samples(dt, robot=robot if torque else None)
    k, _, _ = stretch_needed(samples, robot, limits, torque=torque)
    if k <= 1.0 or k > 1.0 + CHECK_TOL:
        return traj, 1.0
    k *= 1.0 + STRETCH_MARGIN
    return traj.stretched(k), k
