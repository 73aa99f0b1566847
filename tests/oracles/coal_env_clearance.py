"""Oracle of a motion's clearance to its environment: coal's distance calls in a plain loop.

Independent of :mod:`armlab.collision` (its scene, pairs and certified branch and bound): the
robot's shapes are read here from its URDF with Pinocchio (``<collision>`` elements, else
``<visual>``), placed by plain forward kinematics at every sample of a fine grid, and every
shape that moves (parent joint > 0) is measured against every obstacle with
``coal.distance`` (signed: negative is penetration). The world is the robot's base frame moved
by ``robot.transform_base_to_world``. Self-collision is not part of this oracle.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import coal
import numpy as np
import pinocchio as pin


def _geometry(robot):
    urdf = str(robot.urdf_path)
    root = ET.parse(urdf).getroot()
    kind = (
        pin.GeometryType.COLLISION
        if root.find("link/collision") is not None
        else pin.GeometryType.VISUAL
    )
    model = pin.buildModelFromUrdf(urdf)
    return model, pin.buildGeomFromUrdf(model, urdf, kind)


def env_clearance(robot, trajectory, obstacles, dt: float = 0.002):
    """Smallest signed distance [m] between the moving robot shapes and ``obstacles`` along
    ``trajectory``, sampled every ``dt`` [s] (end point included).

    ``obstacles``: sequence of ``(name, coal shape, 4x4 pose in the world)``.
    Returns ``(distance_m, robot geometry name, obstacle name, time_s)``.
    """
    model, geom = _geometry(robot)
    assert list(model.names) == list(robot.model.names)  # no locked joints in these tests
    data, gdata = model.createData(), geom.createData()
    T_bw = np.asarray(robot.transform_base_to_world, float)
    moving = [(k, g) for k, g in enumerate(geom.geometryObjects) if g.parentJoint > 0]
    placed = [(name, shape, coal.Transform3s(T[:3, :3], T[:3, 3])) for name, shape, T in obstacles]
    n = max(1, math.ceil(trajectory.duration / dt))
    times = np.linspace(trajectory.t[0], trajectory.t[-1], n + 1)
    q_all = trajectory.at(times)[0]
    best = (math.inf, "", "", math.nan)
    req = coal.DistanceRequest()
    for t, q in zip(times, q_all, strict=True):
        pin.forwardKinematics(model, data, q)
        pin.updateGeometryPlacements(model, data, geom, gdata)
        for k, g in moving:
            M = T_bw @ gdata.oMg[k].homogeneous
            tf = coal.Transform3s(M[:3, :3], M[:3, 3])
            for name, shape, tf_o in placed:
                res = coal.DistanceResult()
                d = coal.distance(g.geometry, tf, shape, tf_o, req, res)
                if d < best[0]:
                    best = (float(d), g.name, name, float(t))
    return best
