"""What the study's 3D view (``motion.html``) draws besides the arm (issue 27): the obstacles,
the floor and the closest pair of the planned motion.

The glue between the collision check (:mod:`armlab.collision`) and the drawing
(:mod:`armlab.viz_obstacles`, which takes plain descriptions): the obstacles are the study's
``[[obstacle]]`` shapes, the floor ``[robot] floor_z_m``, and the closest pair is the pair with
the smallest signed distance along the motion (the plan stage's certified check,
``ctx.clearance``, :func:`armlab.collision.check_motion`), its witness points evaluated at that
instant (:meth:`armlab.collision.CollisionScene.distances`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from armlab.study.context import StudyContext
    from armlab.trajectory.core import Trajectory

__all__ = ["closest_pair", "environment"]


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
    """Keyword arguments of :func:`armlab.viz.animate` for the study: ``obstacles``,
    ``floor_z_m`` and, once the plan stage has checked the plan, ``closest``."""
    spec = ctx.spec
    out: dict[str, Any] = {"obstacles": tuple(spec.obstacles), "floor_z_m": spec.robot.floor_z_m}
    scene = ctx.collision_scene
    if ctx.trajectory is not None and scene is not None:
        out["closest"] = closest_pair(scene, ctx.trajectory, ctx.clearance)
    return out
