"""Workspace study: Monte-Carlo reach cloud of the tool point (thesis 2.2.2, 3.6).

Uniform random configurations inside the joint ranges are mapped through the forward
kinematics; the cloud gives the reachable region seen from the side (radius from the joint-1
axis vs height) and from above. The maximum reach radius (thesis 2.2.2 requirement ">= 700 mm
with the tool") is refined by a bounded local optimisation from the best samples, because the
extreme of a random cloud always falls short of the true maximum.

Everything is expressed in the robot's **base** frame (the mounting ``transform_base_to_world``
is undone): reach is a property of the arm, not of where it stands.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from armlab.errors import InputError
from armlab.kinematics.forward import fk, fk_batch

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["WorkspaceResult", "workspace_cloud", "max_reach_m", "tool_points_in_base"]


def tool_points_in_base(robot: Robot, q) -> np.ndarray:
    """Tool-point positions in the base frame, (n, 3) in [m], for q (n, n_joints)."""
    T = np.linalg.solve(robot.transform_base_to_world, fk_batch(robot, q))
    return T[:, :3, 3]


def _refine(robot, q0: np.ndarray, objective) -> tuple[float, np.ndarray]:
    """Maximise ``objective(p_tool_in_base)`` from q0 (L-BFGS-B inside the ranges)."""
    from scipy.optimize import minimize  # 0.3 s to import: when a reach is refined

    lim = robot.limits  # L-BFGS-B takes +-inf bounds (an unbounded joint)
    bounds = [
        (None if math.isinf(lo) else lo, None if math.isinf(hi) else hi)
        for lo, hi in zip(lim.lower_rad, lim.upper_rad, strict=True)
    ]
    inv_base = np.linalg.inv(robot.transform_base_to_world)

    def neg(x: np.ndarray) -> float:
        p = (inv_base @ fk(robot, x))[:3, 3]
        return -float(objective(p))

    res = minimize(neg, q0, method="L-BFGS-B", bounds=bounds)
    return -float(res.fun), np.asarray(res.x)


def max_reach_m(robot: Robot, n_samples: int = 2000, seed: int = 0) -> float:
    """Largest distance of the tool point from the base's z axis, in [m] (thesis 2.2.2 "max
    reach radius"): best of ``n_samples`` random in-range configurations, refined by a bounded
    local optimisation (L-BFGS-B) from the best three."""
    rng = np.random.default_rng(seed)
    q = robot.random_q(rng, n_samples)
    p = tool_points_in_base(robot, q)
    radius = np.hypot(p[:, 0], p[:, 1])
    best = float(radius.max())
    for k in np.argsort(radius)[-3:]:
        best = max(best, _refine(robot, q[k], lambda x: np.hypot(x[0], x[1]))[0])
    return best


@dataclass
class WorkspaceResult:
    """Monte-Carlo workspace of the tool point, in the base frame.

    Attributes
    ----------
    robot : str
    n_samples, seed : int
    q : ndarray (n_samples, n_joints)
        The sampled configurations in [rad].
    points_m : ndarray (n_samples, 3)
        Tool-point positions in the base frame in [m].
    max_reach_m : float
        Largest radius from the joint-1 (base z) axis, refined by local optimisation, in [m].
    q_max_reach : ndarray (n_joints,)
        A configuration reaching it.
    max_height_m, min_height_m : float
        Highest / lowest tool-point height (base z), refined, in [m].
    cloud_max_radius_m : float
        Largest radius among the samples only (<= ``max_reach_m``).
    max_distance_m : float
        Largest distance from the base origin among the samples, in [m].
    """

    robot: str
    n_samples: int
    seed: int
    q: np.ndarray = field(repr=False)
    points_m: np.ndarray = field(repr=False)
    max_reach_m: float
    q_max_reach: np.ndarray
    max_height_m: float
    min_height_m: float
    cloud_max_radius_m: float
    max_distance_m: float

    @property
    def radius_m(self) -> np.ndarray:
        """Distance of every sample from the base z axis, (n_samples,) in [m]."""
        return np.hypot(self.points_m[:, 0], self.points_m[:, 1])

    def to_dict(self) -> dict:
        """JSON-able key figures (the cloud itself is left out)."""
        return {
            "robot": self.robot,
            "n_samples": int(self.n_samples),
            "seed": int(self.seed),
            "max_reach_m": float(self.max_reach_m),
            "q_max_reach_rad": [float(x) for x in self.q_max_reach],
            "max_height_m": float(self.max_height_m),
            "min_height_m": float(self.min_height_m),
            "cloud_max_radius_m": float(self.cloud_max_radius_m),
            "max_distance_m": float(self.max_distance_m),
            "frame": "base",
        }


def workspace_cloud(
    robot: Robot, n_samples: int = 20000, seed: int = 0, *, refine: bool = True
) -> WorkspaceResult:
    """Monte-Carlo reach cloud of the tool point (thesis 3.6 workspace analysis).

    Parameters
    ----------
    robot : Robot
    n_samples : int
        Random configurations, uniform inside the joint ranges.
    seed : int
        Seed of ``numpy.random.default_rng``; the result is reproducible from it.
    refine : bool
        Refine max reach / height / depth by L-BFGS-B from the three best samples each.

    Returns
    -------
    WorkspaceResult
    """
    if int(n_samples) < 1:
        raise InputError(f"n_samples must be >= 1, not {n_samples!r}")
    rng = np.random.default_rng(seed)
    q = robot.random_q(rng, int(n_samples))
    p = tool_points_in_base(robot, q)
    radius = np.hypot(p[:, 0], p[:, 1])
    k_r = int(np.argmax(radius))
    best_r, q_r = float(radius[k_r]), q[k_r].copy()
    top, bottom = float(p[:, 2].max()), float(p[:, 2].min())
    if refine:
        for k in np.argsort(radius)[-3:]:
            val, qq = _refine(robot, q[k], lambda x: np.hypot(x[0], x[1]))
            if val > best_r:
                best_r, q_r = val, qq
        for k in np.argsort(p[:, 2])[-3:]:
            top = max(top, _refine(robot, q[k], lambda x: x[2])[0])
        for k in np.argsort(p[:, 2])[:3]:
            bottom = min(bottom, -_refine(robot, q[k], lambda x: -x[2])[0])
    return WorkspaceResult(
        robot=robot.name,
        n_samples=int(n_samples),
        seed=int(seed),
        q=q,
        points_m=p,
        max_reach_m=best_r,
        q_max_reach=q_r,
        max_height_m=top,
        min_height_m=bottom,
        cloud_max_radius_m=float(radius.max()),
        max_distance_m=float(np.linalg.norm(p, axis=1).max()),
    )
