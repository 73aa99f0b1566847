"""Inverse dynamics along trajectories: joint torque, speed and power, and the motor side.

The joint torque is Pinocchio's recursive Newton-Euler algorithm (RNEA) on the robot's model,
payload included, ``tau = M(q) qdd + C(q, qd) qd + g(q)`` (thesis eq. 4-1 without friction),
evaluated for all samples at once by :func:`armlab.robot.rigid_body.inverse_dynamics` (batched
``pinocchio.rneaInParallel``). ``robot.model.gravity`` is the gravity expressed in the base
frame (:class:`~armlab.robot.Robot`), so a tilted ``transform_base_to_world`` is honoured.

The motor side (torque, speed, motoring/generating) is the drive-train model of
:mod:`armlab.robot.drivetrain`, the one used everywhere: ``w_m = N qd``; joint friction
``F_c s + F_v qd`` added to the RNEA torque; ``T_m = tau_out / (N eta)`` while driving
(``tau_out qd >= 0``, holding included) or ``tau_out eta_b / N`` while back-driven,
``+ (J_rotor + J_reducer) N qdd + b_m w_m``. The rotor inertia is therefore counted on the
motor side only: the model's ``armature`` is expected to be zero (as robot_desc arms load); a
model with armature would count it twice.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from armlab.errors import InputError, RobotDescriptionError
from armlab.robot import rigid_body
from armlab.robot.drives import Drive
from armlab.robot.drivetrain import DriveTrain, motor_side
from armlab.trajectory import Trajectory
from armlab.trajectory.sampling import sample_weights  # its home: timing primitives

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = [
    "JointLoads",
    "inverse_dynamics",
    "joint_torques",
    "as_trajectories",
    "sample_weights",
]

RAD_S_TO_RPM = 60.0 / (2.0 * np.pi)


def joint_torques(robot: Robot, q, qd, qdd, *, threads: int = 1) -> np.ndarray:
    """RNEA joint torques for many samples: ``(n_samples, n_joints)`` in [N m].

    A thin alias of :func:`armlab.robot.rigid_body.inverse_dynamics` that always returns a 2-D
    array (a single sample ``(n_joints,)`` gives ``(1, n_joints)``).

    Parameters
    ----------
    robot : Robot
    q, qd, qdd : array (n_samples, n_joints)
        Positions [rad], velocities [rad/s], accelerations [rad/s^2].
    threads : int
        Threads of ``pinocchio.rneaInParallel`` (1 keeps shared machines quiet).
    """
    q, qd, qdd = (np.atleast_2d(np.asarray(x, dtype=float)) for x in (q, qd, qdd))
    return rigid_body.inverse_dynamics(robot, q, qd, qdd, threads=threads)


def as_trajectories(trajectory_or_list, robot: Robot) -> list[Trajectory]:
    """Validate one trajectory or a sequence of them for ``robot``; returns a list.

    Raises :class:`InputError` for anything but Trajectory objects, an empty list, a joint
    count that differs from the robot's, or non-finite samples (the constructor rejects them;
    this also catches arrays modified afterwards).
    """
    if isinstance(trajectory_or_list, Trajectory):
        trajs = [trajectory_or_list]
    elif isinstance(trajectory_or_list, Sequence) and not isinstance(trajectory_or_list, str):
        trajs = list(trajectory_or_list)
    else:
        raise InputError(
            f"expected a Trajectory or a list of them, not {type(trajectory_or_list).__name__}"
        )
    if not trajs:
        raise InputError("no trajectory given")
    for k, tr in enumerate(trajs):
        if not isinstance(tr, Trajectory):
            raise InputError(f"item {k} is a {type(tr).__name__}, not a Trajectory")
        if tr.n_joints != robot.n_joints:
            raise InputError(
                f"trajectory {k} has {tr.n_joints} joints, robot {robot.name} has {robot.n_joints}"
            )
        for name in ("t", "q", "qd", "qdd"):
            a = getattr(tr, name)
            if not np.all(np.isfinite(a)):
                bad = np.argwhere(~np.isfinite(np.atleast_2d(a.T).T))[0]
                raise InputError(f"trajectory {k}: {name} is not finite at sample {bad[0]}")
    return trajs


@dataclass
class JointLoads:
    """Loads of every joint along one trajectory or a sequence of them.

    Time series are ``(n_samples, n_joints)``; several trajectories are stacked one after the
    other (``segment`` says which one a sample belongs to, ``t`` runs on without gaps).

    Attributes
    ----------
    joint_names : list of str
    t : array (n_samples,)
        Time in [s].
    segment : int array (n_samples,)
        Index of the trajectory of each sample.
    weights : array (n_samples,)
        Time each sample stands for in [s] (trapezoidal within each trajectory).
    q, qd, qdd : arrays
        Joint positions [rad], speeds [rad/s], accelerations [rad/s^2].
    torque_Nm : array
        Joint (reducer output) torque from RNEA, payload included, in [N m].
    power_W : array
        Joint mechanical power ``tau qd`` in [W] (positive: the drive gives energy).
    motor_torque_Nm, motor_speed_rad_s : array or None
        Motor shaft torque [N m] and speed [rad/s] (None without drives).
    motoring : bool array or None
        True where the motor drives the load (``(tau + friction) qd >= 0``).
    reflected_inertia_kg_m2 : array (n_joints,) or None
        ``(J_rotor + J_reducer) N^2`` seen at each joint.
    payload_kg : float
    """

    joint_names: list[str]
    t: np.ndarray
    segment: np.ndarray
    weights: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    torque_Nm: np.ndarray
    power_W: np.ndarray
    motor_torque_Nm: np.ndarray | None = None
    motor_speed_rad_s: np.ndarray | None = None
    motoring: np.ndarray | None = None
    reflected_inertia_kg_m2: np.ndarray | None = None
    payload_kg: float = 0.0

    @property
    def n_samples(self) -> int:
        return self.t.size

    @property
    def duration(self) -> float:
        """Total time the samples stand for, in [s]."""
        return float(self.weights.sum())

    @property
    def peak_torque_Nm(self) -> np.ndarray:
        return np.abs(self.torque_Nm).max(axis=0)

    @property
    def rms_torque_Nm(self) -> np.ndarray:
        """Time-weighted RMS joint torque in [N m]."""
        return np.sqrt((self.weights[:, None] * self.torque_Nm**2).sum(0) / self.weights.sum())

    @property
    def peak_speed_rad_s(self) -> np.ndarray:
        return np.abs(self.qd).max(axis=0)

    @property
    def peak_power_W(self) -> np.ndarray:
        return np.abs(self.power_W).max(axis=0)

    @property
    def motor_peak_speed_rpm(self) -> np.ndarray | None:
        if self.motor_speed_rad_s is None:
            return None
        return np.abs(self.motor_speed_rad_s).max(axis=0) * RAD_S_TO_RPM

    @property
    def motor_peak_torque_Nm(self) -> np.ndarray | None:
        if self.motor_torque_Nm is None:
            return None
        return np.abs(self.motor_torque_Nm).max(axis=0)

    @property
    def motor_rms_torque_Nm(self) -> np.ndarray | None:
        if self.motor_torque_Nm is None:
            return None
        w = self.weights[:, None]
        return np.sqrt((w * self.motor_torque_Nm**2).sum(0) / self.weights.sum())

    def to_dict(self) -> dict:
        """Per joint peaks and RMS values (JSON-able; the time series are not included)."""
        out = {}
        for j, name in enumerate(self.joint_names):
            d = {
                "peak_torque_Nm": float(self.peak_torque_Nm[j]),
                "rms_torque_Nm": float(self.rms_torque_Nm[j]),
                "peak_speed_rad_s": float(self.peak_speed_rad_s[j]),
                "peak_power_W": float(self.peak_power_W[j]),
            }
            if self.motor_torque_Nm is not None:
                m_peak, m_rms = self.motor_peak_torque_Nm, self.motor_rms_torque_Nm
                m_rpm = self.motor_peak_speed_rpm
                assert m_peak is not None and m_rms is not None and m_rpm is not None  # motor side
                d["motor_peak_torque_Nm"] = float(m_peak[j])
                d["motor_rms_torque_Nm"] = float(m_rms[j])
                d["motor_peak_speed_rpm"] = float(m_rpm[j])
            out[name] = d
        return {
            "duration_s": self.duration,
            "n_samples": int(self.n_samples),
            "payload_kg": float(self.payload_kg),
            "joints": out,
        }


def _drive_list(robot, drives) -> list[Drive] | None:
    if drives is None:
        if robot.drives is None:
            return None
        return [robot.drives[n] for n in robot.joint_names]
    if isinstance(drives, dict):
        missing = [n for n in robot.joint_names if n not in drives]
        if missing:
            raise InputError(f"drives given for {sorted(drives)} but not for {missing}")
        return [drives[n] for n in robot.joint_names]
    drives = list(drives)
    if len(drives) != robot.n_joints:
        raise InputError(f"{len(drives)} drives given for {robot.n_joints} joints")
    return drives


def inverse_dynamics(robot: Robot, trajectory, *, drives=None, threads: int = 1) -> JointLoads:
    """Joint torque, speed and power along a trajectory, and the motor side of each joint.

    Parameters
    ----------
    robot : Robot
        Its model carries the payload (``robot.payload``).
    trajectory : Trajectory or sequence of Trajectory
        Several trajectories are a duty cycle: stacked one after the other.
    drives : dict of joint name to Drive, or list of Drive, optional
        Drive trains to use instead of ``robot.drives`` (selection tries candidates this way).
    threads : int
        Threads for the batched RNEA.

    Returns
    -------
    JointLoads
        Motor-side fields are None when the robot has no drives and none are given.

    Raises
    ------
    InputError
        Not a trajectory, wrong joint count, NaN samples.
    """
    trajs = as_trajectories(trajectory, robot)
    ts, segs, ws = [], [], []
    offset = 0.0
    for k, tr in enumerate(trajs):
        t = tr.t - tr.t[0] + offset
        ts.append(t)
        segs.append(np.full(tr.n_samples, k))
        ws.append(sample_weights(tr.t))
        offset = t[-1] + (np.diff(tr.t).min() if tr.n_samples > 1 else 1.0)
    q = np.vstack([tr.q for tr in trajs])
    qd = np.vstack([tr.qd for tr in trajs])
    qdd = np.vstack([tr.qdd for tr in trajs])
    tau = joint_torques(robot, q, qd, qdd, threads=threads)
    loads = JointLoads(
        joint_names=list(robot.joint_names),
        t=np.concatenate(ts),
        segment=np.concatenate(segs),
        weights=np.concatenate(ws),
        q=q,
        qd=qd,
        qdd=qdd,
        torque_Nm=tau,
        power_W=tau * qd,
        payload_kg=float(robot.payload.mass_kg),
    )
    dl = _drive_list(robot, drives)
    if dl is not None:
        arrays = DriveTrain.from_drives(dl)
        loads.motor_torque_Nm, loads.motor_speed_rad_s, loads.motoring = motor_side(
            tau, qd, qdd, arrays
        )
        loads.reflected_inertia_kg_m2 = arrays.reflected_inertia_kg_m2
    return loads


def require_drives(robot: Robot, drives=None) -> list[Drive]:
    """The drive list of a robot (or the given one); RobotDescriptionError if there is none."""
    dl = _drive_list(robot, drives)
    if dl is None:
        raise RobotDescriptionError(
            f"{robot.name}: no drives file (drives.toml) — sizing needs motor and reducer data"
        )
    return dl
