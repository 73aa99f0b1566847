"""Joint waypoints where they enter armlab: one check of shape, finiteness and joint ranges.

Every planner that takes joint configurations from its caller (``ptp_sync``'s start and goal,
``cubic_via`` / ``quintic_via``, ``optimal``, ``time_optimal_path``) and the study's kinematics
stage validate them here, so a bad waypoint gives the same :class:`~armlab.errors.InputError`
with the same message everywhere: the row, the joint, the value, its range and the unit.

:class:`InputError` (not :class:`UnreachableError`) because every failure found here is a bad
argument — a wrong shape, a NaN, or a value outside the range the robot description gives —
which is exactly what ``InputError`` documents; ``UnreachableError`` stays for poses that IK
cannot reach. (A planned *result* leaving a range between waypoints is a
:class:`LimitViolation` or :class:`InfeasibleError` raised by the planner itself.)
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from armlab.errors import InputError

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["validate_waypoints", "RANGE_TOL_RAD"]

RANGE_TOL_RAD = 1e-9
"""Slack in [rad] on the joint ranges (rounding of values read from a file)."""

_UNITS = {"rad": 1.0, "deg": 180.0 / math.pi}


def validate_waypoints(
    robot: Robot,
    Q,
    *,
    where: str = "waypoints",
    min_rows: int | None = 2,
    unit: str = "rad",
) -> np.ndarray:
    """Check joint waypoints against the robot: shape, finite values, joint ranges.

    Parameters
    ----------
    robot : Robot
        Gives ``n_joints``, ``joint_names`` and the ranges ``limits.lower_rad/upper_rad``.
    Q : array (n_waypoints, n_joints), or (n_joints,) when ``min_rows`` is None
        Joint positions in [rad].
    where : str
        What the caller calls them; starts every message (``"waypoints.joint"``,
        ``"ptp_sync q_goal"``).
    min_rows : int or None
        Least number of waypoints (2 for a path through them); None: one configuration of
        shape ``(n_joints,)`` (a point-to-point start or goal).
    unit : {"rad", "deg"}
        Unit the messages show values in (the caller's input unit); ``Q`` is always in [rad].

    Returns
    -------
    ndarray
        ``Q`` as a float array of the same shape.

    Raises
    ------
    InputError
        Wrong shape; a NaN or infinite value; a value outside its joint's range by more than
        :data:`RANGE_TOL_RAD`, e.g. ``"waypoints[1]: joint3 = 3 rad is outside its range
        [-1.571, 2.793] rad"``.
    """
    if unit not in _UNITS:
        raise InputError(f"unit must be one of {tuple(_UNITS)}, not {unit!r}")
    n = robot.n_joints
    try:
        W = np.asarray(Q, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{where}: not an array of numbers") from None
    single = min_rows is None
    if single:
        if W.shape != (n,):
            raise InputError(f"{where} has shape {W.shape}, expected ({n},) for {robot.name}")
    elif W.ndim != 2 or W.shape[1] != n or W.shape[0] < min_rows:
        raise InputError(
            f"{where} has shape {W.shape}, expected (n_waypoints >= {min_rows}, {n}) "
            f"for {robot.name}"
        )
    W2 = W.reshape(-1, n)
    names = robot.joint_names

    def row(k: int) -> str:
        return where if single else f"{where}[{k}]"

    bad = ~np.isfinite(W2)
    if np.any(bad):
        k, j = np.argwhere(bad)[0]
        raise InputError(f"{row(k)}: {names[j]} is {W2[k, j]} (not a finite number)")
    lo = np.asarray(robot.limits.lower_rad, float)
    hi = np.asarray(robot.limits.upper_rad, float)
    out = (W2 < lo - RANGE_TOL_RAD) | (W2 > hi + RANGE_TOL_RAD)
    if np.any(out):
        k, j = np.argwhere(out)[0]
        c = _UNITS[unit]
        raise InputError(
            f"{row(k)}: {names[j]} = {W2[k, j] * c:.6g} {unit} is outside its range "
            f"[{lo[j] * c:.6g}, {hi[j] * c:.6g}] {unit}"
        )
    return W
