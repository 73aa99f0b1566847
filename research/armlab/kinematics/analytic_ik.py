"""Analytic inverse kinematics of PUMA-like 6R arms with a spherical wrist (teachbot6).

Method (HEU thesis, 3.4.2). With the modified-DH table (Craig)
``T_{i-1,i} = RotX(alpha_{i-1}) TransX(a_{i-1}) RotZ(theta_i) TransZ(d_i)`` and
``theta_i = q_i + offset_i``, an arm of this family has

* ``alpha_1 = +-90 deg`` (shoulder), ``alpha_2 = 0`` (axes 2 and 3 parallel),
  ``alpha_3 = +-90 deg``, ``alpha_4 = +-90 deg``, ``alpha_5 = +-90 deg``;
* ``a_4 = a_5 = 0`` and ``d_5 = 0``: axes 4, 5, 6 meet in the wrist centre, the origin of DH
  frame 4 (``d_6`` only slides frame 6 along axis 6 and is folded into the tool transform);
* ``a_0, alpha_0`` (a fixed transform before joint 1) are folded into the base.

The wrist centre ``p_w`` (origin of frame 4) depends on ``theta_1..theta_3`` only
(thesis eq. 3-8, with ``sigma_1 = sin alpha_1``, ``sigma_3 = sin alpha_3``)::

    X = a_2 + a_3 c3 + sigma_3 d_4 s3          Y = a_3 s3 - sigma_3 d_4 c3
    rho = a_1 + c2 X - s2 Y                     e = -sigma_1 (d_2 + d_3)
    p_w = (c1 rho - s1 e,  s1 rho + c1 e,  d_1 + sigma_1 (s2 X + c2 Y))

For teachbot6 (``sigma_1 = sigma_3 = -1``, ``d_2 = d_3 = 0``) this is the thesis'
``px = c1 (a1 + a2 c2 + a3 c23 - d4 s23)``, ``pz = -(a2 s2 + a3 s23 + d4 c23)``.

Solution (up to 8 = 2 shoulder x 2 elbow x 2 wrist branches):

1. ``rho = +-sqrt(px^2 + py^2 - e^2)``, ``theta_1 = atan2(py, px) - atan2(e, rho)``
   (thesis: ``atan2(py, px)`` or ``atan2(-py, -px)``);
2. with ``u = rho - a_1``, ``v = sigma_1 (pz - d_1)``:
   ``a_3 c3 + sigma_3 d_4 s3 = K = (u^2 + v^2 - a_2^2 - a_3^2 - d_4^2) / (2 a_2)``, i.e.
   ``theta_3 = phi + atan2(+-sqrt(R^2 - K^2), K)``, ``R = hypot(a_3, d_4)``,
   ``phi = atan2(sigma_3 d_4, a_3)`` (thesis: two branches of ``a3 c3 - d4 s3 = ...``);
3. ``[u; v] = [[X, -Y], [Y, X]] [c2; s2]`` gives ``theta_2 = atan2(X v - Y u, X u + Y v)``
   (the two linear equations 3-23, 3-24);
4. the wrist: ``N = RotX(alpha_3)^T R_03^T R_06 RotX(alpha_4 + alpha_5)^T =
   RotZ(theta_4) RotY(-sigma_4 theta_5) RotZ(f theta_6)`` with ``f = +1`` if
   ``alpha_4 + alpha_5 = 0`` (teachbot6) else ``-1`` — a Z-Y-Z Euler decomposition with two
   branches (``beta`` and ``-beta``).

Joint angles are ``q = theta - offset`` wrapped into the joint range (a ``+-2 pi`` variant is
added for joints whose range is wider than a turn); solutions outside the ranges are dropped.

Singularities
-------------
* **shoulder** (wrist centre on the axis of joint 1, ``hypot(px, py) < 1e-9 m`` with
  ``e = 0``): ``theta_1`` is undefined — :class:`UnreachableError`;
* **wrist** (``sin theta_5 = 0``, axes 4 and 6 aligned; detected when
  ``|sin beta| < 1e-10``): only ``theta_4 + theta_6`` is defined. A single solution per
  shoulder/elbow branch is returned with ``q_4`` set to the reference's ``q_4`` (``q_ref``
  argument, default 0) and ``q_6`` taking up the rest;
* **elbow** (arm fully stretched or folded, ``|K| = R``): the two elbow branches coincide.

Poses are tool poses in the world, ``T_tool_in_world = T_base_in_world @ T_0n @ T_tool_in_n``
(thesis 3.5); the tool placement is read from the Pinocchio model (so :meth:`Robot.set_tool`
is honoured).
"""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from armlab.errors import ArmlabError, InputError, UnreachableError

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = [
    "ik_all",
    "ik_all_batch",
    "ik_all_batch_reasons",
    "ik_nearest",
    "has_analytic_ik",
    "check_poses",
    "IK_REASONS",
]

