"""The limit set of one planning request: the robot's limits, overridden or switched off per call.

Every optimiser keyword follows one rule (issue 5): ``None`` takes the robot's own limit
(``robot.limits``), ``False`` switches that kind of limit off, a scalar or a ``(n_joints,)``
array overrides it. Joint ranges always come from the robot.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from armlab.errors import InputError
from armlab.robot.model import JointLimits

__all__ = ["LimitSet", "resolve_limits", "LIMIT_KEYWORDS"]

#: keyword -> (LimitSet field, JointLimits field, unit)
LIMIT_KEYWORDS = {
    "v_max": ("velocity", "velocity_rad_s", "rad/s"),
    "a_max": ("acceleration", "acceleration_rad_s2", "rad/s^2"),
    "j_max": ("jerk", "jerk_rad_s3", "rad/s^3"),
    "tau_max": ("torque", "effort_Nm", "N m"),
}


@dataclass(frozen=True)
class LimitSet:
    """Effective limits of a request; arrays ``(n_joints,)`` in SI units, ``None`` when off.

    Attributes
    ----------
    joint_names : list of str
    lower_rad, upper_rad : ndarray
        Joint range in [rad] (or [m] for prismatic joints).
    velocity, acceleration, jerk, torque : ndarray or None
        Bounds on ``|qd|`` [rad/s], ``|qdd|`` [rad/s^2], ``|qddd|`` [rad/s^3], ``|tau|`` [N m].
    """

    joint_names: list[str]
    lower_rad: np.ndarray
    upper_rad: np.ndarray
    velocity: np.ndarray | None
    acceleration: np.ndarray | None
    jerk: np.ndarray | None
    torque: np.ndarray | None

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    def joint_limits(self) -> JointLimits:
        """As a :class:`JointLimits` for :meth:`Trajectory.check_limits` (off limits are None)."""
        return JointLimits(
            lower_rad=self.lower_rad,
            upper_rad=self.upper_rad,
            velocity_rad_s=self.velocity,
            effort_Nm=self.torque if self.torque is not None else np.full(self.n_joints, np.inf),
            acceleration_rad_s2=self.acceleration,
            jerk_rad_s3=self.jerk,
        )

    def scaled(self, kind: str, factor) -> LimitSet:
        """A copy with limit ``kind`` multiplied by ``factor`` (scalar or (n_joints,))."""
        cur = getattr(self, kind)
        if cur is None:
            return self
        return replace(self, **{kind: cur * np.asarray(factor, float)})

    def to_dict(self) -> dict:
        def arr(x):
            return None if x is None else dict(zip(self.joint_names, map(float, x), strict=True))

        return {
            "lower_rad": arr(self.lower_rad),
            "upper_rad": arr(self.upper_rad),
            "velocity_rad_s": arr(self.velocity),
            "acceleration_rad_s2": arr(self.acceleration),
            "jerk_rad_s3": arr(self.jerk),
            "torque_Nm": arr(self.torque),
        }


def _one(robot, keyword: str, value) -> np.ndarray | None:
    kind, field, unit = LIMIT_KEYWORDS[keyword]
    n = robot.n_joints
    if value is False:
        return None
    if value is None:
        own = getattr(robot.limits, field)
        if own is None:
            raise InputError(
                f"{robot.name} has no {kind} limit (a plain URDF says nothing about it): pass "
                f"{keyword}=<value in {unit}> (scalar or ({n},)) or {keyword}=False to switch it "
                "off"
            )
        value = own
    if value is True:
        raise InputError(f"{keyword}=True is not a limit: give a number, None or False")
    arr = np.asarray(value, dtype=float)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise InputError(f"{keyword} has shape {arr.shape}, expected a scalar or ({n},)")
    if not np.all(arr > 0) or np.any(np.isnan(arr)):
        j = int(np.flatnonzero(~(arr > 0))[0])
        raise InputError(
            f"{keyword} of {robot.joint_names[j]} is {arr[j]!r}; limits must be > 0 {unit}"
        )
    if np.all(np.isinf(arr)):
        return None
    return arr


def resolve_limits(robot, *, v_max=None, a_max=None, j_max=None, tau_max=None) -> LimitSet:
    """The effective :class:`LimitSet` of a request (None: the robot's; False: off; else override).

    Raises
    ------
    InputError
        Wrong shape, a non-positive value, or ``None`` where the robot has no such limit.
    """
    return LimitSet(
        joint_names=list(robot.joint_names),
        lower_rad=np.asarray(robot.limits.lower_rad, float).copy(),
        upper_rad=np.asarray(robot.limits.upper_rad, float).copy(),
        velocity=_one(robot, "v_max", v_max),
        acceleration=_one(robot, "a_max", a_max),
        jerk=_one(robot, "j_max", j_max),
        torque=_one(robot, "tau_max", tau_max),
    )
