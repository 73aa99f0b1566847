"""Worst-case static load of each joint (thesis 4.2.1-4.2.2), found by optimisation.

The thesis sizes its drives with a static method (HEU thesis, 4.2.1, eq. 4-2):

``tau_j = sum_i m_i g l_ij + sum_i J_ij alpha_j``

the gravity moment of everything outboard of joint ``j`` at the worst pose, plus the inertia of
everything outboard about the joint's axis at that pose times the joint's maximum acceleration.
With a rigid-body model both terms come from one RNEA call from rest: for a direction
``s = +-1``,

``f_j,s(q) = s tau_j(q, qd = 0, qdd = s alpha_j e_j) = s g_j(q) + alpha_j M_jj(q)``

(``M_jj`` is the inertia of the outboard bodies about axis ``j``, payload included).

The worst pose (issue 3, thesis 4.2.1) is the pose inside the joint ranges that maximises the
gravity torque ``|g_j(q)|``; the acceleration term is then taken at that pose. A joint that
carries no gravity anywhere (a vertical joint-1 axis; joint 6 with an on-axis payload) gets the
pose that maximises its inertia term instead — the thesis' joint 1 case. ``criterion="total"``
maximises ``f`` itself (the worst torque to start accelerating against gravity). The search is a
multi-start bounded optimisation (L-BFGS-B with the analytic RNEA derivatives, started from the
best of a seeded random sample, both directions). Power is the thesis' "torque x max speed"
(4.2.2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from armlab.errors import InputError
from armlab.robot import rigid_body

if TYPE_CHECKING:
    from armlab.robot.model import Robot

__all__ = [
    "JointStaticLoad",
    "StaticLoadReport",
    "StaticLoadProblem",
    "build_static_load",
    "static_load",
]


MODES = ("gravity", "inertia", "total")


@dataclass
class StaticLoadProblem:
    """The worst-case load search of one joint, built but not solved.

    ``objective(q, s)`` in [N m] is, by ``mode``: ``"gravity"``: ``s g_j(q)``; ``"inertia"``:
    ``alpha_j M_jj(q)``; ``"total"``: ``f_j,s(q) = s g_j(q) + alpha_j M_jj(q)`` (module
    docstring). ``gradient(q, s)`` is its derivative (n_joints,); ``bounds`` the joint ranges;
    ``starts`` the start poses of the local searches (n_starts, n_joints) with their direction
    ``start_signs``.
    """

    robot: Robot
    joint: int
    acceleration_rad_s2: float
    lower_rad: np.ndarray
    upper_rad: np.ndarray
    starts: np.ndarray
    start_signs: np.ndarray
    mode: str = "total"
    sample_max_gravity_Nm: float = math.nan
    model: pin.Model = field(repr=False, default=None)
    data: pin.Data = field(repr=False, default=None)
    n_evaluations: int = 0

    def __post_init__(self) -> None:
        if self.model is None:
            self.model = self.robot.model  # gravity in the base frame (Robot keeps it so)
        self.data = self.model.createData()
        self._v0 = np.zeros(self.model.nv)

    @property
    def bounds(self) -> list[tuple[float, float]]:
        return list(zip(self.lower_rad.tolist(), self.upper_rad.tolist(), strict=True))

    def _acc(self, s: float) -> np.ndarray:
        a = np.zeros(self.model.nv)
        a[self.joint] = s * self.acceleration_rad_s2
        return a

    def _tau(self, q, a) -> float:
        return float(pin.rnea(self.model, self.data, np.asarray(q, float), self._v0, a)[self.joint])

    def _dtau(self, q, a) -> np.ndarray:
        dq, _, _ = pin.computeRNEADerivatives(
            self.model, self.data, np.asarray(q, float), self._v0, a
        )
        return np.asarray(dq)[self.joint].copy()

    def objective(self, q, s: float = 1.0) -> float:
        self.n_evaluations += 1
        if self.mode == "gravity":
            return s * self._tau(q, self._v0)
        if self.mode == "inertia":
            return self._tau(q, self._acc(1.0)) - self._tau(q, self._v0)
        return s * self._tau(q, self._acc(s))

    def gradient(self, q, s: float = 1.0) -> np.ndarray:
        if self.mode == "gravity":
            return s * self._dtau(q, self._v0)
        if self.mode == "inertia":
            return self._dtau(q, self._acc(1.0)) - self._dtau(q, self._v0)
        return s * self._dtau(q, self._acc(s))

    def gravity_and_inertia(self, q) -> tuple[float, float]:
        """(g_j(q) [N m], M_jj(q) [kg m^2]) at a pose."""
        q = np.asarray(q, float)
        g = pin.computeGeneralizedGravity(self.model, self.data, q)[self.joint]
        M = pin.crba(self.model, self.data, q)
        return float(g), float(M[self.joint, self.joint])

    def solve(self, *, tol: float = 1e-12, max_iter: int = 200) -> tuple[np.ndarray, float, float]:
        """Run the local searches; returns (pose, f at the pose, direction s)."""
        from scipy.optimize import minimize  # here, not at import: scipy.optimize costs ~0.3 s

        best = (self.starts[0].copy(), -math.inf, 1.0)
        for q0, s in zip(self.starts, self.start_signs, strict=True):
            res = minimize(
                lambda q, s=s: -self.objective(q, s),
                q0,
                jac=lambda q, s=s: -self.gradient(q, s),
                method="L-BFGS-B",
                bounds=self.bounds,
                options={"ftol": tol, "gtol": 1e-10, "maxiter": max_iter},
            )
            q = np.clip(res.x, self.lower_rad, self.upper_rad)
            f = self.objective(q, s)
            if f > best[1]:
                best = (q, f, float(s))
        return best


def build_static_load(
    robot: Robot,
    joint,
    *,
    mode: str = "total",
    acceleration_rad_s2: float | None = None,
    n_samples: int = 256,
    n_starts: int = 4,
    rng: np.random.Generator | None = None,
) -> StaticLoadProblem:
    """Build the worst-case load search of one joint.

    Parameters
    ----------
    robot : Robot
    joint : str or int
        Joint name or 1-based number.
    mode : {"gravity", "inertia", "total"}
        What to maximise (:class:`StaticLoadProblem`).
    acceleration_rad_s2 : float, optional
        The joint's maximum acceleration [rad/s^2]; default the robot's limit (0 if it has none).
    n_samples : int
        Random poses (uniform in the joint ranges) evaluated to pick the starts.
    n_starts : int
        Local searches per direction (the best samples of each direction).
    rng : numpy.random.Generator, optional
        Default ``np.random.default_rng(0)``.
    """
    j = robot.joint_index(joint)
    if acceleration_rad_s2 is None:
        lim = robot.limits.acceleration_rad_s2
        acceleration_rad_s2 = 0.0 if lim is None else float(lim[j])
    if not math.isfinite(acceleration_rad_s2) or acceleration_rad_s2 < 0:
        raise InputError(
            f"acceleration of {robot.joint_names[j]} must be finite and >= 0, "
            f"not {acceleration_rad_s2!r}"
        )
    if n_samples < 1 or n_starts < 1:
        raise InputError("n_samples and n_starts must be >= 1")
    if mode not in MODES:
        raise InputError(f"static-load mode must be one of {MODES}, not {mode!r}")
    rng = np.random.default_rng(0) if rng is None else rng
    lo, hi = robot.limits.sample_lower_rad.copy(), robot.limits.sample_upper_rad.copy()
    q = robot.random_q(rng, n_samples)
    q = np.vstack([q, robot.limits.centre_rad])
    zeros = np.zeros_like(q)
    acc = zeros.copy()
    acc[:, j] = acceleration_rad_s2
    g = rigid_body.gravity_torques(robot, q)[:, j]
    tau_acc = rigid_body.inverse_dynamics(robot, q, zeros, acc)[:, j] if mode != "gravity" else g
    inertia_term = tau_acc - g
    starts, signs = [], []
    for s in (1.0,) if mode == "inertia" else (1.0, -1.0):
        f = {"gravity": s * g, "inertia": inertia_term, "total": s * g + inertia_term}[mode]
        for k in np.argsort(-f)[:n_starts]:
            starts.append(q[k])
            signs.append(s)
    return StaticLoadProblem(
        robot=robot,
        joint=j,
        mode=mode,
        acceleration_rad_s2=float(acceleration_rad_s2),
        lower_rad=lo,
        upper_rad=hi,
        starts=np.array(starts),
        start_signs=np.array(signs),
        sample_max_gravity_Nm=float(np.max(np.abs(g))),
    )


@dataclass
class JointStaticLoad:
    """Worst-case static load of one joint.

    ``torque_Nm = gravity_Nm + acceleration_Nm`` at ``pose_rad``; ``gravity_Nm = |g_j|``;
    ``acceleration_Nm = M_jj alpha_j``; ``power_W = torque_Nm x speed_rad_s`` (thesis 4.2.2);
    ``direction`` the sign of the acceleration that adds to gravity.
    """

    joint: str
    torque_Nm: float
    gravity_Nm: float
    acceleration_Nm: float
    inertia_kg_m2: float
    pose_rad: np.ndarray
    acceleration_rad_s2: float
    speed_rad_s: float
    power_W: float
    direction: float

    def to_dict(self) -> dict:
        return {
            "torque_Nm": self.torque_Nm,
            "gravity_Nm": self.gravity_Nm,
            "acceleration_Nm": self.acceleration_Nm,
            "pose": [float(x) for x in self.pose_rad],
            "power_W": self.power_W,
        }


@dataclass
class StaticLoadReport:
    """Worst-case static load of every joint (thesis 4.2.1-4.2.2).

    ``to_dict()`` gives, per joint, ``torque_Nm, gravity_Nm, acceleration_Nm, pose`` (rad
    list), ``payload_kg, power_W``; ``to_markdown()`` the table with the thesis' table 4.2
    beside it when the robot is teachbot6.
    """

    robot_name: str
    joint_names: list[str]
    payload_kg: float
    joints: list[JointStaticLoad]
    n_evaluations: int = 0
    criterion: str = "gravity"

    @property
    def torque_Nm(self) -> np.ndarray:
        return np.array([x.torque_Nm for x in self.joints])

    @property
    def gravity_Nm(self) -> np.ndarray:
        return np.array([x.gravity_Nm for x in self.joints])

    @property
    def acceleration_Nm(self) -> np.ndarray:
        return np.array([x.acceleration_Nm for x in self.joints])

    @property
    def power_W(self) -> np.ndarray:
        return np.array([x.power_W for x in self.joints])

    @property
    def poses_rad(self) -> np.ndarray:
        """(n_joints, n_joints): row j is joint j's worst pose."""
        return np.array([x.pose_rad for x in self.joints])

    def joint(self, name) -> JointStaticLoad:
        for x in self.joints:
            if x.joint == name:
                return x
        raise InputError(f"no joint {name!r} in the static-load report")

    def to_dict(self) -> dict:
        out = {}
        for x in self.joints:
            d = x.to_dict()
            d["payload_kg"] = float(self.payload_kg)
            out[x.joint] = d
        return out

    def to_markdown(self) -> str:
        from armlab.dynamics.reference import static_load_markdown

        return static_load_markdown(self)