TWO_PI = 2.0 * math.pi
_ANGLE_TOL = 1e-9  # tolerance on the +-90 / 0 deg structure of the DH table, in [rad]
_LENGTH_TOL = 1e-12  # zero lengths in the DH table, in [m]
_RANGE_TOL = 1e-9  # slack on joint ranges, in [rad]; accepted solutions are clipped into range
_SHOULDER_TOL_M = 1e-9  # wrist centre this close to the joint-1 axis is singular, in [m]
_WRIST_TOL = 1e-10  # |sin theta_5| below this is the wrist singularity
_REACH_TOL = 1e-12  # relative slack on the reach circles

#: reason codes of :func:`ik_all_batch` (``reasons`` array) and their meaning
IK_REASONS = {
    0: "ok",
    1: "pose contains NaN or infinite values",
    2: "wrist centre on the axis of joint 1 (shoulder singularity)",
    3: "wrist centre outside the reach of the arm",
    4: "no solution inside the joint ranges",
}


# ---------------------------------------------------------------------------- geometry
def _rotx(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _homogeneous(R: np.ndarray | None = None, p=None) -> np.ndarray:
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    if p is not None:
        T[:3, 3] = p
    return T


def _unit_sign(angle: float) -> float | None:
    """+1 / -1 if ``angle`` is +-90 deg (within tolerance), else None."""
    s = math.sin(angle)
    if abs(abs(s) - 1.0) < _ANGLE_TOL and abs(math.cos(angle)) < 1e-6:
        return 1.0 if s > 0 else -1.0
    return None


@dataclass(frozen=True)
class _WristArm:
    """Constants of one PUMA-like arm, from its DH table and the robot's tool/base."""

    d1: float
    a1: float
    s1: float  # sin alpha_1
    e: float  # -sigma_1 (d_2 + d_3): lateral offset of the wrist centre in frame 1
    a2: float
    a3: float
    d4: float
    s3: float  # sin alpha_3
    s4: float  # sin alpha_4
    flip6: float  # +1 if alpha_4 + alpha_5 = 0 else -1
    alpha1: float
    alpha3: float
    alpha45: float
    offset: np.ndarray  # (6,)
    lower: np.ndarray  # (6,)
    upper: np.ndarray  # (6,)
    transform_pre: np.ndarray  # (4, 4) world -> DH frame 0' (base and a_0, alpha_0 undone)
    transform_post: np.ndarray  # (4, 4) tool -> frame 6 placed at the wrist centre


def has_analytic_ik(robot: Robot) -> bool:
    """True if :func:`ik_all` applies to ``robot`` (a DH table of the supported family)."""
    try:
        _arm(robot)
    except ArmlabError:
        return False
    return True


_STRUCTURE_CACHE: dict = {}  # (id(dh), id(model)) -> (dh, model, template): holds both alive
_STRUCTURE_CACHE_SIZE = 16


def _structure(robot) -> _WristArm:
    """The constants of the DH table, checked once per (table, model) pair and cached."""
    dh, model = robot.dh, robot.model
    key = (id(dh), id(model))
    hit = _STRUCTURE_CACHE.get(key)
    if hit is not None and hit[0] is dh and hit[1] is model:
        return hit[2]
    template = _check_structure(robot)
    if len(_STRUCTURE_CACHE) >= _STRUCTURE_CACHE_SIZE:
        _STRUCTURE_CACHE.pop(next(iter(_STRUCTURE_CACHE)))
    _STRUCTURE_CACHE[key] = (dh, model, template)
    return template


def _arm(robot) -> _WristArm:
    """Structure (cached) plus the live parts: joint ranges, base and tool transforms."""
    name = getattr(robot, "name", "robot")
    if getattr(robot, "dh", None) is None:
        raise ArmlabError(
            f"no analytic IK for {name}: no DH table (plain URDF); use armlab.kinematics.ik"
        )
    template = _structure(robot)
    frame = robot.model.frames[robot.tool_frame_id]
    if frame.parentJoint != 6:
        raise ArmlabError(
            f"no analytic IK for {name}: tool frame {robot.tool_frame!r} is not on the last link"
        )
    transform_post = frame.placement.inverse().homogeneous @ template.transform_post
    transform_pre = template.transform_pre @ np.linalg.inv(robot.transform_base_to_world)
    return dataclasses.replace(
        template,
        lower=np.asarray(robot.limits.lower_rad, float),
        upper=np.asarray(robot.limits.upper_rad, float),
        transform_pre=transform_pre,
        transform_post=transform_post,
    )


def _check_structure(robot) -> _WristArm:
    """Check the structure and collect the constants; ArmlabError naming what does not fit.

    The returned ``transform_pre`` only undoes ``a_0, alpha_0`` and ``transform_post`` only
    ``d_6``; :func:`_arm` adds the base and tool transforms.
    """
    name = getattr(robot, "name", "robot")
    dh = robot.dh
    if dh.n_joints != 6 or robot.n_joints != 6:
        raise ArmlabError(f"no analytic IK for {name}: {robot.n_joints} joints, the solver needs 6")
    for j in range(1, 7):
        short = robot.model.joints[j].shortname()
        if not short.startswith("JointModelR") or "Unbounded" in short:
            raise ArmlabError(
                f"no analytic IK for {name}: joint {robot.joint_names[j - 1]} is not a bounded "
                f"revolute joint ({short})"
            )
    a, alpha, d = np.asarray(dh.a_m), np.asarray(dh.alpha_rad), np.asarray(dh.d_m)
    s1, s3, s4, s5 = (_unit_sign(alpha[i]) for i in (1, 3, 4, 5))
    problems = []
    if s1 is None:
        problems.append("alpha_1 is not +-90 deg")
    if abs(math.sin(alpha[2])) > _ANGLE_TOL or math.cos(alpha[2]) < 0:
        problems.append("alpha_2 is not 0 (axes 2 and 3 not parallel)")
    if s3 is None:
        problems.append("alpha_3 is not +-90 deg")
    if s4 is None or s5 is None:
        problems.append("alpha_4/alpha_5 are not +-90 deg (no spherical wrist)")
    if abs(a[4]) > _LENGTH_TOL or abs(a[5]) > _LENGTH_TOL or abs(d[4]) > _LENGTH_TOL:
        problems.append("a_4, a_5, d_5 are not 0 (wrist axes do not intersect)")
    if abs(a[2]) < 1e-6:
        problems.append("a_2 is 0 (no upper arm)")
    if math.hypot(a[3], d[3]) < 1e-6:
        problems.append("a_3 and d_4 are both 0 (no forearm)")
    if problems:
        raise ArmlabError(f"no analytic IK for {name}: " + "; ".join(problems))
    assert s1 is not None and s3 is not None and s4 is not None  # else a problem was raised
    # the Pinocchio model must be the DH chain (joint frame i == DH frame i)
    for i in range(6):
        c, s = math.cos(dh.offset_rad[i]), math.sin(dh.offset_rad[i])
        T = (
            _homogeneous(_rotx(alpha[i]))
            @ _homogeneous(None, (a[i], 0.0, d[i]))
            @ _homogeneous(np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]))
        )
        M = robot.model.jointPlacements[i + 1].homogeneous
        if np.abs(M - T).max() > 1e-9:
            raise ArmlabError(
                f"no analytic IK for {name}: the model's joint {robot.joint_names[i]} does not "
                f"match row {i + 1} of the DH table {dh.source or dh.name}"
            )
    alpha45 = float(alpha[4] + alpha[5])
    flip6 = 1.0 if abs(math.sin(alpha45)) < _ANGLE_TOL and math.cos(alpha45) > 0 else -1.0
    transform_pre = np.linalg.inv(_homogeneous(_rotx(alpha[0])) @ _homogeneous(None, (a[0], 0, 0)))
    transform_post = _homogeneous(None, (0, 0, -d[5]))
    return _WristArm(
        d1=float(d[0]),
        a1=float(a[1]),
        s1=s1,
        e=-s1 * float(d[1] + d[2]),
        a2=float(a[2]),
        a3=float(a[3]),
        d4=float(d[3]),
        s3=s3,
        s4=s4,
        flip6=flip6,
        alpha1=float(alpha[1]),
        alpha3=float(alpha[3]),
        alpha45=alpha45,
        offset=np.asarray(dh.offset_rad, float).copy(),
        lower=np.asarray(dh.lower_rad, float).copy(),
        upper=np.asarray(dh.upper_rad, float).copy(),
        transform_pre=transform_pre,
        transform_post=transform_post,
    )


