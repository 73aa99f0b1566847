r"""Plans that keep clear (issue 27): :func:`~armlab.planning.optimal` with a clearance
constraint, in sequential convex rounds.

Rows
----
A pair (a, b) of collision bodies -- a link and an obstacle, the floor, or two links -- has the
signed distance ``d(q)`` (negative: penetration depth) with witness points ``p_a`` on a and
``p_b`` on b and the unit normal ``n`` from a to b. Moving the bodies changes it, to first
order, by

.. math::
    \nabla_q d = n^T \left(J_b(p_b) - J_a(p_a)\right),

``J_x(p)`` the linear Jacobian of the point ``p`` fixed to the body's joint (zero for an
obstacle; ``J(p) = J_v - [p - o]_\times J_\omega`` from the joint's Jacobian at its origin ``o``,
Pinocchio's ``LOCAL_WORLD_ALIGNED``). The clearance row of a knot ``k`` and a pair, linearised
at the last solution's ``\bar q_k``, is linear in the knot's positions:

.. math::
    d(\bar q_k) + \nabla_q d(\bar q_k)^T (q_k - \bar q_k) \ge c + \delta_{ab},

``c`` the clearance asked (``[plan] clearance_m``) and ``\delta_{ab}`` the pair's back-off
(below). Rows are written for every knot at which a pair comes within ``c +``
:data:`ACTIVATION_M` of touching, along any of the solutions so far (a knot once given a row
keeps it, re-linearised each round). The rows enter the optimiser's compiled problem as
``C q_k >= l`` with ``C`` and ``l`` parameters (:class:`ClearanceRows`; at most
:data:`SLOTS` rows per knot, the problem built once per slot count and cached).

Rounds
------
Round 0 is the plain plan (no rows). Each round then checks the whole motion between the knots
with the collision package's motion check (every pair, on its fine grid); if every pair keeps
``c`` the plan is returned. Otherwise the rows are (re)linearised at the current knots, a pair
that came closer than ``c`` between the knots has its back-off raised by its shortfall plus
:data:`BACKOFF_M` (as the torque back-off lowers a bound the knots alone do not see), and the
problem is solved again from the last solution. After :data:`MAX_ROUNDS` rounds, or a solve
that fails with the rows, the plan is refused with one line naming the pair, the time and the
clearance (or depth) reached.

References: Schulman et al., "Motion planning with sequential convex optimization and convex
collision checking", IJRR 33(9) 2014 (TrajOpt: signed distances linearised with the witness
points' Jacobians, in sequential convex rounds); Ericson, *Real-Time Collision Detection*, 2005
(signed distance, witness points).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
import pinocchio as pin

from armlab._lazy import lazy_import
from armlab.errors import ArmlabError, InfeasibleError

if TYPE_CHECKING:
    import casadi as ca

    from armlab.planning.optimal_problem import OptimalProblem
    from armlab.planning.transcription import Structure
    from armlab.trajectory.core import Trajectory
else:
    ca = lazy_import("casadi")

__all__ = [
    "ACTIVATION_M",
    "BACKOFF_M",
    "MAX_ROUNDS",
    "SLOTS",
    "ClearanceModel",
    "ClearanceRows",
    "MotionClearance",
    "Witness",
    "distance_gradient",
    "plan_clear",
]

#: a pair within the clearance plus this distance [m] at a knot gets a row there
ACTIVATION_M = 0.03
#: extra back-off [m] of a pair that came too close between the knots (beyond its shortfall)
BACKOFF_M = 1e-3
#: re-solves with clearance rows before a plan is refused
MAX_ROUNDS = 6
#: rows per knot the compiled problems offer (the fewest that hold the knot with most rows)
SLOTS = (1, 2, 4, 8)


@dataclass(frozen=True)
class Witness:
    """The signed distance of one pair at one pose, with what its gradient needs.

    Attributes
    ----------
    a, b : str
        The bodies' names (``a`` a link's geometry; ``b`` another link's, an obstacle or
        ``floor``).
    distance_m : float
        Signed distance [m] (negative: penetration depth).
    point_a_m, point_b_m : ndarray (3,)
        Witness points in the world frame [m].
    normal : ndarray (3,)
        Unit vector from a to b (world frame).
    joint_a, joint_b : int
        The joints (indices of ``robot.model``) the bodies move with; 0: fixed in the world.
    """

    a: str
    b: str
    distance_m: float
    point_a_m: np.ndarray
    point_b_m: np.ndarray
    normal: np.ndarray
    joint_a: int
    joint_b: int = 0

    @property
    def pair(self) -> tuple[str, str]:
        return (self.a, self.b)


@dataclass(frozen=True)
class MotionClearance:
    """The closest approach of each pair along a motion (the motion check's answer).

    Attributes
    ----------
    min_distance_m : dict of (str, str) to float
        Each checked pair's smallest signed distance [m] along the motion.
    time_s : dict of (str, str) to float
        The plan time [s] of that smallest distance.
    """

    min_distance_m: dict[tuple[str, str], float]
    time_s: dict[tuple[str, str], float]

    def closest(self) -> tuple[tuple[str, str], float, float]:
        """The pair that came closest, its distance [m] and time [s]."""
        pair = min(self.min_distance_m, key=self.min_distance_m.__getitem__)
        return pair, self.min_distance_m[pair], self.time_s[pair]


class ClearanceModel(Protocol):
    """What the rounds ask of the collision package (an adapter to its API)."""

    robot: Any
    clearance_m: float

    def witnesses(self, q: np.ndarray, within_m: float) -> list[Witness]:
        """Every checked pair closer than ``within_m`` [m] at the pose ``q`` [rad]."""
        ...

    def motion(self, trajectory: Trajectory) -> MotionClearance:
        """Every checked pair's closest approach along the motion (between the samples)."""
        ...


# ---------------------------------------------------------------------------- gradient
def _point_jacobian(model, data, joint: int, point: np.ndarray) -> np.ndarray:
    """(3, nv) linear Jacobian of a point [m] (base frame) fixed to ``joint``; 0 for joint 0."""
    if joint <= 0:
        return np.zeros((3, model.nv))
    J = pin.getJointJacobian(model, data, joint, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
    r = point - data.oMi[joint].translation
    return J[:3] - pin.skew(r) @ J[3:]


def distance_gradient(robot, q: np.ndarray, witness: Witness, data=None) -> np.ndarray:
    r"""``\nabla_q d = n^T (J_b(p_b) - J_a(p_a))`` (n_joints,) of one pair at ``q`` (module
    docstring), the witness points and normal given in the world frame
    (``robot.transform_base_to_world`` maps the model's base frame to it).

    ``data`` may hold ``robot.model``'s joint Jacobians at ``q`` already
    (``pin.computeJointJacobians``); otherwise they are computed here.
    """
    model = robot.model
    if data is None:
        data = model.createData()
        pin.computeJointJacobians(model, data, np.asarray(q, float))
    T = np.asarray(robot.transform_base_to_world, float)
    R, o = T[:3, :3], T[:3, 3]
    pa, pb = R.T @ (witness.point_a_m - o), R.T @ (witness.point_b_m - o)
    n = R.T @ witness.normal
    Ja = _point_jacobian(model, data, witness.joint_a, pa)
    Jb = _point_jacobian(model, data, witness.joint_b, pb)
    return n @ (Jb - Ja)


# ---------------------------------------------------------------------------- rows
@dataclass
class ClearanceRows:
    """Linear rows ``c^T q_k >= l`` on the optimiser's knots, keyed by (knot, pair).

    :meth:`extend` adds them to a compiled problem (hook in
    :meth:`~armlab.planning.optimal_problem.OptimalProblem._attempt`).
    """

    n: int
    N: int
    rows: dict[tuple[int, tuple[str, str]], tuple[np.ndarray, float]] = field(default_factory=dict)

    def slots(self) -> int:
        per_knot = np.zeros(self.N + 1, int)
        for k, _ in self.rows:
            per_knot[k] += 1
        need = int(per_knot.max(initial=0))
        return next((s for s in SLOTS if s >= need), need)

    def arrays(self, M: int) -> tuple[np.ndarray, np.ndarray]:
        """``C`` (n, (N+1) M) column-major parameters and ``l`` ((N+1) M,) lower bounds
        (``-inf`` in unused slots)."""
        C = np.zeros((self.n, (self.N + 1) * M))
        lo = np.full((self.N + 1) * M, -np.inf)
        used = np.zeros(self.N + 1, int)
        for (k, _), (c, l) in sorted(self.rows.items()):
            j = k * M + used[k]
            used[k] += 1
            C[:, j], lo[j] = c, l
        return C, lo

    def extend(self, st: Structure, p: np.ndarray, lbg: np.ndarray, ubg: np.ndarray):
        """The structure with the rows, and its parameters and row bounds."""
        M = self.slots()
        ext = extended_structure(st, M)
        C, lo = self.arrays(M)
        p = np.concatenate([p, C.reshape(-1, order="F")])
        lbg = np.concatenate([lbg, lo])
        ubg = np.concatenate([ubg, np.full(lo.size, np.inf)])
        return ext, p, lbg, ubg


_EXTENDED: dict[tuple[int, int], tuple[Any, Any]] = {}  # (id(st), M) -> (st, extended)


def extended_structure(st: Structure, M: int) -> Structure:
    """``st``'s problem with ``M`` clearance rows per knot: ``sum_i C[i, kM+m] q_k[i]`` (linear
    in the knots; ``C`` appended to the parameters). The original's Jacobian and Hessian
    functions are reused (the rows add a constant Jacobian block and no curvature), so
    nothing of the dynamics is differentiated again. Cached per structure and ``M`` (the
    structure held, so its id is not reused)."""
    hit = _EXTENDED.get((id(st), M))
    if hit is not None and hit[0] is st:
        return hit[1]
    assert st.nlp is not None and st.options is not None
    n, N = st.n, st.N
    nx, np_old = int(st.nlp["x"].numel()), int(st.nlp["p"].numel())
    ng = int(st.nlp["g"].numel())
    x = ca.MX.sym("x", nx)
    p = ca.MX.sym("p", np_old + n * (N + 1) * M)
    p0 = p[:np_old]
    fg = ca.Function("armlab_fg", [st.nlp["x"], st.nlp["p"]], [st.nlp["f"], st.nlp["g"]])
    f, g = fg(x, p0)
    Q = ca.reshape(x[st.slices["q"]], n, N + 1)
    C = ca.reshape(p[np_old:], n, (N + 1) * M)
    cols = list(np.repeat(np.arange(N + 1), M))
    rows = ca.sum1(C * Q[:, cols]).T
    g_ext = ca.vertcat(g, rows)
    opts = {k: v for k, v in st.options.items() if k != "hess_lag"}
    jac = st.solver.get_function("nlp_jac_g")
    _, J0 = jac(x, p0)
    opts["jac_g"] = ca.Function(
        "nlp_jac_g", [x, p], [g_ext, ca.vertcat(J0, ca.jacobian(rows, x))], ["x", "p"],
        ["g", "jac_g_x"],
    )  # fmt: skip
    if opts.get("ipopt.hessian_approximation") == "exact":
        hess = st.options.get("hess_lag") or st.solver.get_function("nlp_hess_l")
        lam_f, lam_g = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", ng + rows.numel())
        opts["hess_lag"] = ca.Function(
            "armlab_clearance_hessian", [x, p, lam_f, lam_g], [hess(x, p0, lam_f, lam_g[:ng])]
        )
    nlp = {"x": x, "p": p, "f": f, "g": g_ext}
    solver = ca.nlpsol("armlab_optimal_clearance", "ipopt", nlp, opts)
    R = rows.numel()
    ext = dataclasses.replace(
        st,
        solver=solver,
        g_fun=ca.Function("g", [x, p], [g_ext]),
        g_kind=np.concatenate([st.g_kind, np.full(R, "clearance")]),
        g_joint=np.concatenate([st.g_joint, np.full(R, -1)]),
        g_tag=None if st.g_tag is None else np.concatenate([st.g_tag, np.full(R, "")]),
        g_col=None if st.g_col is None else np.concatenate([st.g_col, np.full(R, -1)]),
        nlp=nlp,
        options=opts,
        _warm=None,
    )
    if len(_EXTENDED) >= 16:
        _EXTENDED.pop(next(iter(_EXTENDED)))
    _EXTENDED[(id(st), M)] = (st, ext)
    return ext


# ---------------------------------------------------------------------------- rounds
def _knot_q(traj: Trajectory) -> np.ndarray:
    """The joint positions (N+1, n) at the optimiser's knots."""
    return np.asarray(traj.at(np.asarray(traj.meta["knot_times_s"], float))[0])


def _relinearise(
    model: ClearanceModel, q_knots: np.ndarray, rows: ClearanceRows, active: set, backoff: dict
) -> None:
    """Rows at every knot where a pair comes within ``c + ACTIVATION_M`` (and at the knots
    that had one), linearised at ``q_knots``."""
    c = model.clearance_m
    robot = model.robot
    data = robot.model.createData()
    reach = c + ACTIVATION_M + max(backoff.values(), default=0.0)
    rows.rows.clear()
    for k, qk in enumerate(q_knots):
        near = {w.pair: w for w in model.witnesses(qk, reach)}
        keep = {pair for kk, pair in active if kk == k}
        if not near and not keep:
            continue
        pin.computeJointJacobians(robot.model, data, qk)
        for pair, w in near.items():
            if w.distance_m < c + ACTIVATION_M + backoff.get(pair, 0.0) or pair in keep:
                active.add((k, pair))
                grad = distance_gradient(robot, qk, w, data)
                bound = c + backoff.get(pair, 0.0) - w.distance_m + float(grad @ qk)
                rows.rows[(k, pair)] = (grad, bound)


def _refusal(pair, d: float, t: float, c: float, why: str) -> InfeasibleError:
    a, b = pair
    what = f"penetrates {-d * 1e3:.1f} mm deep" if d < 0 else f"comes within {d * 1e3:.1f} mm"
    return InfeasibleError(
        f"clearance: {a} and {b} cannot be kept {c * 1e3:g} mm apart: the plan {what} "
        f"at t = {t:.3f} s ({why})"
    )


def plan_clear(
    first: Callable[[], Trajectory],
    build: Callable[[Sequence[int] | None], OptimalProblem],
    model: ClearanceModel,
    *,
    max_rounds: int = MAX_ROUNDS,
) -> Trajectory:
    """Plan with :func:`optimal` and keep every pair ``model.clearance_m`` apart (module
    docstring).

    Parameters
    ----------
    first : callable
        The plain plan (round 0: ``optimal`` without clearance rows).
    build : callable ``(n_intervals) -> OptimalProblem``
        A fresh problem of the same request on the given grid.
    model : ClearanceModel
        Distances, witness points and the motion check (the collision package).
    max_rounds : int
        Re-solves with rows before refusing.

    Returns
    -------
    Trajectory
        The first plan whose motion keeps the clearance; ``stats["clearance_rounds"]``,
        ``stats["clearance_rows"]`` and ``meta["clearance"]`` (its motion check) say how.

    Raises
    ------
    InfeasibleError
        One line naming the pair, the time and the distance (or depth) reached.
    """
    c = model.clearance_m
    traj = first()
    check = model.motion(traj)
    pair, d, t = check.closest()
    if d >= c:
        return _stamp(traj, check, 0, 0)
    raised = traj.stats.get("n_intervals_raised")
    grid = tuple(raised["to"]) if raised else None
    prob = build(grid)
    rows = ClearanceRows(prob.n, prob.N)
    prob.clearance_rows = rows
    active: set = set()
    backoff: dict[tuple[str, str], float] = {}
    for rnd in range(1, max_rounds + 1):
        _relinearise(model, _knot_q(traj), rows, active, backoff)
        try:
            traj = prob.solve()
        except ArmlabError as exc:
            why = (str(exc).splitlines() or [type(exc).__name__])[0]
            raise _refusal(pair, d, t, c, f"round {rnd}: {why}") from None
        prob.x0 = prob.solution_x
        check = model.motion(traj)
        pair, d, t = check.closest()
        if d >= c:
            return _stamp(traj, check, rnd, len(rows.rows))
        for pr, dm in check.min_distance_m.items():
            if dm < c:
                backoff[pr] = backoff.get(pr, 0.0) + (c - dm) + BACKOFF_M
    raise _refusal(pair, d, t, c, f"still too close after {max_rounds} rounds of clearance rows")


def _stamp(traj: Trajectory, check: MotionClearance, rounds: int, n_rows: int) -> Trajectory:
    pair, d, t = check.closest()
    traj.stats["clearance_rounds"] = rounds
    traj.stats["clearance_rows"] = n_rows
    traj.stats["min_clearance_m"] = d
    traj.meta["clearance"] = {
        "closest_pair": list(pair),
        "min_distance_m": d,
        "time_s": t,
        "per_pair_m": {f"{a}|{b}": v for (a, b), v in check.min_distance_m.items()},
    }
    return traj


def _finite(x: float) -> bool:
    return math.isfinite(x)
