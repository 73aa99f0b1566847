"""Numerical inverse kinematics for any URDF: damped least squares as a QP, solved with OSQP.

Each iteration linearises the pose error ``e = log6(T_tool(q)^-1 T_des)`` (a twist in the
tool frame, Pinocchio ``log6``) around ``q``: ``e(q + dq) ~ e + J_e dq`` with
``J_e = -Jlog6(T_des^-1 T_tool) J_local`` (the Pinocchio IK example), and solves

    min_dq   1/2 ||J_e dq + e||^2 + 1/2 lambda ||dq||^2
    s.t.     max(q_lo - q, -dq_max) <= dq <= min(q_hi - q, dq_max)

i.e. ``P = J_e^T J_e + lambda I``, ``p = J_e^T e``, ``A = I`` (joint ranges as bounds on
``q + dq``, and a per-step bound ``dq_max``). The damping follows Levenberg-Marquardt with the
adaptive term of Sugihara (2011, "Solvability-unconcerned inverse kinematics by the
Levenberg-Marquardt method"): ``lambda = mu (||e||^2 + lambda_0)``; a step that does not reduce
``||e||`` is rejected and ``mu`` grows ten-fold, an accepted one shrinks it. When an attempt
stalls (no progress, or ``max_iter`` spent) it restarts from a uniform random configuration
inside the joint ranges.

OSQP (1.x API) is set up once per joint count (per thread) and only ``update``-d afterwards
(``q``, ``l``, ``u`` and the values of ``P``); the QP is solved in the variable
``x = dq / s`` with ``s = ||J_e^T e||`` so that OSQP's absolute tolerances stay relative to the
step.

Success is reported honestly (:class:`IKResult`): the final position error in [m] and the
rotation angle error in [rad] are measured directly, not taken from the solver.
"""

from __future__ import annotations

import inspect
import math
import threading
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from armlab._lazy import lazy_import
from armlab.errors import InputError, UnreachableError
from armlab.kinematics.analytic_ik import check_poses

if TYPE_CHECKING:
    import osqp
    from scipy import sparse

    from armlab.robot.model import Robot
else:  # loaded at the first numerical IK, not with armlab.kinematics (0.17 s)
    osqp = lazy_import("osqp")
    sparse = lazy_import("scipy.sparse")

__all__ = ["IKResult", "IKSettings", "ik", "ik_solve", "ik_batch"]


@dataclass(frozen=True)
class IKSettings:
    """Tuning of the numerical IK (all have working defaults).

    Attributes
    ----------
    max_step_rad : float
        Per-iteration bound on every ``|dq_j|`` in [rad] (trust region).
    lambda_0 : float
        Constant part of the Levenberg-Marquardt damping, in the units of ``||e||^2``.
    mu_0, mu_min, mu_max : float
        Initial, smallest and largest damping multiplier; above ``mu_max`` the attempt is stuck.
    stall_iterations : int
        An attempt that has not reduced ``||e||^2`` by 2 % over this many iterations restarts.
    """

    max_step_rad: float = 0.5
    lambda_0: float = 1e-4
    mu_0: float = 1.0
    mu_min: float = 1e-6
    mu_max: float = 1e6
    stall_iterations: int = 6


@dataclass
class IKResult:
    """Outcome of one numerical IK solve.

    Attributes
    ----------
    q : ndarray (n_joints,)
        Best configuration found in [rad] (inside the joint ranges), even if not converged.
    success : bool
        Both tolerances met.
    position_error_m : float
        ``|p_tool(q) - p_des|`` in [m].
    rotation_error_rad : float
        Angle of ``R_tool(q)^T R_des`` in [rad].
    iterations : int
        Linearisations (QP solves) over all attempts.
    restarts : int
        Random restarts used.
    """

    q: np.ndarray
    success: bool
    position_error_m: float
    rotation_error_rad: float
    iterations: int
    restarts: int

    def to_dict(self) -> dict:
        return {
            "q": [float(x) for x in self.q],
            "success": bool(self.success),
            "position_error_m": float(self.position_error_m),
            "rotation_error_rad": float(self.rotation_error_rad),
            "iterations": int(self.iterations),
            "restarts": int(self.restarts),
        }


