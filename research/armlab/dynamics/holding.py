"""Static holding check of a pose or a path: the torques that hold it, and the margin left.

The holding torque is the gravity torque ``g(q)`` with the payload (RNEA at rest); the limit
of each joint is its torque limit (``robot.limits.torque_Nm``: for robot_desc arms the thesis'
available torque, stall x ratio x efficiency x derating), and the margin is
``1 - max |g_j| / limit_j``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from armlab.dynamics.inverse import joint_torques
from armlab.errors import InputError
from armlab.trajectory import Trajectory

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["HoldReport", "hold_check"]


@dataclass
class HoldReport:
    """Holding torques of a pose or path.

    Attributes
    ----------
    joint_names : list of str
    q : array (n_samples, n_joints)
    torque_Nm : array (n_samples, n_joints)
        Gravity torque ``g(q)`` with the payload, in [N m].
    limit_Nm : array (n_joints,)
        Effort limit per joint in [N m] (NaN when the description has none).
    in_range : bool array (n_samples,)
        Whether each pose lies inside the joint ranges.
    payload_kg : float
    """

    joint_names: list[str]
    q: np.ndarray
    torque_Nm: np.ndarray
    limit_Nm: np.ndarray
    in_range: np.ndarray
    payload_kg: float

    @property
    def peak_torque_Nm(self) -> np.ndarray:
        return np.abs(self.torque_Nm).max(axis=0)

    @property
    def worst_sample(self) -> np.ndarray:
        """Index of the sample with the largest |torque| of each joint."""
        return np.abs(self.torque_Nm).argmax(axis=0)

    @property
    def margin(self) -> np.ndarray:
        """``1 - peak |torque| / limit`` per joint (NaN without a limit)."""
        return 1.0 - self.peak_torque_Nm / self.limit_Nm

    @property
    def ok(self) -> bool:
        """Every joint with a known limit holds with margin >= 0, and every pose is in range."""
        m = self.margin
        return bool(np.all(m[np.isfinite(m)] >= -1e-12) and np.all(self.in_range))

    def to_dict(self) -> dict:
        out = {}
        for j, name in enumerate(self.joint_names):
            lim, m = float(self.limit_Nm[j]), float(self.margin[j])
            out[name] = {
                "peak_torque_Nm": float(self.peak_torque_Nm[j]),
                "limit_Nm": lim if np.isfinite(lim) else None,
                "margin": m if np.isfinite(m) else None,
                "at_sample": int(self.worst_sample[j]),
            }
        return {
            "payload_kg": self.payload_kg,
            "n_samples": int(self.q.shape[0]),
            "ok": self.ok,
            "all_in_range": bool(np.all(self.in_range)),
            "joints": out,
        }

    def to_markdown(self) -> str:
        lines = [
            f"| joint | holding torque [N m] | limit [N m] | margin | (payload "
            f"{self.payload_kg:g} kg, {self.q.shape[0]} poses) |",
            "|---|---|---|---|---|",
        ]
        for j, name in enumerate(self.joint_names):
            lines.append(
                f"| {name} | {self.peak_torque_Nm[j]:.4g} | {self.limit_Nm[j]:.4g} | "
                f"{100 * self.margin[j]:+.0f} % | sample {self.worst_sample[j]} |"
            )
        return "\n".join(lines) + "\n"


def hold_check(robot: Robot, q_or_path, *, threads: int = 1) -> HoldReport:
    """Torques needed to hold a pose or every pose of a path, with the margin to the limits.

    Parameters
    ----------
    robot : Robot
        Payload included.
    q_or_path : array (n_joints,) or (n_samples, n_joints), or Trajectory
        Joint positions in [rad] (a trajectory's ``q``; its speeds are ignored).

    Returns
    -------
    HoldReport

    Raises
    ------
    InputError
        Wrong shape or non-finite positions.
    """
    q = q_or_path.q if isinstance(q_or_path, Trajectory) else q_or_path
    q = robot.check_q(np.atleast_2d(np.asarray(q, dtype=float)), name="q", batch=True)
    if q.shape[0] == 0:
        raise InputError("q has no poses")
    zeros = np.zeros_like(q)
    tau = joint_torques(robot, q, zeros, zeros, threads=threads)
    effort = robot.limits.torque_Nm
    limit = np.full(robot.n_joints, np.nan) if effort is None else np.array(effort, float)
    return HoldReport(
        joint_names=list(robot.joint_names),
        q=q,
        torque_Nm=tau,
        limit_Nm=limit,
        in_range=robot.within_limits(q),
        payload_kg=float(robot.payload.mass_kg),
    )
