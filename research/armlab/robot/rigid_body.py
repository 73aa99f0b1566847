"""Rigid-body dynamics of a :class:`~armlab.robot.Robot`: the one numeric entry (Pinocchio).

Every numeric torque consumer (trajectory limit checks, the classical and optimal planners,
TOPP, inverse dynamics and sizing, the servo simulation, the plant models) evaluates

    tau = M(q) qdd + C(q, qd) qd + g(q)        (+ armature qdd where the model has armature)

through this module, batched over samples (``pinocchio.rneaInParallel``). Everything reads
``robot.model``, whose gravity is the gravity expressed in the robot's **base** frame:
:class:`~armlab.robot.Robot` keeps ``model.gravity = R_base_in_world^T g_world`` in step with
``transform_base_to_world``, so a rotated base (a wall or ceiling mount) is honoured by
construction and nothing here rotates gravity again. The symbolic twin
(:mod:`armlab.robot.symbolic`) reads the same ``model.gravity``.

Shapes: joint arrays are ``(n_joints,)`` for one sample or ``(n, n_joints)`` for ``n``
samples; results have the shape of the input (``(n_joints,)`` or ``(n, n_joints)``; the mass
matrix ``(n_joints, n_joints)`` or ``(n, n_joints, n_joints)``). Units: [rad], [rad/s],
[rad/s^2] in, [N m] and [kg m^2] out (prismatic joints: [m], [N], [kg]).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from armlab.errors import InputError

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = ["inverse_dynamics", "gravity_torques", "nonlinear_effects", "mass_matrix"]


def _samples(robot, x, name: str) -> np.ndarray:
    """``x`` as a finite float array (n_joints,) or (n, n_joints); InputError otherwise."""
    nj = robot.model.nv
    a = np.asarray(x, dtype=float)
    if a.ndim not in (1, 2) or a.shape[-1] != nj:
        who = getattr(robot, "name", "the robot")
        raise InputError(f"{name} has shape {np.shape(x)}, expected ({nj},) or (n, {nj}) for {who}")
    if not np.all(np.isfinite(a)):
        raise InputError(f"{name} contains NaN or infinite values")
    return a


def _rnea(robot, q, qd, qdd, threads: int) -> np.ndarray:
    """Batched RNEA on ``robot.model`` of validated arrays of one common shape."""
    single = q.ndim == 1
    q2, qd2, qdd2 = (np.atleast_2d(a) for a in (q, qd, qdd))
    n = max(1, int(threads))
    pool = pin.ModelPool(robot.model, n)
    tau = np.asarray(
        pin.rneaInParallel(n, pool, *(np.asfortranarray(a.T) for a in (q2, qd2, qdd2)))
    )
    # (n_joints, n_samples); a batch of one, or a one-joint arm, comes back as a vector
    tau = np.ascontiguousarray(tau.reshape(q2.shape[1], q2.shape[0]).T)
    return tau[0] if single else tau


def inverse_dynamics(robot: Robot, q, qd, qdd, *, threads: int = 1) -> np.ndarray:
    """Joint torques ``tau = M(q) qdd + C(q, qd) qd + g(q)`` (RNEA), in [N m].

    Parameters
    ----------
    robot : Robot
        Its ``model`` (payload included, gravity in the base frame) is used.
    q, qd, qdd : array (n_joints,) or (n, n_joints)
        Positions [rad], velocities [rad/s], accelerations [rad/s^2], all of one shape.
    threads : int
        Threads of ``pinocchio.rneaInParallel`` (1 keeps shared machines quiet).

    Returns
    -------
    ndarray (n_joints,) or (n, n_joints)
        The shape of ``q``.

    Raises
    ------
    InputError
        Wrong shapes, shapes that differ, NaN or infinite values.
    """
    arrays = [_samples(robot, x, name) for name, x in (("q", q), ("qd", qd), ("qdd", qdd))]
    if not arrays[0].shape == arrays[1].shape == arrays[2].shape:
        raise InputError("q, qd and qdd must have the same shape")
    return _rnea(robot, arrays[0], arrays[1], arrays[2], threads)


def gravity_torques(robot: Robot, q, *, threads: int = 1) -> np.ndarray:
    """Gravity torques ``g(q)`` (the torques that hold the arm at rest), in [N m].

    Parameters
    ----------
    robot : Robot
    q : array (n_joints,) or (n, n_joints)
        Positions [rad].
    threads : int
        Threads of the batched RNEA.

    Returns
    -------
    ndarray of the shape of ``q``
    """
    q = _samples(robot, q, "q")
    z = np.zeros_like(q)
    return _rnea(robot, q, z, z, threads)


def nonlinear_effects(robot: Robot, q, qd, *, threads: int = 1) -> np.ndarray:
    """Coriolis, centrifugal and gravity torques ``C(q, qd) qd + g(q)``, in [N m].

    Parameters
    ----------
    robot : Robot
    q, qd : array (n_joints,) or (n, n_joints)
        Positions [rad] and velocities [rad/s], of one shape.
    threads : int
        Threads of the batched RNEA.

    Returns
    -------
    ndarray of the shape of ``q``
    """
    q, qd = _samples(robot, q, "q"), _samples(robot, qd, "qd")
    if q.shape != qd.shape:
        raise InputError("q and qd must have the same shape")
    return _rnea(robot, q, qd, np.zeros_like(q), threads)


def mass_matrix(robot: Robot, q) -> np.ndarray:
    """Joint-space mass matrix ``M(q)`` (CRBA, armature on the diagonal), in [kg m^2].

    Parameters
    ----------
    robot : Robot
    q : array (n_joints,) or (n, n_joints)
        Positions [rad].

    Returns
    -------
    ndarray (n_joints, n_joints) or (n, n_joints, n_joints)
        Symmetric.
    """
    q = _samples(robot, q, "q")
    model = robot.model
    data = model.createData()
    out = np.empty((max(1, q.size // model.nv), model.nv, model.nv))
    for k, qk in enumerate(np.atleast_2d(q)):
        M = np.triu(pin.crba(model, data, qk))  # older Pinocchio fills the upper triangle only
        out[k] = M + np.triu(M, 1).T
    return out[0] if q.ndim == 1 else out
