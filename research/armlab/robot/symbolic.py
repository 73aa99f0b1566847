"""Symbolic inverse dynamics for CasADi, built from a Pinocchio model.

Pinocchio's own CasADi bindings are not used (not available in our build): the recursive
Newton-Euler algorithm (RNEA, Featherstone 2008 ch. 5; Pinocchio's ``rnea``) is written here with
CasADi ``SX`` over the model's kinematic tree — ``model.parents``, ``model.jointPlacements``,
``model.inertias`` (payload included, see :meth:`armlab.robot.model.Robot.attach_payload`),
joint axes — for revolute and prismatic joints (axis-aligned or unaligned).

Conventions are Pinocchio's: spatial vectors are ``[linear; angular]`` expressed in the joint
frame; ``liMi = jointPlacement_i * M_joint(q_i)`` is the placement of joint ``i`` in its parent.

Forward pass, for each joint ``i`` with parent ``p`` and motion subspace ``S_i``::

    v_i = liMi^-1 . v_p + S_i qd_i
    a_i = liMi^-1 . a_p + S_i qdd_i + v_i x (S_i qd_i)          (a_0 = -gravity)
    f_i = I_i a_i + v_i x* (I_i v_i)

backward pass ``tau_i = S_i^T f_i + armature_i qdd_i`` and ``f_p += liMi . f_i``.

The result is one ``casadi.Function("rnea", [q, qd, qdd], [tau])`` per model, cached on a hash
of everything the dynamics depend on (tree, placements, inertias, axes, gravity, armature), so a
payload change gives a new function and an unchanged robot reuses the old one.
"""

from __future__ import annotations

import hashlib
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from armlab._lazy import lazy_import
from armlab.errors import RobotDescriptionError

if TYPE_CHECKING:
    import casadi as ca  # the real module for the type checker (CasADi ships type stubs)
else:
    ca = lazy_import("casadi")  # CasADi loads at the first symbolic build, not with the package

__all__ = [
    "inverse_dynamics_function",
    "parametric_inverse_dynamics_function",
    "dynamic_parameters",
    "dynamics_key",
    "kinematics_key",
    "joint_kinds",
]

_CACHE: dict[str, ca.Function] = {}
_PCACHE: dict[str, ca.Function] = {}
_CACHE_MAX = 64

_AXES = {
    "X": np.array([1.0, 0.0, 0.0]),
    "Y": np.array([0.0, 1.0, 0.0]),
    "Z": np.array([0.0, 0.0, 1.0]),
}


def _model_of(robot_or_model) -> pin.Model:
    return robot_or_model.model if hasattr(robot_or_model, "model") else robot_or_model


def joint_kinds(model: pin.Model) -> list[tuple[str, np.ndarray]]:
    """``[(kind, unit axis)]`` for each joint of the model, kind ``"revolute"`` or ``"prismatic"``.

    Raises
    ------
    RobotDescriptionError
        A joint that is neither a 1-DOF revolute nor a 1-DOF prismatic joint.
    """
    out = []
    for i in range(1, model.njoints):
        jm = model.joints[i]
        name = jm.shortname()
        short = name.replace("JointModel", "")
        if short in ("RX", "RY", "RZ"):
            out.append(("revolute", _AXES[short[1]]))
        elif short in ("PX", "PY", "PZ"):
            out.append(("prismatic", _AXES[short[1]]))
        elif short == "RevoluteUnaligned":
            out.append(("revolute", np.asarray(jm.extract().axis, float)))
        elif short == "PrismaticUnaligned":
            out.append(("prismatic", np.asarray(jm.extract().axis, float)))
        else:
            raise RobotDescriptionError(
                f"symbolic dynamics: joint {model.names[i]!r} is a {name}; only 1-DOF revolute "
                "and prismatic joints are supported"
            )
    return out


def kinematics_key(robot_or_model) -> str:
    """A hash of the kinematic tree, joint axes and gravity (not the inertias)."""
    return _hash(_model_of(robot_or_model), inertias=False)


def dynamics_key(robot_or_model) -> str:
    """A hash of everything the inverse dynamics depend on (the cache key)."""
    return _hash(_model_of(robot_or_model), inertias=True)


