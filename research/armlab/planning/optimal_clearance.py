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
obstacle; ``J(p) = J_v - [p - o]_\times J_\omega`` from the joint's Jacobian at its origin
``o``, Pinocchio's ``LOCAL_WORLD_ALIGNED``; both from the collision package,
:meth:`armlab.collision.CollisionScene.distance_jacobian`). The clearance row of a knot ``k``
and a pair, linearised at the last solution's ``\bar q_k``, is linear in the knot's positions:

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
with the collision package's certified motion check (:func:`armlab.collision.check_motion`:
every checked pair, between the samples); if every pair keeps ``c`` the plan is returned.
Otherwise the rows are (re)linearised at the current knots, a pair that came closer than ``c``
between the knots has its back-off raised by its shortfall plus :data:`BACKOFF_M` (as the
torque back-off lowers a bound the knots alone do not see), and the problem is solved again
from the last solution. After :data:`MAX_ROUNDS` rounds, or a solve that fails with the rows,
the plan is refused with one line naming the pair, the time and the clearance (or depth)
reached. A waypoint closer than ``c`` is bad input (:class:`~armlab.errors.InputError` naming
the waypoint and the pair).

References: Schulman et al., "Motion planning with sequential convex optimization and convex
collision checking", IJRR 33(9) 2014 (TrajOpt: signed distances linearised with the witness
points' Jacobians, in sequential convex rounds); Ericson, *Real-Time Collision Detection*, 2005
(signed distance, witness points).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab._lazy import lazy_import
from armlab.errors import ArmlabError, InfeasibleError, InputError

if TYPE_CHECKING:
    import casadi as ca

    from armlab.collision import ClearanceReport, CollisionScene
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
    "ClearanceRows",
    "extended_structure",
    "plan_clear",
    "stamp_clearance",
]

#: a pair within the clearance plus this distance [m] at a knot gets a row there
ACTIVATION_M = 0.03
#: extra back-off [m] of a pair that came too close between the knots (beyond its shortfall)
BACKOFF_M = 1e-3
#: re-solves with clearance rows before a plan is refused
MAX_ROUNDS = 6
#: rows per knot the compiled problems offer (the fewest that hold the knot with most rows)
SLOTS = (1, 2, 4, 8)


# ---------------------------------------------------------------------------- rows
@dataclass
class ClearanceRows:
    """Linear rows ``c^T q_k >= l`` on the optimiser's knots, keyed by (knot, pair).

    :meth:`extend` adds them to a compiled problem (hook in
    :meth:`~armlab.planning.optimal_problem.OptimalProblem._attempt`).
    """

    n: int
    N: int
    rows: dict[tuple[int, Any], tuple[np.ndarray, float]] = field(default_factory=dict)

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
    cols = [int(k) for k in np.repeat(np.arange(N + 1), M)]
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
    scene: CollisionScene,
    q_knots: np.ndarray,
    rows: ClearanceRows,
    active: set[tuple[int, int]],
    backoff: np.ndarray,
) -> None:
    """Rows at every knot where a pair comes within ``c + backoff + ACTIVATION_M`` (and at
    the knots that had one), linearised at ``q_knots`` (``scene.distance_jacobian``)."""
    c = scene.clearance_m
    rows.rows.clear()
    for k, qk in enumerate(q_knots):
        d, grad = scene.distance_jacobian(qk)
        near = set(np.flatnonzero(d < c + backoff + ACTIVATION_M).tolist())
        near |= {pair for kk, pair in active if kk == k}
        for pair in sorted(near):
            active.add((k, pair))
            g = grad[pair]
            rows.rows[(k, pair)] = (g, c + backoff[pair] - d[pair] + float(g @ qk))


def _refusal(report: ClearanceReport, why: str) -> InfeasibleError:
    return InfeasibleError(
        f"clearance: optimal cannot keep {report.clearance_m * 1e3:g} mm: "
        f"{report.message('its plan')} ({why})"
    )


