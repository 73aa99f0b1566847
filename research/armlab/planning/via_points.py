"""Cubic and quintic polynomials through via points in joint space (thesis 6.3.2).

HEU thesis, 6.3.2: each joint follows, on each segment of duration ``T``, the cubic
``theta(t) = c0 + c1 t + c2 t^2 + c3 t^3`` fixed by the positions and velocities at both ends::

    c0 = q0,   c1 = v0,
    c2 = 3 (q1 - q0) / T^2 - (2 v0 + v1) / T,
    c3 = -2 (q1 - q0) / T^3 + (v0 + v1) / T^2

Velocities at the via points (the thesis leaves them open):

* ``"heuristic"`` — the usual continuity rule (Craig, Introduction to Robotics, 7.3): zero
  where the slopes ``(q_{k+1} - q_k) / T_k`` of the two adjacent segments change sign (or one
  is zero), else their mean. Acceleration jumps at the via points.
* ``"spline"`` — the velocities that make the acceleration continuous too (clamped cubic
  spline with zero end velocities).
* an array ``(m, n_joints)`` given by the caller.

The quintic variant also matches accelerations at the ends of each segment (zero at the first
and last point; at via points the central difference of the via velocities, or given), so the
acceleration is continuous and the jerk finite.

Durations: given per segment, or chosen from the limits (each segment starts from the
shortest joint trapezoid, then the whole motion is stretched uniformly until every velocity,
acceleration, jerk and torque limit holds).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from scipy.interpolate import CubicSpline

from armlab._keywords import renamed_keywords
from armlab.errors import InputError, LimitViolation
from armlab.planning.timescale import check_in_range, finish, stretch_needed
from armlab.robot.limits import resolve_limits
from armlab.trajectory.core import Trajectory
from armlab.trajectory.profiles import trapezoid_min_time
from armlab.trajectory.sampling import sample_times
from armlab.trajectory.waypoints import validate_waypoints

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["cubic_via", "quintic_via", "via_velocities"]


def via_velocities(waypoints, durations, rule: str = "heuristic") -> np.ndarray:
    """Velocities (m, n_joints) in [rad/s] at the waypoints, zero at both ends.

    Parameters
    ----------
    waypoints : array (m, n_joints)
    durations : array (m - 1,)
        Segment durations in [s].
    rule : {"heuristic", "spline"}
        See the module docstring.
    """
    W = np.asarray(waypoints, float)
    T = np.asarray(durations, float)
    m = W.shape[0]
    V = np.zeros_like(W)
    if m <= 2:
        return V
    if rule == "spline":
        t = np.concatenate([[0.0], np.cumsum(T)])
        return CubicSpline(t, W, axis=0, bc_type="clamped")(t, 1)
    if rule != "heuristic":
        raise InputError(f"unknown via-velocity rule {rule!r}; use 'heuristic' or 'spline'")
    slope = np.diff(W, axis=0) / T[:, None]
    left, right = slope[:-1], slope[1:]
    same = np.sign(left) * np.sign(right) > 0
    V[1:-1] = np.where(same, 0.5 * (left + right), 0.0)
    return V


def _cubic_coeffs(q0, q1, v0, v1, T):
    """(4, n_joints) coefficients of thesis 6.3.2's cubic on [0, T]."""
    d = q1 - q0
    return np.stack([q0, v0, 3 * d / T**2 - (2 * v0 + v1) / T, -2 * d / T**3 + (v0 + v1) / T**2])


def _quintic_coeffs(q0, q1, v0, v1, a0, a1, T):
    """(6, n_joints) coefficients of the quintic matching position, velocity, acceleration."""
    d = q1 - q0 - v0 * T - a0 * T * T / 2
    e = v1 - v0 - a0 * T
    f = a1 - a0
    c3 = (10 * d - 4 * e * T + f * T * T / 2) / T**3
    c4 = (-15 * d + 7 * e * T - f * T * T) / T**4
    c5 = (6 * d - 3 * e * T + f * T * T / 2) / T**5
    return np.stack([q0, v0, a0 / 2, c3, c4, c5])