# ---------------------------------------------------------------------------- input checks
def check_poses(poses, *, name: str = "pose", allow_nan: bool = True) -> tuple[np.ndarray, bool]:
    """Validate tool poses: (4, 4) or (n, 4, 4) homogeneous transforms.

    Returns the poses as (n, 4, 4) and whether a single pose was given. NaN entries are allowed
    if ``allow_nan`` (the batch solvers flag them per pose); a wrong shape, a bottom row other than
    ``[0, 0, 0, 1]`` or a non-orthonormal rotation (``|R^T R - I| > 1e-6``) raise
    :class:`InputError` naming the pose index.
    """
    T = np.asarray(poses, dtype=float)
    if T.shape[-2:] != (4, 4) or T.ndim not in (2, 3):
        raise InputError(f"{name} has shape {T.shape}, expected (4, 4) or (n, 4, 4)")
    single = T.ndim == 2
    T = T.reshape(-1, 4, 4)
    finite = np.all(np.isfinite(T), axis=(1, 2))
    if not allow_nan and not finite.all():
        k = int(np.flatnonzero(~finite)[0])
        where = name if single else f"{name}[{k}]"
        raise InputError(f"{where} contains NaN or infinite values")
    Tf = np.where(finite[:, None, None], T, np.eye(4))
    bottom = np.abs(Tf[:, 3] - np.array([0.0, 0.0, 0.0, 1.0])).max(axis=1) > 1e-9
    R = Tf[:, :3, :3]
    ortho = np.abs(np.swapaxes(R, 1, 2) @ R - np.eye(3)).max(axis=(1, 2)) > 1e-6
    det = np.linalg.det(R) < 0
    bad = np.flatnonzero(bottom | ortho | det)
    if bad.size:
        k = int(bad[0])
        what = (
            "bottom row is not [0, 0, 0, 1]"
            if bottom[k]
            else "rotation is not orthonormal"
            if ortho[k]
            else "rotation is a reflection"
        )
        where = name if single else f"{name}[{k}]"
        raise InputError(f"{where}: {what}")
    return T, single