def plan_clear(
    first: Callable[[], Trajectory],
    build: Callable[[tuple[int, ...] | None], OptimalProblem],
    scene: CollisionScene,
    *,
    max_rounds: int = MAX_ROUNDS,
) -> Trajectory:
    """Plan with :func:`optimal` and keep every checked pair of ``scene`` at least
    ``scene.clearance_m`` apart (module docstring).

    Parameters
    ----------
    first : callable
        The plain plan as ``optimal`` makes it without clearance rows (its finer grids), for
        a round 0 whose own solve fails.
    build : callable ``(n_intervals) -> OptimalProblem``
        A fresh problem of the same request on the given grid (None: the requested one).
    scene : armlab.collision.CollisionScene
        Distances and their gradients, and the motion check
        (:func:`armlab.collision.check_motion`).
    max_rounds : int
        Re-solves with rows before refusing.

    Returns
    -------
    Trajectory
        The first plan whose motion keeps the clearance; ``stats["clearance_rounds"]``,
        ``stats["clearance_rows"]``, ``stats["min_clearance_m"]`` and ``meta["clearance"]``
        (the motion check, :meth:`ClearanceReport.to_dict`).

    Raises
    ------
    InfeasibleError
        One line naming the pair, the time and the distance (or depth) reached.
    """
    from armlab.collision import check_motion

    prob = build(None)
    _check_waypoints(scene, prob.waypoints)
    try:  # round 0: the plain plan, its solution the warm start of round 1
        traj = prob.solve()
        prob.x0 = prob.solution_x
    except ArmlabError:  # as optimal() handles it (finer grids), then a cold round 1
        traj = first()
        raised = traj.stats.get("n_intervals_raised")
        prob = build(tuple(raised["to"]) if raised else None)
    report = check_motion(scene, traj)
    if report.ok:
        return _stamp(traj, report, 0, 0)
    rows = ClearanceRows(prob.n, prob.N)
    prob.clearance_rows = rows
    names = _pair_index(scene, traj)
    active: set[tuple[int, int]] = set()
    backoff = np.zeros(scene.n_pairs)
    for rnd in range(1, max_rounds + 1):
        _relinearise(scene, _knot_q(traj), rows, active, backoff)
        try:
            traj = prob.solve()
        except ArmlabError:  # the diagnosis names a limit; what failed are the rows
            raise _refusal(report, f"no plan meets the clearance rows of round {rnd}") from None
        prob.x0 = prob.solution_x
        report = check_motion(scene, traj)
        if report.ok:
            return _stamp(traj, report, rnd, len(rows.rows))
        for pc in report.pairs:
            if pc.min_distance_m < report.clearance_m:
                k = names[pc.pair]
                backoff[k] += report.clearance_m - pc.min_distance_m + BACKOFF_M
    raise _refusal(report, f"still too close after {max_rounds} rounds of clearance rows")


def _check_waypoints(scene: CollisionScene, waypoints: np.ndarray) -> None:
    """InputError naming the waypoint and the pair if a waypoint is closer than the clearance
    (a waypoint in collision is bad input: no plan through it can keep clear)."""
    c = scene.clearance_m
    for k, w in enumerate(waypoints):
        dist = scene.distances(w)
        i = dist.closest()
        if i >= 0 and dist.distance_m[i] < c:
            d = float(dist.distance_m[i])
            how = f"penetrate {-d * 1e3:.3g} mm" if d < 0 else f"are {d * 1e3:.3g} mm apart"
            raise InputError(
                f"waypoint {k}: {dist.pair_name(i)} {how}, closer than the clearance of "
                f"{c * 1e3:g} mm"
            )


def _pair_index(scene: CollisionScene, traj: Trajectory) -> dict[str, int]:
    """The report's pair names (``"link2_0 (link2) and table"``) to pair indices."""
    dist = scene.distances(np.asarray(traj.q[0]))
    return {dist.pair_name(k): k for k in range(scene.n_pairs)}


def stamp_clearance(traj: Trajectory, report: ClearanceReport) -> Trajectory:
    """Put a motion check on the plan: ``stats["min_clearance_m"]`` [m] and
    ``meta["clearance"]`` (:meth:`~armlab.collision.ClearanceReport.to_dict`)."""
    traj.stats["min_clearance_m"] = report.min_distance_m
    traj.meta["clearance"] = report.to_dict()
    return traj


def _stamp(traj: Trajectory, report: ClearanceReport, rounds: int, n_rows: int) -> Trajectory:
    stamp_clearance(traj, report)
    traj.stats["clearance_rounds"] = rounds
    traj.stats["clearance_rows"] = n_rows
    return traj
