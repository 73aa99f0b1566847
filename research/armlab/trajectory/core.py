"""The :class:`Trajectory`: the one currency between planners and consumers.

A trajectory is sampled: times ``t`` (n_samples,) in [s] and joint positions ``q``, velocities
``qd``, accelerations ``qdd`` (and jerks ``qddd`` where the planner defines them), each
``(n_samples, n_joints)`` in [rad], [rad/s], [rad/s^2], [rad/s^3]. Between samples it is
evaluated by quintic Hermite interpolation of (q, qd, qdd) — exact for the piecewise
polynomials the planners produce when the samples are their knots.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab.errors import InputError
from armlab.robot import rigid_body
from armlab.robot.limits import Limits

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["Trajectory", "LimitReport", "LIMIT_KINDS"]

LIMIT_KINDS = ("position", "velocity", "acceleration", "jerk", "torque")


@dataclass
class LimitReport:
    """Peak ratio of a trajectory to each limit, per joint (``<= 1`` means within the limit).

    ``ratios[kind]`` is an array ``(n_joints,)`` for kind in :data:`LIMIT_KINDS` (absent when the
    robot has no such limit or the trajectory has no such signal). For ``position`` the ratio is
    ``|q - centre| / half range``. ``at_s[kind]`` holds the time of each peak in [s].
    """

    joint_names: list[str]
    ratios: dict[str, np.ndarray] = field(default_factory=dict)
    at_s: dict[str, np.ndarray] = field(default_factory=dict)

    def worst(self) -> tuple[str, str, float]:
        """(kind, joint, ratio) of the largest ratio over all kinds and joints."""
        best = ("", "", -np.inf)
        for kind, r in self.ratios.items():
            j = int(np.argmax(r))
            if r[j] > best[2]:
                best = (kind, self.joint_names[j], float(r[j]))
        return best

    def ok(self, tol: float = 1e-9) -> bool:
        """True if every ratio is <= 1 + tol."""
        return all(bool(np.all(r <= 1.0 + tol)) for r in self.ratios.values())

    def violations(self, tol: float = 1e-9) -> list[tuple[str, str, float, float]]:
        """(kind, joint, ratio, time in [s]) of every ratio above 1 + tol."""
        out = []
        for kind, r in self.ratios.items():
            for j in np.flatnonzero(r > 1.0 + tol):
                out.append((kind, self.joint_names[j], float(r[j]), float(self.at_s[kind][j])))
        return out

    def to_dict(self) -> dict[str, dict[str, float]]:
        """``{kind: {joint: ratio}}`` for JSON."""
        return {
            k: dict(zip(self.joint_names, map(float, r), strict=True))
            for k, r in self.ratios.items()
        }


def _as_series(x, n: int, name: str, n_joints: int | None) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.ndim == 1 and n_joints in (None, 1) and a.shape[0] == n:
        a = a[:, None]
    if a.ndim != 2 or a.shape[0] != n or (n_joints is not None and a.shape[1] != n_joints):
        want = f"({n}, {n_joints if n_joints is not None else 'n_joints'})"
        raise InputError(f"Trajectory {name} has shape {a.shape}, expected {want}")
    if not np.all(np.isfinite(a)):
        bad = np.argwhere(~np.isfinite(a))[0]
        raise InputError(f"Trajectory {name} is not finite at sample {bad[0]}, joint {bad[1]}")
    return a


class Trajectory:
    """Sampled joint trajectory.

    Parameters
    ----------
    t : array (n_samples,)
        Strictly increasing sample times in [s] (shifted so that ``t[0]`` may be nonzero).
    q, qd, qdd : array (n_samples, n_joints)
        Positions [rad], velocities [rad/s], accelerations [rad/s^2].
    qddd : array (n_samples, n_joints), optional
        Jerks [rad/s^3] where the planner defines them.
    joint_names : list of str, optional
    method : str
        Which planner made it (reported in summaries).

    Attributes
    ----------
    report : LimitReport or None
        Set by planners that check feasibility on a fine grid.
    stats : dict
        Solver statistics (iterations, solve time, ...) set by optimisers.
    meta : dict
        Anything else a planner records (waypoints, profile, ...).
    """

    def __init__(self, t, q, qd, qdd, qddd=None, *, joint_names=None, method: str = ""):
        t = np.asarray(t, dtype=float).reshape(-1)
        if t.size < 1 or not np.all(np.isfinite(t)):
            raise InputError("Trajectory t must be a non-empty finite (n_samples,) array")
        if t.size > 1 and not np.all(np.diff(t) > 0):
            raise InputError("Trajectory t must be strictly increasing")
        n = t.size
        self.t = t
        self.q = _as_series(q, n, "q", None)
        nj = self.q.shape[1]
        self.qd = _as_series(qd, n, "qd", nj)
        self.qdd = _as_series(qdd, n, "qdd", nj)
        self.qddd = None if qddd is None else _as_series(qddd, n, "qddd", nj)
        if joint_names is not None and len(joint_names) != nj:
            raise InputError(f"Trajectory has {nj} joints but {len(joint_names)} joint names")
        self.joint_names = (
            list(joint_names) if joint_names is not None else [f"joint{i + 1}" for i in range(nj)]
        )
        self.method = method
        self.report: LimitReport | None = None
        self.stats: dict[str, Any] = {}
        self.meta: dict[str, Any] = {}

    # ------------------------------------------------------------------ facts
    @property
    def n_samples(self) -> int:
        return self.t.size

    @property
    def n_joints(self) -> int:
        return self.q.shape[1]

    @property
    def duration(self) -> float:
        """Duration in [s]."""
        return float(self.t[-1] - self.t[0])

    def __repr__(self) -> str:
        return (
            f"Trajectory(method={self.method!r}, duration={self.duration:.4g} s, "
            f"n_samples={self.n_samples}, n_joints={self.n_joints})"
        )

    # ------------------------------------------------------------------ evaluation
    def at(self, times) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Evaluate (q, qd, qdd, qddd) at ``times`` (n,) in [s] by quintic Hermite interpolation.

        Times outside ``[t[0], t[-1]]`` are clamped (the arm rests at its end points).
        """
        times = np.clip(np.asarray(times, dtype=float).reshape(-1), self.t[0], self.t[-1])
        if self.n_samples == 1:
            z = np.zeros((times.size, self.n_joints))
            return np.repeat(self.q, times.size, 0), z, z.copy(), z.copy()
        k = np.clip(np.searchsorted(self.t, times, side="right") - 1, 0, self.n_samples - 2)
        h = (self.t[k + 1] - self.t[k])[:, None]
        s = ((times - self.t[k])[:, None]) / h
        p0, p1 = self.q[k], self.q[k + 1]
        v0, v1 = self.qd[k] * h, self.qd[k + 1] * h
        a0, a1 = self.qdd[k] * h**2, self.qdd[k + 1] * h**2
        # quintic Hermite coefficients of p(s) = sum c_i s^i on s in [0, 1]
        c0, c1, c2 = p0, v0, 0.5 * a0
        d = p1 - p0 - v0 - 0.5 * a0
        e = v1 - v0 - a0
        f = a1 - a0
        c3 = 10 * d - 4 * e + 0.5 * f
        c4 = -15 * d + 7 * e - f
        c5 = 6 * d - 3 * e + 0.5 * f
        q = c0 + s * (c1 + s * (c2 + s * (c3 + s * (c4 + s * c5))))
        qd = (c1 + s * (2 * c2 + s * (3 * c3 + s * (4 * c4 + s * 5 * c5)))) / h
        qdd = (2 * c2 + s * (6 * c3 + s * (12 * c4 + s * 20 * c5))) / h**2
        qddd = (6 * c3 + s * (24 * c4 + s * 60 * c5)) / h**3
        return q, qd, qdd, qddd

    def sample(self, dt: float) -> Trajectory:
        """The trajectory on a uniform grid of step ``dt`` [s] from ``t[0]``; the last sample is
        the end point (the last step may be shorter). Jerk is kept only if this trajectory has
        one."""
        if not np.isfinite(dt) or dt <= 0:
            raise InputError(f"sample step dt must be a positive number of seconds, not {dt!r}")
        n = int(np.floor(self.duration / dt + 1e-9))
        times = self.t[0] + dt * np.arange(n + 1)
        if self.t[-1] - times[-1] > 1e-9 * max(1.0, dt):
            times = np.append(times, self.t[-1])
        q, qd, qdd, qddd = self.at(times)
        # Hermite jerk of a jerk-less profile (trapezoid) means nothing
        jerk = qddd if self.qddd is not None else None
        out = Trajectory(times, q, qd, qdd, jerk, joint_names=self.joint_names, method=self.method)
        out.report, out.stats, out.meta = self.report, dict(self.stats), dict(self.meta)
        return out

    def concat(self, other: Trajectory, *, tol: float = 1e-9) -> Trajectory:
        """This trajectory followed by ``other`` (shifted in time to start where this one ends).

        The join must be continuous in q and qd to ``tol``.
        """
        if other.n_joints != self.n_joints:
            raise InputError("cannot concatenate trajectories with different joint counts")
        jump = max(np.abs(other.q[0] - self.q[-1]).max(), np.abs(other.qd[0] - self.qd[-1]).max())
        if jump > tol:
            raise InputError(f"trajectories do not join: jump of {jump:.3g} in q or qd")
        t2 = other.t[1:] - other.t[0] + self.t[-1]
        jerk = None
        if self.qddd is not None and other.qddd is not None:
            jerk = np.vstack([self.qddd, other.qddd[1:]])
        out = Trajectory(
            np.concatenate([self.t, t2]),
            np.vstack([self.q, other.q[1:]]),
            np.vstack([self.qd, other.qd[1:]]),
            np.vstack([self.qdd, other.qdd[1:]]),
            jerk,
            joint_names=self.joint_names,
            method=self.method if self.method == other.method else f"{self.method}+{other.method}",
        )
        return out

    # ------------------------------------------------------------------ limits
    def torques(self, robot: Robot) -> np.ndarray:
        """Inverse-dynamics joint torques (n_samples, n_joints) in [N m] (Pinocchio RNEA,
        :func:`armlab.robot.rigid_body.inverse_dynamics`; gravity follows the robot's base)."""
        self._check_robot(robot)
        return rigid_body.inverse_dynamics(robot, self.q, self.qd, self.qdd)

    def _check_robot(self, robot) -> None:
        if robot.n_joints != self.n_joints:
            raise InputError(
                f"trajectory has {self.n_joints} joints, robot {robot.name} has {robot.n_joints}"
            )

    def check_limits(
        self, robot: Robot, *, dt: float | None = None, torque: bool = True, limits=None
    ) -> LimitReport:
        """Peak ratio to each of the robot's limits per joint.

        Parameters
        ----------
        robot : Robot
        dt : float, optional
            Resample on this grid [s] first (a fine grid catches peaks between knots).
        torque : bool
            Include the torque ratio (RNEA at every sample, payload included).
        limits : Limits, optional
            Use these limits instead of ``robot.limits`` (e.g. a request's, from
            :func:`armlab.robot.resolve_limits`); kinds that are None are not reported.
        """
        self._check_robot(robot)
        traj = self if dt is None else self.sample(dt)
        lim = robot.limits if limits is None else limits
        if not isinstance(lim, Limits) or lim.n_joints != self.n_joints:
            raise InputError(f"limits must be a Limits of {self.n_joints} joints, not {lim!r}")
        report = LimitReport(list(robot.joint_names))
        centre = 0.5 * (lim.upper_rad + lim.lower_rad)
        half = 0.5 * (lim.upper_rad - lim.lower_rad)

        def put(kind: str, signal: np.ndarray | None, scale) -> None:
            if signal is None or scale is None:
                return
            r = np.abs(signal) / np.asarray(scale, dtype=float)
            k = np.argmax(r, axis=0)
            report.ratios[kind] = r[k, np.arange(r.shape[1])]
            report.at_s[kind] = traj.t[k]

        put("position", traj.q - centre, half)
        put("velocity", traj.qd, lim.velocity_rad_s)
        put("acceleration", traj.qdd, lim.acceleration_rad_s2)
        put("jerk", traj.qddd, lim.jerk_rad_s3)
        if torque and lim.torque_Nm is not None:
            put("torque", traj.torques(robot), lim.torque_Nm)
        return report
