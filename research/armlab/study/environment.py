"""The study's environment (issue 27): the collision scene the ``optimal`` planner keeps clear
of (:func:`study_scene`), and what the 3D view (``motion.html``) draws besides the arm: the
obstacles, the floor and the closest pair of the planned motion (:func:`environment`).

A study describes an environment when it has an ``[[obstacle]]``, a ``[robot] floor_z_m`` or a
``[plan] clearance_m > 0``; without one, nothing here changes the study (the plan stage's own
collision check still runs).

For the view, the glue between the collision check (:mod:`armlab.collision`) and the drawing
(:mod:`armlab.viz_obstacles`, which takes plain descriptions): the obstacles are the study's
``[[obstacle]]`` shapes, the floor ``[robot] floor_z_m``, and the closest pair is the pair with
the smallest signed distance along the motion (the plan's certified check,
:func:`armlab.collision.check_motion`), its witness points evaluated at that instant
(:meth:`armlab.collision.CollisionScene.distances`). A study with no obstacle, no floor and no
clearance (``[plan] clearance_m = 0``) draws none of them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from armlab.study.context import StudyContext
    from armlab.trajectory.core import Trajectory

__all__ = ["closest_pair", "environment", "has_environment", "study_scene"]


def has_environment(spec) -> bool:
    """True when the study has obstacles, a floor or a clearance (module docstring)."""
    return bool(spec.obstacles) or spec.robot.floor_z_m is not None or spec.plan.clearance_m > 0


def study_scene(ctx: StudyContext, robot=None):
    """The :class:`~armlab.collision.CollisionScene` of the study
    (:meth:`~armlab.collision.CollisionScene.from_study`) for ``robot`` (default
    ``ctx.robot``), or None when the study describes no environment."""
    if not has_environment(ctx.spec):
        return None
    from armlab.collision import CollisionScene

    return CollisionScene.from_study(ctx.spec, ctx.robot if robot is None else robot)


def closest_pair(scene, trajectory: Trajectory, report=None):
    """The :class:`~armlab.viz_obstacles.ClosestPair` of ``trajectory`` in ``scene``: the pair
    of the motion check ``report`` (computed if None) with its witness points in the world
    frame at the time of its smallest distance; None when the scene checks no pair."""
    from armlab.collision import check_motion
    from armlab.viz_obstacles import ClosestPair

    if scene.n_pairs == 0:
        return None
    if report is None:
        report = check_motion(scene, trajectory)
    t = float(trajectory.t[0]) + float(report.time_s)
    q = trajectory.at(np.array([t]))[0][0]
    dist = scene.distances(q)
    names = [dist.pair_name(k) for k in range(scene.n_pairs)]
    k = names.index(report.pair) if report.pair in names else dist.closest()
    a, b = dist.pairs[k]
    return ClosestPair(
        a, b, float(dist.distance_m[k]), dist.point_a_m[k], dist.point_b_m[k], float(report.time_s)
    )


def environment(ctx: StudyContext) -> dict[str, Any]:
    """Keyword arguments of :func:`armlab.viz.animate` for the study's environment:
    ``obstacles``, ``floor_z_m`` and ``closest`` (module docstring); empty when the study
    describes none."""
    spec = ctx.spec
    if not has_environment(spec):
        return {}
    out: dict[str, Any] = {"obstacles": tuple(spec.obstacles), "floor_z_m": spec.robot.floor_z_m}
    scene = study_scene(ctx)
    if ctx.trajectory is not None and scene is not None:
        out["closest"] = closest_pair(scene, ctx.trajectory)
    return out
