"""The geometric path of TOPP (:class:`GeometricPath`, ``q(s)`` for ``s`` in [0, 1]), its path
dynamics ``tau = m sdd + c sd^2 + g`` (:func:`path_dynamics`) and the path grid
(:func:`path_grid`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy.interpolate import CubicSpline

from armlab.errors import InputError
from armlab.robot import rigid_body
from armlab.trajectory.core import Trajectory

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["GeometricPath", "path_dynamics", "path_grid", "END_REFINEMENT", "VELOCITY_POINTS"]

#: geometric refinement levels of the first and last path intervals
END_REFINEMENT = 8
#: where, inside each path interval, the velocity limit is imposed (besides the nodes)
VELOCITY_POINTS = (0.25, 0.5, 0.75)


# ----------------------------------------------------------------------------- path
class GeometricPath:
    """A joint path ``q(s)``, ``s`` in [0, 1], with derivatives up to the third.

    Built from joint points ``(n_points, n_joints)`` — a cubic spline (not-a-knot) through
    them, parameterised by normalised cumulative chord length — or from a
    :class:`Trajectory`: its geometry sampled densely (``n_resample`` instants and its knots)
    and treated the same way (its timing is discarded).
    """

    def __init__(self, path, n_joints: int, n_resample: int = 400) -> None:
        self.trajectory = None
        if isinstance(path, Trajectory):
            if path.n_joints != n_joints:
                raise InputError(f"path has {path.n_joints} joints, the robot {n_joints}")
            if path.n_samples < 2 or path.duration <= 0:
                raise InputError("path Trajectory must have at least two samples")
            # its geometry, re-parameterised by chord length: a timed trajectory starts and
            # ends at rest, so q'(t) vanishes there and a time parameter is singular for TOPP
            self.trajectory = path
            t = np.unique(np.concatenate([np.linspace(path.t[0], path.t[-1], n_resample), path.t]))
            pts = path.at(t)[0]
            keep = np.concatenate([[True], np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-9])
            keep[-1] = True
            pts = pts[keep]
            if pts.shape[0] < 2:
                raise InputError("path Trajectory does not move")
        else:
            pts = np.asarray(path, dtype=float)
            if pts.ndim != 2 or pts.shape[1] != n_joints or pts.shape[0] < 2:
                raise InputError(
                    f"path has shape {pts.shape}, expected (n_points >= 2, {n_joints})"
                )
            if not np.all(np.isfinite(pts)):
                raise InputError("path contains NaN or infinite values")
        step = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        if np.any(step < 1e-12):
            k = int(np.flatnonzero(step < 1e-12)[0])
            raise InputError(f"path points {k} and {k + 1} coincide; remove the duplicate")
        ss = np.concatenate([[0.0], np.cumsum(step)])
        ss /= ss[-1]
        self.points = pts
        self.s_points = ss
        bc = "not-a-knot" if pts.shape[0] > 3 else "natural"
        self.spline = CubicSpline(ss, pts, bc_type=bc, axis=0)
        self._d = [self.spline.derivative(k) for k in (1, 2, 3)]

    def __call__(self, s) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``q, q', q'', q'''`` at ``s`` (n,), each (n, n_joints)."""
        s = np.clip(np.asarray(s, float).reshape(-1), 0.0, 1.0)
        return self.spline(s), self._d[0](s), self._d[1](s), self._d[2](s)

    def tangent(self, s) -> np.ndarray:
        """``q'`` at ``s`` (n,): (n, n_joints)."""
        return self._d[0](np.clip(np.asarray(s, float).reshape(-1), 0.0, 1.0))


def path_dynamics(robot: Robot, q, dq, ddq) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``m, c, g`` (each (n, n_joints)) so that ``tau = m sdd + c sd^2 + g`` along the path.

    ``q``, ``dq = q'``, ``ddq = q''`` are (n, n_joints); ``g`` in [N m], ``m = M q'`` and
    ``c = M q'' + C(q, q') q'`` in [N m s^2] (batched :mod:`armlab.robot.rigid_body` calls).
    """
    q = np.asarray(q, dtype=float)
    z = np.zeros_like(q)
    # one batched RNEA of the three stacked: rnea(q, 0, 0), rnea(q, 0, q'), rnea(q, q', q'')
    tau = rigid_body.inverse_dynamics(
        robot, np.vstack([q, q, q]), np.vstack([z, z, dq]), np.vstack([z, dq, ddq])
    )
    g, m, c = np.split(tau, 3)
    return m - g, c - g, g


def path_grid(n_intervals: int, end_levels: int = END_REFINEMENT) -> np.ndarray:
    """Uniform grid on [0, 1] whose first and last intervals are split geometrically
    (halves, quarters, ...): from rest the path speed rises in a short distance, and a whole
    uniform interval of constant ``sdd`` would cost up to ``ds / sd`` of extra time there."""
    s = np.linspace(0.0, 1.0, n_intervals + 1)
    ds = s[1]
    extra = ds * 0.5 ** np.arange(1, end_levels + 1)
    return np.unique(np.concatenate([s, extra, 1.0 - extra]))