# ---------------------------------------------------------------------------- the solver
def _solve(arm: _WristArm, T_world: np.ndarray, q4_ref: np.ndarray):
    """Raw solutions of n poses: q (n, 8, 6) wrapped to (-pi, pi], finite (n, 8) and reason
    codes (n,) before the joint-range filter. Branch index = 4 i_shoulder + 2 i_elbow + i_wrist.
    """
    n = T_world.shape[0]
    finite_pose = np.all(np.isfinite(T_world), axis=(1, 2))
    T = (
        arm.transform_pre
        @ np.where(finite_pose[:, None, None], T_world, np.eye(4))
        @ arm.transform_post
    )
    px, py, pz = T[:, 0, 3], T[:, 1, 3], T[:, 2, 3]
    R06 = T[:, :3, :3]
    reason = np.zeros(n, dtype=np.int8)
    reason[~finite_pose] = 1

    # -- joint 1: two shoulder branches (rho > 0, rho < 0)
    r2 = px * px + py * py
    e = arm.e
    rho2 = r2 - e * e
    shoulder_singular = (np.sqrt(r2) < _SHOULDER_TOL_M) & (abs(e) < _SHOULDER_TOL_M)
    too_close_axis = rho2 < -_REACH_TOL * max(e * e, 1e-300)
    rho_abs = np.sqrt(np.maximum(rho2, 0.0))
    rho = np.stack([rho_abs, -rho_abs], axis=1)  # (n, 2)
    th1 = np.arctan2(py, px)[:, None] - np.arctan2(e, rho)

    # -- joint 3: two elbow branches per shoulder branch
    u = rho - arm.a1  # (n, 2)
    v = (arm.s1 * (pz - arm.d1))[:, None] * np.ones((1, 2))
    a2, a3, d4, s3 = arm.a2, arm.a3, arm.d4, arm.s3
    R = math.hypot(a3, d4)
    phi = math.atan2(s3 * d4, a3)
    K = (u * u + v * v - a2 * a2 - a3 * a3 - d4 * d4) / (2.0 * a2)
    disc = R * R - K * K
    reach_ok = disc >= -_REACH_TOL * R * R  # (n, 2)
    sq = np.sqrt(np.maximum(disc, 0.0))
    th3 = phi + np.arctan2(np.stack([sq, -sq], axis=2), K[:, :, None])  # (n, 2, 2)
    c3, s3_ = np.cos(th3), np.sin(th3)
    X = a2 + a3 * c3 + s3 * d4 * s3_
    Y = a3 * s3_ - s3 * d4 * c3
    uu, vv = u[:, :, None], v[:, :, None]
    th2 = np.arctan2(X * vv - Y * uu, X * uu + Y * vv)  # (n, 2, 2)
    th1b = np.broadcast_to(th1[:, :, None], th2.shape)

    # -- wrist: N = RotX(alpha_3)^T R03^T R06 RotX(alpha_4 + alpha_5)^T
    c1, s1 = np.cos(th1b), np.sin(th1b)
    c23, s23 = np.cos(th2 + th3), np.sin(th2 + th3)
    ca1, sa1 = math.cos(arm.alpha1), math.sin(arm.alpha1)
    # R03 = RotZ(th1) RotX(alpha_1) RotZ(th2 + th3)
    R03 = np.empty(th2.shape + (3, 3))
    R03[..., 0, 0] = c1 * c23 - s1 * ca1 * s23
    R03[..., 0, 1] = -c1 * s23 - s1 * ca1 * c23
    R03[..., 0, 2] = s1 * sa1
    R03[..., 1, 0] = s1 * c23 + c1 * ca1 * s23
    R03[..., 1, 1] = -s1 * s23 + c1 * ca1 * c23
    R03[..., 1, 2] = -c1 * sa1
    R03[..., 2, 0] = sa1 * s23
    R03[..., 2, 1] = sa1 * c23
    R03[..., 2, 2] = ca1
    left = _rotx(arm.alpha3).T
    right = _rotx(arm.alpha45).T
    N = left @ np.swapaxes(R03, -1, -2) @ R06[:, None, None] @ right  # (n, 2, 2, 3, 3)
    h = np.hypot(N[..., 0, 2], N[..., 1, 2])
    wrist_singular = h < _WRIST_TOL
    th = np.empty((n, 2, 2, 2, 6))
    th[..., 0] = th1b[..., None]
    th[..., 1] = th2[..., None]
    th[..., 2] = th3[..., None]
    for k, w in enumerate((1.0, -1.0)):
        beta = np.arctan2(w * h, N[..., 2, 2])
        alpha_ = np.arctan2(w * N[..., 1, 2], w * N[..., 0, 2])
        gamma = np.arctan2(w * N[..., 2, 1], -w * N[..., 2, 0])
        # wrist singularity: keep theta_4 = offset_4 + q4_ref, theta_6 takes up the rest
        a_ref = (arm.offset[3] + q4_ref)[:, None, None] * np.ones_like(beta)
        up = N[..., 2, 2] > 0
        g_up = np.arctan2(N[..., 1, 0], N[..., 0, 0]) - a_ref
        g_down = a_ref + np.arctan2(N[..., 1, 0], -N[..., 0, 0])
        alpha_ = np.where(wrist_singular, a_ref, alpha_)
        gamma = np.where(wrist_singular, np.where(up, g_up, g_down), gamma)
        beta = np.where(wrist_singular, np.where(up, 0.0, math.pi), beta)
        th[..., k, 3] = alpha_
        th[..., k, 4] = -arm.s4 * beta
        th[..., k, 5] = arm.flip6 * gamma
    q = th.reshape(n, 8, 6) - arm.offset
    q = np.mod(q + math.pi, TWO_PI) - math.pi  # (-pi, pi]
    q = np.where(q <= -math.pi, q + TWO_PI, q)
    ok = np.broadcast_to(reach_ok[:, :, None, None], (n, 2, 2, 2)).copy()
    ok[..., 1] &= ~wrist_singular  # both wrist branches coincide: keep one
    ok = ok.reshape(n, 8)
    ok &= finite_pose[:, None] & ~shoulder_singular[:, None] & ~too_close_axis[:, None]
    reason[(reason == 0) & shoulder_singular] = 2
    reason[(reason == 0) & ~ok.any(axis=1)] = 3
    return q, ok, reason


