"""The thesis' requirements as a duty cycle: each joint at its maximum speed and acceleration.

Thesis chapter 2 gives, per joint, a maximum speed and acceleration (HEU thesis, ch. 2 table); its
table 4.3 verdict compares the drives against the static worst case of 4.2.1. To size the
drives along a motion with the same content, :func:`requirement_moves` builds one move per
joint:

* every joint starts at rest at **that joint's worst static pose** (:func:`static_load`);
* the joint accelerates at its maximum acceleration in the direction that adds to gravity
  (so the first sample carries exactly the static-load torque of eq. 4-2), cruises at its
  maximum speed for ``cruise_s`` and decelerates to rest (a trapezoidal profile); the other
  joints hold still;
* if the joint range does not leave room for the whole move, the cruise is shortened (and if
  even the ramps do not fit, the move goes the other way; ``meta["note"]`` says so).

The six moves form one duty cycle (``size(robot, moves)`` stacks them).

The maximum speed is the **requirement**, the description's ``<limit velocity>`` (thesis table
2.1 in the URDF), not ``robot.limits.velocity_rad_s``: that one is already capped by the drive
train (motor speed / ratio, :func:`armlab.robot.resolve_limits`), and sizing is what checks
whether the drive meets the requirement. The acceleration is ``robot.limits``' (drives.toml,
thesis table 2.1).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from armlab.errors import InputError
from armlab.robot.limits import description_limits
from armlab.trajectory import Trajectory
from armlab.trajectory.profiles import MotionProfile, trapezoid_peak_speed, trapezoid_ramp_length

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["requirement_moves", "trapezoid_move"]


def trapezoid_move(
    q_start,
    joint: int,
    direction: float,
    speed: float,
    acceleration: float,
    cruise_s: float,
    dt: float,
    joint_names=None,
) -> Trajectory:
    """One joint's trapezoidal move from rest to rest, sampled every ``dt`` [s].

    Phases (a :class:`~armlab.trajectory.profiles.MotionProfile`): ``+a`` for ``v/a`` s, ``0``
    for ``cruise_s`` s, ``-a`` for ``v/a`` s (signs times ``direction``). At a phase boundary
    (within 1e-12 s) the sample takes the acceleration of the phase that starts there, so the
    first sample has ``qdd = direction x a`` at rest; the last one is at rest.
    """
    if speed <= 0 or acceleration <= 0 or dt <= 0 or cruise_s < 0:
        raise InputError("speed, acceleration and dt must be > 0 and cruise_s >= 0")
    q_start = np.asarray(q_start, float)
    ta = speed / acceleration
    prof = MotionProfile(
        np.array([ta, cruise_s, ta]), np.array([acceleration, 0.0, -acceleration]), np.zeros(3)
    )
    T = ta + cruise_s + ta
    n = int(np.floor(T / dt + 1e-9))
    t = dt * np.arange(n + 1)
    if T - t[-1] > 1e-9 * max(1.0, dt):
        t = np.append(t, T)
    pos, vel, _, _ = prof.evaluate(t)
    # the acceleration a sample just below a phase boundary (rounding of k dt) would miss
    acc = prof.evaluate(t + 1e-12)[2]
    acc[-1] = 0.0  # the last sample is the end of the move: at rest
    s = float(direction)
    nj = q_start.size
    q = np.repeat(q_start[None, :], t.size, axis=0)
    qd = np.zeros((t.size, nj))
    qdd = np.zeros((t.size, nj))
    q[:, joint] += s * pos
    qd[:, joint] = s * vel
    qdd[:, joint] = s * acc
    return Trajectory(t, q, qd, qdd, joint_names=joint_names, method="requirement move")


def requirement_moves(
    robot: Robot,
    static=None,
    *,
    velocity_rad_s=None,
    acceleration_rad_s2=None,
    cruise_s: float = 0.5,
    dt: float = 1e-3,
) -> list[Trajectory]:
    """One trapezoidal move per joint at its maximum speed and acceleration (module docstring).

    Parameters
    ----------
    robot : Robot
    static : StaticLoadReport, optional
        Worst poses; computed with :func:`static_load` if not given.
    velocity_rad_s, acceleration_rad_s2 : array (n_joints,), optional
        Override the required speed (default: the URDF's ``<limit velocity>``, falling back to
        ``robot.limits`` where it has none) and acceleration (default ``robot.limits``), e.g.
        twice them for a move that is too fast.
    cruise_s : float
        Time at full speed in [s].
    dt : float
        Sample step in [s].

    Returns
    -------
    list of Trajectory
        One per joint, in joint order; ``meta`` holds ``joint``, ``direction`` and ``note``.
    """
    if static is None:
        from armlab.dynamics.static_load import static_load

        static = static_load(robot)
    v = velocity_rad_s
    if v is None:
        v = description_limits(robot.model, robot.joint_names).velocity_rad_s
        v = robot.limits.velocity_rad_s if v is None else v
    if v is None:
        raise InputError(f"{robot.name} has no velocity limits: pass velocity_rad_s")
    a = robot.limits.acceleration_rad_s2 if acceleration_rad_s2 is None else acceleration_rad_s2
    if a is None:
        raise InputError(f"{robot.name} has no acceleration limits: pass acceleration_rad_s2")
    v = np.asarray(v, float).reshape(-1)
    a = np.asarray(a, float).reshape(-1)
    for name, x in (("velocity_rad_s", v), ("acceleration_rad_s2", a)):
        if x.shape != (robot.n_joints,) or not np.all(np.isfinite(x)) or np.any(x <= 0):
            raise InputError(f"{name} must be {robot.n_joints} positive finite numbers")
    lo, hi = robot.limits.lower_rad, robot.limits.upper_rad
    moves = []
    for j, load in enumerate(static.joints):
        q0 = np.clip(load.pose_rad, lo, hi)
        s = load.direction if load.direction != 0 else 1.0
        ramp = float(trapezoid_ramp_length(v[j], a[j]))  # accelerate + decelerate
        room = {1.0: hi[j] - q0[j], -1.0: q0[j] - lo[j]}
        note = ""
        if room[s] < ramp and room[-s] > room[s]:
            s, note = -s, "no room to accelerate with gravity: moved the other way"
        cruise = min(cruise_s, max(0.0, (room[s] - ramp) / v[j]))
        speed = v[j]
        if room[s] < ramp:
            speed = float(trapezoid_peak_speed(max(room[s], 0.0), v[j], a[j])) * (1 - 1e-9)
            note = (note + "; " if note else "") + f"range too short: peak speed {speed:.3g} rad/s"
        elif cruise < cruise_s:
            note = (note + "; " if note else "") + f"cruise shortened to {cruise:.3g} s"
        if speed <= 0:
            raise InputError(f"{robot.joint_names[j]}: no room to move from its worst pose")
        tr = trapezoid_move(q0, j, s, speed, a[j], cruise, dt, joint_names=robot.joint_names)
        tr.meta.update({"joint": robot.joint_names[j], "direction": s, "note": note})
        moves.append(tr)
    return moves