def _hash(model, inertias: bool) -> str:
    h = hashlib.sha1()
    h.update(np.asarray(model.parents, dtype=np.int64).tobytes())
    for kind, axis in joint_kinds(model):
        h.update(kind.encode())
        h.update(np.round(axis, 15).tobytes())
    for i in range(1, model.njoints):
        h.update(model.jointPlacements[i].homogeneous.tobytes())
        if inertias:
            h.update(model.inertias[i].toDynamicParameters().tobytes())
    h.update(np.asarray(model.gravity.vector).tobytes())
    if inertias:
        h.update(np.asarray(model.armature).tobytes())
    return h.hexdigest()


def _rotation(axis: np.ndarray, angle):
    """Rodrigues: R = I + sin(q) K + (1 - cos(q)) K^2 (exact 0/1 entries for axis-aligned)."""
    k = np.asarray(axis, float)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    K2 = K @ K
    s, c = ca.sin(angle), ca.cos(angle)
    return ca.DM(np.eye(3)) + s * ca.DM(K) + (1 - c) * ca.DM(K2)


def _build(model: pin.Model) -> ca.Function:
    nq = model.nq
    kinds = joint_kinds(model)
    q = ca.SX.sym("q", nq)
    qd = ca.SX.sym("qd", nq)
    qdd = ca.SX.sym("qdd", nq)
    nj = model.njoints
    pi = ca.SX.sym("pi", 10 * (nj - 1) + nq)  # dynamic parameters of each body, armature
    # per body (index 0: the base): casadi SX or DM expressions, filled in below
    R: list[Any] = [None] * nj
    p: list[Any] = [None] * nj
    S: list[Any] = [None] * nj
    v_lin: list[Any] = [None] * nj
    v_ang: list[Any] = [None] * nj
    a_lin: list[Any] = [None] * nj
    a_ang: list[Any] = [None] * nj
    f_lin: list[Any] = [None] * nj
    f_ang: list[Any] = [None] * nj
    g = np.asarray(model.gravity.vector, float)
    v_lin[0] = ca.SX.zeros(3)
    v_ang[0] = ca.SX.zeros(3)
    a_lin[0] = ca.SX(-g[:3])
    a_ang[0] = ca.SX(-g[3:])
    armature = pi[10 * (nj - 1) :]
    for i in range(1, nj):
        par = model.parents[i]
        idx = model.joints[i].idx_q
        kind, axis = kinds[i - 1]
        M0 = model.jointPlacements[i]
        R0, p0 = ca.DM(M0.rotation), ca.DM(M0.translation)
        if kind == "revolute":
            R[i] = ca.mtimes(R0, _rotation(axis, q[idx]))
            p[i] = p0
            s_lin, s_ang = ca.DM.zeros(3), ca.DM(axis)
        else:
            R[i] = R0
            p[i] = p0 + ca.mtimes(R0, ca.DM(axis)) * q[idx]
            s_lin, s_ang = ca.DM(axis), ca.DM.zeros(3)
        S[i] = (s_lin, s_ang)
        Rt = R[i].T
        # liMi^-1 . v_parent
        vl = ca.mtimes(Rt, v_lin[par] - ca.cross(p[i], v_ang[par]))
        va = ca.mtimes(Rt, v_ang[par])
        al = ca.mtimes(Rt, a_lin[par] - ca.cross(p[i], a_ang[par]))
        aa = ca.mtimes(Rt, a_ang[par])
        vj_lin, vj_ang = s_lin * qd[idx], s_ang * qd[idx]
        vl, va = vl + vj_lin, va + vj_ang
        # a_i += S qdd + v_i x v_J  (motion cross product)
        al = al + s_lin * qdd[idx] + ca.cross(va, vj_lin) + ca.cross(vl, vj_ang)
        aa = aa + s_ang * qdd[idx] + ca.cross(va, vj_ang)
        v_lin[i], v_ang[i], a_lin[i], a_ang[i] = vl, va, al, aa
        # body inertia from its dynamic parameters [m, h = m c, I about the joint origin]
        # (Pinocchio's toDynamicParameters order: m, hx, hy, hz, Ixx, Ixy, Iyy, Ixz, Iyz, Izz)
        d = pi[10 * (i - 1) : 10 * i]
        m, h = d[0], d[1:4]
        I_o = ca.vertcat(
            ca.horzcat(d[4], d[5], d[7]), ca.horzcat(d[5], d[6], d[8]), ca.horzcat(d[7], d[8], d[9])
        )

        def inertia_times(lin, ang, m=m, h=h, I_o=I_o):
            # f_lin = m lin - h x ang ; f_ang = I_o ang + h x lin
            fl = m * lin - ca.cross(h, ang)
            fa = ca.mtimes(I_o, ang) + ca.cross(h, lin)
            return fl, fa

        fl, fa = inertia_times(al, aa)
        hl, ha = inertia_times(vl, va)
        # v x* h  (force cross product)
        fl = fl + ca.cross(va, hl)
        fa = fa + ca.cross(va, ha) + ca.cross(vl, hl)
        f_lin[i], f_ang[i] = fl, fa
    tau: list[Any] = [None] * nq
    for i in range(nj - 1, 0, -1):
        idx = model.joints[i].idx_q
        s_lin, s_ang = S[i]
        tau[idx] = ca.dot(s_lin, f_lin[i]) + ca.dot(s_ang, f_ang[i]) + armature[idx] * qdd[idx]
        par = model.parents[i]
        if par > 0:
            fl = ca.mtimes(R[i], f_lin[i])
            fa = ca.mtimes(R[i], f_ang[i]) + ca.cross(p[i], fl)
            f_lin[par] = f_lin[par] + fl
            f_ang[par] = f_ang[par] + fa
    return ca.Function(
        "rnea_p", [q, qd, qdd, pi], [ca.vertcat(*tau)], ["q", "qd", "qdd", "pi"], ["tau"]
    )


