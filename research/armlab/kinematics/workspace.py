"""Workspace studies: reach of the tool point.

(First version: max reach only; the Monte-Carlo cloud and plots extend this module.)
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize

from armlab.kinematics.forward import fk, tool_positions

__all__ = ["max_reach_m"]


def max_reach_m(robot, n_samples: int = 2000, seed: int = 0) -> float:
    """Largest distance of the tool point from the base's z axis, in [m] (thesis 2.2.2 "max
    reach radius"): best of ``n_samples`` random in-range configurations, refined by a bounded
    local optimisation (L-BFGS-B) from the best few."""
    rng = np.random.default_rng(seed)
    q = robot.random_q(rng, n_samples)
    p = tool_positions(robot, q)
    radius = np.hypot(p[:, 0], p[:, 1])
    bounds = list(zip(robot.limits.lower_rad, robot.limits.upper_rad, strict=True))

    def neg_radius(x: np.ndarray) -> float:
        t = fk(robot, x)
        return -float(np.hypot(t[0, 3], t[1, 3]))

    best = float(radius.max())
    for k in np.argsort(radius)[-3:]:
        res = minimize(neg_radius, q[k], method="L-BFGS-B", bounds=bounds)
        best = max(best, -float(res.fun))
    return best