def static_load(
    robot: Robot,
    *,
    criterion: str = "gravity",
    acceleration_rad_s2=None,
    n_samples: int = 256,
    n_starts: int = 4,
    seed: int = 0,
    gravity_tol_Nm: float = 1e-9,
) -> StaticLoadReport:
    """Worst-case holding + accelerating torque of every joint, with the pose that causes it.

    Parameters
    ----------
    robot : Robot
        Payload included (``robot.payload``; use ``robot.with_payload(m)`` to change it).
    criterion : {"gravity", "total"}
        ``"gravity"`` (issue 3, thesis 4.2.1): the pose maximises the gravity torque and the
        acceleration term is added at that pose; a joint whose gravity torque stays below
        ``gravity_tol_Nm`` everywhere gets the pose of its largest inertia term. ``"total"``:
        the pose maximises gravity + acceleration term together.
    acceleration_rad_s2 : array (n_joints,), optional
        Maximum joint accelerations [rad/s^2]; default the robot's limits (zero without them:
        the gravity term alone).
    n_samples, n_starts : int
        Random poses that seed the search, and local searches per direction (see
        :func:`build_static_load`).
    seed : int
        Seed of the random start poses.

    Returns
    -------
    StaticLoadReport
    """
    if criterion not in ("gravity", "total"):
        raise InputError(f"criterion must be 'gravity' or 'total', not {criterion!r}")
    rng = np.random.default_rng(seed)
    acc = acceleration_rad_s2
    if acc is None:
        acc = robot.limits.acceleration_rad_s2
    acc = np.zeros(robot.n_joints) if acc is None else np.asarray(acc, float).reshape(-1)
    if acc.shape != (robot.n_joints,):
        raise InputError(f"acceleration_rad_s2 has shape {acc.shape}, expected ({robot.n_joints},)")
    speed = robot.limits.require(["velocity"], where="static_load").velocity_rad_s
    assert speed is not None  # require() raised otherwise
    joints, n_eval = [], 0
    for j, name in enumerate(robot.joint_names):
        problem = build_static_load(
            robot,
            j + 1,
            mode=criterion,
            acceleration_rad_s2=float(acc[j]),
            n_samples=n_samples,
            n_starts=n_starts,
            rng=rng,
        )
        if criterion == "gravity" and problem.sample_max_gravity_Nm < gravity_tol_Nm:
            n_eval += problem.n_evaluations
            problem = build_static_load(
                robot,
                j + 1,
                mode="inertia",
                acceleration_rad_s2=float(acc[j]),
                n_samples=n_samples,
                n_starts=n_starts,
                rng=rng,
            )
        q, _, s = problem.solve()
        g, m_jj = problem.gravity_and_inertia(q)
        n_eval += problem.n_evaluations
        grav, acc_term = abs(g), m_jj * float(acc[j])
        torque = grav + acc_term
        direction = float(np.sign(g)) if abs(g) > 1e-12 else s
        joints.append(
            JointStaticLoad(
                joint=name,
                torque_Nm=torque,
                gravity_Nm=grav,
                acceleration_Nm=acc_term,
                inertia_kg_m2=m_jj,
                pose_rad=q,
                acceleration_rad_s2=float(acc[j]),
                speed_rad_s=float(speed[j]),
                power_W=torque * float(speed[j]),
                direction=direction,
            )
        )
    return StaticLoadReport(
        robot_name=robot.name,
        joint_names=list(robot.joint_names),
        payload_kg=float(robot.payload.mass_kg),
        joints=joints,
        n_evaluations=n_eval,
        criterion=criterion,
    )
