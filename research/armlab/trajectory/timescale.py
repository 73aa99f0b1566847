"""Limits for the classical planners, and the uniform time stretch that meets them.

Stretching a trajectory in time by ``k >= 1`` (``q_k(t) = q(t / k)``) divides the velocities
by ``k``, the accelerations by ``k^2`` and the jerks by ``k^3``. Inverse dynamics
``tau = M(q) qdd + C(q, qd) qd + g(q)`` becomes ``g + (tau - g) / k^2`` at the same path point,
so the smallest ``k`` that meets every limit follows in closed form from the samples
(:func:`stretch_needed`). The planners use it to slow down instead of violating a limit, and
say which limit set the pace (``Trajectory.meta["slowdown"]``).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pinocchio as pin

from armlab.errors import InputError, LimitViolation

__all__ = ["planner_limits", "stretch_needed", "finish", "check_in_range"]


def _per_joint(robot, value, name: str) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.ndim == 0:
        a = np.full(robot.n_joints, float(a))
    if a.shape != (robot.n_joints,):
        raise InputError(f"{name} has shape {a.shape}, expected a scalar or ({robot.n_joints},)")
    if np.any(np.isnan(a)) or np.any(a <= 0):
        raise InputError(f"{name} must be > 0 for every joint, got {a.tolist()}")
    return a


def planner_limits(
    robot,
    v_max=None,
    a_max=None,
    j_max=None,
    *,
    need: tuple[str, ...] = ("velocity", "acceleration"),
):
    """The robot's :class:`JointLimits` with per-call overrides.

    Parameters
    ----------
    robot : Robot
    v_max, a_max, j_max : float or array (n_joints,), optional
        Override the velocity [rad/s], acceleration [rad/s^2], jerk [rad/s^3] limits
        (``np.inf`` switches one off).
    need : tuple of str
        Limits the planner cannot work without.

    Raises
    ------
    InputError
        A needed limit is missing from the description (plain URDF without drives.toml) and not
        given, or an override has the wrong shape or a value <= 0.
    """
    lim = robot.limits
    v = lim.velocity_rad_s if v_max is None else _per_joint(robot, v_max, "v_max")
    a = lim.acceleration_rad_s2 if a_max is None else _per_joint(robot, a_max, "a_max")
    j = lim.jerk_rad_s3 if j_max is None else _per_joint(robot, j_max, "j_max")
    for kind, arr, arg in (
        ("velocity", v, "v_max"),
        ("acceleration", a, "a_max"),
        ("jerk", j, "j_max"),
    ):
        if kind in need and (arr is None or np.any(~(np.asarray(arr) > 0))):
            raise InputError(
                f"{robot.name} has no {kind} limit for every joint (no drives.toml?): pass {arg}"
            )
    return replace(
        lim,
        velocity_rad_s=np.asarray(v, float),
        acceleration_rad_s2=None if a is None else np.asarray(a, float),
        jerk_rad_s3=None if j is None else np.asarray(j, float),
    )


def check_in_range(robot, q, what: str) -> None:
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


def stretch_needed(traj, robot, limits, *, torque: bool = True) -> tuple[float, str, str]:
    """Smallest time-stretch factor ``k >= 1`` that brings ``traj`` within ``limits``.

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
    cands: list[tuple[float, str, int]] = []
    r = _ratio(traj.qd, limits.velocity_rad_s)
    cands.append((float(r.max()), "velocity", int(r.argmax())))
    if limits.acceleration_rad_s2 is not None:
        r = _ratio(traj.qdd, limits.acceleration_rad_s2)
        cands.append((math.sqrt(r.max()), "acceleration", int(r.argmax())))
    if limits.jerk_rad_s3 is not None and traj.qddd is not None:
        r = _ratio(traj.qddd, limits.jerk_rad_s3)
        cands.append((float(np.cbrt(r.max())), "jerk", int(r.argmax())))
    eff = np.asarray(limits.effort_Nm, float)
    if torque and np.all(eff > 0) and np.any(np.isfinite(eff)):
        model, data = robot.model, robot.model.createData()
        n = traj.n_samples
        g = np.empty((n, robot.n_joints))
        tau = np.empty((n, robot.n_joints))
        for k in range(n):
            g[k] = pin.computeGeneralizedGravity(model, data, traj.q[k])
            tau[k] = pin.rnea(model, data, traj.q[k], traj.qd[k], traj.qdd[k])
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


def finish(traj, robot, limits, *, torque: bool, what: str):
    """Set ``traj.report`` and raise :class:`LimitViolation` if any limit is still broken."""
    traj.report = traj.check_limits(robot, torque=torque, limits=limits)
    bad = traj.report.violations(tol=1e-9)
    if bad:
        kind, joint, ratio, at = max(bad, key=lambda b: b[2])
        raise LimitViolation(
            f"{what}: {joint} {kind} reaches {ratio:.4g} x its limit at t = {at:.4g} s"
        )
    return traj