def _range_variants(arm: _WristArm, q: np.ndarray, ok: np.ndarray):
    """Bring raw solutions into the joint ranges; add +-2 pi variants where a range is wider
    than a turn. Returns (q (n, m, 6), valid (n, m), blocking (n, m, 6) out-of-range flags)."""
    lo, hi = arm.lower, arm.upper
    per_joint: list[list[np.ndarray]] = []
    for j in range(6):
        qj = q[..., j]
        if hi[j] - lo[j] <= TWO_PI + _RANGE_TOL:
            # at most one representative (two only at an exact +-pi bound): pick the in-range one
            cand = qj
            for shift in (TWO_PI, -TWO_PI):
                moved = qj + shift
                inside = (moved >= lo[j] - _RANGE_TOL) & (moved <= hi[j] + _RANGE_TOL)
                outside = (cand < lo[j] - _RANGE_TOL) | (cand > hi[j] + _RANGE_TOL)
                cand = np.where(outside & inside, moved, cand)
            per_joint.append([cand])
        else:
            kmin = math.ceil((lo[j] - math.pi) / TWO_PI)
            kmax = math.floor((hi[j] + math.pi) / TWO_PI)
            per_joint.append([qj + TWO_PI * k for k in range(kmin, kmax + 1)])
    combos = list(itertools.product(*[range(len(p)) for p in per_joint]))
    out = np.empty(q.shape[:1] + (q.shape[1] * len(combos), 6))
    for c, idx in enumerate(combos):
        for j in range(6):
            out[:, c * q.shape[1] : (c + 1) * q.shape[1], j] = per_joint[j][idx[j]]
    blocking = (out < lo - _RANGE_TOL) | (out > hi + _RANGE_TOL)
    valid = np.tile(ok, (1, len(combos))) & ~blocking.any(axis=2)
    np.clip(out, lo, hi, out=out)
    return out, valid, blocking


