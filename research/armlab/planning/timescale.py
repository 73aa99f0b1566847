"""The uniform time stretch that brings a classical plan within its limits.

The limits of a request are a :class:`armlab.robot.Limits` from
:func:`armlab.robot.resolve_limits` (the robot's, overridden or switched off per call).

Stretching a trajectory in time by ``k >= 1`` (``q_k(t) = q(t / k)``) divides the velocities
by ``k``, the accelerations by ``k^2`` and the jerks by ``k^3``. Inverse dynamics
``tau = M(q) qdd + C(q, qd) qd + g(q)`` becomes ``g + (tau - g) / k^2`` at the same path point,
so the smallest ``k`` that meets every limit follows in closed form from the samples
(:func:`stretch_needed`). The planners use it to slow down instead of violating a limit, and
say which limit set the pace (``Trajectory.meta["slowdown"]``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from armlab.errors import LimitViolation
from armlab.robot import rigid_body

if TYPE_CHECKING:
    from armlab.robot.model import Robot
    from armlab.trajectory.core import Trajectory

__all__ = ["stretch_needed", "finish", "check_in_range"]


def check_in_range(robot: Robot, q, what: str) -> None:
    """Raise :class:`LimitViolation` naming the joint if ``q`` (n_joints,) or (n, n_joints)
    leaves the joint range."""
    q2 = np.atleast_2d(np.asarray(q, float))
    lo, hi = robot.limits.lower_rad, robot.limits.upper_rad
    bad = (q2 < lo - 1e-9) | (q2 > hi + 1e-9)
    if np.any(bad):
        k, j = np.argwhere(bad)[0]
        raise LimitViolation(
            f"{what}: {robot.joint_names[j]} = {q2[k, j]:.6g} rad is outside its range "
            f"[{lo[j]:.6g}, {hi[j]:.6g}] rad" + (f" (sample {k})" if q2.shape[0] > 1 else "")
        )


def _ratio(signal, limit) -> np.ndarray:
    """Peak |signal| / limit per joint (0 where the limit is infinite)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.abs(signal).max(axis=0) / np.asarray(limit, float)
    return np.where(np.isfinite(r), r, 0.0)


def stretch_needed(traj, robot: Robot, limits, *, torque: bool = True) -> tuple[float, str, str]:
    """Smallest time-stretch factor ``k >= 1`` that brings ``traj`` within ``limits``
    (a :class:`~armlab.robot.Limits`; kinds that are None are not limited).

    ``k = max(r_v, sqrt(r_a), cbrt(r_j), k_tau)`` with ``r`` the peak ratios of the samples
    and ``k_tau`` the exact factor for the torques: ``|g + (tau - g) x| <= tau_max`` with
    ``x = 1 / k^2`` is an interval in ``x`` that contains 0 whenever gravity alone is within
    the limit.

    Returns
    -------
    (k, kind, joint)
        The factor and the limit that sets it (``("", "")`` if ``k == 1``).

    Raises
    ------
    LimitViolation
        Gravity alone exceeds a joint's torque limit somewhere (no speed can fix it).
    """
    cands: list[tuple[float, str, int]] = [(1.0, "", 0)]
    if limits.velocity_rad_s is not None:
        r = _ratio(traj.qd, limits.velocity_rad_s)
        cands.append((float(r.max()), "velocity", int(r.argmax())))
    if limits.acceleration_rad_s2 is not None:
        r = _ratio(traj.qdd, limits.acceleration_rad_s2)
        cands.append((math.sqrt(r.max()), "acceleration", int(r.argmax())))
    if limits.jerk_rad_s3 is not None and traj.qddd is not None:
        r = _ratio(traj.qddd, limits.jerk_rad_s3)
        cands.append((float(np.cbrt(r.max())), "jerk", int(r.argmax())))
    eff = limits.torque_Nm
    if torque and eff is not None and np.any(np.isfinite(eff)):
        g = rigid_body.gravity_torques(robot, traj.q)
        tau = rigid_body.inverse_dynamics(robot, traj.q, traj.qd, traj.qdd)
        over = np.abs(g) > eff * (1 + 1e-12)
        if np.any(over):
            k, j = np.argwhere(over)[0]
            raise LimitViolation(
                f"{robot.name}: gravity alone needs {abs(g[k, j]):.4g} N m at "
                f"{robot.joint_names[j]} (t = {traj.t[k]:.4g} s), above its torque limit "
                f"{eff[j]:.4g} N m: no slower motion can meet it"
            )
        d = tau - g
        with np.errstate(divide="ignore", invalid="ignore"):
            xmax = np.where(d > 0, (eff - g) / d, np.where(d < 0, (-eff - g) / d, np.inf))
        xmax = np.clip(xmax, 0.0, np.inf)
        kk = np.where(xmax >= 1, 1.0, 1.0 / np.sqrt(np.maximum(xmax, 1e-300)))
        jj = int(np.argmax(kk.max(axis=0)))
        cands.append((float(kk.max()), "torque", jj))
    k, kind, j = max(cands, key=lambda c: c[0])
    if k <= 1.0:
        return 1.0, "", ""
    return k, kind, robot.joint_names[j]


def finish(traj, robot: Robot, limits, *, torque: bool, what: str) -> Trajectory:
    """Set ``traj.report`` and raise :class:`LimitViolation` if any limit is still broken."""
    traj.report = traj.check_limits(robot, torque=torque, limits=limits)
    bad = traj.report.violations(tol=1e-9)
    if bad:
        kind, joint, ratio, at = max(bad, key=lambda b: b[2])
        raise LimitViolation(
            f"{what}: {joint} {kind} reaches {ratio:.4g} x its limit at t = {at:.4g} s"
        )
    return traj