class _StepQP:
    """The damped least-squares step as an OSQP problem, set up once for n variables."""

    _solve_kwargs: dict = {}

    def __init__(self, n: int) -> None:
        self.n = n
        P = sparse.triu(np.ones((n, n)), format="csc")  # dense upper triangle
        self._rows, self._cols = P.nonzero()
        # csc data order: column-major within the upper triangle
        order = np.lexsort((self._rows, self._cols))
        self._rows, self._cols = self._rows[order], self._cols[order]
        A = sparse.identity(n, format="csc")
        self.solver = osqp.OSQP()
        self.solver.setup(
            P,
            np.zeros(n),
            A,
            -np.ones(n),
            np.ones(n),
            verbose=False,
            eps_abs=1e-9,
            eps_rel=1e-9,
            max_iter=4000,
            check_termination=10,
        )
        if "raise_error" in inspect.signature(self.solver.solve).parameters:
            self._solve_kwargs = {"raise_error": False}

    def step(
        self, H: np.ndarray, g: np.ndarray, lower: np.ndarray, upper: np.ndarray
    ) -> np.ndarray:
        """argmin 1/2 x^T H x + g^T x, lower <= x <= upper (H dense symmetric (n, n)).

        Solved in ``x / s`` with ``s = ||g||`` so OSQP's absolute tolerances scale with the step.
        """
        scale = max(float(np.linalg.norm(g)), 1e-300)
        self.solver.update(
            Px=H[self._rows, self._cols], q=g / scale, l=lower / scale, u=upper / scale
        )
        res = self.solver.solve(**self._solve_kwargs)
        x = np.asarray(res.x, dtype=float)
        if x.shape != (self.n,) or not np.all(np.isfinite(x)):  # solver failure: safe fallback
            x = np.clip(np.linalg.solve(H, -g / scale), lower / scale, upper / scale)
        return np.clip(x * scale, lower, upper)


_local = threading.local()


def _qp(n: int) -> _StepQP:
    cache = getattr(_local, "qps", None)
    if cache is None:
        cache = _local.qps = {}
    if n not in cache:
        cache[n] = _StepQP(n)
    return cache[n]


def _errors(oMf: pin.SE3, oMdes: pin.SE3) -> tuple[float, float]:
    pos = float(np.linalg.norm(oMf.translation - oMdes.translation))
    rot = float(np.linalg.norm(pin.log3(oMf.rotation.T @ oMdes.rotation)))
    return pos, rot


def ik_solve(
    robot: Robot,
    pose,
    q_seed=None,
    *,
    tol_pos_m: float = 1e-6,
    tol_rot_rad: float = 1e-6,
    max_iter: int = 100,
    restarts: int = 50,
    rng: np.random.Generator | None = None,
    frame: str | None = None,
    settings: IKSettings | None = None,
) -> IKResult:
    """Numerical IK of one pose; never raises on failure, reports it.

    Parameters
    ----------
    robot : Robot
        Any robot (URDF); redundant arms (Panda) included.
    pose : array (4, 4)
        Desired pose of the tool (or ``frame``) in the world.
    q_seed : array (n_joints,), optional
        Start configuration in [rad] (clipped into the ranges); default the middle of the ranges.
    tol_pos_m, tol_rot_rad : float
        Success tolerances on the position error in [m] and rotation angle error in [rad].
    max_iter : int
        Iterations per attempt.
    restarts : int
        Random restarts (uniform inside the joint ranges) after a failed attempt.
    rng : numpy.random.Generator, optional
        Source of the restart configurations; default ``np.random.default_rng(0)``
        (deterministic).
    frame : str, optional
        Frame to place; default the tool frame.
    settings : IKSettings, optional

    Returns
    -------
    IKResult
    """
    T, single = check_poses(pose, allow_nan=False)
    if not single:
        raise InputError(f"pose has shape {np.shape(pose)}; ik_solve takes one (4, 4) pose")
    settings = settings or IKSettings()
    rng = np.random.default_rng(0) if rng is None else rng
    model, data = robot.model, robot.data
    fid = robot.frame_id(frame)
    lo, hi = robot.limits.lower_rad, robot.limits.upper_rad
    n = robot.n_joints
    if q_seed is None:
        q = robot.limits.centre_rad
    else:
        q = np.clip(robot.check_q(q_seed, name="q_seed"), lo, hi)
    T_des = np.linalg.solve(robot.transform_base_to_world, T[0])
    oMdes = pin.SE3(T_des[:3, :3], T_des[:3, 3])
    qp = _qp(n)
    eye = np.eye(n)

    def evaluate(qq: np.ndarray):
        pin.forwardKinematics(model, data, qq)
        oMf = pin.updateFramePlacement(model, data, fid)
        iMd = oMf.actInv(oMdes)
        err = pin.log6(iMd).vector
        return oMf, iMd, err

    best_q, best_pos, best_rot = q.copy(), math.inf, math.inf
    iterations = 0
    attempt = 0
    for attempt in range(restarts + 1):
        if attempt > 0:
            q = robot.random_q(rng)
        oMf, iMd, err = evaluate(q)
        e2 = float(err @ err)
        mu = settings.mu_0
        last_progress_e2, last_progress_it = e2, 0
        for it in range(max_iter):
            pos, rot = _errors(oMf, oMdes)
            if pos + rot < best_pos + best_rot:
                best_q, best_pos, best_rot = q.copy(), pos, rot
            if pos <= tol_pos_m and rot <= tol_rot_rad:
                return IKResult(q.copy(), True, pos, rot, iterations, attempt)
            iterations += 1
            J = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL)
            Je = -pin.Jlog6(iMd.inverse()) @ J
            lam = mu * (e2 + settings.lambda_0)
            H = Je.T @ Je + lam * eye
            g = Je.T @ err
            lower = np.maximum(lo - q, -settings.max_step_rad)
            upper = np.minimum(hi - q, settings.max_step_rad)
            dq = qp.step(H, g, lower, upper)
            q_new = np.clip(q + dq, lo, hi)
            oMf_new, iMd_new, err_new = evaluate(q_new)
            e2_new = float(err_new @ err_new)
            if e2_new < e2:
                q, oMf, iMd, err, e2 = q_new, oMf_new, iMd_new, err_new, e2_new
                mu = max(mu / 10.0, settings.mu_min)
            else:
                mu *= 10.0
                # J was evaluated at q by computeFrameJacobian; restore the kinematics of q
                pin.forwardKinematics(model, data, q)
                pin.updateFramePlacement(model, data, fid)
                if mu > settings.mu_max:
                    break
            if e2 < 0.98 * last_progress_e2:
                last_progress_e2, last_progress_it = e2, it
            elif it - last_progress_it > settings.stall_iterations:
                break
        pos, rot = _errors(oMf, oMdes)
        if pos + rot < best_pos + best_rot:
            best_q, best_pos, best_rot = q.copy(), pos, rot
        if pos <= tol_pos_m and rot <= tol_rot_rad:
            return IKResult(q.copy(), True, pos, rot, iterations, attempt)
    return IKResult(best_q, False, best_pos, best_rot, iterations, attempt)