def ik_all_batch(robot: Robot, poses, *, q_ref=None) -> tuple[np.ndarray, np.ndarray]:
    """Every analytic solution of many poses at once (fully vectorised).

    Parameters
    ----------
    robot : Robot
        A 6R arm with a spherical wrist and a DH table (teachbot6).
    poses : array (n, 4, 4) or (4, 4)
        Tool poses in the world (``T_base_in_world @ T_tool_in_base``), lengths in [m].
    q_ref : array (n_joints,) or (n, n_joints), optional
        Reference configuration(s) in [rad]; only its ``q_4`` is used, at a wrist singularity
        (default 0).

    Returns
    -------
    solutions : array (n, m, n_joints)
        Joint positions in [rad]; ``m = 8`` for joint ranges no wider than a turn, times the
        number of ``+-2 pi`` variants otherwise. Rows where ``valid`` is False hold garbage.
        Branch order: ``4 i_shoulder + 2 i_elbow + i_wrist`` (``i = 0`` the "+" root).
    valid : array (n, m) of bool
        True for reachable, non-singular solutions inside the joint ranges (the value is clipped
        into the range when it lies within 1e-9 rad outside).

    Raises
    ------
    ArmlabError
        The robot is not of the supported family.
    InputError
        Wrong shape, non-homogeneous pose (NaN poses are reported as all-invalid instead).

    See Also
    --------
    ik_all_batch_reasons : the same with a reason code per pose.
    """
    sol, valid, _ = ik_all_batch_reasons(robot, poses, q_ref=q_ref)
    return sol, valid