class _PiecewisePoly:
    """Piecewise polynomial in local time: coeffs (n_seg, deg + 1, n_joints), knots (n_seg+1,)."""

    def __init__(self, knots: np.ndarray, coeffs: np.ndarray) -> None:
        self.knots, self.coeffs = knots, coeffs

    def evaluate(self, t: np.ndarray):
        n_seg = self.coeffs.shape[0]
        i = np.clip(np.searchsorted(self.knots, t, side="right") - 1, 0, n_seg - 1)
        tau = (t - self.knots[i])[:, None]
        c = self.coeffs[i]  # (n, deg + 1, nj)
        deg = c.shape[1] - 1
        out = []
        for der in range(4):
            acc = np.zeros((t.size, c.shape[2]))
            for p in range(deg, der - 1, -1):
                fac = math.factorial(p) / math.factorial(p - der)
                acc = acc * tau + fac * c[:, p, :]
            out.append(acc)
        return out

    def critical_times(self) -> np.ndarray:
        """Times inside segments where some joint's velocity or acceleration peaks (roots of
        the 2nd and 3rd derivatives), so that samples there show the exact peaks."""
        out = []
        n_seg, _, nj = self.coeffs.shape
        for s in range(n_seg):
            T = self.knots[s + 1] - self.knots[s]
            for j in range(nj):
                poly = np.polynomial.Polynomial(self.coeffs[s, :, j])
                for der in (2, 3):
                    dp = poly.deriv(der)
                    if dp.degree() < 1 or not np.any(dp.coef):
                        continue
                    roots: np.ndarray = dp.roots()  # numpy's stubs: elements are object_
                    out += [
                        self.knots[s] + r.real
                        for r in roots
                        if abs(r.imag) < 1e-12 and 0 < r.real < T
                    ]
        return np.array(out)

    def extremes(self) -> tuple[np.ndarray, np.ndarray]:
        """Exact min and max (n_joints,) over the whole motion (roots of the derivative)."""
        n_seg, _, nj = self.coeffs.shape
        lo = np.full(nj, np.inf)
        hi = np.full(nj, -np.inf)
        for s in range(n_seg):
            T = self.knots[s + 1] - self.knots[s]
            for j in range(nj):
                c = self.coeffs[s, :, j]
                poly = np.polynomial.Polynomial(c)
                roots: np.ndarray = poly.deriv().roots()  # numpy's stubs: elements are object_
                ts = [0.0, T] + [r.real for r in roots if abs(r.imag) < 1e-12 and 0 < r.real < T]
                vals = poly(np.array(ts))
                lo[j], hi[j] = min(lo[j], vals.min()), max(hi[j], vals.max())
        return lo, hi


def _sample_times(knots: np.ndarray, dt: float, extra: np.ndarray) -> np.ndarray:
    """Uniform grid of step ``dt`` plus every knot (the via points are samples, where the
    acceleration may step) plus the ``extra`` times (velocity and acceleration peaks), all
    kept exactly (:func:`armlab.trajectory.sampling.sample_times`)."""
    return sample_times(float(knots[-1]), dt, np.concatenate([knots[1:-1], extra]))


