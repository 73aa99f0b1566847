"""The transcription of the optimal-trajectory problem into one CasADi NLP (IPOPT).

Decision variables per interval: joint positions, velocities (and accelerations in jerk mode)
at the knots, the piecewise-constant input (acceleration or jerk) and the segment durations,
all scaled; constraints: the exact polynomial integration of each interval, the convex-hull
bounds that keep velocity, acceleration and position inside their limits between the knots,
and -- with torque limits -- the inverse dynamics of the symbolic twin
(:func:`armlab.robot.symbolic.parametric_inverse_dynamics_function`, gravity in the base frame)
at the knots. The compiled NLP depends only on the robot's kinematic tree, the sizes and the
flags, so it is built once and cached (:func:`structure`); the payload, limits, scales and grid
fractions are parameters. The problem and its solve are in :mod:`armlab.planning.optimal`.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from armlab._lazy import lazy_import
from armlab.robot.symbolic import kinematics_key, parametric_inverse_dynamics_function

if TYPE_CHECKING:
    import casadi as ca  # the real module for the type checker (CasADi ships type stubs)
else:
    ca = lazy_import("casadi")  # CasADi loads at the first symbolic build

__all__ = ["Structure", "structure", "build_structure", "ipopt_options"]

#: expression graph of the NLP: "MX" (maps of the SX inverse dynamics; fast to build) or "SX"
SYMBOLIC = "SX"
#: IPOPT Hessian: "limited-memory" (L-BFGS) or "exact"
HESSIAN = "exact"
#: where, inside each interval, the torque is also constrained (fractions; none by default:
#: with the balanced grid the fine-grid back-off is cheaper than midpoint rows, measured)
TORQUE_INTERIOR_POINTS: tuple[float, ...] = ()

_STRUCTURES: dict[tuple, Structure] = {}
_STRUCTURES_MAX = 32


# ----------------------------------------------------------------------------- structure
@dataclass
class Structure:
    """One compiled NLP: depends only on the robot dynamics, sizes and flags (cached)."""

    solver: ca.Function
    g_fun: ca.Function
    n: int
    seg_n: tuple[int, ...]
    mode: str
    torque_rows: bool
    g_kind: np.ndarray
    g_joint: np.ndarray
    n_pi: int
    nx: int
    slices: dict[str, slice]
    build_time_s: float

    @property
    def N(self) -> int:
        return int(sum(self.seg_n))


def ipopt_options(max_iter: int) -> dict:
    return {
        "print_time": False,
        "ipopt.print_level": 0,
        "ipopt.sb": "yes",
        "ipopt.max_iter": max_iter,
        "ipopt.tol": 1e-9,
        "ipopt.constr_viol_tol": 1e-9,
        # L-BFGS stalls in the dual residual once the objective no longer moves: accept then
        # (primal feasibility, what the limits need, stays at 1e-9)
        "ipopt.acceptable_tol": 1e-4,
        "ipopt.acceptable_constr_viol_tol": 1e-9,
        "ipopt.acceptable_obj_change_tol": 1e-9,
        "ipopt.acceptable_iter": 5,
        "ipopt.mu_strategy": "adaptive",
        "ipopt.linear_solver": "mumps",
        # quasi-Newton Hessian: measured faster here than the exact Hessian of the torque rows
        "ipopt.hessian_approximation": HESSIAN,
    }


def build_structure(
    rnea_p,
    n_pi: int,
    n: int,
    seg_n: tuple[int, ...],
    mode: str,
    objective: str,
    torque_rows: bool,
    fixed_duration: bool,
    max_iter: int,
) -> Structure:
    t0 = _time.perf_counter()
    # SX or MX, chosen by a module constant; both share the symbolic API, and typing it as the
    # union makes mypy reject every mixed SX/MX operation it cannot rule out
    X: Any = ca.MX if SYMBOLIC == "MX" else ca.SX
    N = int(sum(seg_n))
    # decision variables are scaled: physical = scaled * scale (scales are parameters)
    Q = X.sym("q", n, N + 1)
    Vs = X.sym("v", n, N + 1)
    As = X.sym("a", n, N + 1) if mode == "jerk" else None
    Us = X.sym("u", n, N)
    nseg = len(seg_n)
    Ts = X.sym("T", nseg)  # segment durations / their warm-start values
    blocks = (
        [("q", Q), ("v", Vs)] + ([("a", As)] if As is not None else []) + [("u", Us), ("T", Ts)]
    )
    slices, start = {}, 0
    for name, m in blocks:
        slices[name] = slice(start, start + m.numel())
        start += m.numel()
    x = ca.vertcat(*[ca.vec(m) for _, m in blocks])
    p_tau = X.sym("tau_scale", n)
    p_w = X.sym("w_smooth")
    p_uref = X.sym("u_ref", n)
    p_ew = X.sym("energy_w", n)
    s_v = X.sym("s_v", n)
    s_a = X.sym("s_a", n)
    s_u = X.sym("s_u", n)
    s_T = X.sym("s_T", nseg)
    frac = X.sym("fractions", N)  # h_k = T_seg(k) * fraction_k
    p_pi = X.sym("inertial_parameters", n_pi)  # payload is a parameter, not structure
    p = ca.vertcat(p_tau, p_w, p_uref, p_ew, s_v, s_a, s_u, s_T, frac, p_pi)

    def rnea(qq, vv, aa):
        m = qq.shape[1]
        return rnea_p.map(m)(qq, vv, aa, ca.repmat(p_pi, 1, m))

    V = Vs * ca.repmat(s_v, 1, N + 1)
    U = Us * ca.repmat(s_u, 1, N)
    A = As * ca.repmat(s_a, 1, N + 1) if mode == "jerk" else None
    T = Ts * s_T
    seg_of = np.repeat(np.arange(nseg), seg_n)
    select = np.zeros((N, nseg))
    select[np.arange(N), seg_of] = 1.0
    H = ca.mtimes(ca.DM(select), T) * frac
    rv, ra = ca.repmat(s_v, 1, N), ca.repmat(s_a, 1, N)

    Hr = ca.repmat(H.T, n, 1)
    Qa, Qb, Va, Vb = Q[:, :N], Q[:, 1:], V[:, :N], V[:, 1:]
    rows: list[tuple] = []  # (expr, kind, per-joint)
    if A is not None:  # jerk mode
        Aa, Ab = A[:, :N], A[:, 1:]
        rows.append((Qb - (Qa + Hr * Va + Hr**2 / 2 * Aa + Hr**3 / 6 * U), "dynamics", True))
        rows.append(((Vb - (Va + Hr * Aa + Hr**2 / 2 * U)) / rv, "dynamics", True))
        rows.append(((Ab - (Aa + Hr * U)) / ra, "dynamics", True))
        rows.append(((Va + Aa * Hr / 2) / rv, "velocity", True))
        rows.append((Qa + Va * Hr / 3, "position", True))
        rows.append((Qb - Vb * Hr / 3, "position", True))
    else:
        rows.append((Qb - (Qa + Hr * Va + Hr**2 / 2 * U), "dynamics", True))
        rows.append(((Vb - (Va + Hr * U)) / rv, "dynamics", True))
        rows.append((Qa + Va * Hr / 2, "position", True))
    need_tau = torque_rows or objective == "energy"
    tau_nodes: list[Any] = []
    if need_tau:
        if mode == "jerk":
            tau_nodes = [rnea(Q, V, A)]
        else:
            tau_nodes = [rnea(Qa, Va, U), rnea(Qb, Vb, U)]
        if torque_rows:
            inner = []
            for th in TORQUE_INTERIOR_POINTS:  # exact states at a fraction th of each interval
                d = Hr * th
                if mode == "jerk":
                    qi = Qa + d * Va + d**2 / 2 * Aa + d**3 / 6 * U
                    vi = Va + d * Aa + d**2 / 2 * U
                    ai = Aa + d * U
                else:
                    qi = Qa + d * Va + d**2 / 2 * U
                    vi = Va + d * U
                    ai = U
                inner.append(rnea(qi, vi, ai))
            for tn in tau_nodes + inner:
                rows.append((tn / ca.repmat(p_tau, 1, tn.shape[1]), "torque", True))
    scalar_rows: list[tuple] = []
    if fixed_duration:
        scalar_rows.append((ca.sum1(T), "duration"))
    g_parts, kinds, joints = [], [], []
    for expr, kind, _ in rows:
        g_parts.append(ca.vec(expr))
        kinds += [kind] * expr.numel()
        joints += list(np.tile(np.arange(n), expr.shape[1]))
    for expr, kind in scalar_rows:
        g_parts.append(expr)
        kinds.append(kind)
        joints.append(-1)
    g = ca.vertcat(*g_parts)

    Un = U / ca.repmat(p_uref, 1, N)
    smooth = ca.dot(ca.sum1(Un**2).T, H)
    if objective in ("time", "time+smooth"):
        f = ca.sum1(T) + p_w * smooth
    elif objective == "jerk":
        f = smooth
    else:  # energy
        ew = [ca.sum1(ca.repmat(p_ew, 1, tn.shape[1]) * tn**2) for tn in tau_nodes]
        if mode == "jerk":
            e = ew[0]
            f = ca.dot(((e[:, :N] + e[:, 1:]) / 2).T, H)
        else:
            f = ca.dot(((ew[0] + ew[1]) / 2).T, H)
    nlp = {"x": x, "p": p, "f": f, "g": g}
    solver = ca.nlpsol("armlab_optimal", "ipopt", nlp, ipopt_options(max_iter))
    g_fun = ca.Function("g", [x, p], [g])
    return Structure(
        solver=solver,
        g_fun=g_fun,
        n=n,
        seg_n=seg_n,
        mode=mode,
        torque_rows=torque_rows,
        g_kind=np.array(kinds),
        g_joint=np.array(joints),
        n_pi=n_pi,
        nx=int(x.numel()),
        slices=slices,
        build_time_s=_time.perf_counter() - t0,
    )


def structure(robot, n, seg_n, mode, objective, torque_rows, fixed_duration, max_iter) -> Structure:
    need_tau = torque_rows or objective == "energy"
    kkey = kinematics_key(robot) if need_tau else None
    key = (
        kkey,
        n,
        seg_n,
        mode,
        objective,
        torque_rows,
        fixed_duration,
        max_iter,
        HESSIAN,
        TORQUE_INTERIOR_POINTS,
        SYMBOLIC,
    )
    st = _STRUCTURES.get(key)
    if st is None:
        rnea_p = parametric_inverse_dynamics_function(robot) if need_tau else None
        n_pi = rnea_p.size1_in(3) if rnea_p is not None else 0
        st = build_structure(
            rnea_p, n_pi, n, seg_n, mode, objective, torque_rows, fixed_duration, max_iter
        )
        if len(_STRUCTURES) >= _STRUCTURES_MAX:
            _STRUCTURES.pop(next(iter(_STRUCTURES)))
        _STRUCTURES[key] = st
    return st