def ik_all_batch_reasons(
    robot: Robot, poses, *, q_ref=None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`ik_all_batch` plus ``reasons (n,)`` (codes of :data:`IK_REASONS`)."""
    arm = _arm(robot)
    T, _ = check_poses(poses)
    q4 = _q4_ref(robot, q_ref, T.shape[0])
    return _solve_in_chunks(arm, T, q4)


_CHUNK = 4096  # poses per vectorised pass: keeps the temporaries in cache (2x faster at 1e5)


def _solve_in_chunks(arm: _WristArm, T: np.ndarray, q4: np.ndarray):
    """Range-filtered solutions, validity and reasons of (n, 4, 4) poses, chunk by chunk."""
    parts = []
    for i in range(0, max(T.shape[0], 1), _CHUNK):
        q, ok, reason = _solve(arm, T[i : i + _CHUNK], q4[i : i + _CHUNK])
        sol, valid, _ = _range_variants(arm, q, ok)
        reason[(reason == 0) & ~valid.any(axis=1)] = 4
        parts.append((sol, valid, reason))
    if len(parts) == 1:
        return parts[0]
    return tuple(np.concatenate(x) for x in zip(*parts, strict=True))


def _q4_ref(robot, q_ref, n: int) -> np.ndarray:
    if q_ref is None:
        return np.zeros(n)
    q = np.asarray(q_ref, dtype=float)
    if q.ndim == 1:
        q = robot.check_q(q, name="q_ref")
        return np.full(n, q[3])
    q = robot.check_q(q, name="q_ref", batch=True)
    if q.shape[0] != n:
        raise InputError(f"q_ref has {q.shape[0]} rows for {n} poses")
    return q[:, 3].copy()


def _unreachable_message(robot, arm: _WristArm, T: np.ndarray, code: int, where: str) -> str:
    """A one-line reason for pose ``T`` (1, 4, 4) that has no solution."""
    if code == 1:
        return f"{where}: {IK_REASONS[1]}"
    Tw = arm.transform_pre @ T[0] @ arm.transform_post
    pw = Tw[:3, 3]
    if code == 2:
        return (
            f"{where}: {IK_REASONS[2]} (wrist centre {np.round(pw, 6).tolist()} m in the "
            "base): joint 1 is undefined"
        )
    if code == 3:
        r = math.hypot(pw[0], pw[1])
        if r * r < arm.e * arm.e:
            return (
                f"{where}: outside reach: wrist centre {r:.4f} m from the joint-1 axis, "
                f"closer than the shoulder offset {abs(arm.e):.4f} m"
            )
        rho = math.sqrt(max(r * r - arm.e * arm.e, 0.0))
        dist = math.hypot(rho - arm.a1, pw[2] - arm.d1)
        R = math.hypot(arm.a3, arm.d4)
        return (
            f"{where}: outside reach: wrist centre {dist:.4f} m from the shoulder (joint 2) "
            f"axis, reachable {abs(arm.a2 - R):.4f}..{arm.a2 + R:.4f} m"
        )
    # code 4: every candidate violates some range
    q, ok, _ = _solve(arm, T, np.zeros(1))
    _, _, blocking = _range_variants(arm, q, ok)
    m = ok.shape[1]
    blk = blocking[0, :m][ok[0]]
    counts = blk.sum(axis=0)
    parts = [
        f"{robot.joint_names[j]} blocks {int(counts[j])}"
        for j in np.argsort(-counts)
        if counts[j] > 0
    ]
    return (
        f"{where}: all {int(ok[0].sum())} solutions lie outside the joint ranges ("
        + ", ".join(parts)
        + ")"
    )


def ik_all(robot: Robot, pose, *, q_ref=None, unique_tol_rad: float = 1e-10) -> np.ndarray:
    """Every in-range analytic IK solution of one tool pose (thesis 3.4.2).

    Parameters
    ----------
    robot : Robot
        6R arm with a spherical wrist and a DH table (``robot.dh``), e.g. teachbot6.
    pose : array (4, 4)
        Tool pose in the world, ``T_base_in_world @ T_0n(theta) @ T_tool_in_n`` (thesis 3.5).
    q_ref : array (n_joints,), optional
        Only used at a wrist singularity (``sin theta_5 = 0``): ``q_4 = q_ref[3]`` (default 0)
        and ``q_6`` takes up the rest.
    unique_tol_rad : float
        Solutions closer than this (max over joints, in [rad]) are returned once.

    Returns
    -------
    array (k, n_joints)
        ``1 <= k <= 8`` solutions in [rad] (more if a range is wider than a turn), in branch
        order (shoulder, elbow, wrist).

    Raises
    ------
    UnreachableError
        Outside the reach, on the shoulder singularity axis, or every solution outside the joint
        ranges (the message names the blocking joints).
    ArmlabError
        The robot has no analytic IK (no DH table or not a spherical-wrist PUMA-like arm).
    InputError
        Malformed or non-finite pose.
    """
    T, single = check_poses(pose, allow_nan=False)
    if not single:
        raise InputError(
            f"pose has shape {np.shape(pose)}; ik_all takes one (4, 4) pose "
            "(use ik_all_batch for many)"
        )
    arm = _arm(robot)
    q4 = _q4_ref(robot, q_ref, 1)
    q, ok, reason = _solve(arm, T, q4)
    sol, valid, _ = _range_variants(arm, q, ok)
    if not valid[0].any():
        code = int(reason[0]) or 4
        raise UnreachableError(_unreachable_message(robot, arm, T, code, f"{robot.name} pose"))
    out: list[np.ndarray] = []
    for row in sol[0][valid[0]]:
        if all(np.abs(row - o).max() > unique_tol_rad for o in out):
            out.append(row)
    return np.array(out)


def _weights(robot, weights) -> np.ndarray:
    if weights is None:
        return np.ones(robot.n_joints)
    w = np.asarray(weights, dtype=float)
    if w.shape != (robot.n_joints,) or not np.all(np.isfinite(w)) or np.any(w < 0):
        raise InputError(f"weights must be {robot.n_joints} finite values >= 0, got {w!r}")
    return w


def ik_nearest(robot: Robot, poses, q_ref, weights=None, *, sequential: bool = False) -> np.ndarray:
    """The in-range analytic solution closest to a reference (thesis 3.4.2, 6.3.1).

    Among the valid solutions of each pose, pick the one minimising the weighted distance
    ``sum_j w_j (q_j - q_ref_j)^2`` (thesis 6.3.1: "compute an objective for the remaining
    solutions and choose the best"; the weighted joint distance is our reading of it).

    Parameters
    ----------
    robot : Robot
    poses : array (4, 4) or (n, 4, 4)
        Tool poses in the world.
    q_ref : array (n_joints,) or (n, n_joints)
        Reference configuration(s) in [rad].
    weights : array (n_joints,), optional
        ``w_j >= 0``; default all ones.
    sequential : bool
        If True (Cartesian paths), pose ``k`` uses the solution of pose ``k - 1`` as its
        reference (``q_ref`` must then be one configuration, the reference of pose 0): keeps
        the branch continuous along a path.

    Returns
    -------
    array (n_joints,) for one pose, (n, n_joints) for many, in [rad].

    Raises
    ------
    UnreachableError
        A pose has no valid solution; the message names the pose index and the reason.
    InputError
        Malformed or non-finite pose (named by index), bad ``q_ref`` or ``weights``.
    """
    T, single = check_poses(poses, name="poses", allow_nan=False)
    n = T.shape[0]
    w = _weights(robot, weights)
    qr = np.asarray(q_ref, dtype=float)
    if sequential:
        qr = robot.check_q(qr, name="q_ref")
    elif qr.ndim == 2:
        qr = robot.check_q(qr, name="q_ref", batch=True)
        if qr.shape[0] != n:
            raise InputError(f"q_ref has {qr.shape[0]} rows for {n} poses")
    else:
        qr = np.broadcast_to(robot.check_q(qr, name="q_ref"), (n, robot.n_joints))
    arm = _arm(robot)
    # sequential: the q4 reference for wrist singularities is refined in the loop below
    q4 = np.full(n, qr[3]) if sequential else qr[:, 3]
    sol, valid, reason = _solve_in_chunks(arm, T, q4)
    bad = np.flatnonzero(~valid.any(axis=1))
    if bad.size:
        k = int(bad[0])
        where = f"{robot.name} pose" if single else f"{robot.name} pose {k} (of {n})"
        raise UnreachableError(
            _unreachable_message(robot, arm, T[k : k + 1], int(reason[k]), where)
        )
    if not sequential:
        cost = np.einsum("nmj,j->nm", (sol - qr[:, None, :]) ** 2, w)
        cost = np.where(valid, cost, np.inf)
        best = sol[np.arange(n), np.argmin(cost, axis=1)]
        return best[0] if single else best
    out = np.empty((n, robot.n_joints))
    prev = qr
    for k in range(n):
        cand = sol[k][valid[k]]
        if np.any(np.abs(np.sin(cand[:, 4])) < 1e-6):  # wrist singular: re-solve with prev q4
            qk, okk, _ = _solve(arm, T[k : k + 1], np.array([prev[3]]))
            s2, v2, _ = _range_variants(arm, qk, okk)
            cand = s2[0][v2[0]]
        cost = ((cand - prev) ** 2) @ w
        prev = cand[int(np.argmin(cost))]
        out[k] = prev
    return out[0] if single else out
