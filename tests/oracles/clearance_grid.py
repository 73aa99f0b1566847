"""Oracle of a motion's clearance: a plain loop over coal's distance calls on a fine time grid.

Independent of :mod:`armlab.collision`'s evaluation path: the configuration comes from the
trajectory, each shape's pose from Pinocchio's forward kinematics (``oMi`` of its joint times
its placement on the joint) and each pair's signed distance from ``coal.distance`` on those
poses -- not from ``pinocchio.computeDistances``, the scene's cached data or its bound between
samples. Only the list of shapes and pairs is taken from the scene (what it checks).
"""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin


def grid_distances(scene, trajectory, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(times (n,), signed distances (n, n_pairs)) on a uniform grid of ``dt`` plus the end."""
    t = np.append(np.arange(trajectory.t[0], trajectory.t[-1], dt), trajectory.t[-1])
    q = trajectory.at(t)[0]
    return t, np.array([config_distances(scene, row) for row in q])


def config_distances(scene, q) -> np.ndarray:
    """Signed distance of each of the scene's pairs at ``q`` by ``coal.distance``."""
    model = scene.robot.model
    data = model.createData()
    pin.forwardKinematics(model, data, np.asarray(q, float))
    objs = scene.geometry.geometryObjects

    poses = []
    for obj in objs:
        M = data.oMi[obj.parentJoint] * obj.placement
        poses.append(coal.Transform3s(M.rotation, M.translation))
    out = []
    req = coal.DistanceRequest()
    for cp in scene.geometry.collisionPairs:
        i, j = cp.first, cp.second
        res = coal.DistanceResult()
        out.append(coal.distance(objs[i].geometry, poses[i], objs[j].geometry, poses[j], req, res))
    return np.array(out)