def _via_plan(
    robot,
    waypoints,
    durations,
    velocities,
    accelerations,
    *,
    degree: int,
    dt: float,
    v_max,
    a_max,
    j_max,
    tau_max,
) -> Trajectory:
    method = "cubic_via" if degree == 3 else "quintic_via"
    W = validate_waypoints(robot, waypoints, where=f"{method} waypoints")
    dt = float(dt)
    if not math.isfinite(dt) or dt <= 0:
        raise InputError(f"dt must be a positive number of seconds, not {dt!r}")
    given_v = velocities is not None and not isinstance(velocities, str)
    rule = "heuristic" if velocities is None else velocities
    if given_v:
        V_given = np.asarray(velocities, float)
        if V_given.shape != W.shape or not np.all(np.isfinite(V_given)):
            raise InputError(f"velocities have shape {V_given.shape}, expected {W.shape}")
    A_given = None
    if accelerations is not None:
        A_given = np.asarray(accelerations, float)
        if A_given.shape != W.shape or not np.all(np.isfinite(A_given)):
            raise InputError(f"accelerations have shape {A_given.shape}, expected {W.shape}")
    lim = resolve_limits(
        robot,
        v_max=v_max,
        a_max=a_max,
        j_max=j_max,
        tau_max=tau_max,
        need=("velocity",) if durations is not None else ("velocity", "acceleration"),
        where=method,
    )
    torque = lim.torque_Nm is not None  # tau_max=False switched it off in resolve_limits
    merged = 0
    if durations is None:
        # merge repeated waypoints (a zero-length segment has no natural duration)
        keep = np.concatenate([[True], np.any(np.abs(np.diff(W, axis=0)) > 1e-12, axis=1)])
        merged = int((~keep).sum())
        W = W[keep]
        if given_v:
            V_given = V_given[keep]
        if A_given is not None:
            A_given = A_given[keep]
        if W.shape[0] == 1:
            z = np.zeros((1, robot.n_joints))
            traj = Trajectory(
                [0.0],
                W,
                z,
                z.copy(),
                z.copy() if degree == 5 else None,
                joint_names=robot.joint_names,
                method=method,
            )
            traj.meta.update(zero_length=True, waypoints=W.tolist(), merged_waypoints=merged)
            return finish(traj, robot, lim, torque=torque, what=method)
        D = np.abs(np.diff(W, axis=0))
        vel, acc = lim.velocity_rad_s, lim.acceleration_rad_s2
        assert vel is not None and acc is not None  # needed: resolve_limits raised otherwise
        T = np.array(
            [
                max(trapezoid_min_time(d, v, a) for d, v, a in zip(row, vel, acc, strict=True))
                for row in D
            ]
        )
        fixed = False
    else:
        T = np.asarray(durations, float).reshape(-1)
        if T.shape != (W.shape[0] - 1,) or not np.all(np.isfinite(T)) or np.any(T <= 0):
            raise InputError(
                f"durations must be {W.shape[0] - 1} finite values > 0 [s], "
                f"got {np.asarray(durations).tolist()}"
            )
        fixed = True

    def build(T):
        knots = np.concatenate([[0.0], np.cumsum(T)])
        V = V_given if given_v else via_velocities(W, T, rule)
        if degree == 3:
            coeffs = np.stack(
                [_cubic_coeffs(W[k], W[k + 1], V[k], V[k + 1], T[k]) for k in range(T.size)]
            )
        else:
            if A_given is not None:
                A = A_given
            else:
                A = np.zeros_like(W)
                if W.shape[0] > 2:
                    A[1:-1] = (V[2:] - V[:-2]) / (T[:-1] + T[1:])[:, None]
            coeffs = np.stack(
                [
                    _quintic_coeffs(W[k], W[k + 1], V[k], V[k + 1], A[k], A[k + 1], T[k])
                    for k in range(T.size)
                ]
            )
        pp = _PiecewisePoly(knots, coeffs)
        smooth = degree == 5 or (not given_v and rule == "spline")
        t = _sample_times(knots, dt, pp.critical_times())
        q, qd, qdd, qddd = pp.evaluate(t)
        q[np.searchsorted(t, knots)] = W  # the via points exactly
        traj = Trajectory(
            t, q, qd, qdd, qddd if smooth else None, joint_names=robot.joint_names, method=method
        )
        return traj, pp, V

    def needed(traj):  # on the evaluation's peaks (knots, left limits, interior extremes)
        return stretch_needed(
            traj.limit_samples(robot=robot if torque else None), robot, lim, torque=torque
        )

    traj, pp, V = build(T)
    k, kind, joint = needed(traj)
    slowdown = None
    if k > 1 + 1e-12:
        if fixed:
            raise LimitViolation(
                f"{method}: with the given durations {joint} {kind} reaches "
                f"{traj.check_limits(robot, torque=torque, limits=lim).worst()[2]:.4g} x its "
                f"limit; the segments need about {k:.3g} x longer"
            )
        T0 = T.sum()
        first = (kind, joint)
        for _ in range(60):  # scale-invariant rules converge in one pass; given velocities not
            T = T * k * (1 + 1e-9)
            traj, pp, V = build(T)
            k, kind, joint = needed(traj)
            if k <= 1 + 1e-12:
                break
        else:
            raise LimitViolation(
                f"{method}: cannot meet the {kind} limit of {joint} by slowing "
                "down (are the given via velocities above the limit?)"
            )
        slowdown = {"factor": float(T.sum() / T0), "kind": first[0], "joint": first[1]}
    lo, hi = pp.extremes()
    check_in_range(robot, np.vstack([lo, hi]), f"{method} (overshoot between via points)")
    traj.meta.update(
        waypoints=W.tolist(),
        durations_s=T.tolist(),
        knot_times_s=pp.knots.tolist(),
        via_velocities=V.tolist(),
        velocity_rule="given" if given_v else rule,
        merged_waypoints=merged,
        slowdown=slowdown,
        dt_s=dt,
    )
    return finish(traj, robot, lim, torque=torque, what=method)


