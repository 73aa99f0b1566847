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

Where the plan passes a pose whose gravity torque alone is above a limit (its motion holds the
joint there) no stretch meets that torque limit in general -- slowing down moves the torque
towards gravity -- and ``stretch_needed`` refuses. An excess of the other limits is then
still removed: the stretch they need (``k - 1 <= CHECK_TOL``, which changes a torque by
``2 (k - 1) |tau - g|``) is made and kept if every limit, torque included, holds after it
(issue 15: 3 of 1 000 random 5-waypoint teachbot6 problems were left with a jerk 6e-9 to
6e-8 over its limit -- where looked at, in the last interval, where the goal state is set
exactly); otherwise none is made, and :attr:`Absorbed.skipped` says why. Either way the
plan's own limit check is the verdict.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from armlab.errors import LimitViolation
from armlab.planning.timescale import CHECK_TOL, stretch_needed

if TYPE_CHECKING:
    from armlab.robot.limits import Limits
    from armlab.robot.model import Robot
    from armlab.trajectory.core import Trajectory
    from armlab.trajectory.sampling import LimitSamples

__all__ = ["Absorbed", "absorb_tolerance", "STRETCH_MARGIN"]

#: the stretch factor is raised by this fraction (torque peaks between refined samples)
STRETCH_MARGIN = 1e-9


@dataclass
class Absorbed:
    """What :func:`absorb_tolerance` made of a plan."""

    #: the plan, stretched by ``k`` or as it was (``k = 1``)
    traj: Trajectory
    k: float
    #: why no stretch was made where the plan passes a pose whose gravity torque alone is
    #: above a limit (module docstring); None otherwise
    skipped: str | None
    #: ``traj``'s limit samples at the caller's ``dt`` where they were computed (for its
    #: :meth:`~armlab.trajectory.Trajectory.check_limits`), else None
    samples: LimitSamples | None


def absorb_tolerance(
    traj: Trajectory,
    robot: Robot,
    limits: Limits,
    *,
    torque: bool,
    dt: float | None = None,
    samples: LimitSamples | None = None,
) -> Absorbed:
    """``traj`` stretched in time by the smallest ``k`` (times ``1 + STRETCH_MARGIN``) that
    brings every limit within ``limits`` if that ``k`` is at most ``1 + CHECK_TOL``, else
    ``traj`` itself (``k = 1``); where gravity alone exceeds a torque limit on the path, the
    stretch the other limits need, kept if every limit still holds after it (module
    docstring).

    ``dt`` [s] adds a uniform grid to the limit samples (the optimisers' fine check step).
    Times in ``meta`` are the caller's to scale by ``k``. ``samples``: ``traj``'s
    :meth:`~armlab.trajectory.Trajectory.limit_samples` at ``dt`` (with the torques when
    ``torque``) if the caller has them (the optimiser's last back-off check): not computed
    again.
    """
    with_tau = robot if torque else None
    if samples is None or (torque and samples.tau is None):
        samples = traj.limit_samples(dt, robot=with_tau)
    skipped = None
    try:
        k, _, _ = stretch_needed(samples, robot, limits, torque=torque)
    except LimitViolation as exc:  # gravity alone above a torque limit on the path
        skipped = str(exc)
        k, _, _ = stretch_needed(samples, robot, limits, torque=False)
    if k <= 1.0 or k > 1.0 + CHECK_TOL:
        return Absorbed(traj, 1.0, skipped, samples)
    k *= 1.0 + STRETCH_MARGIN
    cand = traj.stretched(k)
    if skipped is None:
        return Absorbed(cand, k, None, None)
    cand_samples = cand.limit_samples(dt, robot=with_tau)
    if cand.check_limits(robot, dt=dt, limits=limits, torque=torque, samples=cand_samples).ok():
        return Absorbed(cand, k, None, cand_samples)
    return Absorbed(traj, 1.0, skipped, samples)