def dynamic_parameters(robot_or_model) -> np.ndarray:
    """The inertial parameter vector of :func:`parametric_inverse_dynamics_function`.

    ``[m, m c_x, m c_y, m c_z, Ixx, Ixy, Iyy, Ixz, Iyz, Izz]`` of each body about its joint
    frame (Pinocchio's ``Inertia.toDynamicParameters``; payload included), then the armature.
    """
    model = _model_of(robot_or_model)
    parts = [model.inertias[i].toDynamicParameters() for i in range(1, model.njoints)]
    parts.append(np.asarray(model.armature, float))
    return np.concatenate(parts)


def parametric_inverse_dynamics_function(robot_or_model) -> ca.Function:
    """``rnea_p(q, qd, qdd, pi) -> tau`` with the inertial parameters ``pi`` as an input.

    ``tau`` is linear in ``pi`` (:func:`dynamic_parameters`), so one function serves every
    payload of a robot: it is cached on the kinematics only (:func:`kinematics_key`).
    """
    model = _model_of(robot_or_model)
    key = kinematics_key(model)
    fn = _PCACHE.get(key)
    if fn is None:
        fn = _build(model)
        if len(_PCACHE) >= _CACHE_MAX:
            _PCACHE.pop(next(iter(_PCACHE)))
        _PCACHE[key] = fn
    return fn


def inverse_dynamics_function(robot_or_model) -> ca.Function:
    """Joint torques ``tau = M(q) qdd + C(q, qd) qd + g(q)`` as a CasADi function.

    Parameters
    ----------
    robot_or_model : Robot or pinocchio.Model
        Revolute and prismatic 1-DOF joints; the payload is part of ``model.inertias``.

    Returns
    -------
    casadi.Function
        ``rnea(q, qd, qdd) -> tau``, each ``(n_joints,)`` in SI units ([rad] or [m], [N m] or
        [N]); an SX function (the parametric one with this model's inertias folded in), so it
        can be called on SX, MX or numbers. Cached per model hash.
    """
    model = _model_of(robot_or_model)
    key = dynamics_key(model)
    fn = _CACHE.get(key)
    if fn is None:
        fp = parametric_inverse_dynamics_function(model)
        q, qd, qdd = (ca.SX.sym(n, model.nq) for n in ("q", "qd", "qdd"))
        tau = fp(q, qd, qdd, ca.DM(dynamic_parameters(model)))
        fn = ca.Function("rnea", [q, qd, qdd], [tau], ["q", "qd", "qdd"], ["tau"])
        if len(_CACHE) >= _CACHE_MAX:
            _CACHE.pop(next(iter(_CACHE)))
        _CACHE[key] = fn
    return fn