def ik(
    robot: Robot,
    pose,
    q_seed=None,
    *,
    tol_pos_m: float = 1e-6,
    tol_rot_rad: float = 1e-6,
    max_iter: int = 100,
    restarts: int = 50,
    rng: np.random.Generator | None = None,
    frame: str | None = None,
    settings: IKSettings | None = None,
) -> np.ndarray:
    """Numerical IK of one pose: the configuration (n_joints,) in [rad].

    Same parameters as :func:`ik_solve`.

    Raises
    ------
    UnreachableError
        No configuration inside the joint ranges meets the tolerances after all restarts; the
        message gives the best errors reached.
    """
    res = ik_solve(
        robot,
        pose,
        q_seed,
        tol_pos_m=tol_pos_m,
        tol_rot_rad=tol_rot_rad,
        max_iter=max_iter,
        restarts=restarts,
        rng=rng,
        frame=frame,
        settings=settings,
    )
    if not res.success:
        raise UnreachableError(
            f"{robot.name}: numerical IK failed after {res.restarts} restarts and "
            f"{res.iterations} iterations (best position error {res.position_error_m:.3g} m, "
            f"rotation error {res.rotation_error_rad:.3g} rad; tolerances {tol_pos_m:g} m, "
            f"{tol_rot_rad:g} rad): pose outside the reachable workspace or the joint ranges?"
        )
    return res.q


def ik_batch(
    robot: Robot, poses, q_seed=None, *, sequential: bool = True, **kwargs
) -> tuple[np.ndarray, list[IKResult]]:
    """Numerical IK of many poses (n, 4, 4).

    With ``sequential=True`` (paths) pose ``k`` is seeded with the solution of pose ``k - 1``
    (``q_seed`` seeds pose 0), which keeps the branch continuous. Keywords go to
    :func:`ik_solve`.

    Returns
    -------
    q : ndarray (n, n_joints)
        Best configurations in [rad].
    results : list of IKResult
    """
    T, _ = check_poses(poses, name="poses", allow_nan=False)
    results = []
    seed = q_seed
    for k in range(T.shape[0]):
        res = ik_solve(robot, T[k], seed, **kwargs)
        results.append(res)
        if sequential and res.success:
            seed = res.q
    return np.array([r.q for r in results]), results
