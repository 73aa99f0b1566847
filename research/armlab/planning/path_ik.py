"""Inverse kinematics along a Cartesian path (:mod:`armlab.planning.cartesian` times it).

Every sample of a path goes through inverse kinematics -- analytic for spherical-wrist arms,
a Newton corrector seeded from the previous point for any other URDF -- keeping one IK branch
along the whole path; a jump between branches (a singularity, or the only in-range branch
ending) raises :class:`UnreachableError` with the arc length and point. The joint-space path
derivatives follow exactly from the path's (no finite differences)::

    J(q) g = [dp/ds; w_s]                 g = dq/ds
    J(q) h = [d2p/ds2; dw_s/ds] - Jdot g  h = d2q/ds2   (Jdot g: Pinocchio's classical
                                                         acceleration at (q, g, 0))
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from armlab.errors import ArmlabError, UnreachableError
from armlab.kinematics import has_analytic_ik, ik, ik_all_batch, ik_nearest

if TYPE_CHECKING:
    from armlab.planning.paths import CartesianPath
    from armlab.robot.model import Robot

__all__ = ["track_path", "path_derivatives"]

_JUMP_RAD = 0.3  # largest joint step between probe points (<= probe_step_m apart)


# ---------------------------------------------------------------------- IK along a path
def where_on(path, s: float) -> str:
    p = path.evaluate(np.array([s])).position[0]
    return f"s = {s:.6g} m, p = [{p[0]:.4f}, {p[1]:.4f}, {p[2]:.4f}] m"


def _newton(
    robot, pose: np.ndarray, q: np.ndarray, iters: int = 30, tol: float = 1e-12
) -> tuple[np.ndarray, bool]:
    """Newton corrector on SE(3) from a nearby seed (any URDF)."""
    model, data, fid = robot.model, robot.data, robot.tool_frame_id
    Tb = robot.transform_base_to_world
    T_in_base = np.linalg.solve(Tb, pose)
    oMdes = pin.SE3(T_in_base[:3, :3], T_in_base[:3, 3])
    lo, hi = robot.limits.lower_rad, robot.limits.upper_rad
    for _ in range(iters):
        pin.framesForwardKinematics(model, data, q)
        oMf = data.oMf[fid]
        # error in LOCAL_WORLD_ALIGNED: position difference and rotation log in world axes
        e_p = oMdes.translation - oMf.translation
        e_r = oMf.rotation @ pin.log3(oMf.rotation.T @ oMdes.rotation)
        err = np.concatenate([e_p, e_r])
        if np.abs(err).max() < tol:
            return q, bool(np.all(q >= lo - 1e-9) and np.all(q <= hi + 1e-9))
        J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL_WORLD_ALIGNED)
        dq = np.linalg.lstsq(J, err, rcond=None)[0]
        step = np.abs(dq).max()
        if step > 0.5:
            dq *= 0.5 / step
        q = q + dq
    return q, False


def track_path(robot: Robot, path: CartesianPath, s, q_ref, *, guide=None) -> np.ndarray:
    """Joint positions (n, n_joints) along ``path`` at arc lengths ``s`` (n,), on one branch.

    Parameters
    ----------
    robot : Robot
    path : CartesianPath
    s : array (n,)
        Increasing arc lengths in [m].
    q_ref : array (n_joints,)
        Configuration at (or near) ``s[0]``: the branch to keep.
    guide : array (n, n_joints), optional
        A reference per sample (e.g. a finer solution interpolated): each sample takes the
        IK solution nearest to it instead of to the previous sample.

    Raises
    ------
    UnreachableError
        A point is unreachable in the joint ranges, or consecutive solutions jump by more than
        0.3 rad (a singularity or a branch change); the message gives ``s`` and the point.
    """
    s = np.asarray(s, float).reshape(-1)
    poses = path.evaluate(s).poses()
    n = s.size
    q_ref = robot.check_q(q_ref, name="q_ref")
    if has_analytic_ik(robot):
        try:
            if guide is None:
                q = ik_nearest(robot, poses, q_ref, sequential=True)
            else:
                q = ik_nearest(robot, poses, guide)
        except UnreachableError as exc:
            k = _failed_index(robot, poses)
            raise UnreachableError(
                f"{path.kind}: the point at {where_on(path, s[k])} is unreachable ({exc})"
            ) from None
        q = np.atleast_2d(q)
    else:
        q = np.empty((n, robot.n_joints))
        prev = q_ref
        for k in range(n):
            seed = prev if guide is None else guide[k]
            qk, ok = _newton(robot, poses[k], seed.copy())
            if not ok:
                try:
                    qk = ik(robot, poses[k], seed, tol_pos_m=1e-10, tol_rot_rad=1e-10, restarts=0)
                    qk, ok = _newton(robot, poses[k], qk)
                except ArmlabError:
                    ok = False
            if not ok:
                raise UnreachableError(
                    f"{path.kind}: the point at {where_on(path, s[k])} is "
                    f"unreachable inside the joint ranges of {robot.name}"
                )
            q[k] = prev = qk
    if guide is None:  # step into sample k from the one before (q_ref before sample 0)
        steps = np.abs(np.diff(np.vstack([q_ref[None], q]), axis=0))
    else:  # distance of sample k from its guide
        steps = np.abs(q - guide)
    if steps.size and steps.max() > _JUMP_RAD:
        k, j = (int(i) for i in np.unravel_index(int(np.argmax(steps)), steps.shape))
        raise UnreachableError(
            f"{path.kind}: no continuous IK branch near {where_on(path, s[k])}: "
            f"{robot.joint_names[j]} jumps {steps[k, j]:.3g} rad (a singularity, a joint range "
            "end, or the end of the reachable part of this branch)"
        )
    return q


def _failed_index(robot, poses) -> int:
    _, valid = ik_all_batch(robot, poses)
    bad = np.flatnonzero(~valid.any(axis=1))
    return int(bad[0]) if bad.size else 0


def path_derivatives(robot: Robot, q, sample) -> tuple[np.ndarray, np.ndarray]:
    """``g = dq/ds`` and ``h = d2q/ds2`` (n, n_joints) along a tracked path.

    ``J g = [dp/ds; w_s]`` and ``J h = [d2p/ds2; dw_s/ds] - Jdot g`` with the world-aligned
    tool Jacobian; ``Jdot g`` is the classical acceleration of the tool frame at
    ``(q, g, qdd = 0)`` (Pinocchio ``getFrameClassicalAcceleration``). A redundant arm follows
    the minimum-norm rates ``g = J^+ xi`` (:class:`MinNormFlow`), whose derivative along the
    path is ``h = J^+ (xi' - Jdot g) + (I - J^+ J) Jdot^T lambda`` with ``lambda = (J J^T)^-1
    xi`` (``g = J^T lambda`` differentiated; ``Jdot`` from Pinocchio's
    ``getFrameJacobianTimeVariation`` at the velocity ``g``).
    """
    model, data, fid = robot.model, robot.data, robot.tool_frame_id
    Rb = robot.transform_base_to_world[:3, :3]
    n, nj = q.shape
    g = np.empty((n, nj))
    h = np.empty((n, nj))
    xi = np.hstack([sample.dp_ds, sample.w_s]) @ np.kron(np.eye(2), Rb)  # world -> base axes
    xi2 = np.hstack([sample.d2p_ds2, sample.dw_s]) @ np.kron(np.eye(2), Rb)
    zero = np.zeros(nj)
    square = nj == 6
    for k in range(n):
        J = pin.computeFrameJacobian(model, data, q[k], fid, pin.LOCAL_WORLD_ALIGNED)
        if square:
            gk = np.linalg.solve(J, xi[k])
        else:
            lam = np.linalg.lstsq(J @ J.T, xi[k], rcond=None)[0]
            gk = J.T @ lam
        pin.forwardKinematics(model, data, q[k], gk, zero)
        acc = pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
        rhs = xi2[k] - np.concatenate([acc.linear, acc.angular])
        if square:
            h[k] = np.linalg.solve(J, rhs)
        else:
            pin.computeJointJacobiansTimeVariation(model, data, q[k], gk)
            Jdot = pin.getFrameJacobianTimeVariation(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            hk = np.linalg.lstsq(J, rhs, rcond=None)[0]
            w = Jdot.T @ lam
            h[k] = hk + w - np.linalg.lstsq(J, J @ w, rcond=None)[0]
        g[k] = gk
    return g, h


class MinNormFlow:
    """The joint path of a redundant arm along a Cartesian path: the solution of
    ``dq/ds = J(q)^+ xi(s)`` from ``q_start`` (``xi = [dp/ds; w_s]`` in base axes, ``J^+`` the
    minimum-norm inverse), so that the rates of :func:`path_derivatives` are its exact
    derivatives. Integrated once with classical Runge-Kutta (RK4) steps of at most
    ``step_m``; :meth:`at` takes one RK4 step from the nearest node below each ``s`` and
    polishes the pose with minimum-norm Newton steps (:func:`_newton`).

    Raises :class:`UnreachableError` (with ``s`` and the point) where the flow leaves a joint
    range or turns a joint by more than 0.3 rad per step (a singularity).
    """

    def __init__(self, robot, path, q_start, step_m: float = 2.5e-4) -> None:
        self.robot, self.path = robot, path
        L = path.length
        m = max(1, math.ceil(L / step_m))
        self.nodes = np.linspace(0.0, L, m + 1)
        Rb = robot.transform_base_to_world[:3, :3]
        self._axes = np.kron(np.eye(2), Rb)
        q = np.empty((m + 1, robot.n_joints))
        q[0] = q_start
        stages = np.concatenate([self.nodes, 0.5 * (self.nodes[:-1] + self.nodes[1:])])
        xi = self._xi(stages)
        xi_node, xi_mid = xi[: m + 1], xi[m + 1 :]
        for k in range(m):
            q[k + 1] = self._rk4(
                q[k], self.nodes[k + 1] - self.nodes[k], xi_node[k], xi_mid[k], xi_node[k + 1]
            )
            self._check(q[k + 1], q[k], self.nodes[k + 1])
        self.q = q

    def _xi(self, s) -> np.ndarray:
        smp = self.path.evaluate(np.asarray(s, float))
        return np.hstack([smp.dp_ds, smp.w_s]) @ self._axes

    def _rate(self, q, xi) -> np.ndarray:
        r = self.robot
        J = pin.computeFrameJacobian(r.model, r.data, q, r.tool_frame_id, pin.LOCAL_WORLD_ALIGNED)
        return J.T @ np.linalg.lstsq(J @ J.T, xi, rcond=None)[0]

    def _rk4(self, q, ds, xi0, xi_half, xi1) -> np.ndarray:
        k1 = self._rate(q, xi0)
        k2 = self._rate(q + ds / 2 * k1, xi_half)
        k3 = self._rate(q + ds / 2 * k2, xi_half)
        k4 = self._rate(q + ds * k3, xi1)
        return q + ds / 6 * (k1 + 2 * k2 + 2 * k3 + k4)

    def _check(self, q, q_before, s: float) -> None:
        r = self.robot
        lo, hi = r.limits.lower_rad, r.limits.upper_rad
        if not np.all(np.isfinite(q)) or np.any(q < lo - 1e-9) or np.any(q > hi + 1e-9):
            raise UnreachableError(
                f"{self.path.kind}: the point at {where_on(self.path, s)} is unreachable inside "
                f"the joint ranges of {r.name} along the minimum-norm joint path"
            )
        step = np.abs(q - q_before)
        if step.max() > _JUMP_RAD:
            j = int(np.argmax(step))
            raise UnreachableError(
                f"{self.path.kind}: no continuous IK branch near {where_on(self.path, s)}: "
                f"{r.joint_names[j]} jumps {step[j]:.3g} rad (a singularity)"
            )

    def at(self, s) -> np.ndarray:
        """Joint positions (n, n_joints) at arc lengths ``s`` (n,) in [m]."""
        s = np.clip(np.asarray(s, float).reshape(-1), 0.0, self.path.length)
        k = np.clip(np.searchsorted(self.nodes, s, side="right") - 1, 0, self.nodes.size - 1)
        s0 = self.nodes[k]
        xi = self._xi(np.concatenate([s0, 0.5 * (s0 + s), s]))
        n = s.size
        poses = self.path.evaluate(s).poses()
        out = np.empty((n, self.robot.n_joints))
        for i in range(n):
            q = self.q[k[i]]
            if s[i] > s0[i]:
                q = self._rk4(q, s[i] - s0[i], xi[i], xi[n + i], xi[2 * n + i])
            q, ok = _newton(self.robot, poses[i], q.copy())
            if not ok:
                self._check(q, q, s[i])  # out of range: names the point
                raise UnreachableError(
                    f"{self.path.kind}: the point at {where_on(self.path, s[i])} is unreachable "
                    f"along the minimum-norm joint path of {self.robot.name}"
                )
            out[i] = q
        return out


# ---------------------------------------------------------------------- timing
