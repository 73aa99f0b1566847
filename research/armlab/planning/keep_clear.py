"""The planners that do not plan around obstacles report the clearance of their plan and refuse
one that comes too close (issue 27).

The Cartesian planners (:func:`~armlab.planning.line`, :func:`~armlab.planning.arc3`,
:func:`~armlab.planning.blend`: the tool's path is the user's) and the TOPP
(:func:`~armlab.planning.time_optimal_path`: the joint path is given) only time a path; the
geometry of that path is not theirs to change. Given ``clearance=`` (an
:class:`armlab.collision.CollisionScene`, its ``clearance_m`` the distance to keep) they check
the whole motion (:func:`armlab.collision.check_motion`, certified between the samples) and
either return the plan with the check (``stats["min_clearance_m"]``, ``meta["clearance"]``) or
raise :class:`armlab.collision.CollisionError` with one line naming the pair, the time and the
depth. :func:`~armlab.planning.optimal` plans around obstacles instead
(:mod:`armlab.planning.optimal_clearance`).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, ParamSpec

if TYPE_CHECKING:
    from armlab.trajectory.core import Trajectory

__all__ = ["keep_clear", "refuses_collision"]

P = ParamSpec("P")


def keep_clear(traj: Trajectory, scene: Any, what: str) -> Trajectory:
    """``traj`` with its clearance report, or :class:`~armlab.collision.CollisionError`
    naming the pair, the time and the depth (``scene`` None: ``traj`` unchanged).

    Parameters
    ----------
    traj : Trajectory
    scene : armlab.collision.CollisionScene or None
    what : str
        The planner, for the message (``"the line plan collides: ..."``).
    """
    if scene is None:
        return traj
    from armlab.collision import check_motion
    from armlab.planning.optimal_clearance import stamp_clearance

    report = check_motion(scene, traj)
    stamp_clearance(traj, report)
    report.raise_if_failed(f"the {what} plan")
    return traj


def refuses_collision(what: str) -> Callable[[Callable[P, Trajectory]], Callable[P, Trajectory]]:
    """Decorator: the planner takes ``clearance=`` (a CollisionScene) and :func:`keep_clear`
    checks its plan."""

    def wrap(planner: Callable[P, Trajectory]) -> Callable[P, Trajectory]:
        @functools.wraps(planner)
        def checked(*args: P.args, **kwargs: P.kwargs) -> Trajectory:
            scene = kwargs.pop("clearance", None)
            return keep_clear(planner(*args, **kwargs), scene, what)

        return checked

    return wrap
