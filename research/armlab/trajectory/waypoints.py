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

__all__ = [
    "validate_waypoints",
    "validate_joint_state",
    "check_stoppable",
    "RANGE_TOL_RAD",
    "COINCIDE_RAD",
    "range_with_tolerance",
]

RANGE_TOL_RAD = 1e-9
#: consecutive waypoints closer than this in every joint [rad] coincide (a planner through
#: waypoints refuses them: a segment of no length)
COINCIDE_RAD = 1e-12
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
    # one test that every value is a number within its range (NaN fails a comparison; an
    # infinite value passes only an unbounded joint's range, so with one, finiteness too);
    # where it fails, the checks below name the first problem
    lo_tol, hi_tol, bounded = range_with_tolerance(robot.limits)
    if ((W2 >= lo_tol) & (W2 <= hi_tol)).all() and (bounded or np.isfinite(W2).all()):
        return W
    names = robot.joint_names

    def row(k: int) -> str:
        return where if single else f"{where}[{k}]"

    bad = ~np.isfinite(W2)
    if bad.any():
        k, j = np.argwhere(bad)[0]
        raise InputError(f"{row(k)}: {names[j]} is {W2[k, j]} (not a finite number)")
    lo = np.asarray(robot.limits.lower_rad, float)
    hi = np.asarray(robot.limits.upper_rad, float)
    out = (W2 < lo - RANGE_TOL_RAD) | (W2 > hi + RANGE_TOL_RAD)
    if out.any():
        k, j = np.argwhere(out)[0]
        c = _UNITS[unit]
        raise InputError(
            f"{row(k)}: {names[j]} = {W2[k, j] * c:.6g} {unit} is outside its range "
            f"[{lo[j] * c:.6g}, {hi[j] * c:.6g}] {unit}"
        )
    return W


def range_with_tolerance(limits) -> tuple[np.ndarray, np.ndarray, bool]:
    """``(lower - RANGE_TOL_RAD, upper + RANGE_TOL_RAD, every joint bounded)`` of a
    :class:`~armlab.robot.Limits`, read-only: what a waypoint must lie within (made once and
    kept with the Limits, :meth:`~armlab.robot.Limits.derived`)."""
    return limits.derived("waypoint range", _range_with_tolerance)


def _range_with_tolerance(limits) -> tuple[np.ndarray, np.ndarray, bool]:
    lo = np.asarray(limits.lower_rad, float) - RANGE_TOL_RAD
    hi = np.asarray(limits.upper_rad, float) + RANGE_TOL_RAD
    lo.flags.writeable = hi.flags.writeable = False
    return lo, hi, bool(np.isfinite(lo).all() and np.isfinite(hi).all())


def validate_joint_state(robot: Robot, x, name: str, limit, kind: str, *, where: str) -> np.ndarray:
    """A start or goal speed or acceleration of a replanning request, checked where it enters.

    Parameters
    ----------
    robot : Robot
    x : None or array (n_joints,)
        Joint speeds in [rad/s] or accelerations in [rad/s^2]; None is rest (zeros).
    name : str
        The caller's keyword (``"qd_start"``, ``"qdd_start"``, ``"qd_goal"``).
    limit : None or array (n_joints,)
        The limit of that kind (None: not limited).
    kind : str
        ``"velocity"`` or ``"acceleration"`` (for the message).
    where : str
        The planner (``"ptp_sync"``, ``"optimal"``); starts every message.

    Returns
    -------
    ndarray (n_joints,)

    Raises
    ------
    InputError
        Wrong shape, a non-finite value, or a joint beyond its limit (naming the keyword and the
        joint: brake first).
    """
    if x is None:
        return np.zeros(robot.n_joints)
    try:
        arr = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{where} {name}: not an array of numbers") from None
    if arr.shape != (robot.n_joints,):
        raise InputError(f"{where} {name} must have shape ({robot.n_joints},), not {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{where} {name} must be finite")
    if limit is not None:
        over = np.abs(arr) > np.asarray(limit) * (1 + 1e-12)
        if np.any(over):
            k = int(np.flatnonzero(over)[0])
            raise InputError(
                f"{where} {name}: {robot.joint_names[k]} at {arr[k]:.6g} is beyond its "
                f"{kind} limit {float(np.asarray(limit)[k]):.6g} (brake first)"
            )
    return arr


def check_stoppable(robot: Robot, qd, qdd, v_max, j_max, *, where: str) -> None:
    """Refuse a start state whose acceleration the jerk limit cannot bring to zero before the
    speed passes its limit: the speed then peaks at ``qd + qdd |qdd| / (2 j_max)``.

    Raises
    ------
    InputError
        Naming the joint, the state and the limits (brake first).
    """
    qd, qdd = np.asarray(qd, float), np.asarray(qdd, float)
    v, j = np.asarray(v_max, float), np.asarray(j_max, float)
    peak = qd + qdd * np.abs(qdd) / (2 * j)
    over = np.abs(peak) > v * (1 + 1e-12)
    if np.any(over):
        k = int(np.flatnonzero(over)[0])
        raise InputError(
            f"{where} qdd_start: {robot.joint_names[k]} at {qdd[k]:.6g} rad/s^2 with qd_start "
            f"{qd[k]:.6g} rad/s reaches {peak[k]:.6g} rad/s before its jerk limit "
            f"{float(j[k]):.6g} rad/s^3 can stop the acceleration, beyond its velocity limit "
            f"{float(v[k]):.6g} rad/s (brake first)"
        )