@renamed_keywords(torque="tau_max= (False: no torque limit)")
def cubic_via(
    robot: Robot,
    waypoints,
    durations=None,
    velocities=None,
    *,
    dt: float = 0.01,
    v_max=None,
    a_max=None,
    j_max=None,
    tau_max=None,
) -> Trajectory:
    """Cubic polynomials through via points in joint space (thesis 6.3.2).

    Parameters
    ----------
    robot : Robot
    waypoints : array (m, n_joints)
        Positions in [rad], inside the joint ranges; the motion starts and ends at rest.
    durations : array (m - 1,), optional
        Segment durations in [s]. Default: the shortest that meet the limits (uniform stretch
        of per-segment trapezoid times); repeated waypoints are then merged.
    velocities : {"heuristic", "spline"} or array (m, n_joints), optional
        Via-point velocities: the continuity rule (default), a C2 spline, or given [rad/s].
    dt : float
        Sample period in [s]; the via points are samples too.
    v_max, a_max, j_max : None, False, float or array (n_joints,)
        Limits (:func:`armlab.robot.resolve_limits`): None the robot's, False off, a value
        replaces it; velocity is needed, and acceleration when ``durations`` are not given.
    tau_max : None, False, float or array (n_joints,)
        Torque limit in [N m] (:func:`armlab.robot.resolve_limits`): None the robot's, False
        no torque check, a value replaces it; the inverse-dynamics torques are kept within it
        (slowing down if needed).

    Returns
    -------
    Trajectory
        ``method = "cubic_via"``; ``meta``: waypoints, durations_s, knot_times_s,
        via_velocities, velocity_rule, slowdown. ``qddd`` only for ``"spline"`` (the other
        rules step the acceleration at the via points).

    Raises
    ------
    InputError
        Bad shapes or durations; a waypoint outside a joint range
        (:func:`~armlab.trajectory.waypoints.validate_waypoints`).
    LimitViolation
        The overshoot between via points leaves a joint range, or the given durations break
        a limit (the message names joint and limit).
    """
    return _via_plan(
        robot,
        waypoints,
        durations,
        velocities,
        None,
        degree=3,
        dt=dt,
        v_max=v_max,
        a_max=a_max,
        j_max=j_max,
        tau_max=tau_max,
    )


@renamed_keywords(torque="tau_max= (False: no torque limit)")
def quintic_via(
    robot: Robot,
    waypoints,
    durations=None,
    velocities=None,
    accelerations=None,
    *,
    dt: float = 0.01,
    v_max=None,
    a_max=None,
    j_max=None,
    tau_max=None,
) -> Trajectory:
    """Quintic polynomials through via points: as :func:`cubic_via`, with continuous
    acceleration (``accelerations`` (m, n_joints) in [rad/s^2] optional; default zero at the
    ends and the central difference of the via velocities between). ``qddd`` is given and the
    jerk limit is met too."""
    return _via_plan(
        robot,
        waypoints,
        durations,
        velocities,
        accelerations,
        degree=5,
        dt=dt,
        v_max=v_max,
        a_max=a_max,
        j_max=j_max,
        tau_max=tau_max,
    )
